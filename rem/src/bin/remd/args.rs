//! remd's command line: the clap flags ([`RemdArgs`]), handed to the library as plain
//! [`DaemonOptions`], which `rem::daemon::config` resolves with a TOML file into the daemon's
//! settings. The library itself knows no flag parser.

use std::net::SocketAddr;
use std::path::PathBuf;

use clap::Parser;
use rem::daemon::config::DaemonOptions;

/// remd's command line.
#[derive(Parser, Debug, Default, Clone)]
#[command(
    name = "remd",
    version,
    about = "REM daemon: runs processes for the cluster and relays their messages"
)]
pub struct RemdArgs {
    /// TOML file with the same settings (flags and environment win).
    #[arg(long, env = "REMD_CONFIG")]
    pub config: Option<PathBuf>,
    /// This host's name in the cluster ([A-Za-z0-9._-]).
    #[arg(long, env = "REMD_NAME")]
    pub name: Option<String>,
    /// Address to listen on (port 0 picks one; the bound address is printed).
    #[arg(long, env = "REMD_LISTEN")]
    pub listen: Option<SocketAddr>,
    /// Address other daemons and processes use to reach this one.
    #[arg(long, env = "REMD_ADVERTISE")]
    pub advertise: Option<String>,
    /// Members to join through (any one live member is enough).
    #[arg(long, env = "REMD_JOIN", value_delimiter = ',')]
    pub join: Vec<String>,
    /// File holding the cluster secret.
    #[arg(long, env = "REM_SECRET_FILE")]
    pub secret_file: Option<PathBuf>,
    /// A program that may be spawned: its absolute path, optionally `:FIRST|FIRST` to allow
    /// only these first arguments, e.g. `/usr/local/bin/sunray:worker|controller` (repeatable).
    #[arg(long = "allow", env = "REMD_ALLOW", value_delimiter = ',')]
    pub allow: Vec<String>,
    /// Accept `--allow PATH` without an argument rule: any client may then run PATH with any
    /// arguments, as remd's user (refused without this flag).
    #[arg(long, env = "REMD_ALLOW_ANY_ARGS")]
    pub allow_any_args: bool,
    /// Environment variables a spawn may set: names, or prefixes ending in `*` (repeatable)
    /// [default: SUNRAY_WORKER_*, RUST_LOG].
    #[arg(long = "env-allow", env = "REMD_ENV_ALLOW", value_delimiter = ',')]
    pub env_allow: Vec<String>,
    /// A limit, `NAME=VALUE` (repeatable; sizes take K, M, G): spawn_count, host_processes,
    /// mailbox_bytes, link_bytes, relay_bytes, checkpoint_bytes, checkpoint_quota, log_bytes,
    /// log_quota. See docs/rem.md.
    #[arg(long = "limit", env = "REMD_LIMITS", value_delimiter = ',')]
    pub limits: Vec<String>,
    /// The user spawned processes run as (a name or uid) when remd runs as root.
    #[arg(long, env = "REMD_RUN_AS")]
    pub run_as: Option<String>,
    /// Allow plain HTTP/2 off this host: listening on a non-loopback address, or calling
    /// other daemons there, without TLS.
    #[arg(long, env = "REMD_INSECURE")]
    pub insecure: bool,
    /// Serve the web view (hosts, jobs, images filling in) on this address, plain HTTP, for
    /// holders of a login token (`rem web-token`); off by default. Port 0 picks one (the bound
    /// address is printed). Use a loopback address unless a proxy adds TLS.
    #[arg(long, env = "REMD_WEB")]
    pub web: Option<SocketAddr>,
    /// Directory for checkpoints.
    #[arg(long, env = "REMD_STATE_DIR")]
    pub state_dir: Option<PathBuf>,
    /// Milliseconds between this daemon's probes of one other member (failure detection;
    /// the probe's timeout is two fifths of it) [default: 200].
    #[arg(long, env = "REMD_PROBE_MS")]
    pub probe_ms: Option<u64>,
    /// Milliseconds a member that failed a probe is suspected before it is declared lost
    /// (it can refute meanwhile) [default: 400].
    #[arg(long, env = "REMD_SUSPECT_MS")]
    pub suspect_ms: Option<u64>,
    /// Largest relay message payload in bytes.
    #[arg(long, env = "REMD_MAX_MESSAGE")]
    pub max_message: Option<usize>,
    /// Milliseconds between SIGTERM and SIGKILL when a process is killed [default: 2000].
    #[arg(long, env = "REMD_KILL_GRACE_MS")]
    pub kill_grace_ms: Option<u64>,
    /// Render slots (threads) this host lends the farm; 0 lends none (the host still runs
    /// controllers) [default: its cores, or its cgroup's CPU limit rounded up].
    #[arg(long, env = "REMD_SLOTS")]
    pub slots: Option<u32>,
    /// Lend fewer slots while this host's own (non-farm) work keeps its CPUs busy, as the
    /// thesis's nice did for workstation owners: the slots left beside the owner's load.
    #[arg(long, env = "REMD_OWNER_FIRST")]
    pub owner_first: bool,
    /// PEM certificate to serve TLS with (with --tls-key; plain HTTP/2 without).
    #[arg(long, env = "REMD_TLS_CERT")]
    pub tls_cert: Option<PathBuf>,
    /// PEM private key of --tls-cert.
    #[arg(long, env = "REMD_TLS_KEY")]
    pub tls_key: Option<PathBuf>,
    /// CA to verify other daemons with [default: the daemon's own certificate].
    #[arg(long, env = "REMD_TLS_CA")]
    pub tls_ca: Option<PathBuf>,
    /// Name to expect in other daemons' certificates.
    #[arg(long, env = "REMD_TLS_DOMAIN")]
    pub tls_domain: Option<String>,
    /// Announce this REM protocol instead of the build's own (only newer): to try how a farm
    /// of mixed versions behaves before an upgrade (docs/cluster.md).
    #[arg(long, env = "REMD_ANNOUNCE_PROTOCOL", hide = true)]
    pub announce_protocol: Option<u32>,
}

