//! Real `remd` processes on loopback for `sunray submit` against a real farm: a small cluster
//! of them sharing a secret ([`LoopbackCluster`]) on the shared harness
//! ([`rem::testing::RemdProcesses`]), with the farm's flags, the daemons' logs, and the
//! sunray commands and record checks these tests need.

use super::bins::{remd_bin, sunray, sunray_bin};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub use rem::testing::Remd;
use rem::testing::RemdProcesses;

/// The job lease of a [`LoopbackCluster`]'s daemons (`job_lease_ms`): a farm job's controller
/// that writes nothing for this long is replaced.
pub const LEASE_MS: u64 = 3000;

/// How long a [`LoopbackCluster`]'s daemons suspect a member before declaring it lost.
const SUSPECT_MS: u64 = 300;

/// The secret of a [`LoopbackCluster`].
pub const SECRET: &str = "submit-test-secret";

/// `n` remd daemons named a, b, c ... on loopback, sharing a secret, allowed to run sunray
/// (the harness's [`RemdProcesses`], which it derefs to: `daemons`, `secret_file`, `dir`,
/// `state_dir`, `daemon`).
pub struct LoopbackCluster(RemdProcesses);

impl std::ops::Deref for LoopbackCluster {
    type Target = RemdProcesses;
    fn deref(&self) -> &RemdProcesses {
        &self.0
    }
}

impl std::ops::DerefMut for LoopbackCluster {
    fn deref_mut(&mut self) -> &mut RemdProcesses {
        &mut self.0
    }
}

impl LoopbackCluster {
    pub fn start(n: usize) -> LoopbackCluster {
        LoopbackCluster::start_with(n, |_, _| {})
    }

    /// [`LoopbackCluster::start`], calling `prepare(name, state_dir)` before each daemon
    /// starts (to mount a file system at a part of its state directory, say).
    pub fn start_with(n: usize, prepare: impl Fn(&str, &Path)) -> LoopbackCluster {
        LoopbackCluster::start_inner(n, false, SUSPECT_MS, prepare, &[])
    }

    /// [`LoopbackCluster::start`], every daemon with these remd flags too (`--slots 1`).
    pub fn start_with_flags(n: usize, extra: &[&str]) -> LoopbackCluster {
        LoopbackCluster::start_inner(n, false, SUSPECT_MS, |_, _| {}, extra)
    }

    /// [`LoopbackCluster::start`] with daemons that suspect a member that fails a probe for
    /// `suspect_ms` before they declare it lost (a farm tuned against false alarms: a
    /// stopped host counts as live that long).
    pub fn start_suspecting_for(n: usize, suspect_ms: u64) -> LoopbackCluster {
        LoopbackCluster::start_inner(n, false, suspect_ms, |_, _| {}, &[])
    }

    /// [`LoopbackCluster::start`], daemon `a` serving its web view too (`--web`, on a port the
    /// OS picks; [`LoopbackCluster::web_url`]).
    pub fn start_web(n: usize) -> LoopbackCluster {
        LoopbackCluster::start_web_with(n, &[])
    }

    /// [`LoopbackCluster::start_web`], every daemon with these remd flags too.
    pub fn start_web_with(n: usize, extra: &[&str]) -> LoopbackCluster {
        LoopbackCluster::start_inner(n, true, SUSPECT_MS, |_, _| {}, extra)
    }

    /// The web view's URL of daemon `a` (started by [`LoopbackCluster::start_web`]).
    pub fn web_url(&self) -> String {
        self.daemons[0].web.clone().expect("started with start_web")
    }

    fn start_inner(
        n: usize,
        web: bool,
        suspect_ms: u64,
        prepare: impl Fn(&str, &Path),
        extra: &[&str],
    ) -> LoopbackCluster {
        let mut c = LoopbackCluster(RemdProcesses::new(remd_bin(), SECRET));
        for i in 0..n {
            let name = rem::testing::daemon_name(i);
            let join = c.daemons.first().map(|d| d.addr.clone());
            prepare(&name, &c.state_dir(&name));
            let d = c.start_daemon(&name, join.as_deref(), web && i == 0, suspect_ms, extra);
            c.daemons.push(d);
        }
        c.converge(n);
        c
    }

