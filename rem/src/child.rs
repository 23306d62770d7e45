//! Building one child process: arguments, environment (the `REM_*` variables), nice value,
//! process group and parent-death signal; and signalling its group.

use std::process::Stdio;

use crate::ids::ProcId;
use crate::process::{ProcessConfig, StartSpec};

/// Environment variables every spawned process receives.
pub mod env {
    /// Address (`HOST:PORT`) of the local remd.
    pub const ADDR: &str = "REM_ADDR";
    /// This host's name.
    pub const HOST: &str = "REM_HOST";
    /// The process's own id (`HOST/NUMBER`).
    pub const PROC_ID: &str = "REM_PROC_ID";
    /// The job id.
    pub const JOB_ID: &str = "REM_JOB_ID";
    /// The process id of the job's owner (empty when the job has none).
    pub const OWNER_ID: &str = "REM_OWNER_ID";
    /// Largest relay payload in bytes.
    pub const MAX_MESSAGE: &str = "REM_MAX_MESSAGE";
    pub use crate::auth::{ENV_SECRET as SECRET, ENV_SECRET_FILE as SECRET_FILE};
    pub use crate::transport::{ENV_TLS_CA as TLS_CA, ENV_TLS_DOMAIN as TLS_DOMAIN};
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
