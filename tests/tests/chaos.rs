//! A chaos soak on loopback (issue "Nothing lost under chaos"): five real remd daemons, three
//! users with client keys of their own, eight jobs handed to the farm with `--detach` over
//! the run (three SPD scenes, the three strategies), and meanwhile, at times drawn from a
//! seed, at least 30 faults: a daemon killed with SIGKILL with everything under it (the
//! controllers' hosts included) and started again on the same state directory a moment
//! later, a daemon stopped (SIGSTOP) for up to 4 s and continued, and a daemon stopped with
//! SIGTERM and started again on its state directory. Faults overlap (two hosts at a time are
//! out), never more than a majority keeps the farm's supervisor working.
//!
//! At the end: every job finished; every image byte-identical to `sunray render`; no sunray
//! process left; every state directory within its limits; every daemon answering. It prints
//! what happened: faults by kind, controller moves, lines given back and duplicated, time
//! lost against the same jobs on a quiet farm, and what was lost (nothing).
//!
//! `CHAOS_SEED=N` runs another schedule; the default seed is fixed, so CI runs one schedule.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use rand::{Rng, SeedableRng};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use sunray_e2e::bins::sunray_bin;
use sunray_e2e::fixtures::spd;
use sunray_e2e::reference::reference;
use sunray_e2e::remd::LoopbackCluster;

