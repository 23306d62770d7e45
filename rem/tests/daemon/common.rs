//! rem's test clusters, on the shared harness (`rem::testing`): daemons allowed to run
//! `rem-echo`, sharing [`SECRET`], in this process ([`in_process`]) or as real `remd`
//! processes ([`remds`]); and what only these tests need (rem-echo's environment, /proc).
#![allow(dead_code)]

use std::time::{Duration, Instant};

use rem::daemon::config::DaemonSettings;
pub use rem::testing::{
    next_event, process_client, wait_hosts, InProcessRemds, LocalRemds, Remd, RemdProcesses,
};
use rem::RemClient;

pub const REMD: &str = env!("CARGO_BIN_EXE_remd");
pub const ECHO: &str = env!("CARGO_BIN_EXE_rem-echo");
pub const SECRET: &str = "test-cluster-secret";

/// `n` daemons in this process, allowed to run `rem-echo`; `configure` adjusts each one's
/// settings.
pub async fn in_process(n: usize, configure: impl Fn(&mut DaemonSettings)) -> InProcessRemds {
    InProcessRemds::start(n, SECRET, &[ECHO], configure).await
}

/// `n` remd processes named a, b, c ..., allowed to run `rem-echo`, with `extra` flags; each
/// after the first joins through the first.
pub fn remds(n: usize, extra: &[&str]) -> RemdProcesses {
    remds_allowing(n, &[ECHO], extra)
}

/// Like [`remds`], with these `--allow` rules instead of rem-echo alone (rem-echo is a test
/// program, allowed with any arguments: `--allow-any-args`).
pub fn remds_allowing(n: usize, allow: &[&str], extra: &[&str]) -> RemdProcesses {
    let mut c = RemdProcesses::new(REMD, SECRET);
    let flags: Vec<String> = allow
        .iter()
        .flat_map(|r| ["--allow", r])
        .chain(["--allow-any-args"])
        .chain(extra.iter().copied())
        .map(String::from)
        .collect();
    c.start_all(n, |_| flags.clone());
    c
}

/// Starts one more remd in `cluster` (not added to its daemons), allowed to run rem-echo.
pub fn start_daemon(
    cluster: &RemdProcesses,
    name: &str,
    join: Option<&str>,
    extra: &[&str],
) -> Remd {
    let flags: Vec<String> = ["--allow", ECHO, "--allow-any-args"]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect();
    cluster.launch(name, join, &flags, std::process::Stdio::inherit())
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

/// The `/proc/PID/stat` fields (1-based numbering as in proc(5)).
pub fn proc_stat_field(pid: u32, field: usize) -> String {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    // Field 2 (comm) may hold spaces; it ends at the last ')'.
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    rest.split_whitespace().nth(field - 3).unwrap().to_string()
}
