//! The Docker Compose cluster for the `cluster` tests: checks that docker works (a failure
//! under CI, a printed skip elsewhere), builds the image from this build's release binaries,
//! starts `deploy/docker-compose.yml` under a unique project name and takes it down again
//! (containers, network, volumes) when the guard is dropped, even after a failed assertion.

use super::bins::{ensure_built, workspace};
use super::fixtures::spd_dir;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

/// Every compose project these tests start is named `PREFIX<pid>_<n>`.
pub const PREFIX: &str = "sunraye2e_";
/// The image the tests build and use (not `latest`, which is the user's).
pub const IMAGE: &str = "sunray-rem:e2e";
pub const HOSTS: [&str; 6] = ["ws1", "ws2", "ws3", "ws4", "ws5", "ws6"];

/// How to run compose here: `docker-compose` (v1) or `docker compose` (v2).
fn compose_program() -> Option<Vec<String>> {
    let works = |prog: &[&str]| {
        Command::new(prog[0])
            .args(&prog[1..])
            .arg("version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    [&["docker-compose"][..], &["docker", "compose"][..]]
        .into_iter()
        .find(|p| works(p))
        .map(|p| p.iter().map(|s| s.to_string()).collect())
}

/// Why the cluster cannot run here, if it cannot.
fn docker_problem() -> Option<String> {
    let info = Command::new("docker")
        .args(["info", "--format", "{{.ServerVersion}}"])
        .output();
    match info {
        Err(e) => return Some(format!("docker is not installed ({e})")),
        Ok(o) if !o.status.success() => {
            return Some(format!(
                "docker does not work: {}",
                String::from_utf8_lossy(&o.stderr).trim()
            ))
        }
        Ok(_) => {}
    }
    if compose_program().is_none() {
        return Some("neither docker-compose nor `docker compose` is installed".into());
    }
    None
}

fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// One test at a time per test binary: the cluster takes the machine's cores.
pub fn serial() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// `None` (after printing why) when docker is not usable and we are not under CI; under CI
/// that is a failure. Otherwise builds the image once and returns the binaries' folder.
pub fn prepare() -> Option<PathBuf> {
    static READY: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let ready = READY.get_or_init(|| {
        if let Some(why) = docker_problem() {
            return Err(why);
        }
        remove_leftovers();
        let dir = ensure_built().clone();
        build_image(&dir);
        Ok(dir)
    });
    match ready {
        Ok(dir) => Some(dir.clone()),
        Err(why) if in_ci() => panic!("CI is set but the cluster tests cannot run: {why}"),
        Err(why) => {
            eprintln!("skipping the compose cluster tests: {why}");
            None
        }
    }
}

fn build_image(bin_dir: &Path) {
    let out = Command::new("bash")
        .arg(workspace().join("deploy/build-image.sh"))
        .env("SKIP_CARGO", "1")
        .env("BIN_DIR", bin_dir)
        .env("SUNRAY_IMAGE", IMAGE)
        .output()
        .expect("run deploy/build-image.sh");
    assert!(
        out.status.success(),
        "deploy/build-image.sh failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Removes containers and networks of earlier runs whose test process is gone (a killed
/// run cannot clean up after itself); a concurrent run's cluster is left alone.
fn remove_leftovers() {
    let stale = |name: &str| -> bool {
        let Some(rest) = name.trim_start_matches('/').strip_prefix(PREFIX) else {
            return false;
        };
        let pid: u32 = rest
            .split('_')
            .next()
            .and_then(|p| p.parse().ok())
            .unwrap_or(0);
        pid == 0 || !Path::new(&format!("/proc/{pid}")).exists()
    };
    let list = |args: &[&str]| -> Vec<String> {
        Command::new("docker")
            .args(args)
            .output()
            .map(|o| {
                String::from_utf8_lossy(&o.stdout)
                    .lines()
                    .map(str::to_string)
                    .collect()
            })
            .unwrap_or_default()
    };
    let containers: Vec<String> = list(&["ps", "-a", "--format", "{{.Names}}"])
        .into_iter()
        .filter(|n| stale(n))
        .collect();
    if !containers.is_empty() {
        let _ = Command::new("docker")
            .args(["rm", "-f", "-v"])
            .args(&containers)
            .output();
    }
    for net in list(&["network", "ls", "--format", "{{.Name}}"]) {
        if stale(&net) {
            let _ = Command::new("docker")
                .args(["network", "rm", &net])
                .output();
        }
    }
    for vol in list(&["volume", "ls", "--format", "{{.Name}}"]) {
        if stale(&vol) {
            let _ = Command::new("docker").args(["volume", "rm", &vol]).output();
        }
    }
}

fn running_as_root() -> bool {
    (unsafe { libc::getuid() }) == 0
}

/// The user the daemons run as: nobody (65534), as deploy/ ships, when the tests run as root
/// (who can give it the cluster's files), else the tests' own user.
pub fn daemon_user() -> (u32, u32) {
    if running_as_root() {
        (65534, 65534)
    } else {
        (unsafe { libc::getuid() }, unsafe { libc::getgid() })
    }
}

/// A running compose cluster; `docker-compose down -v` when dropped.
pub struct ComposeCluster {
    pub project: String,
    program: Vec<String>,
    pub dir: tempfile::TempDir,
    pub out_dir: PathBuf,
}

impl ComposeCluster {
    /// Starts the six workstations and waits (bounded) until ws1 sees all of them alive.
    pub fn up() -> ComposeCluster {
        static COUNT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = tempfile::tempdir().unwrap();
        let out_dir = dir.path().join("out");
        std::fs::create_dir(&out_dir).unwrap();
        // The secret, TLS certificate and key, given to the daemons' user, as
        // deploy/credentials.sh does.
        let give = running_as_root().then(daemon_user);
        rem::auth::cluster_files::write(&dir.path().join("credentials"), give, &[]).unwrap();
        if let Some((uid, gid)) = give {
            std::os::unix::fs::chown(&out_dir, Some(uid), Some(gid)).unwrap();
        }
        let cluster = ComposeCluster {
            project: format!("{PREFIX}{}_{n}", std::process::id()),
            program: compose_program().expect("compose"),
            dir,
            out_dir,
        };
        let st = cluster
            .compose()
            .args(["up", "-d", "--quiet-pull"])
            .output()
            .unwrap();
        if !st.status.success() {
            // Older compose has no --quiet-pull.
            let st = cluster.compose().args(["up", "-d"]).output().unwrap();
            assert!(
                st.status.success(),
                "compose up: {}",
                String::from_utf8_lossy(&st.stderr)
            );
        }
        cluster.wait_hosts(Duration::from_secs(60), |hosts| {
            HOSTS.iter().all(|h| alive(hosts, h))
        });
        cluster
    }

    /// `docker-compose -p PROJECT -f deploy/docker-compose.yml` with the test's settings.
    pub fn compose(&self) -> Command {
        let mut c = Command::new(&self.program[0]);
        c.args(&self.program[1..])
            .arg("-p")
            .arg(&self.project)
            .arg("-f")
            .arg(workspace().join("deploy/docker-compose.yml"))
            .env("SUNRAY_IMAGE", IMAGE)
            .env("SUNRAY_SCENES", spd_dir())
            .env("SUNRAY_OUT", &self.out_dir)
            .env("REM_CREDENTIALS", self.dir.path().join("credentials"))
            // ws1's web view on a free port of this machine's loopback (`web_url`).
            .env("REM_WEB_PORT", "")
            .env("SUNRAY_USER", {
                let (uid, gid) = daemon_user();
                format!("{uid}:{gid}")
            })
            .env_remove("COMPOSE_FILE")
            .env_remove("COMPOSE_PROJECT_NAME")
            .stdin(Stdio::null());
        c
    }

    /// A script of the repository (e.g. deploy/load.sh) run against this cluster.
    pub fn script(&self, path: &str) -> Command {
        let compose = self.compose();
        let mut c = Command::new("bash");
        c.arg(workspace().join(path));
        for (k, v) in compose.get_envs() {
            match v {
                Some(v) => c.env(k, v),
                None => c.env_remove(k),
            };
        }
        c.env("COMPOSE", self.program.join(" "))
            .env("COMPOSE_PROJECT_NAME", &self.project)
            .env(
                "COMPOSE_FILE",
                workspace().join("deploy/docker-compose.yml"),
            );
        c
    }

    /// `compose exec -T HOST ARGS...`
    pub fn exec(&self, host: &str, args: &[&str]) -> Command {
        let mut c = self.compose();
        c.args(["exec", "-T", host]).args(args);
        c
    }

    /// ws1's web view as published on this machine (`http://127.0.0.1:PORT/`).
    pub fn web_url(&self) -> String {
        let o = self
            .compose()
            .args(["port", "ws1", "8080"])
            .output()
            .unwrap();
        let addr = String::from_utf8_lossy(&o.stdout).trim().to_string();
        assert!(
            o.status.success() && !addr.is_empty(),
            "compose port ws1 8080: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        format!("http://{addr}/")
    }

    /// The cluster's secret (made by [`ComposeCluster::up`]).
    pub fn secret(&self) -> rem::Secret {
        rem::Secret::from_file(&self.dir.path().join("credentials/secret")).unwrap()
    }

    /// The container id of a workstation.
    pub fn container(&self, host: &str) -> String {
        let o = self.compose().args(["ps", "-q", host]).output().unwrap();
        let id = String::from_utf8_lossy(&o.stdout).trim().to_string();
        assert!(!id.is_empty(), "no container for {host}");
        id
    }

    pub fn network(&self) -> String {
        format!("{}_farm", self.project)
    }

    /// `docker ARGS... CONTAINER-OF-HOST`, which must succeed.
    pub fn docker(&self, args: &[&str], host: &str) {
        let id = self.container(host);
        let o = Command::new("docker").args(args).arg(&id).output().unwrap();
        assert!(
            o.status.success(),
            "docker {args:?} {host}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }

    /// Hangs a workstation (every process stopped, nothing dead): `docker pause`, or where
    /// the cgroup freezer does not work (nested containers) SIGSTOP to each of its processes.
    pub fn freeze(&self, host: &str) {
        let id = self.container(host);
        let paused = Command::new("docker")
            .args(["pause", &id])
            .output()
            .unwrap();
        if !paused.status.success() {
            eprintln!(
                "docker pause {host}: {}; stopping its processes instead",
                String::from_utf8_lossy(&paused.stderr).trim()
            );
            self.signal_all(host, libc::SIGSTOP);
        }
    }

    /// Undoes [`freeze`](Self::freeze).
    pub fn thaw(&self, host: &str) {
        let id = self.container(host);
        let _ = Command::new("docker").args(["unpause", &id]).output();
        self.signal_all(host, libc::SIGCONT);
    }

    /// Sends `sig` to every process of a workstation's container (their host pids).
    fn signal_all(&self, host: &str, sig: i32) {
        let id = self.container(host);
        let o = Command::new("docker")
            .args(["top", &id, "-eo", "pid"])
            .output()
            .unwrap();
        assert!(o.status.success(), "docker top {host}");
        let pids: Vec<i32> = String::from_utf8_lossy(&o.stdout)
            .lines()
            .filter_map(|l| l.trim().parse().ok())
            .collect();
        assert!(!pids.is_empty(), "no processes in {host}");
        for pid in pids {
            // SAFETY: kill(2) with a pid and a signal number has no memory effects.
            let rc = unsafe { libc::kill(pid, sig) };
            assert_eq!(rc, 0, "kill({pid}, {sig}) in {host}");
        }
    }

    /// A workstation's address on the farm network (reachable from this host).
    pub fn ip(&self, host: &str) -> String {
        let o = Command::new("docker")
            .args([
                "inspect",
                "-f",
                "{{range .NetworkSettings.Networks}}{{.IPAddress}}{{end}}",
                &self.container(host),
            ])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    }

    /// This build's `rem` on this host, as another machine would run it against `host`'s
    /// daemon: the cluster's secret, and TLS when `tls`.
    pub fn rem_from_outside(&self, host: &str, tls: bool) -> Command {
        let creds = self.dir.path().join("credentials");
        let mut c = Command::new(super::bins::rem_bin());
        c.arg("--remd")
            .arg(format!("{}:7070", self.ip(host)))
            .arg("--secret-file")
            .arg(creds.join(rem::auth::cluster_files::SECRET))
            .env_remove("REM_TLS_CA")
            .env_remove("REM_TLS_DOMAIN");
        if tls {
            c.arg("--tls-ca")
                .arg(creds.join(rem::auth::cluster_files::CERT))
                .arg("--tls-domain")
                .arg(rem::auth::cluster_files::TLS_DOMAIN);
        }
        c
    }

    /// The user ids of a workstation's processes named `comm` (as the host's `ps` sees them;
    /// docker top wants the pid column).
    pub fn uids_of(&self, host: &str, comm: &str) -> Vec<u32> {
        let id = self.container(host);
        let o = Command::new("docker")
            .args(["top", &id, "-eo", "pid,uid,comm"])
            .output()
            .unwrap();
        assert!(o.status.success(), "docker top {host}");
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .filter_map(|l| {
                let mut f = l.split_whitespace().skip(1);
                let uid = f.next()?.parse().ok()?;
                (f.next()? == comm).then_some(uid)
            })
            .collect()
    }

    /// `rem hosts --json` as `via` sees the cluster.
    pub fn hosts(&self, via: &str) -> Vec<serde_json::Value> {
        let o = self
            .exec(via, &["/bin/rem", "hosts", "--json"])
            .output()
            .unwrap();
        if !o.status.success() {
            return Vec::new();
        }
        serde_json::from_slice::<serde_json::Value>(&o.stdout)
            .ok()
            .and_then(|v| v.as_array().cloned())
            .unwrap_or_default()
    }

    /// Polls `rem hosts --json` on ws1 (then ws2) until `cond` holds; panics after `timeout`.
    pub fn wait_hosts(
        &self,
        timeout: Duration,
        cond: impl Fn(&[serde_json::Value]) -> bool,
    ) -> Vec<serde_json::Value> {
        let end = Instant::now() + timeout;
        let mut last = Vec::new();
        while Instant::now() < end {
            for via in ["ws1", "ws2"] {
                let hosts = self.hosts(via);
                if !hosts.is_empty() {
                    if cond(&hosts) {
                        return hosts;
                    }
                    last = hosts;
                    break;
                }
            }
            std::thread::sleep(Duration::from_millis(250)); // polling interval, not a wait
        }
        panic!("hosts did not reach the condition in {timeout:?}: {last:#?}");
    }

    /// A file written by the containers to /out.
    pub fn out(&self, name: &str) -> PathBuf {
        self.out_dir.join(name)
    }

    /// What the containers logged (printed when a test fails).
    pub fn logs(&self) -> String {
        let o = self
            .compose()
            .args(["logs", "--no-color", "--tail", "40"])
            .output();
        o.map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default()
    }
}

impl Drop for ComposeCluster {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("--- cluster logs ---\n{}", self.logs());
        }
        let _ = self
            .compose()
            .args(["down", "-v", "--remove-orphans", "-t", "2"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
        // Files the containers wrote belong to SUNRAY_USER: nobody when we are root (who
        // may remove them), else us; TempDir removes them.
    }
}

/// Whether host `name` is listed alive.
pub fn alive(hosts: &[serde_json::Value], name: &str) -> bool {
    hosts
        .iter()
        .any(|h| h["name"] == name && h["alive"] == true)
}

pub fn lost(hosts: &[serde_json::Value], name: &str) -> bool {
    hosts
        .iter()
        .any(|h| h["name"] == name && h["alive"] == false)
}
