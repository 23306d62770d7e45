//! remd's settings: command line, environment variables and a TOML file (`--config`), in that
//! order of precedence. The `remd` binary parses its flags and environment into
//! [`DaemonOptions`] (plain values, no parser here); [`DaemonSettings::from_options`] lays them
//! over the file and resolves the result.
//!
//! | flag | environment | file key | default |
//! |---|---|---|---|
//! | `--name` | `REMD_NAME` | `name` | the host name |
//! | `--listen` | `REMD_LISTEN` | `listen` | `127.0.0.1:7077` |
//! | `--advertise` | `REMD_ADVERTISE` | `advertise` | the bound address |
//! | `--join` (comma list) | `REMD_JOIN` | `join` (array) | none |
//! | `--secret-file` | `REM_SECRET_FILE` (or the secret in `REM_SECRET`) | `secret_file` | required |
//! | `--allow` (repeatable) | `REMD_ALLOW` (comma list) | `allow` (array) | nothing may be spawned |
//! | `--allow-any-args` | `REMD_ALLOW_ANY_ARGS` | `allow_any_args` | false: every `allow` entry needs `:FIRST\|FIRST` |
//! | `--env-allow` (repeatable) | `REMD_ENV_ALLOW` | `env_allow` (array) | `SUNRAY_WORKER_*`, `RUST_LOG` |
//! | `--limit NAME=VALUE` (repeatable) | `REMD_LIMITS` | `[limits]` table | see [`Limits`] |
//! | `--run-as` | `REMD_RUN_AS` | `run_as` | remd's own user |
//! | `--insecure` | `REMD_INSECURE` | `insecure` | false: plain HTTP/2 only on loopback |
//! | `--web` | `REMD_WEB` | `web` | off (see [`crate::daemon::web`]) |
//! | `--state-dir` | `REMD_STATE_DIR` | `state_dir` | a fresh temporary directory |
//! | `--probe-ms` | `REMD_PROBE_MS` | `probe_ms` | 200 |
//! | `--suspect-ms` | `REMD_SUSPECT_MS` | `suspect_ms` | 400 |
//! | `--max-message` | `REMD_MAX_MESSAGE` | `max_message` | 16 MiB |
//! | `--kill-grace-ms` | `REMD_KILL_GRACE_MS` | `kill_grace_ms` | 2000 |
//! | `--slots` | `REMD_SLOTS` | `slots` | its cores (a cgroup's CPU limit, rounded up) |
//! | `--owner-first` | `REMD_OWNER_FIRST` | `owner_first` | false: lend every slot, whatever else runs |
//! | `--tls-cert`, `--tls-key`, `--tls-ca`, `--tls-domain` | `REMD_TLS_*` | `tls_*` | no TLS |

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Deserialize;

use crate::auth::secret::Secret;
use crate::daemon::limits::Limits;
use crate::daemon::policy::{ProgramRule, SpawnPolicy, DEFAULT_ENV_ALLOW};
use crate::daemon::process::child::RunAs;
use crate::error::{Error, Result};
use crate::membership::swim::SwimConfig;
use crate::wire::protocol::PROTOCOL;
use crate::wire::transport::ServerTlsFiles;

/// The most render slots one host may lend.
pub const MAX_SLOTS: u32 = 4096;

pub use crate::wire::{DEFAULT_ADDR, DEFAULT_MAX_MESSAGE, DEFAULT_PORT};

