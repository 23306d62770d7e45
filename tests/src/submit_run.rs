//! A `sunray submit --events` followed as it runs: its JSON events collected by a thread,
//! waits on conditions over them (bounded), and the rest of its stderr.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// A `sunray submit --events` (here or in a container); its events are read as they come,
/// the other lines of its stderr kept as text.
pub struct SubmitRun {
    pub child: Child,
    events: mpsc::Receiver<serde_json::Value>,
    pub seen: Vec<serde_json::Value>,
    text: std::sync::Arc<Mutex<String>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

impl SubmitRun {
    /// Starts `cmd` with `--events`.
    pub fn start(mut cmd: Command) -> SubmitRun {
        let mut child = cmd
            .arg("--events")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let err = child.stderr.take().unwrap();
        let (tx, rx) = mpsc::channel();
        let text = std::sync::Arc::new(Mutex::new(String::new()));
        let keep = text.clone();
        let reader = std::thread::spawn(move || {
            for line in BufReader::new(err).lines() {
                let Ok(line) = line else { return };
                match serde_json::from_str::<serde_json::Value>(&line) {
                    Ok(v) if v.get("event").is_some() => {
                        let _ = tx.send(v);
                    }
                    _ => {
                        eprintln!("[submit] {line}");
                        let mut t = keep.lock().unwrap_or_else(|e| e.into_inner());
                        t.push_str(&line);
                        t.push('\n');
                    }
                }
            }
        });
        SubmitRun {
            child,
            events: rx,
            seen: Vec::new(),
            text,
            reader: Some(reader),
        }
    }

    /// Waits (bounded) until `cond` holds of the events so far, and returns its value.
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
                Err(_) => panic!(
                    "condition not reached in {timeout:?}; events {:#?}\n{}",
                    self.seen,
                    self.text()
                ),
            }
        }
    }

    /// Waits until at least `n` lines are in.
    pub fn wait_done(&mut self, n: u64, timeout: Duration) {
        self.wait_until(timeout, |seen| {
            seen.iter()
                .any(|v| v["event"] == "line" && v["done"].as_u64() >= Some(n))
                .then_some(())
        })
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

    /// The pid of node `node`'s worker, from the `spawned` events.
    pub fn worker_pid(&self, node: u64) -> i32 {
        self.seen
            .iter()
            .find(|v| v["event"] == "spawned" && v["node"] == node)
            .and_then(|v| v["pid"].as_i64())
            .expect("spawned event") as i32
    }

    /// node -> host from the `spawned` events.
    pub fn hosts(&self) -> Vec<(u64, String)> {
        self.seen
            .iter()
            .filter(|v| v["event"] == "spawned")
            .map(|v| {
                (
                    v["node"].as_u64().unwrap_or(0),
                    v["host"].as_str().unwrap_or("").to_string(),
                )
            })
            .collect()
    }

    /// Waits for the end (bounded), collecting the rest of the events.
    pub fn wait(&mut self, timeout: Duration) -> std::process::ExitStatus {
        let end = Instant::now() + timeout;
        loop {
            if let Some(st) = self.child.try_wait().unwrap() {
                if let Some(r) = self.reader.take() {
                    let _ = r.join(); // the pipe is at its end: every event is in the channel
                }
                while let Ok(v) = self.events.try_recv() {
                    self.seen.push(v);
                }
                return st;
            }
            if let Ok(v) = self.events.recv_timeout(Duration::from_millis(50)) {
                self.seen.push(v);
            }
            assert!(
                Instant::now() < end,
                "submit did not finish in {timeout:?}\n{}",
                self.text()
            );
        }
    }

    /// The non-event lines of stderr (the per-node table, notes, errors).
    pub fn text(&self) -> String {
        self.text.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

impl Drop for SubmitRun {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