impl RemdArgs {
    /// The flags' values, for the library.
    pub fn into_options(self) -> DaemonOptions {
        DaemonOptions {
            config: self.config,
            name: self.name,
            listen: self.listen,
            advertise: self.advertise,
            join: self.join,
            secret_file: self.secret_file,
            allow: self.allow,
            allow_any_args: self.allow_any_args.then_some(true),
            env_allow: self.env_allow,
            limits: self.limits,
            run_as: self.run_as,
            insecure: self.insecure.then_some(true),
            web: self.web,
            state_dir: self.state_dir,
            probe_ms: self.probe_ms,
            suspect_ms: self.suspect_ms,
            max_message: self.max_message,
            kill_grace_ms: self.kill_grace_ms,
            slots: self.slots,
            owner_first: self.owner_first.then_some(true),
            tls_cert: self.tls_cert,
            tls_key: self.tls_key,
            tls_ca: self.tls_ca,
            tls_domain: self.tls_domain,
            announce_protocol: self.announce_protocol,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_reach_the_options() {
        let o = RemdArgs::parse_from([
            "remd",
            "--config",
            "c.toml",
            "--name",
            "h",
            "--allow",
            "/a,/b",
            "--allow-any-args",
            "--limit",
            "spawn_count=8",
            "--insecure",
        ])
        .into_options();
        assert_eq!(o.config, Some(PathBuf::from("c.toml")));
        assert_eq!(o.name.as_deref(), Some("h"));
        assert_eq!(o.allow, ["/a", "/b"]);
        assert_eq!(o.allow_any_args, Some(true));
        assert_eq!(o.limits, ["spawn_count=8"]);
        assert_eq!(o.insecure, Some(true));
    }
}
