//! Test harness: daemons on loopback, in this process ([`InProcessRemds`], through
//! `rem::daemon::embedded`) or as real `remd` processes ([`RemdProcesses`], for what is about the
//! process itself: signals, kill -9, its nice value, its command line and environment).
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rem::daemon::config::DaemonSettings;
use rem::daemon::embedded::EmbeddedRemd;
use rem::{HostInfo, Incoming, Relay, RemClient, Secret};

pub const REMD: &str = env!("CARGO_BIN_EXE_remd");
pub const ECHO: &str = env!("CARGO_BIN_EXE_rem-echo");
pub const SECRET: &str = "test-cluster-secret";

/// One remd process; killed (SIGCONT + SIGKILL) when dropped.
pub struct Remd {
    pub name: String,
    pub addr: String,
    pub child: Child,
}

impl Remd {
    pub fn pid(&self) -> i32 {
        self.child.id() as i32
    }

    pub fn signal(&self, sig: i32) {
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

/// What both harnesses offer: daemon addresses, the shared secret, clients, convergence.
pub trait LocalRemds {
    /// The daemons' addresses, in order (a, b, c ...).
    fn addrs(&self) -> Vec<String>;

    /// The cluster secret.
    fn secret(&self) -> Secret {
        Secret::new(SECRET).unwrap()
    }

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

/// `n` daemons in this process, named a, b, c ...; each after the first joins through the
/// first; allowed to run `rem-echo`; `configure` adjusts each one's settings.
pub struct InProcessRemds {
    pub dir: tempfile::TempDir,
    pub daemons: Vec<EmbeddedRemd>,
}

impl InProcessRemds {
    pub async fn start(n: usize, configure: impl Fn(&mut DaemonSettings)) -> InProcessRemds {
        let dir = tempfile::tempdir().unwrap();
        let mut daemons: Vec<EmbeddedRemd> = Vec::new();
        for i in 0..n {
            let name = ((b'a' + i as u8) as char).to_string();
            let mut s = DaemonSettings::new(&name, Secret::new(SECRET).unwrap());
            s.allow_program(ECHO);
            s.state_dir = Some(dir.path().join(format!("state-{name}")));
            s.join = daemons
                .first()
                .map(|d| d.addr().to_string())
                .into_iter()
                .collect();
            configure(&mut s);
            daemons.push(EmbeddedRemd::start(s).await.unwrap());
        }
        InProcessRemds { dir, daemons }
    }
}

impl LocalRemds for InProcessRemds {
    fn addrs(&self) -> Vec<String> {
        self.daemons.iter().map(|d| d.addr().to_string()).collect()
    }
}

/// A cluster of remd processes sharing a secret file and a temp dir.
pub struct RemdProcesses {
    pub dir: tempfile::TempDir,
    pub secret_file: PathBuf,
    pub daemons: Vec<Remd>,
}

impl LocalRemds for RemdProcesses {
    fn addrs(&self) -> Vec<String> {
        self.daemons.iter().map(|d| d.addr.clone()).collect()
    }
}

impl RemdProcesses {
    /// `n` daemons named a, b, c ...; each after the first joins through the first.
    pub fn start(n: usize, extra: &[&str]) -> RemdProcesses {
        RemdProcesses::start_allowing(n, &[ECHO], extra)
    }

    /// Like [`RemdProcesses::start`], with these `--allow` rules instead of rem-echo alone.
    pub fn start_allowing(n: usize, allow: &[&str], extra: &[&str]) -> RemdProcesses {
        let allow: Vec<String> = allow
            .iter()
            .flat_map(|r| ["--allow".to_string(), r.to_string()])
            .collect();
        let extra: Vec<&str> = allow
            .iter()
            .map(String::as_str)
            .chain(extra.iter().copied())
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let secret_file = dir.path().join("secret");
        rem::auth::secret::write_private(&secret_file, format!("{SECRET}\n")).unwrap();
        let mut c = RemdProcesses {
            dir,
            secret_file,
            daemons: Vec::new(),
        };
        for i in 0..n {
            let name = ((b'a' + i as u8) as char).to_string();
            let join = c.daemons.first().map(|d| d.addr.clone());
            let d = c.start_daemon_with(&name, join.as_deref(), &extra);
            c.daemons.push(d);
        }
        c
    }

    /// Starts one more remd (not added to `daemons`), allowed to run rem-echo.
    pub fn start_daemon(&self, name: &str, join: Option<&str>, extra: &[&str]) -> Remd {
        let mut args = vec!["--allow", ECHO];
        args.extend_from_slice(extra);
        self.start_daemon_with(name, join, &args)
    }

    fn start_daemon_with(&self, name: &str, join: Option<&str>, extra: &[&str]) -> Remd {
        let state = self.dir.path().join(format!("state-{name}"));
        let mut cmd = Command::new(REMD);
        cmd.args(["--name", name, "--listen", "127.0.0.1:0"])
            .arg("--secret-file")
            .arg(&self.secret_file)
            .arg("--state-dir")
            .arg(&state)
            .args(extra)
            .env_remove("REM_SECRET")
            .env_remove("REM_SECRET_FILE")
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        if let Some(j) = join {
            cmd.args(["--join", j]);
        }
        let mut child = cmd.spawn().expect("start remd");
        let addr = read_addr(&mut child);
        Remd {
            name: name.to_string(),
            addr,
            child,
        }
    }
}

fn read_addr(child: &mut Child) -> String {
    let out = child.stdout.take().unwrap();
    let mut line = String::new();
    BufReader::new(out).read_line(&mut line).unwrap();
    rem::wire::listening_addr(&line)
        .unwrap_or_else(|| panic!("bad first line {line:?}"))
        .to_string()
}

/// Spawns `rem-echo env SECONDS` on daemon `c`'s host (job `job`) and returns its id and the
/// environment it printed (as `NAME=VALUE` lines, and `uid=N`).
pub async fn spawn_env_printer(
    c: &RemClient,
    job: &str,
    seconds: u32,
) -> (rem::ProcId, std::collections::BTreeMap<String, String>) {
    spawn_env_printer_of(c, ECHO, job, seconds).await
}

/// [`spawn_env_printer`] with rem-echo at another path.
pub async fn spawn_env_printer_of(
    c: &RemClient,
    program: &str,
    job: &str,
    seconds: u32,
) -> (rem::ProcId, std::collections::BTreeMap<String, String>) {
    let spawned = c
        .spawn(rem::SpawnRequest {
            program: program.into(),
            args: vec!["env".into(), seconds.to_string()],
            job: Some(job.into()),
            ..rem::SpawnRequest::default()
        })
        .await
        .unwrap();
    let id = spawned.processes[0].proc_id.clone();
    let end = Instant::now() + Duration::from_secs(10);
    loop {
        let logs = c.logs(&id).await.unwrap();
        let text = String::from_utf8_lossy(&logs.stdout).to_string();
        if text.contains("uid=") {
            let vars = text
                .lines()
                .filter_map(|l| l.split_once('='))
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            return (id, vars);
        }
        assert!(Instant::now() < end, "rem-echo env printed nothing");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// A client of `addr` that proves itself with a spawned process's token.
pub async fn process_client(addr: &str, token: &str) -> RemClient {
    let mut opts = rem::ConnectOptions::new(addr, Secret::new("unused").unwrap());
    opts.credential = rem::Credential::ProcessToken(token.to_string());
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
    pred: impl Fn(&rem::JobEvent) -> bool,
) -> rem::JobEvent {
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

/// The `/proc/PID/stat` fields (1-based numbering as in proc(5)).
pub fn proc_stat_field(pid: u32, field: usize) -> String {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    // Field 2 (comm) may hold spaces; it ends at the last ')'.
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    rest.split_whitespace().nth(field - 3).unwrap().to_string()
}

pub fn exists(p: &Path) -> bool {
    p.exists()
}
