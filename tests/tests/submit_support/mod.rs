//! Shared by the `submit_*` tests: the `sunray` and `remd` binaries (built on first use, as
//! this package cannot name another package's binaries), a cluster of real `remd` processes
//! on loopback, and a `sunray submit` whose `--events` are read as they happen.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

pub const SECRET: &str = "submit-test-secret";

/// The directory holding this build's binaries (target/<profile>).
fn bin_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> -> target/<profile>
    exe.parent()
        .and_then(Path::parent)
        .expect("target dir")
        .to_path_buf()
}

/// Builds `sunray` and `remd` once per test binary (a no-op when they are up to date).
fn ensure_built() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = bin_dir();
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| env!("CARGO").to_string());
        let target = dir.parent().expect("target root").to_path_buf();
        let mut cmd = Command::new(cargo);
        cmd.args(["build", "--quiet", "-p", "sunray", "-p", "rem", "--bins"])
            .arg("--target-dir")
            .arg(&target)
            .current_dir(env!("CARGO_MANIFEST_DIR"));
        if dir.file_name().is_some_and(|n| n == "release") {
            cmd.arg("--release");
        }
        let st = cmd.status().expect("run cargo build");
        assert!(st.success(), "building sunray and remd failed");
        dir
    })
}

pub fn sunray_bin() -> PathBuf {
    ensure_built().join("sunray")
}

pub fn remd_bin() -> PathBuf {
    ensure_built().join("remd")
}

pub fn sunray() -> Command {
    let mut c = Command::new(sunray_bin());
    c.env_remove("REM_ADDR")
        .env_remove("REM_SECRET")
        .env_remove("REM_SECRET_FILE");
    c
}

pub fn spd(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../../shared/scenes/spd/{name}.nff"))
}

pub fn default_scene() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../sunray/src/scene/default_scene.yari")
}

/// `sunray render` of `scene` with `flags`: the PNG bytes and the stats JSON.
pub fn reference(dir: &Path, scene: &Path, flags: &[&str]) -> (Vec<u8>, serde_json::Value) {
    let out = dir.join("reference.png");
    let json = dir.join("reference.json");
    let st = sunray()
        .arg("render")
        .arg("-q")
        .arg(scene)
        .args(flags)
        .arg("-o")
        .arg(&out)
        .arg("--stats-json")
        .arg(&json)
        .status()
        .unwrap();
    assert!(st.success());
    (std::fs::read(&out).unwrap(), read_json(&json))
}

pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// One remd process; killed when dropped.
pub struct Remd {
    pub name: String,
    pub addr: String,
    pub child: Child,
}

impl Remd {
    pub fn signal(&self, sig: i32) {
        unsafe {
            libc::kill(self.child.id() as i32, sig);
        }
    }
}

impl Drop for Remd {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `n` remd daemons named a, b, c ... on loopback, sharing a secret, allowed to run sunray.
pub struct Cluster {
    pub dir: tempfile::TempDir,
    pub secret_file: PathBuf,
    pub daemons: Vec<Remd>,
}

impl Cluster {
    pub fn start(n: usize) -> Cluster {
        let dir = tempfile::tempdir().unwrap();
        let secret_file = dir.path().join("secret");
        std::fs::write(&secret_file, format!("{SECRET}\n")).unwrap();
        let mut c = Cluster {
            dir,
            secret_file,
            daemons: Vec::new(),
        };
        for i in 0..n {
            let name = ((b'a' + i as u8) as char).to_string();
            let join = c.daemons.first().map(|d| d.addr.clone());
            let d = c.start_daemon(&name, join.as_deref());
            c.daemons.push(d);
        }
        c.converge(n);
        c
    }

    fn start_daemon(&self, name: &str, join: Option<&str>) -> Remd {
        let mut cmd = Command::new(remd_bin());
        cmd.args(["--name", name, "--listen", "127.0.0.1:0"])
            .args(["--heartbeat-ms", "150", "--lost-after-ms", "900"])
            .arg("--allow")
            .arg(sunray_bin())
            .arg("--secret-file")
            .arg(&self.secret_file)
            .arg("--state-dir")
            .arg(self.dir.path().join(format!("state-{name}")))
            .env_remove("REM_SECRET")
            .env_remove("REM_SECRET_FILE")
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        if let Some(j) = join {
            cmd.args(["--join", j]);
        }
        let mut child = cmd.spawn().expect("start remd");
        let out = child.stdout.take().unwrap();
        let mut line = String::new();
        BufReader::new(out).read_line(&mut line).unwrap();
        let addr = line
            .trim()
            .strip_prefix("remd listening on ")
            .unwrap_or_else(|| panic!("bad first line {line:?}"))
            .to_string();
        Remd {
            name: name.to_string(),
            addr,
            child,
        }
    }

