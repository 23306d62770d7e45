//! Building one child process: arguments, a clean environment (only `PATH`, the variables
//! the spawn was allowed to set, and the `REM_*` variables remd sets; nothing of remd's own
//! environment, so no `LD_PRELOAD` or secret reaches it), nice value, the user it runs as,
//! process group and parent-death signal; and signalling its group.

use std::collections::BTreeMap;
use std::process::Stdio;
use std::time::Duration;

use crate::auth::token::Token;
use crate::daemon::limits::Limits;
use crate::daemon::policy::SpawnPolicy;
use crate::wire::env;
use crate::wire::ids::ProcId;

/// The `PATH` every child gets.
pub const CHILD_PATH: &str = "/usr/local/bin:/usr/bin:/bin";

/// The user and group children run as (when remd runs as root).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunAs {
    /// User id.
    pub uid: u32,
    /// Group id.
    pub gid: u32,
}

impl RunAs {
    /// Looks a user up by name (or takes a number) in the system's user database.
    pub fn lookup(user: &str) -> crate::Result<Self> {
        if let Ok(uid) = user.parse::<u32>() {
            return Ok(RunAs { uid, gid: uid });
        }
        let name = std::ffi::CString::new(user)
            .map_err(|_| crate::Error::Config(format!("bad user name {user:?}")))?;
        // SAFETY: getpwnam returns a pointer into static storage or null; it is read at once,
        // before any other call could reuse it (remd reads settings before starting threads
        // that look users up).
        let pw = unsafe { libc::getpwnam(name.as_ptr()) };
        if pw.is_null() {
            return Err(crate::Error::Config(format!(
                "no user {user:?} on this host"
            )));
        }
        // SAFETY: non-null, points to a valid passwd record.
        let (uid, gid) = unsafe { ((*pw).pw_uid, (*pw).pw_gid) };
        Ok(RunAs { uid, gid })
    }
}

/// What a process table needs from the daemon's settings.
#[derive(Clone, Debug)]
pub struct ProcessConfig {
    pub host: String,
    pub addr: String,
    pub policy: SpawnPolicy,
    pub limits: Limits,
    /// Environment handed to every child besides the per-process variables (TLS, limits).
    pub base_env: Vec<(String, String)>,
    pub kill_grace: Duration,
    /// The user children run as (`None`: remd's own).
    pub run_as: Option<RunAs>,
    /// The host's process cache, given to every child (`REM_CACHE_DIR`).
    pub cache_dir: Option<std::path::PathBuf>,
}

/// One start request, already placed on this host.
#[derive(Clone, Debug, Default)]
pub struct StartSpec {
    pub job: String,
    pub owner: String,
    /// The user the processes belong to.
    pub user: String,
    pub program: String,
    pub args: Vec<String>,
    pub env: BTreeMap<String, String>,
    pub nice: Option<i32>,
    pub count: u32,
    /// For a job's controller: the job record it runs and its epoch (empty, 0 otherwise).
    pub job_record: String,
    pub job_epoch: u64,
    /// Render slots each process holds: at least `slots_min` (0: none, not counted), at
    /// most `slots_max` (0: all that are free).
    pub slots_min: u32,
    pub slots_max: u32,
}

/// The command for one process of `spec`, with id `id` and attach token `token` (not yet
/// started). `spec.env` must have passed the daemon's [`SpawnPolicy`].
pub fn command(
    cfg: &ProcessConfig,
    spec: &StartSpec,
    id: &ProcId,
    (token, slots): (&Token, u32),
) -> tokio::process::Command {
    let mut cmd = tokio::process::Command::new(&spec.program);
    cmd.args(&spec.args)
        .env_clear()
        .env("PATH", CHILD_PATH)
        .envs(&spec.env)
        .envs(cfg.base_env.iter().map(|(k, v)| (k, v)))
        .env(env::PROC_TOKEN, token.as_str())
        .env(env::ADDR, &cfg.addr)
        .env(env::HOST, &cfg.host)
        .env(env::PROC_ID, id.as_str())
        .env(env::JOB_ID, &spec.job)
        .env(env::OWNER_ID, &spec.owner)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0);
    if let Some(dir) = &cfg.cache_dir {
        cmd.env(env::CACHE_DIR, dir);
    }
    if !spec.job_record.is_empty() {
        cmd.env(env::JOB_RECORD, &spec.job_record)
            .env(env::JOB_EPOCH, spec.job_epoch.to_string());
    }
    if spec.slots_min > 0 {
        cmd.env(env::SLOTS, slots.to_string());
    }
    if let Some(user) = cfg.run_as {
        // std drops the supplementary groups when it changes the user as root.
        cmd.uid(user.uid).gid(user.gid);
    }
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
