//! The embedded default: with no remd configured, `sunray submit` runs a private remd inside
//! its own process, on loopback, with a fresh secret, allowed to start only this program's
//! `worker`. So the README's main command works on a fresh machine with nothing installed.
//!
//! Its checkpoints live in a state directory that outlives the process (so `--resume` and
//! `sunray jobs` work here too): `$SUNRAY_STATE_DIR`, else `$XDG_STATE_HOME/sunray`, else
//! `~/.local/state/sunray`.

use rem::config::Settings;
use rem::Secret;
use std::path::PathBuf;
use std::time::Duration;
use tokio::sync::oneshot;

/// The host name the private daemon goes by.
pub const HOST: &str = "local";

/// A daemon running in this process.
pub struct EmbeddedRem {
    /// Where it listens: `127.0.0.1:PORT`, the port chosen by the OS.
    pub addr: String,
    /// The fresh random cluster secret it accepts.
    pub secret: Secret,
    stop: Option<oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<rem::Result<()>>,
}

impl EmbeddedRem {
    /// Starts a daemon on `127.0.0.1:0` allowed to spawn `allow`, keeping checkpoints in
    /// `state_dir` (a temporary directory when `None`).
    pub async fn start(allow: Vec<PathBuf>, state_dir: Option<PathBuf>) -> rem::Result<Self> {
        let secret = Secret::new(fresh_secret())?;
        let mut settings = Settings::new(HOST, secret.clone());
        settings.allow = allow;
        if let Some(dir) = &state_dir {
            std::fs::create_dir_all(dir)?;
        }
        settings.state_dir = state_dir;
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
        settings.listen = listener.local_addr()?;
        let addr = settings.listen.to_string();
        let (stop, stopped) = oneshot::channel::<()>();
        let task = tokio::spawn(rem::server::run(settings, listener, async move {
            let _ = stopped.await;
        }));
        Ok(EmbeddedRem {
            addr,
            secret,
            stop: Some(stop),
            task,
        })
    }

    /// Shuts the daemon down (its children are ended), waiting a bounded time.
    pub async fn stop(mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        let _ = tokio::time::timeout(Duration::from_secs(8), &mut self.task).await;
    }
}

/// Where the embedded daemon keeps checkpoints.
pub fn state_dir() -> Option<PathBuf> {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = env("SUNRAY_STATE_DIR") {
        return Some(d);
    }
    if let Some(d) = env("XDG_STATE_HOME") {
        return Some(d.join("sunray"));
    }
    env("HOME").map(|h| h.join(".local/state/sunray"))
}

/// 32 random bytes as hex, from the kernel (falling back to time and process id).
fn fresh_secret() -> String {
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
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_fresh_hex() {
        let (a, b) = (fresh_secret(), fresh_secret());
        assert_eq!(a.len(), 64);
        assert!(a.bytes().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
    }

    #[test]
    fn a_private_daemon_answers_with_its_secret_only() {
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async {
            let dir = std::env::temp_dir().join(format!("sunray-emb-{}", std::process::id()));
            let rem = EmbeddedRem::start(vec![], Some(dir.clone())).await.unwrap();
            let client = rem::RemClient::connect(&rem.addr, rem.secret.clone())
                .await
                .unwrap();
            let hosts = client.hosts().await.unwrap();
            assert_eq!(hosts[0].name, HOST);
            let wrong = rem::RemClient::connect(&rem.addr, Secret::new("nope").unwrap())
                .await
                .unwrap();
            assert!(wrong.hosts().await.is_err());
            rem.stop().await;
            let _ = std::fs::remove_dir_all(dir);
        });
    }
}