    /// What daemon `name` has logged (its stderr, warnings and errors).
    pub fn log(&self, name: &str) -> String {
        std::fs::read_to_string(self.dir.path().join(format!("remd-{name}.log")))
            .unwrap_or_default()
    }

    fn start_daemon(
        &self,
        name: &str,
        join: Option<&str>,
        web: bool,
        suspect_ms: u64,
        extra: &[&str],
    ) -> Remd {
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(self.dir.path().join(format!("remd-{name}.log")))
            .unwrap();
        let mut flags: Vec<String> = ["--probe-ms", "150", "--suspect-ms"]
            .map(String::from)
            .to_vec();
        flags.push(suspect_ms.to_string());
        // A stopped farm-job controller is replaced after 3 s without a record write.
        flags.extend(["--limit".into(), format!("job_lease_ms={LEASE_MS}")]);
        flags.extend([
            "--allow".into(),
            format!("{}:worker|controller", sunray_bin().display()),
        ]);
        if web {
            flags.extend(["--web".into(), "127.0.0.1:0".into()]);
        }
        flags.extend(extra.iter().map(|f| f.to_string()));
        self.launch(name, join, &flags, Stdio::from(log))
    }

    /// Runs `f` with a client of daemon `a`, on a runtime of its own.
    fn with_client<T, F: std::future::Future<Output = T>>(
        &self,
        f: impl FnOnce(rem::RemClient) -> F,
    ) -> T {
        self.with_client_of(&self.daemons[0].name, f)
    }