const DAEMONS: usize = 5;
const JOBS: usize = 8;
const MIN_FAULTS: usize = 30;
const USERS: [&str; 3] = ["alice", "bob", "carol"];
const SCENES: [&str; 3] = ["mount6", "tetra6", "balls4"];
const STRATEGIES: [&str; 3] = ["dynamic", "blocks", "interleaved"];
const FLAGS: [&str; 2] = ["--resolution", "48x64"];
/// Each line takes this much longer: a job lasts a few seconds, so faults hit it.
const LINE_MS: &str = "120";
/// The most daemons out (killed, stopped or restarting) at once: a majority of five stays.
const MAX_OUT: usize = 2;
/// The state directory's bound in this test: checkpoints, records, chunks and caches of
/// eight small jobs (REM's own limits keep it there; a leak would pass it).
const STATE_DIR_BYTES: u64 = 64 << 20;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Daemon {
    Up,
    /// Stopped with SIGSTOP until then.
    Stopped(Instant),
    /// Killed (or ended with SIGTERM); started again then.
    Down(Instant),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Fault {
    Kill,
    Stop,
    Restart,
}

/// A job of the soak: who submits it, what, and when (seconds after the start).
#[derive(Clone, Debug)]
struct JobPlan {
    id: String,
    user: &'static str,
    scene: &'static str,
    strategy: &'static str,
    at_s: f64,
}

fn plans(prefix: &str, rng: &mut impl Rng, spread_s: f64) -> Vec<JobPlan> {
    (0..JOBS)
        .map(|i| JobPlan {
            id: format!("{prefix}-{i}"),
            user: USERS[i % USERS.len()],
            scene: SCENES[i % SCENES.len()],
            strategy: STRATEGIES[(i / 2) % STRATEGIES.len()],
            at_s: i as f64 * spread_s + rng.random_range(0.0..spread_s / 2.0),
        })
        .collect()
}

/// The soak's farm: the daemons, each user's key file, what each daemon is doing now.
struct Farm {
    cluster: LoopbackCluster,
    keys: BTreeMap<&'static str, PathBuf>,
    state: BTreeMap<String, Daemon>,
}

impl Farm {
    fn start() -> Farm {
        let cluster = LoopbackCluster::start(DAEMONS);
        let secret = rem::Secret::from_file(&cluster.secret_file).unwrap();
        let keys = USERS
            .iter()
            .map(|u| {
                let path = cluster.dir.path().join(format!("{u}.key"));
                std::fs::write(&path, secret.client_key_line(u).unwrap()).unwrap();
                (*u, path)
            })
            .collect();
        let state = cluster
            .daemons
            .iter()
            .map(|d| (d.name.clone(), Daemon::Up))
            .collect();
        Farm {
            cluster,
            keys,
            state,
        }
    }

    fn up(&self) -> Vec<String> {
        self.state
            .iter()
            .filter(|(_, s)| **s == Daemon::Up)
            .map(|(n, _)| n.clone())
            .collect()
    }

    /// `sunray` as `user`, through daemon `via`.
    fn sunray_as(&self, user: &str, via: &str) -> Command {
        let mut c = Command::new(sunray_bin());
        c.env("REM_ADDR", &self.cluster.daemon(via).addr)
            .env("REM_SECRET_FILE", &self.keys[user])
            .env_remove("REM_SECRET")
            .env("SUNRAY_WORKER_LINE_DELAY_MS", LINE_MS);
        c
    }

    /// Submits `job` through a daemon that is up; a refusal is the test's failure.
    fn submit(&self, job: &JobPlan, via: &str) {
        let out = self
            .sunray_as(job.user, via)
            .args([
                "submit",
                "--detach",
                "--hosts",
                "2",
                "--checkpoint-ms",
                "300",
            ])
            .args(["--job", &job.id, "--strategy", job.strategy])
            .args(FLAGS)
            .arg(spd(job.scene))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "submit {} through {via}: {}",
            job.id,
            String::from_utf8_lossy(&out.stderr)
        );
    }

    /// Starts daemon `name` again on its state directory, joining a daemon that is up, and
    /// waits until it has heard of the others that are up.
    fn start_again(&mut self, name: &str) {
        let join = self.up().into_iter().find(|n| n != name).unwrap();
        self.cluster.restart_daemon(name, &join);
        self.state.insert(name.to_string(), Daemon::Up);
        self.cluster.wait_alive_at_least(name, self.up().len());
    }

    /// Brings back whatever is due at `now` (or everything, at the end).
    fn heal(&mut self, now: Instant, all: bool) {
        let due: Vec<(String, Daemon)> = self
            .state
            .iter()
            .filter(|(_, s)| match s {
                Daemon::Up => false,
                Daemon::Stopped(t) | Daemon::Down(t) => all || *t <= now,
            })
            .map(|(n, s)| (n.clone(), *s))
            .collect();
        for (name, s) in due {
            match s {
                Daemon::Stopped(_) => {
                    self.cluster.daemon(&name).signal(libc::SIGCONT);
                    self.state.insert(name, Daemon::Up);
                }
                Daemon::Down(_) => self.start_again(&name),
                Daemon::Up => {}
            }
        }
    }

    /// Injects a fault of a kind drawn from `rng` on a daemon that is up.
    fn inject(&mut self, rng: &mut impl Rng, now: Instant) -> Option<Fault> {
        let up = self.up();
        if DAEMONS - up.len() >= MAX_OUT || up.len() < 2 {
            return None;
        }
        let name = up[rng.random_range(0..up.len())].clone();
        let back = now + Duration::from_millis(rng.random_range(800..4000));
        let fault = match rng.random_range(0..10) {
            0..=3 => Fault::Kill,
            4..=7 => Fault::Stop,
            _ => Fault::Restart,
        };
        match fault {
            Fault::Kill => {
                self.cluster.kill_daemon(&name);
                self.state.insert(name, Daemon::Down(back));
            }
            Fault::Stop => {
                self.cluster.daemon(&name).signal(libc::SIGSTOP);
                self.state.insert(name, Daemon::Stopped(back));
            }
            Fault::Restart => {
                self.cluster.stop_daemon(&name);
                self.start_again(&name);
            }
        }
        Some(fault)
    }

    /// Waits (bounded) for `job` to end through a daemon that is up; its record.
    fn wait_ended(&self, job: &JobPlan) -> serde_json::Value {
        let end = Instant::now() + Duration::from_secs(180);
        loop {
            let via = &self.up()[0];
            let out = self
                .sunray_as(job.user, via)
                .args(["jobs", "--json"])
                .output()
                .unwrap();
            let listed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
            let found = listed
                .as_array()
                .and_then(|a| a.iter().find(|j| j["job"] == job.id.as_str()).cloned());
            if let Some(j) = &found {
                if !matches!(
                    j["state"].as_str(),
                    Some("running" | "recovering" | "queued")
                ) {
                    return j.clone();
                }
            }
            assert!(
                Instant::now() < end,
                "job {} never ended: {found:?}",
                job.id
            );
            std::thread::sleep(Duration::from_millis(250));
        }
    }

    /// What each daemon up says of `job`'s image and has logged of it, for a fetch that
    /// failed (seen twice in CI, never when run alone: a finished job's checkpoint read with
    /// 60 of 64 lines).
    fn fetch_report(&self, job: &JobPlan, dir: &Path) -> String {
        let mut report = String::new();
        for d in self.up() {
            let o = self
                .sunray_as(job.user, &d)
                .args(["fetch", &job.id, "-o"])
                .arg(dir.join(format!("{}-via-{d}.png", job.id)))
                .output()
                .unwrap();
            let said = String::from_utf8_lossy(&o.stderr);
            report += &format!("\nfetch via {d}: {} {said}", o.status);
        }
        for d in self.up() {
            let log = self.cluster.log(&d);
            let about: Vec<&str> = log
                .lines()
                .filter(|l| l.contains(&job.id) || l.contains("WARN") || l.contains("ERROR"))
                .filter(|l| !l.contains("--run-as"))
                .collect();
            let tail = &about[about.len().saturating_sub(30)..];
            report += &format!(
                "\n--- {d}'s log, {} lines about it or warnings, the last:\n{}",
                about.len(),
                tail.join("\n")
            );
        }
        report
    }

    /// The job's image through a daemon that is up, and its statistics.
    fn fetch(&self, job: &JobPlan, dir: &Path) -> (Vec<u8>, serde_json::Value) {
        let via = &self.up()[0];
        let out = dir.join(format!("{}.png", job.id));
        // `fetch` itself waits (up to 10 s) when the job list says finished before the
        // checkpoint copies that answer have the last line (seen once in 5 runs: 63 of 64).
        let st = self
            .sunray_as(job.user, via)
            .args(["fetch", &job.id, "-o"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "{}{}",
            String::from_utf8_lossy(&st.stderr),
            self.fetch_report(job, dir)
        );
        let key = self.keys[job.user].clone();
        let addr = self.cluster.daemon(via).addr.clone();
        let stats = runtime().block_on(async move {
            let client = rem::RemClient::connect(&addr, rem::Secret::from_file(&key).unwrap())
                .await
                .unwrap();
            client
                .get_checkpoint(&format!("{}.stats", job.id))
                .await
                .unwrap()
        });
        let stats = stats.map_or(serde_json::Value::Null, |b| {
            serde_json::from_slice(&b).unwrap()
        });
        (std::fs::read(&out).unwrap(), stats)
    }
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
}

/// Seconds from submit to finished in a job's statistics.
fn job_seconds(stats: &serde_json::Value) -> f64 {
    stats["timeline"]["finished"].as_f64().unwrap_or(0.0)
}

/// The bytes under `dir`, every file counted.
fn dir_bytes(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .map(|e| match e.file_type() {
            Ok(t) if t.is_dir() => dir_bytes(&e.path()),
            _ => e.metadata().map_or(0, |m| m.len()),
        })
        .sum()
}

/// The pids of sunray processes (the test's binary) still running.
fn sunray_processes() -> Vec<String> {
    let bin = sunray_bin();
    let mut left = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let exe = std::fs::read_link(e.path().join("exe"));
        if exe.is_ok_and(|p| p == bin) {
            let cmd = std::fs::read(e.path().join("cmdline")).unwrap_or_default();
            left.push(String::from_utf8_lossy(&cmd).replace('\0', " "));
        }
    }
    left
}

