//! A remd inside the current process: [`crate::daemon::server::run`] on a loopback port the OS
//! chooses, in the current tokio runtime. `sunray submit`'s embedded default runs one; tests
//! run clusters of them without starting processes (tests about the process itself, such as
//! signals, start the `remd` binary).

use std::time::Duration;

use tokio::sync::oneshot;

use crate::auth::secret::Secret;
use crate::client::rem_client::RemClient;
use crate::daemon::config::DaemonSettings;
use crate::error::Result;

/// A daemon running in this process; stopped by [`EmbeddedRemd::stop`] (or, less gently,
/// when dropped).
#[derive(Debug)]
pub struct EmbeddedRemd {
    name: String,
    addr: String,
    secret: Secret,
    stop: Option<oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<Result<()>>,
}

impl EmbeddedRemd {
    /// Starts a daemon with `settings`, listening on 127.0.0.1 at a port the OS chooses
    /// (`settings.listen` is replaced). A state directory that does not exist is created.
    pub async fn start(mut settings: DaemonSettings) -> Result<EmbeddedRemd> {
        if let Some(dir) = &settings.state_dir {
            std::fs::create_dir_all(dir)?;
        }
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
        settings.listen = listener.local_addr()?;
        let addr = settings.listen.to_string();
        let (name, secret) = (settings.name.clone(), settings.secret.clone());
        let (stop, stopped) = oneshot::channel::<()>();
        let task = tokio::spawn(crate::daemon::server::run(settings, listener, async move {
            let _ = stopped.await;
        }));
        Ok(EmbeddedRemd {
            name,
            addr,
            secret,
            stop: Some(stop),
            task,
        })
    }

    /// The host name it goes by.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// `127.0.0.1:PORT`.
    pub fn addr(&self) -> &str {
        &self.addr
    }

    /// Its cluster secret.
    pub fn secret(&self) -> &Secret {
        &self.secret
    }

    /// A client connected to it with its secret.
    pub async fn client(&self) -> Result<RemClient> {
        RemClient::connect(&self.addr, self.secret.clone()).await
    }

    /// Shuts the daemon down (its children are ended), waiting a bounded time.
    pub async fn stop(mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        let _ = tokio::time::timeout(Duration::from_secs(8), &mut self.task).await;
    }
}

impl Drop for EmbeddedRemd {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
    }
}

/// The secret a private daemon keeps in `dir` (`dir/secret`, mode 600), made fresh the first
/// time: its checkpoints are sealed with it, so a later private daemon of the same state
/// directory believes them.
pub fn kept_secret(dir: &std::path::Path) -> Result<Secret> {
    let path = dir.join("secret");
    match std::fs::read(&path) {
        Ok(bytes) => Secret::new(bytes),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(dir)?;
            let secret = fresh_secret()?;
            crate::auth::secret::write_private(&path, secret.as_bytes())?;
            Ok(secret)
        }
        Err(e) => Err(crate::Error::Config(format!(
            "cannot read {}: {e}",
            path.display()
        ))),
    }
}

/// A fresh cluster secret for a private daemon: 32 random bytes from the kernel as hex
/// (falling back to the time and process id where there is no `/dev/urandom`).
pub fn fresh_secret() -> Result<Secret> {
    let mut bytes = [0u8; 32];
    let ok = std::fs::File::open("/dev/urandom")
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut bytes))
        .is_ok();
    if !ok {
        let t = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let seed = t ^ (u128::from(std::process::id()) << 64);
        bytes[..16].copy_from_slice(&seed.to_le_bytes());
    }
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    Secret::new(hex)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_fresh() {
        let (a, b) = (fresh_secret().unwrap(), fresh_secret().unwrap());
        assert_eq!(a.as_bytes().len(), 64);
        assert!(a.as_bytes().iter().all(u8::is_ascii_hexdigit));
        assert_ne!(a.as_bytes(), b.as_bytes());
    }

    #[tokio::test]
    async fn two_embedded_daemons_form_a_cluster_and_refuse_a_wrong_secret() {
        let secret = fresh_secret().unwrap();
        let a = EmbeddedRemd::start(DaemonSettings::new("a", secret.clone()))
            .await
            .unwrap();
        let mut s = DaemonSettings::new("b", secret.clone());
        s.join = vec![a.addr().to_string()];
        let b = EmbeddedRemd::start(s).await.unwrap();
        let client = a.client().await.unwrap();
        let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
        loop {
            let hosts = client.hosts().await.unwrap();
            if hosts.len() == 2 && hosts.iter().all(|h| h.alive) {
                break;
            }
            assert!(tokio::time::Instant::now() < deadline, "{hosts:#?}");
            tokio::time::sleep(Duration::from_millis(25)).await;
        }
        let wrong = RemClient::connect(a.addr(), Secret::new("nope").unwrap())
            .await
            .unwrap();
        assert!(wrong.hosts().await.is_err());
        b.stop().await;
        a.stop().await;
    }
}