/// One layer of remd's options, value by value: what its command line and environment said
/// (the `remd` binary fills it in), or what the TOML file named by `config` says (the same
/// keys, with `_`; `[limits]` a table). [`DaemonSettings::from_options`] lays the first over
/// the second. Empty values leave the layer below (or the default) in place.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DaemonOptions {
    /// TOML file with the same settings (flags and environment win); not a key of the file.
    #[serde(skip)]
    pub config: Option<PathBuf>,
    /// This host's name in the cluster ([A-Za-z0-9._-]).
    pub name: Option<String>,
    /// Address to listen on (port 0 picks one; the bound address is printed).
    pub listen: Option<SocketAddr>,
    /// Address other daemons and processes use to reach this one.
    pub advertise: Option<String>,
    /// Members to join through (any one live member is enough).
    #[serde(default)]
    pub join: Vec<String>,
    /// File holding the cluster secret.
    pub secret_file: Option<PathBuf>,
    /// A program that may be spawned: its absolute path, optionally `:FIRST|FIRST` to allow
    /// only these first arguments, e.g. `/usr/local/bin/sunray:worker|controller` (repeatable).
    #[serde(default)]
    pub allow: Vec<String>,
    /// Accept an `allow` entry without an argument rule (any client may then run it with any
    /// arguments, as remd's user); refused otherwise.
    pub allow_any_args: Option<bool>,
    /// Environment variables a spawn may set: names, or prefixes ending in `*` (repeatable)
    /// [default: SUNRAY_WORKER_*, RUST_LOG].
    #[serde(default)]
    pub env_allow: Vec<String>,
    /// A limit, `NAME=VALUE` (repeatable; sizes take K, M, G): spawn_count, host_processes,
    /// mailbox_bytes, link_bytes, relay_bytes, checkpoint_bytes, checkpoint_quota, log_bytes,
    /// log_quota. See docs/rem.md. In the file, a `[limits]` table of numbers or strings.
    #[serde(default, deserialize_with = "limits_table")]
    pub limits: Vec<String>,
    /// The user spawned processes run as (a name or uid) when remd runs as root.
    pub run_as: Option<String>,
    /// Allow plain HTTP/2 off this host: listening on a non-loopback address, or calling
    /// other daemons there, without TLS.
    pub insecure: Option<bool>,
    /// Serve the web view (hosts, jobs, images filling in) on this address, plain HTTP, for
    /// holders of a login token (`rem web-token`); off by default. Port 0 picks one (the bound
    /// address is printed). Use a loopback address unless a proxy adds TLS.
    pub web: Option<SocketAddr>,
    /// Directory for checkpoints.
    pub state_dir: Option<PathBuf>,
    /// Milliseconds between this daemon's probes of one other member (failure detection;
    /// the probe's timeout is two fifths of it) [default: 200].
    pub probe_ms: Option<u64>,
    /// Milliseconds a member that failed a probe is suspected before it is declared lost
    /// (it can refute meanwhile) [default: 400].
    pub suspect_ms: Option<u64>,
    /// Largest relay message payload in bytes.
    pub max_message: Option<usize>,
    /// Milliseconds between SIGTERM and SIGKILL when a process is killed [default: 2000].
    pub kill_grace_ms: Option<u64>,
    /// Render slots (threads) this host lends the farm [default: its cores, or its cgroup's
    /// CPU limit rounded up].
    pub slots: Option<u32>,
    /// Lend fewer slots while the host's own (non-farm) work keeps its CPUs busy.
    pub owner_first: Option<bool>,
    /// PEM certificate to serve TLS with (with --tls-key; plain HTTP/2 without).
    pub tls_cert: Option<PathBuf>,
    /// PEM private key of --tls-cert.
    pub tls_key: Option<PathBuf>,
    /// CA to verify other daemons with [default: the daemon's own certificate].
    pub tls_ca: Option<PathBuf>,
    /// Name to expect in other daemons' certificates.
    pub tls_domain: Option<String>,
    /// The REM protocol to announce, when newer than this build's (to try a mixed farm, as
    /// during an upgrade); not a key of the file.
    #[serde(skip)]
    pub announce_protocol: Option<u32>,
}

/// Everything a daemon runs with.
#[derive(Clone, Debug)]
pub struct DaemonSettings {
    /// This host's name in the cluster ([A-Za-z0-9._-]).
    pub name: String,
    /// Address to listen on (port 0 lets the OS choose).
    pub listen: SocketAddr,
    /// Address others use to reach this daemon [default: the bound address].
    pub advertise: Option<String>,
    /// Members to join through.
    pub join: Vec<String>,
    /// The cluster secret.
    pub secret: Secret,
    /// Where the secret came from (handed to children as `REM_SECRET_FILE`).
    pub secret_file: Option<PathBuf>,
    /// The programs that may be spawned, and the environment names a spawn may set.
    pub policy: SpawnPolicy,
    /// Hard limits (processes, queued bytes, checkpoints, logs).
    pub limits: Limits,
    /// The user children run as (`None`: remd's own).
    pub run_as: Option<RunAs>,
    /// Plain HTTP/2 is allowed off loopback.
    pub insecure: bool,
    /// Directory for checkpoints [default: a temporary one].
    pub state_dir: Option<PathBuf>,
    /// Where to serve the web view (`None`: no web view).
    pub web: Option<SocketAddr>,
    /// The membership protocol's timing (probe period, suspicion timeout ...).
    pub swim: SwimConfig,
    /// Time between samples of this host's load.
    pub load_interval: Duration,
    /// Largest relay message payload in bytes.
    pub max_message: usize,
    /// Capacity of every relay queue (envelopes).
    pub queue: usize,
    /// Time between SIGTERM and SIGKILL when a process is killed.
    pub kill_grace: Duration,
    /// Render slots lent (`None`: the host's cores, or its cgroup's limit rounded up).
    pub slots: Option<u32>,
    /// Lend fewer slots while the host's own work keeps its CPUs busy.
    pub owner_first: bool,
    /// TLS certificate and key to serve with (`None`: plain HTTP/2).
    pub tls: Option<ServerTlsFiles>,
    /// The REM protocol announced to peers [default: this build's].
    pub protocol: u32,
}

