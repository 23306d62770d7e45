//! Test harness (the `testing` feature): remd daemons on loopback, in this process
//! ([`InProcessRemds`], through [`EmbeddedRemd`]) or as real `remd` processes
//! ([`RemdProcesses`], for what is about the process itself: signals, kill -9, its nice value,
//! its command line, environment and output), and what tests do with them (clients,
//! convergence, waiting for hosts and events). Used by rem's own tests and benches and by the
//! workspace's end-to-end tests; the paths of the binaries (`env!("CARGO_BIN_EXE_remd")`),
//! the secret and the programs the daemons may run come from them.
// Test support: a failed step panics, as in the tests themselves.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::daemon::config::DaemonSettings;
use crate::daemon::embedded::EmbeddedRemd;
use crate::wire::{listening_addr, web_view_url};
use crate::{HostInfo, Incoming, JobEvent, Relay, RemClient, Secret};

/// The name of the `i`th daemon of a test cluster: a, b, c ...
pub fn daemon_name(i: usize) -> String {
    ((b'a' + i as u8) as char).to_string()
}

/// One remd process; killed (SIGCONT + SIGKILL) when dropped.
pub struct Remd {
    /// Its name in the cluster.
    pub name: String,
    /// The address it listens on.
    pub addr: String,
    /// The web view's URL (`http://127.0.0.1:PORT/`) when it was started with `--web`.
    pub web: Option<String>,
    /// The process.
    pub child: Child,
}

impl Remd {
    /// The process id.
    pub fn pid(&self) -> i32 {
        self.child.id() as i32
    }

    /// Sends the daemon signal `sig`.
    pub fn signal(&self, sig: i32) {
        // SAFETY: kill(2) has no memory-safety preconditions; the child is ours (not reaped
        // before drop).
        unsafe {
            libc::kill(self.pid(), sig);
        }
    }

