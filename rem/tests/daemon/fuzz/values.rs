//! Hostile values of every field type: strings (empty, long, non-ASCII, NUL, paths),
//! process ids, users, job names, numbers at their limits, byte blobs, argument lists,
//! environment maps, and the records and envelopes built of them.

use std::collections::BTreeMap;
use std::time::{SystemTime, UNIX_EPOCH};

use super::credentials::fuzz_user;
use super::rng::Rng;
use super::FAKE_DAEMONS;
use crate::common::ECHO;
use rem::wire::proto;

/// What the generator needs to know of the cluster.
#[derive(Clone)]
pub(super) struct World {
    pub(super) names: Vec<String>,
    pub(super) addrs: Vec<String>,
}

/// Hostile values of every field type.
pub(super) struct Gen<'a> {
    pub(super) rng: &'a mut Rng,
    pub(super) world: &'a World,
}

impl Gen<'_> {
    pub(super) fn string(&mut self) -> String {
        let r = &mut *self.rng;
        match r.below(16) {
            0 => String::new(),
            1 | 2 => {
                let n = 1 + r.below(12);
                r.alnum(n)
            }
            3 => {
                let n = r.pick(&[128, 129, 4096, 70_000]);
                "x".repeat(n)
            }
            4 => r
                .pick(&[
                    "é",
                    "日本語",
                    "\u{202e}evil",
                    "🦀🦀",
                    "\u{fffd}",
                    "Ω/1",
                    "ø-ø",
                ])
                .into(),
            5 => self.proc_id(),
            6 => r
                .pick(&["a\0b", "\0", "exit\0", "a/1\0", "\0\0\0\0"])
                .into(),
            7 => {
                let n = r.len();
                String::from_utf8_lossy(&r.bytes(n)).into_owned()
            }
            8 => r.pick(&self.world.names),
            9 => r
                .pick(&[" ", "\n", "\r\n", "\t", "a b", "-", ".", "..", "_"])
                .into(),
            10 => r
                .pick(&[
                    "../x",
                    "a/b/c",
                    "/etc/passwd",
                    "..\\x",
                    "./",
                    "%s%n%x",
                    "$(reboot)",
                ])
                .into(),
            11 => r.pick(&FAKE_DAEMONS).into(),
            12 => ECHO.into(),
            _ => {
                let n = 1 + r.below(40);
                r.alnum(n)
            }
        }
    }

    pub(super) fn proc_id(&mut self) -> String {
        let r = &mut *self.rng;
        let host = r.pick(&["a", "b", "fz0", "zz", "", "a/b", "..", "日本"]);
        match r.below(10) {
            0 => format!("{host}/{}", r.below(40)),
            1 => format!("{host}/{}", r.next()),
            2 => format!("{host}/18446744073709551616"),
            3 => format!("{host}/-1"),
            4 => format!("{host}/"),
            5 => format!("/{}", r.below(9)),
            6 => r
                .pick(&["a//1", "a/1/2", "a/1 ", " a/1", "a/0x1", "a/+1", "a/1\0"])
                .into(),
            // A valid id with a huge number (see
            // `found_a_kill_of_a_long_process_id_loses_no_envelope_between_daemons`).
            7 => format!("{host}/{}", "9".repeat(r.pick(&[20, 4096, 100_000]))),
            _ => format!("{host}/{}", r.below(2000)),
        }
    }

    /// A job record: any id, user, state, epoch and application bytes.
    pub(super) fn spawn_request(&mut self) -> proto::SpawnRequest {
        proto::SpawnRequest {
            program: self.program(),
            args: self.args(),
            env: self.env(),
            nice: self.nice(),
            count: self.u32(),
            allow_same_host: self.rng.one_in(2),
            job: self.job(),
            owner: if self.rng.one_in(2) {
                String::new()
            } else {
                self.proc_id()
            },
            host: if self.rng.one_in(2) {
                String::new()
            } else {
                self.string()
            },
            avoid_hosts: self.many(Gen::string),
            slots_min: self.u32(),
            slots_max: self.u32(),
            up_to: self.rng.one_in(2),
        }
    }

    pub(super) fn job_record(&mut self) -> proto::JobRecord {
        proto::JobRecord {
            id: self.job(),
            user: self.user(),
            state: if self.rng.one_in(4) {
                self.string()
            } else {
                self.rng.pick(&rem::store::job_store::STATES).into()
            },
            epoch: self.u64(),
            controller: self.proc_id(),
            controller_host: self.string(),
            created_unix_ms: self.u64(),
            updated_unix_ms: self.u64(),
            progress_done: self.u64(),
            progress_total: self.u64(),
            app: self.data(),
            controller_spawn: self.rng.one_in(2).then(|| self.spawn_request()),
            message: self.string(),
            title: self.string(),
            priority: self.u32(),
            slots: self.u32(),
            slots_wanted: self.u32(),
        }
    }

    /// A user name: the fuzzer's own, another, or anything (`..`, empty, long, unicode).
    pub(super) fn user(&mut self) -> String {
        match self.rng.below(4) {
            0 => self.string(),
            1 => self.rng.pick(&["..", ".", "", "a/b", "mallory"]).into(),
            _ => fuzz_user(),
        }
    }

    /// On whose behalf a daemon asks: missing, or any user, admin or not.
    pub(super) fn acting(&mut self) -> Option<proto::Acting> {
        if self.rng.one_in(4) {
            return None;
        }
        Some(proto::Acting {
            user: self.user(),
            admin: self.rng.one_in(2),
        })
    }

    pub(super) fn job(&mut self) -> String {
        match self.rng.below(4) {
            0 => self.string(),
            _ => format!("job{}", self.rng.below(24)),
        }
    }

    pub(super) fn u32(&mut self) -> u32 {
        let r = &mut *self.rng;
        match r.below(8) {
            0 => 0,
            1 => u32::MAX,
            2 => u32::MAX - 1,
            3 => 1 << 31,
            4 => r.below(5) as u32,
            5 => 257,
            _ => r.next() as u32,
        }
    }

    pub(super) fn u64(&mut self) -> u64 {
        let r = &mut *self.rng;
        match r.below(7) {
            0 => 0,
            1 => u64::MAX,
            2 => i64::MAX as u64,
            3 => now_ns(),
            4 => now_ns().saturating_sub(r.below(1 << 30) as u64),
            5 => now_ns().saturating_add(120_000_000_000),
            _ => r.next(),
        }
    }

    pub(super) fn nice(&mut self) -> Option<i32> {
        let r = &mut *self.rng;
        match r.below(10) {
            0 => None,
            1 => Some(i32::MIN),
            2 => Some(i32::MAX),
            3 => Some(-21),
            4 => Some(-20),
            5 => Some(-1),
            6 => Some(19),
            7 => Some(20),
            8 => Some(0),
            _ => Some(r.next() as i32),
        }
    }

    pub(super) fn data(&mut self) -> Vec<u8> {
        let n = match self.rng.below(24) {
            0 => 256 << 10,
            1 => (256 << 10) + 1,
            _ => self.rng.len(),
        };
        self.rng.bytes(n)
    }

    pub(super) fn strings(&mut self) -> Vec<String> {
        let n = match self.rng.below(12) {
            0 => 257,
            1 => 5000,
            _ => self.rng.below(4),
        };
        (0..n).map(|_| self.string()).collect()
    }

    /// A program: mostly the one allowed (rem-echo), else anything.
    pub(super) fn program(&mut self) -> String {
        let r = &mut *self.rng;
        match r.below(8) {
            0..=3 => ECHO.into(),
            4 => r
                .pick(&["/bin/sh", "/bin/true", "/usr/bin/env", "/", "rem-echo"])
                .into(),
            5 => format!("{ECHO}{}", r.pick(&["\0", "/..", "/", " ", "x"])),
            6 => format!("{}/../{}", ECHO.rsplit_once('/').unwrap().0, "rem-echo"),
            _ => self.string(),
        }
    }

    /// Arguments: mostly `exit CODE` (what the daemons allow), else anything.
    pub(super) fn args(&mut self) -> Vec<String> {
        let r = &mut *self.rng;
        match r.below(6) {
            0 | 1 => vec!["exit".into(), r.pick(&["0", "3", "255", "-1", "x"]).into()],
            2 => vec![r
                .pick(&["spin", "env", "echo", "sink", "", "exit\0", "EXIT"])
                .into()],
            3 => {
                let mut a = vec!["exit".to_string()];
                a.extend(self.strings());
                a
            }
            _ => self.strings(),
        }
    }

    pub(super) fn env(&mut self) -> BTreeMap<String, String> {
        let n = match self.rng.below(12) {
            0 => 65,
            1 => 2000,
            _ => self.rng.below(3),
        };
        (0..n)
            .map(|_| {
                let key = match self.rng.below(3) {
                    0 => self
                        .rng
                        .pick(&[
                            "SUNRAY_WORKER_X",
                            "RUST_LOG",
                            "LD_PRELOAD",
                            "PATH",
                            "REM_PROC_TOKEN",
                            "",
                            "A=B",
                        ])
                        .to_string(),
                    1 => format!("SUNRAY_WORKER_{}", self.rng.below(100_000)),
                    _ => self.string(),
                };
                (key, self.string())
            })
            .collect()
    }

    pub(super) fn envelope(&mut self) -> proto::Envelope {
        proto::Envelope {
            from: self.proc_id(),
            to: self.proc_id(),
            payload: self.data(),
        }
    }

    pub(super) fn event(&mut self) -> proto::JobEvent {
        proto::JobEvent {
            job: self.job(),
            proc_id: self.proc_id(),
            host: self.string(),
            kind: self.rng.pick(&[0, 1, 2, 3, 4, -1, i32::MAX]),
            exit_code: self.nice(),
            signal: self.nice(),
            message: self.string(),
            owner: self.proc_id(),
        }
    }

    pub(super) fn undeliverable(&mut self) -> proto::Undeliverable {
        proto::Undeliverable {
            to: self.proc_id(),
            reason: self.string(),
            sender: self.proc_id(),
        }
    }

    pub(super) fn many<T>(&mut self, mut one: impl FnMut(&mut Self) -> T) -> Vec<T> {
        let n = match self.rng.below(16) {
            0 => 300,
            _ => self.rng.below(4),
        };
        (0..n).map(|_| one(self)).collect()
    }
}

pub(super) fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}
