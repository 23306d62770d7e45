//! `rem`: looks at and drives a REM cluster through one remd.
//!
//! `rem [--remd ADDR] [--secret-file PATH] hosts|queue|ps|spawn|kill|logs ...`; `--json` on
//! listings ([`listings`]: hosts, the queue, processes).

use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use clap::{Args, Parser, Subcommand};
use rem::client::rem_client::ConnectOptions;
use rem::wire::transport::ClientTls;
use rem::{EventKind, Incoming, ProcId, RemClient, Secret, SpawnRequest};
use serde_json::json;

mod listings;
use listings::{hosts, ps, queue};

#[derive(Parser, Debug)]
#[command(name = "rem", version, about = "Look at and drive a REM cluster")]
struct Cli {
    /// Address of a remd (usually the local one).
    #[arg(long, env = "REM_ADDR", default_value = rem::daemon::config::DEFAULT_ADDR, global = true)]
    remd: String,
    /// File holding the cluster secret (or set REM_SECRET).
    #[arg(long, env = "REM_SECRET_FILE", global = true)]
    secret_file: Option<PathBuf>,
    /// CA certificate (PEM) to verify remd's TLS certificate; enables TLS.
    #[arg(long, env = "REM_TLS_CA", global = true)]
    tls_ca: Option<PathBuf>,
    /// Name to verify in remd's certificate (default: the address's host).
    #[arg(long, env = "REM_TLS_DOMAIN", global = true)]
    tls_domain: Option<String>,
    /// The user to act as with the cluster secret (default: the login name); a client-key
    /// file is always its own user's.
    #[arg(long, env = "REM_USER", global = true)]
    user: Option<String>,
    /// Act as admin (needs the cluster secret): kill and read the logs of every user's
    /// processes.
    #[arg(long, global = true)]
    admin: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The hosts of the cluster and their load.
    Hosts {
        #[arg(long)]
        json: bool,
    },
    /// The farm's queue: every user's active jobs, the slots each holds and may hold, and
    /// the place of those waiting.
    Queue {
        #[arg(long)]
        json: bool,
    },
    /// The processes REM runs on the live hosts.
    Ps {
        #[arg(long)]
        json: bool,
    },
    /// Start processes on the least-loaded hosts.
    Spawn(SpawnArgs),
    /// End a process.
    Kill { proc_id: String },
    /// Print a process's kept stdout (to stdout) and stderr (to stderr).
    Logs { proc_id: String },
    /// Print a user's client key (needs the cluster secret): a file holding it lets that
    /// user run jobs (rem, sunray submit) as that user only, without being able to act as
    /// another user, an admin or a daemon. Reads no network.
    ClientKey,
    /// Print a login token for the web view (`remd --web`): your client key (from the
    /// cluster secret, or the client-key file itself), which shows your jobs; with `--admin`
    /// (needs the secret) the admin token, which shows everyone's. Reads no network.
    WebToken {
        /// The admin token.
        #[arg(long)]
        admin: bool,
    },
    /// Make a cluster's shared files in DIR, keeping any that exist: the secret (`secret`,
    /// mode 600) and one TLS certificate for every daemon (`cluster.pem`, for the name
    /// `rem.cluster`) with its key (`cluster.key`, mode 600). Reads no network.
    Credentials {
        dir: PathBuf,
        /// Give the files to UID:GID (needs root), the user remd runs as.
        #[arg(long, value_name = "UID:GID")]
        owner: Option<String>,
        /// Another name for the certificate (repeatable).
        #[arg(long = "name")]
        names: Vec<String>,
    },
}