    /// Waits for the process to exit (bounded).
    pub fn wait_exit(&mut self, timeout: Duration) -> Option<std::process::ExitStatus> {
        let end = Instant::now() + timeout;
        while Instant::now() < end {
            if let Ok(Some(st)) = self.child.try_wait() {
                return Some(st);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    }
}

impl Drop for Remd {
    fn drop(&mut self) {
        self.signal(libc::SIGCONT);
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// What both kinds of local cluster offer: daemon addresses, the shared secret, clients,
/// convergence.
#[allow(async_fn_in_trait)]
pub trait LocalRemds {
    /// The daemons' addresses, in order (a, b, c ...).
    fn addrs(&self) -> Vec<String>;

    /// The cluster secret.
    fn secret(&self) -> Secret;

    /// A client of daemon `i`.
    async fn client(&self, i: usize) -> RemClient {
        RemClient::connect(&self.addrs()[i], self.secret())
            .await
            .unwrap()
    }

    /// Waits until every daemon sees every other alive.
    async fn converge(&self, timeout: Duration) {
        let n = self.addrs().len();
        for i in 0..n {
            let c = self.client(i).await;
            wait_hosts(&c, timeout, |hosts| {
                hosts.len() == n && hosts.iter().all(|h| h.alive)
            })
            .await;
        }
    }
}

/// Daemons in this process, named a, b, c ...; each after the first joins through the first.
pub struct InProcessRemds {
    /// Their state directories are under it.
    pub dir: tempfile::TempDir,
    /// The daemons, in order.
    pub daemons: Vec<EmbeddedRemd>,
    secret: Secret,
}

impl InProcessRemds {
    /// `n` daemons sharing `secret`, allowed to run `programs`; `configure` adjusts each one's
    /// settings last.
    pub async fn start(
        n: usize,
        secret: &str,
        programs: &[&str],
        configure: impl Fn(&mut DaemonSettings),
    ) -> InProcessRemds {
        let dir = tempfile::tempdir().unwrap();
        let secret = Secret::new(secret).unwrap();
        let mut daemons: Vec<EmbeddedRemd> = Vec::new();
        for i in 0..n {
            let name = daemon_name(i);
            let mut s = DaemonSettings::new(&name, secret.clone());
            for p in programs {
                s.allow_program(p);
            }
            s.state_dir = Some(dir.path().join(format!("state-{name}")));
            s.join = daemons
                .first()
                .map(|d| d.addr().to_string())
                .into_iter()
                .collect();
            configure(&mut s);
            daemons.push(EmbeddedRemd::start(s).await.unwrap());
        }
        InProcessRemds {
            dir,
            daemons,
            secret,
        }
    }
}

impl LocalRemds for InProcessRemds {
    fn addrs(&self) -> Vec<String> {
        self.daemons.iter().map(|d| d.addr().to_string()).collect()
    }

    fn secret(&self) -> Secret {
        self.secret.clone()
    }
}

/// remd processes sharing a secret file and a temporary directory (their state directories
/// are `state-NAME` in it).
pub struct RemdProcesses {
    /// The shared directory.
    pub dir: tempfile::TempDir,
    /// The file holding the secret (mode 600).
    pub secret_file: PathBuf,
    /// The daemons started with [`RemdProcesses::start_all`] or pushed by the caller.
    pub daemons: Vec<Remd>,
    remd: PathBuf,
    secret: Secret,
}

impl LocalRemds for RemdProcesses {
    fn addrs(&self) -> Vec<String> {
        self.daemons.iter().map(|d| d.addr.clone()).collect()
    }

    fn secret(&self) -> Secret {
        self.secret.clone()
    }
}

impl RemdProcesses {
    /// No daemons yet: the directory and the secret file; daemons run the `remd` binary.
    pub fn new(remd: impl Into<PathBuf>, secret: &str) -> RemdProcesses {
        let dir = tempfile::tempdir().unwrap();
        let secret_file = dir.path().join("secret");
        crate::auth::secret::write_private(&secret_file, format!("{secret}\n")).unwrap();
        RemdProcesses {
            dir,
            secret_file,
            daemons: Vec::new(),
            remd: remd.into(),
            secret: Secret::new(secret).unwrap(),
        }
    }

    /// Starts daemons a, b, c ... until there are `n`, each after the first joining through
    /// the first, each with `flags(name)`, its stderr inherited.
    pub fn start_all(&mut self, n: usize, flags: impl Fn(&str) -> Vec<String>) {
        for i in self.daemons.len()..n {
            let name = daemon_name(i);
            let join = self.daemons.first().map(|d| d.addr.clone());
            let d = self.launch(&name, join.as_deref(), &flags(&name), Stdio::inherit());
            self.daemons.push(d);
        }
    }

    /// Daemon `name`'s state directory.
    pub fn state_dir(&self, name: &str) -> PathBuf {
        self.dir.path().join(format!("state-{name}"))
    }

    /// The daemon named `name`.
    pub fn daemon(&self, name: &str) -> &Remd {
        self.daemons.iter().find(|d| d.name == name).unwrap()
    }

    /// Starts one remd named `name` (not added to `daemons`) on a loopback port the OS picks,
    /// with the cluster's secret file, its state directory, `--join join` and `flags`, its
    /// stderr to `stderr`; waits for its address (and, with `--web` among the flags, its web
    /// view's URL).
    pub fn launch(&self, name: &str, join: Option<&str>, flags: &[String], stderr: Stdio) -> Remd {
        let mut cmd = Command::new(&self.remd);
        cmd.args(["--name", name, "--listen", "127.0.0.1:0"])
            .arg("--secret-file")
            .arg(&self.secret_file)
            .arg("--state-dir")
            .arg(self.state_dir(name))
            .args(flags)
            .env_remove("REM_SECRET")
            .env_remove("REM_SECRET_FILE")
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(stderr);
        if let Some(j) = join {
            cmd.args(["--join", j]);
        }
        let mut child = cmd.spawn().expect("start remd");
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let addr = read_line(&mut out, listening_addr, "first");
        let web = flags
            .iter()
            .any(|f| f == "--web")
            .then(|| read_line(&mut out, web_view_url, "second"));
        Remd {
            name: name.to_string(),
            addr,
            web,
            child,
        }
    }
}

/// The value `parse` finds in the next line of remd's output.
fn read_line(out: &mut impl BufRead, parse: fn(&str) -> Option<&str>, which: &str) -> String {
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    parse(&line)
        .unwrap_or_else(|| panic!("bad {which} line {line:?}"))
        .to_string()
}

/// A client of `addr` that proves itself with a spawned process's token.
pub async fn process_client(addr: &str, token: &str) -> RemClient {
    let mut opts = crate::ConnectOptions::new(addr, Secret::new("unused").unwrap());
    opts.credential = crate::Credential::ProcessToken(token.to_string());
    RemClient::connect_with(opts).await.unwrap()
}

/// Polls `rem hosts` until `pred` holds; panics after `timeout`. Returns the hosts.
pub async fn wait_hosts(
    c: &RemClient,
    timeout: Duration,
    pred: impl Fn(&[HostInfo]) -> bool,
) -> Vec<HostInfo> {
    let end = Instant::now() + timeout;
    loop {
        let hosts = c.hosts().await.unwrap();
        if pred(&hosts) {
            return hosts;
        }
        assert!(
            Instant::now() < end,
            "condition not reached in {timeout:?}: {hosts:#?}"
        );
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
}

/// The next job event on `relay` matching `pred` (bounded).
pub async fn next_event(
    relay: &mut Relay,
    timeout: Duration,
    pred: impl Fn(&JobEvent) -> bool,
) -> JobEvent {
    tokio::time::timeout(timeout, async {
        loop {
            match relay.recv().await.unwrap() {
                Incoming::Event(e) if pred(&e) => return e,
                _ => {}
            }
        }
    })
    .await
    .expect("event did not arrive in time")
}
