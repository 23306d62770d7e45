//! Building one child process: arguments, environment (the `REM_*` variables), nice value,
//! process group and parent-death signal; and signalling its group.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Stdio;
use std::time::Duration;

use crate::ids::ProcId;
use crate::wire::env;

/// What a process table needs from the daemon's settings.
#[derive(Clone, Debug)]
pub struct ProcessConfig {
    pub host: String,
    pub addr: String,
    pub allow: Vec<PathBuf>,
    /// Environment handed to every child besides the per-process variables (secret, TLS, limits).
    pub base_env: Vec<(String, String)>,
    pub log_bytes: usize,
    pub kill_grace: Duration,
}

/// One start request, already placed on this host.
#[derive(Clone, Debug, Default)]
pub struct StartSpec {
    pub job: String,
    pub owner: String,
    pub program: String,
    pub args: Vec<String>,
    pub env: BTreeMap<String, String>,
    pub nice: Option<i32>,
    pub count: u32,
}

/// The command for one process of `spec`, with id `id` (not yet started).
pub fn command(cfg: &ProcessConfig, spec: &StartSpec, id: &ProcId) -> tokio::process::Command {
    let mut cmd = tokio::process::Command::new(&spec.program);
    cmd.args(&spec.args)
        .envs(&spec.env)
        .envs(cfg.base_env.iter().map(|(k, v)| (k, v)))
        .env(env::ADDR, &cfg.addr)
        .env(env::HOST, &cfg.host)
        .env(env::PROC_ID, id.as_str())
        .env(env::JOB_ID, &spec.job)
        .env(env::OWNER_ID, &spec.owner)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0);
    let nice = spec.nice;
    // SAFETY: only async-signal-safe calls (setpriority, prctl) between fork and exec; they
    // act on the child alone, so remd keeps its own priority.
    unsafe {
        cmd.pre_exec(move || {
            if let Some(n) = nice {
                if libc::setpriority(libc::PRIO_PROCESS, 0, n) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
            }
            libc::prctl(
                libc::PR_SET_PDEATHSIG,
                libc::SIGKILL as libc::c_ulong,
                0,
                0,
                0,
            );
            Ok(())
        });
    }
    cmd
}

/// Sends `sig` to the process group led by `pid`.
pub fn signal_group(pid: u32, sig: libc::c_int) {
    if pid > 0 {
        // SAFETY: plain syscall; a negative pid addresses the child's process group.
        unsafe {
            libc::kill(-(pid as libc::pid_t), sig);
        }
    }
}