impl DaemonSettings {
    /// Allows `program` (any arguments) to be spawned.
    pub fn allow_program(&mut self, program: impl Into<PathBuf>) {
        self.policy.programs.push(ProgramRule {
            path: program.into(),
            first_args: None,
        });
    }

    /// DaemonSettings with defaults for `name` and `secret` (used by tests and embedders).
    pub fn new(name: &str, secret: Secret) -> Self {
        DaemonSettings {
            name: name.to_string(),
            listen: std::net::SocketAddr::from(([127, 0, 0, 1], DEFAULT_PORT)),
            advertise: None,
            join: Vec::new(),
            secret,
            secret_file: None,
            policy: SpawnPolicy {
                programs: Vec::new(),
                env_allow: DEFAULT_ENV_ALLOW.map(String::from).to_vec(),
            },
            limits: Limits::default(),
            run_as: None,
            insecure: false,
            state_dir: None,
            web: None,
            swim: SwimConfig::default(),
            load_interval: Duration::from_secs(1),
            max_message: DEFAULT_MAX_MESSAGE,
            queue: 4096,
            kill_grace: Duration::from_secs(2),
            slots: None,
            owner_first: false,
            protocol: PROTOCOL,
            tls: None,
        }
    }

    /// Resolves the options (flags and environment) over the file named by `args.config`.
    pub fn from_options(args: DaemonOptions) -> Result<Self> {
        let file = match &args.config {
            Some(path) => load_file(path)?,
            None => DaemonOptions::default(),
        };
        let name = match args.name.or(file.name) {
            Some(n) => n,
            None => sysinfo::System::host_name()
                .map(|h| h.split('.').next().unwrap_or_default().to_string())
                .unwrap_or_default(),
        };
        if !crate::wire::ids::is_valid_name(&name) {
            return Err(Error::Config(format!(
                "bad host name {name:?}: use 1 to 128 of [A-Za-z0-9._-]"
            )));
        }
        let secret_path = args.secret_file.or(file.secret_file);
        if let Some(path) = &secret_path {
            check_secret_file(path)?;
        }
        let (secret, secret_file) = Secret::resolve(secret_path.as_deref())?;
        if secret.is_client_key() {
            return Err(Error::Config(
                "the secret holds a client key (from `rem client-key`); remd needs the cluster \
                 secret itself"
                    .into(),
            ));
        }
        let mut s = DaemonSettings::new(&name, secret);
        s.secret_file = secret_file;
        s.listen = args.listen.or(file.listen).unwrap_or(s.listen);
        s.advertise = args.advertise.or(file.advertise);
        s.join = pick(args.join, file.join);
        s.policy.programs = pick(args.allow, file.allow)
            .iter()
            .map(|rule| ProgramRule::parse(rule))
            .collect::<Result<_>>()?;
        let any_args = args.allow_any_args.or(file.allow_any_args).unwrap_or(false);
        check_argument_rules(&s.policy.programs, any_args)?;
        let env_allow = pick(args.env_allow, file.env_allow);
        if !env_allow.is_empty() {
            s.policy.env_allow = env_allow;
        }
        for pair in file.limits.iter().chain(&args.limits) {
            s.limits.set_pair(pair).map_err(Error::Config)?;
        }
        s.run_as = args
            .run_as
            .or(file.run_as)
            .map(|u| RunAs::lookup(&u))
            .transpose()?;
        s.insecure = args.insecure.or(file.insecure).unwrap_or(false);
        s.state_dir = args.state_dir.or(file.state_dir);
        s.web = args.web.or(file.web);
        if let Some(ms) = args.probe_ms.or(file.probe_ms) {
            if !(20..=60_000).contains(&ms) {
                return Err(Error::Config(format!(
                    "probe-ms {ms} is outside 20..=60000"
                )));
            }
            s.swim.set_probe_period(Duration::from_millis(ms));
        }
        if let Some(ms) = args.suspect_ms.or(file.suspect_ms) {
            if !(20..=600_000).contains(&ms) {
                return Err(Error::Config(format!(
                    "suspect-ms {ms} is outside 20..=600000"
                )));
            }
            s.swim.suspect_after = Duration::from_millis(ms);
        }
        if let Some(m) = args.max_message.or(file.max_message) {
            s.max_message = m.max(1);
        }
        if let Some(ms) = args.kill_grace_ms.or(file.kill_grace_ms) {
            s.kill_grace = Duration::from_millis(ms);
        }
        s.slots = checked_slots(args.slots.or(file.slots))?;
        s.owner_first = args.owner_first.or(file.owner_first).unwrap_or(false);
        s.protocol = announced_protocol(args.announce_protocol)?;
        let cert = args.tls_cert.or(file.tls_cert);
        let key = args.tls_key.or(file.tls_key);
        s.tls = match (cert, key) {
            (Some(cert), Some(key)) => Some(ServerTlsFiles {
                cert,
                key,
                ca: args.tls_ca.or(file.tls_ca),
                domain: args.tls_domain.or(file.tls_domain),
            }),
            (None, None) => None,
            _ => {
                return Err(Error::Config(
                    "TLS needs both --tls-cert and --tls-key".into(),
                ))
            }
        };
        Ok(s)
    }
}