// `rem spawn`'s arguments (its help is the variant's).
#[derive(Args, Debug)]
struct SpawnArgs {
    #[arg(long, short = 'n', default_value_t = 1)]
    count: u32,
    #[arg(long)]
    nice: Option<i32>,
    /// Allow more than one process per host.
    #[arg(long)]
    allow_same_host: bool,
    #[arg(long)]
    job: Option<String>,
    /// Environment variable for the processes (repeatable).
    #[arg(long = "env", value_name = "KEY=VALUE")]
    env: Vec<String>,
    /// Stay attached as the job's owner, print its events, exit with the first non-zero code.
    #[arg(long)]
    wait: bool,
    #[arg(long)]
    json: bool,
    /// Absolute path of the program (on the hosts' allow-lists).
    program: String,
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    args: Vec<String>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("rem: {e}");
            return ExitCode::FAILURE;
        }
    };
    let (remd, tls) = (cli.remd.clone(), cli.tls_ca.is_some());
    match runtime.block_on(run(cli)) {
        Ok(code) => code,
        Err(e) => {
            match e.downcast_ref::<rem::Error>().filter(|e| e.is_transport()) {
                Some(e) => {
                    let root = e.root_cause();
                    let hint = if tls || root.contains("refused") {
                        ""
                    } else {
                        " (if remd uses TLS, give --tls-ca or set REM_TLS_CA)"
                    };
                    eprintln!("rem: cannot reach remd at {remd}: {root}{hint}");
                }
                None => eprintln!("rem: {e:#}"),
            }
            ExitCode::FAILURE
        }
    }
}

async fn connect(cli: &Cli) -> anyhow::Result<RemClient> {
    let (secret, _) = Secret::resolve(cli.secret_file.as_deref())?;
    let mut opts = ConnectOptions::new(cli.remd.clone(), secret);
    opts.user = cli.user.clone();
    opts.admin = cli.admin;
    if let Some(ca) = &cli.tls_ca {
        opts.tls = Some(ClientTls::from_file(ca, cli.tls_domain.clone())?);
    }
    // A transport failure is named with the address by `main`; the rest speak for themselves.
    Ok(RemClient::connect_with(opts).await?)
}

async fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    // The commands that read no network.
    match &cli.command {
        Command::ClientKey => return client_key(&cli),
        Command::WebToken { admin } => return web_token(&cli, *admin),
        Command::Credentials { dir, owner, names } => {
            return credentials(dir, owner.as_deref(), names)
        }
        _ => {}
    }
    let client = connect(&cli).await?;
    let out = &mut std::io::stdout().lock();
    match cli.command {
        Command::Hosts { json } => hosts(&client, out, json).await?,
        Command::Ps { json } => ps(&client, out, json).await?,
        Command::Queue { json } => queue(&client, out, json).await?,
        Command::Spawn(args) => return spawn(&client, out, args).await,
        Command::Kill { proc_id } => {
            let id: ProcId = proc_id.parse()?;
            client.kill(&id).await?;
        }
        Command::Logs { proc_id } => logs(&client, out, &proc_id).await?,
        Command::ClientKey | Command::WebToken { .. } | Command::Credentials { .. } => {}
    }
    Ok(ExitCode::SUCCESS)
}

/// `rem client-key`: the user's client-key line.
fn client_key(cli: &Cli) -> anyhow::Result<ExitCode> {
    let (secret, _) = Secret::resolve(cli.secret_file.as_deref())?;
    let user = cli
        .user
        .clone()
        .unwrap_or_else(rem::auth::identity::default_user);
    println!("{}", secret.client_key_line(&user)?);
    Ok(ExitCode::SUCCESS)
}