    /// Runs `f` with a client of daemon `name`, on a runtime of its own.
    fn with_client_of<T, F: std::future::Future<Output = T>>(
        &self,
        name: &str,
        f: impl FnOnce(rem::RemClient) -> F,
    ) -> T {
        let addr = self.daemon(name).addr.clone();
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            let secret = rem::Secret::new(SECRET).unwrap();
            let client = rem::RemClient::connect(&addr, secret).await.unwrap();
            f(client).await
        })
    }

    /// Waits until the first daemon sees all `n` hosts alive (bounded).
    fn converge(&self, n: usize) {
        self.wait_alive(&self.daemons[0].name.clone(), n)
    }

    /// Waits (bounded) until daemon `via` sees exactly `n` hosts alive.
    pub fn wait_alive(&self, via: &str, n: usize) {
        self.wait_hosts(via, |alive| alive == n)
    }

    /// Waits (bounded) until daemon `via` sees at least `n` hosts alive (a daemon just
    /// started again has heard of its peers).
    pub fn wait_alive_at_least(&self, via: &str, n: usize) {
        self.wait_hosts(via, |alive| alive >= n)
    }

    fn wait_hosts(&self, via: &str, enough: impl Fn(usize) -> bool) {
        self.with_client_of(via, |client| async move {
            let end = Instant::now() + Duration::from_secs(20);
            loop {
                let hosts = client.hosts().await.unwrap();
                if enough(hosts.iter().filter(|h| h.alive).count()) {
                    return;
                }
                assert!(Instant::now() < end, "cluster did not converge: {hosts:#?}");
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    }

    /// The REM processes of the cluster, as daemon `via` lists them.
    pub fn processes_via(&self, via: &str) -> Vec<rem::ProcessInfo> {
        self.with_client_of(via, |client| async move { client.ps().await.unwrap() })
    }

    /// The kept output of REM process `proc_id` (stdout, then stderr), through daemon `via`.
    pub fn output_via(&self, via: &str, proc_id: &str) -> String {
        let id = rem::ProcId::parse(proc_id).unwrap();
        self.with_client_of(via, |client| async move {
            let logs = client.logs(&id).await.unwrap();
            format!(
                "{}{}",
                String::from_utf8_lossy(&logs.stdout),
                String::from_utf8_lossy(&logs.stderr)
            )
        })
    }

    /// The farm's queue, through daemon `a`.
    pub fn queue(&self) -> rem::wire::proto::QueueReply {
        self.with_client(|client| async move { client.queue().await.unwrap() })
    }

    /// A client-key file of `user` (made from the cluster's secret on first use): commands
    /// given it act as that user alone.
    pub fn key_file(&self, user: &str) -> std::path::PathBuf {
        let path = self.dir.path().join(format!("{user}.key"));
        if !path.exists() {
            let secret = rem::Secret::new(SECRET).unwrap();
            std::fs::write(&path, secret.client_key_line(user).unwrap()).unwrap();
        }
        path
    }

    /// A `sunray` command acting as `user` (its client key), talking to daemon `via`.
    pub fn sunray_as(&self, user: &str, via: &str) -> Command {
        let mut c = self.sunray_via(via);
        c.env("REM_SECRET_FILE", self.key_file(user));
        c
    }

    /// The REM processes of the cluster (to check that nothing was started).
    pub fn processes(&self) -> Vec<rem::ProcessInfo> {
        self.with_client(|client| async move { client.ps().await.unwrap() })
    }

    /// The record of job `id` as daemon `via` lists it.
    pub fn record(&self, via: &str, id: &str) -> Option<rem::JobRecord> {
        let id = id.to_string();
        self.with_client_of(via, |client| async move {
            client
                .list_jobs()
                .await
                .unwrap()
                .into_iter()
                .find(|r| r.id == id)
        })
    }

    /// What REM's store keeps under `key` (the test user's), through daemon `via`.
    pub fn stored(&self, via: &str, key: &str) -> Option<Vec<u8>> {
        let key = key.to_string();
        self.with_client_of(via, |client| async move {
            client.get_checkpoint(&key).await.unwrap()
        })
    }

    /// Stores `record` through daemon `via` (as its user), as a successor controller would.
    pub fn put_record(&self, via: &str, record: rem::JobRecord) {
        self.with_client_of(via, |client| async move {
            client.put_job(record).await.unwrap();
        })
    }

    /// Waits (bounded) until daemon `via` lists job `id` with a record `pred` accepts.
    pub fn wait_record(
        &self,
        via: &str,
        id: &str,
        what: &str,
        pred: impl Fn(&rem::JobRecord) -> bool,
    ) -> rem::JobRecord {
        let end = Instant::now() + Duration::from_secs(60);
        loop {
            if let Some(r) = self.record(via, id).filter(|r| pred(r)) {
                return r;
            }
            assert!(
                Instant::now() < end,
                "job {id} never {what}: {:?}",
                self.record(via, id)
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// A `sunray` command with the cluster's secret, talking to daemon `via`.
    pub fn sunray_via(&self, via: &str) -> Command {
        let mut c = sunray();
        c.env("REM_ADDR", &self.daemon(via).addr)
            .env("REM_SECRET_FILE", &self.secret_file)
            .env_remove("REM_SECRET");
        c
    }

    /// Kills daemon `name` with SIGKILL (its processes die with it) and waits for it.
    pub fn kill_daemon(&mut self, name: &str) {
        let d = self.daemons.iter_mut().find(|d| d.name == name).unwrap();
        let _ = d.child.kill();
        let _ = d.child.wait();
    }

    /// Ends daemon `name` with SIGTERM (it ends its processes first) and waits for it
    /// (bounded; then SIGKILL).
    pub fn stop_daemon(&mut self, name: &str) {
        let d = self.daemons.iter_mut().find(|d| d.name == name).unwrap();
        d.signal(libc::SIGTERM);
        if d.wait_exit(Duration::from_secs(10)).is_none() {
            let _ = d.child.kill();
            let _ = d.child.wait();
        }
    }

    /// Starts daemon `name` (killed or stopped before) again on its state directory, joining
    /// the cluster through daemon `join_via`; it listens on a new port.
    pub fn restart_daemon(&mut self, name: &str, join_via: &str) {
        self.restart_daemon_with(name, join_via, &[]);
    }

    /// [`LoopbackCluster::restart_daemon`] with `extra` flags (a newer announced protocol,
    /// say: what an upgraded daemon would be).
    pub fn restart_daemon_with(&mut self, name: &str, join_via: &str, extra: &[&str]) {
        let join = self.daemon(join_via).addr.clone();
        let d = self.start_daemon(name, Some(&join), false, SUSPECT_MS, extra);
        let slot = self.daemons.iter_mut().find(|d| d.name == name).unwrap();
        *slot = d;
    }

    /// `sunray submit` against daemon `a`.
    pub fn submit(&self) -> Command {
        let mut c = sunray();
        c.arg("submit")
            .arg("--remd")
            .arg(&self.daemons[0].addr)
            .arg("--secret-file")
            .arg(&self.secret_file);
        c
    }
}