/// The slots to lend, if set: at most [`MAX_SLOTS`].
fn checked_slots(slots: Option<u32>) -> Result<Option<u32>> {
    match slots {
        Some(n) if n > MAX_SLOTS => Err(Error::Config(format!(
            "slots {n} is outside 0..={MAX_SLOTS}"
        ))),
        s => Ok(s),
    }
}

/// The protocol to announce: this build's, or a newer one asked for (`--announce-protocol`).
fn announced_protocol(asked: Option<u32>) -> Result<u32> {
    match asked {
        Some(p) if p < PROTOCOL => Err(Error::Config(format!(
            "--announce-protocol {p}: this remd speaks protocol {PROTOCOL}, and announces no \
             older one"
        ))),
        Some(p) => Ok(p),
        None => Ok(PROTOCOL),
    }
}

/// The file's `[limits]` table (numbers, or strings such as "64M") as `NAME=VALUE` pairs,
/// the form of `--limit`.
fn limits_table<'de, D: serde::Deserializer<'de>>(
    de: D,
) -> std::result::Result<Vec<String>, D::Error> {
    let table = std::collections::BTreeMap::<String, toml::Value>::deserialize(de)?;
    Ok(table
        .into_iter()
        .map(|(name, value)| match value {
            toml::Value::String(v) => format!("{name}={v}"),
            other => format!("{name}={other}"),
        })
        .collect())
}

/// Refuses a secret file that other users may read (or that cannot be examined).
/// Refuses an allowed program without an argument rule, unless the administrator said so
/// (`any_args`): with any arguments a multi-tool such as `sunray` writes files wherever remd's
/// user can (`sunray spd ... -o ANYPATH`) for whoever holds a client key.
fn check_argument_rules(programs: &[ProgramRule], any_args: bool) -> Result<()> {
    match programs.iter().find(|r| r.first_args.is_none()) {
        Some(rule) if !any_args => Err(Error::Config(format!(
            "--allow {0}: no argument rule, so any client could run it with any arguments; \
             write {0}:FIRST|FIRST (for sunray: {0}:worker|controller), or add \
             --allow-any-args to mean it",
            rule.path.display()
        ))),
        _ => Ok(()),
    }
}

fn check_secret_file(path: &Path) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    let meta = std::fs::metadata(path)
        .map_err(|e| Error::Config(format!("cannot read secret file {}: {e}", path.display())))?;
    let mode = meta.permissions().mode();
    if mode & 0o004 != 0 {
        return Err(Error::Config(format!(
            "secret file {} is readable by every user (mode {:o}): chmod 600 it",
            path.display(),
            mode & 0o777
        )));
    }
    if mode & 0o040 != 0 {
        tracing::warn!(
            file = %path.display(),
            "the secret file is readable by its group: every member can act as a daemon"
        );
    }
    Ok(())
}

fn pick<T>(flags: Vec<T>, file: Vec<T>) -> Vec<T> {
    if flags.is_empty() {
        file
    } else {
        flags
    }
}

fn load_file(path: &Path) -> Result<DaemonOptions> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::Config(format!("cannot read {}: {e}", path.display())))?;
    toml::from_str(&text).map_err(|e| Error::Config(format!("{}: {e}", path.display())))
}

#[cfg(test)]
mod tests;