/// `rem web-token`: a login token for the web view (the admin's with `admin`).
fn web_token(cli: &Cli, admin: bool) -> anyhow::Result<ExitCode> {
    let (secret, _) = Secret::resolve(cli.secret_file.as_deref())?;
    if admin {
        println!("{}", rem::daemon::web::login::admin_token(&secret)?);
    } else {
        let (user, key) = secret.client_credential(cli.user.as_deref())?;
        println!(
            "{}{user}:{}",
            rem::auth::identity::CLIENT_KEY_PREFIX,
            hex::encode(key)
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// `rem credentials`: a cluster's shared files in `dir`.
fn credentials(
    dir: &std::path::Path,
    owner: Option<&str>,
    names: &[String],
) -> anyhow::Result<ExitCode> {
    let owner = owner
        .map(rem::auth::cluster_files::parse_owner)
        .transpose()?;
    for w in rem::auth::cluster_files::write(dir, owner, names)? {
        let what = if w.created { "made" } else { "kept" };
        println!("{what} {}", w.path.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// `rem spawn`: starts the processes, prints where; with `--wait`, follows them as their
/// owner until they exit.
async fn spawn(client: &RemClient, out: &mut impl Write, a: SpawnArgs) -> anyhow::Result<ExitCode> {
    let mut envs = BTreeMap::new();
    for kv in a.env {
        let Some((k, v)) = kv.split_once('=') else {
            bail!("--env {kv:?} is not KEY=VALUE")
        };
        envs.insert(k.to_string(), v.to_string());
    }
    let mut relay = if a.wait {
        Some(client.attach(a.job.as_deref()).await?)
    } else {
        None
    };
    let req = SpawnRequest {
        program: a.program,
        args: a.args,
        env: envs,
        nice: a.nice,
        count: a.count,
        allow_same_host: a.allow_same_host,
        job: a.job,
        owner: relay.as_ref().map(|r| r.id().clone()),
        ..SpawnRequest::default()
    };
    let spawned = client.spawn(req).await?;
    if a.json {
        let v: Vec<_> = spawned
            .processes
            .iter()
            .map(|p| json!({"job": spawned.id, "proc_id": p.proc_id.to_string(), "host": p.host, "pid": p.pid}))
            .collect();
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        for p in &spawned.processes {
            writeln!(out, "{} {} {} pid {}", spawned.id, p.proc_id, p.host, p.pid)?;
        }
    }
    out.flush()?;
    if let Some(relay) = relay.as_mut() {
        // The reply is the proof of the start: a quick process's Exited (sent by the
        // host that ran it) may overtake the Started event (sent by the placing host).
        for p in &spawned.processes {
            writeln!(out, "{} started on {}", p.proc_id, p.host)?;
        }
        out.flush()?;
        return wait_for_exits(out, relay, spawned.processes.len()).await;
    }
    Ok(ExitCode::SUCCESS)
}

/// `rem logs`: the process's kept stdout to stdout, its stderr to stderr.
async fn logs(client: &RemClient, out: &mut impl Write, proc_id: &str) -> anyhow::Result<()> {
    let id: ProcId = proc_id.parse()?;
    let logs = client.logs(&id).await?;
    out.write_all(&logs.stdout)?;
    std::io::stderr().write_all(&logs.stderr)?;
    if logs.truncated {
        eprintln!("rem: (older output was dropped)");
    }
    Ok(())
}

async fn wait_for_exits(
    out: &mut impl Write,
    relay: &mut rem::Relay,
    mut left: usize,
) -> anyhow::Result<ExitCode> {
    let mut code = 0u8;
    while left > 0 {
        match relay.recv().await? {
            Incoming::Event(ev) => {
                let kind = EventKind::try_from(ev.kind).unwrap_or(EventKind::Unspecified);
                match kind {
                    EventKind::Started => {} // printed from the spawn reply
                    EventKind::Exited => {
                        left -= 1;
                        match (ev.exit_code, ev.signal) {
                            (Some(c), _) => writeln!(out, "{} exited with code {c}", ev.proc_id)?,
                            (None, Some(s)) => {
                                writeln!(out, "{} killed by signal {s}", ev.proc_id)?
                            }
                            _ => writeln!(out, "{} exited", ev.proc_id)?,
                        }
                        let c = ev.exit_code.map_or(1, |c| c.clamp(0, 255) as u8);
                        if code == 0 && c != 0 {
                            code = c;
                        }
                    }
                    EventKind::Lost => {
                        left -= 1;
                        writeln!(out, "{} lost: {}", ev.proc_id, ev.message)?;
                        code = code.max(1);
                    }
                    EventKind::Unspecified => {}
                }
                out.flush()?;
            }
            Incoming::Message { from, payload } => {
                writeln!(out, "message from {from}: {} bytes", payload.len())?
            }
            Incoming::Undeliverable { .. } => {}
        }
    }
    Ok(ExitCode::from(code))
}