    /// Waits until the first daemon sees all `n` hosts alive (bounded).
    fn converge(&self, n: usize) {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            let secret = rem::Secret::new(SECRET).unwrap();
            let client = rem::RemClient::connect(&self.daemons[0].addr, secret)
                .await
                .unwrap();
            let end = Instant::now() + Duration::from_secs(20);
            loop {
                let hosts = client.hosts().await.unwrap();
                if hosts.iter().filter(|h| h.alive).count() == n {
                    return;
                }
                assert!(Instant::now() < end, "cluster did not converge: {hosts:#?}");
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        });
    }

    /// The REM processes of the cluster (to check that nothing was started).
    pub fn processes(&self) -> Vec<rem::ProcessInfo> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            let secret = rem::Secret::new(SECRET).unwrap();
            let client = rem::RemClient::connect(&self.daemons[0].addr, secret)
                .await
                .unwrap();
            client.ps().await.unwrap()
        })
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

    pub fn daemon(&self, name: &str) -> &Remd {
        self.daemons.iter().find(|d| d.name == name).unwrap()
    }
}

/// A running `sunray submit --events`, its events read by a thread.
pub struct Running {
    pub child: Child,
    events: mpsc::Receiver<serde_json::Value>,
    pub seen: Vec<serde_json::Value>,
}

impl Running {
    pub fn start(mut cmd: Command) -> Running {
        let mut child = cmd
            .arg("--events")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let err = child.stderr.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines() {
                let Ok(line) = line else { return };
                match serde_json::from_str::<serde_json::Value>(&line) {
                    Ok(v) if v.get("event").is_some() => {
                        let _ = tx.send(v);
                    }
                    _ => eprintln!("[submit] {line}"),
                }
            }
        });
        Running {
            child,
            events: rx,
            seen: Vec::new(),
        }
    }

    /// Waits (bounded) until `cond` holds of the events seen so far, and returns its value.
    pub fn wait_until<T>(
        &mut self,
        timeout: Duration,
        cond: impl Fn(&[serde_json::Value]) -> Option<T>,
    ) -> T {
        let end = Instant::now() + timeout;
        loop {
            if let Some(t) = cond(&self.seen) {
                return t;
            }
            let left = end.saturating_duration_since(Instant::now());
            match self.events.recv_timeout(left) {
                Ok(v) => self.seen.push(v),
                Err(_) => panic!("condition not reached in {timeout:?}; saw {:#?}", self.seen),
            }
        }
    }

    /// Waits until node `node` has had `n` lines accepted.
    pub fn wait_lines_of(&mut self, node: u64, n: usize) {
        self.wait_until(Duration::from_secs(60), |seen| {
            (seen
                .iter()
                .filter(|v| v["event"] == "line" && v["node"] == node)
                .count()
                >= n)
                .then_some(())
        })
    }

    /// Waits for the process to end (bounded) and returns its status.
    pub fn wait(&mut self, timeout: Duration) -> std::process::ExitStatus {
        let end = Instant::now() + timeout;
        loop {
            if let Some(st) = self.child.try_wait().unwrap() {
                while let Ok(v) = self.events.try_recv() {
                    self.seen.push(v);
                }
                return st;
            }
            // Keep collecting events while waiting.
            if let Ok(v) = self.events.recv_timeout(Duration::from_millis(20)) {
                self.seen.push(v);
            }
            assert!(Instant::now() < end, "submit did not finish in {timeout:?}");
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The node of `event` (1-based) and the pid of that worker from the spawned events.
pub fn worker_pid(run: &Running, node: u64) -> i32 {
    run.seen
        .iter()
        .find(|v| v["event"] == "spawned" && v["node"] == node)
        .and_then(|v| v["pid"].as_i64())
        .expect("spawned event") as i32
}

pub fn signal(pid: i32, sig: i32) {
    unsafe {
        libc::kill(pid, sig);
    }
}

/// Runs a command to its end, printing its stderr on failure.
pub fn output(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    }
    out
}