#[test]
fn eight_jobs_of_three_users_finish_byte_identical_through_30_overlapping_faults() {
    let seed: u64 = std::env::var("CHAOS_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(42);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let dir = tempfile::tempdir().unwrap();
    let mut farm = Farm::start();
    let want: BTreeMap<&str, Vec<u8>> = SCENES
        .iter()
        .map(|s| (*s, reference(dir.path(), &spd(s), &FLAGS).0))
        .collect();
    // The same scenes on the quiet farm, one at a time: what a job costs without faults.
    let mut clean_s = BTreeMap::new();
    for (i, scene) in SCENES.iter().enumerate() {
        let job = JobPlan {
            id: format!("quiet-{i}"),
            user: USERS[i],
            scene,
            strategy: "dynamic",
            at_s: 0.0,
        };
        farm.submit(&job, "a");
        farm.wait_ended(&job);
        clean_s.insert(*scene, job_seconds(&farm.fetch(&job, dir.path()).1));
    }

    eprintln!("quiet farm: {clean_s:?} s a job");
    let jobs = plans("chaos", &mut rng, 4.0);
    let start = Instant::now();
    let mut faults: BTreeMap<Fault, u32> = BTreeMap::new();
    let mut next_fault = start + Duration::from_millis(rng.random_range(300..1200));
    let mut submitted = 0;
    let deadline = start + Duration::from_secs(150);
    while submitted < JOBS || faults.values().sum::<u32>() < MIN_FAULTS as u32 {
        assert!(
            Instant::now() < deadline,
            "the schedule overran: {faults:?}"
        );
        let now = Instant::now();
        farm.heal(now, false);
        if submitted < JOBS && start.elapsed().as_secs_f64() >= jobs[submitted].at_s {
            let up = farm.up();
            let via = up[rng.random_range(0..up.len())].clone();
            farm.submit(&jobs[submitted], &via);
            submitted += 1;
        }
        if now >= next_fault {
            if let Some(f) = farm.inject(&mut rng, now) {
                *faults.entry(f).or_default() += 1;
            }
            next_fault = now + Duration::from_millis(rng.random_range(700..1600));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    farm.heal(Instant::now(), true);
    let injected_s = start.elapsed().as_secs_f64();
    // The faults are over once every daemon sees every other alive again: a daemon just
    // continued or started again is not yet among the live peers the others ask for a
    // checkpoint, and `fetch` reads the newest copy on the live hosts (a finished job once
    // failed its fetch with 60 of 64 lines on the hosts that answered; the likeliest reading
    // is that the copy with all 64 was on a host the others did not yet see alive).
    for d in &farm.cluster.daemons {
        farm.cluster.wait_alive(&d.name, DAEMONS);
    }

    let mut moves = 0;
    let (mut requeued, mut duplicated, mut resumed, mut lost_s) = (0, 0, 0, 0.0);
    let mut lost = Vec::new();
    for job in &jobs {
        let r = farm.wait_ended(job);
        if r["state"] != "finished" {
            lost.push(format!("{}: {}", job.id, r));
            continue;
        }
        let (png, stats) = farm.fetch(job, dir.path());
        if png != want[job.scene] {
            lost.push(format!("{}: the image differs from sunray render", job.id));
        }
        moves += r["epoch"].as_u64().unwrap_or(1).saturating_sub(1);
        let lines = &stats["lines"];
        requeued += lines["requeued"].as_u64().unwrap_or(0);
        duplicated += lines["duplicated"].as_u64().unwrap_or(0);
        resumed += lines["resumed"].as_u64().unwrap_or(0);
        lost_s += job_seconds(&stats) - clean_s[job.scene];
    }
    // Nothing is left running once every job has ended (bounded: keepers finish their
    // builds, workers told to stop exit).
    let end = Instant::now() + Duration::from_secs(30);
    let mut left = sunray_processes();
    while !left.is_empty() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(200));
        left = sunray_processes();
    }
    let sizes: Vec<(String, u64)> = farm
        .cluster
        .daemons
        .iter()
        .map(|d| (d.name.clone(), dir_bytes(&farm.cluster.state_dir(&d.name))))
        .collect();
    for d in &farm.cluster.daemons {
        farm.cluster.wait_alive(&d.name, DAEMONS);
    }

    let n_faults: u32 = faults.values().sum();
    eprintln!("chaos soak, seed {seed}: {JOBS} jobs of {} users on {DAEMONS} daemons, {n_faults} faults in {injected_s:.1} s", USERS.len());
    eprintln!("| what | count |\n|---|---|");
    for (f, n) in &faults {
        eprintln!("| fault: {f:?} | {n} |");
    }
    eprintln!("| controller moves (epochs past the first) | {moves} |");
    eprintln!("| lines taken from checkpoints by a new controller | {resumed} |");
    eprintln!("| lines given back and rendered again | {requeued} |");
    eprintln!("| duplicate lines (stragglers' copies) | {duplicated} |");
    eprintln!("| time lost against a quiet farm, all jobs | {lost_s:.1} s |");
    eprintln!("| jobs or images lost | {} |", lost.len());
    eprintln!("state directories: {sizes:?}");
    assert!(lost.is_empty(), "{lost:#?}");
    assert!(n_faults >= MIN_FAULTS as u32, "{faults:?}");
    assert!(left.is_empty(), "sunray processes left: {left:#?}");
    for (name, bytes) in sizes {
        assert!(bytes <= STATE_DIR_BYTES, "{name}: {bytes} bytes");
    }
}
