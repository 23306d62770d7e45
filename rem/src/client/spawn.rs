//! What a client asks to spawn ([`SpawnRequest`]) and what it gets ([`Job`], one [`Spawned`]
//! per process started).

use std::collections::BTreeMap;

use crate::wire::ids::ProcId;
use crate::wire::proto;

/// What to spawn. `count` defaults to 1.
#[derive(Clone, Debug)]
pub struct SpawnRequest {
    /// Absolute path; must be on the allow-list of every chosen host.
    pub program: String,
    /// Its arguments.
    pub args: Vec<String>,
    /// Environment variables added to what REM gives every process (`REM_*`).
    pub env: BTreeMap<String, String>,
    /// Nice value applied with setpriority (-20..19); `None` = inherit remd's.
    pub nice: Option<i32>,
    /// How many processes, on the least-loaded hosts.
    pub count: u32,
    /// Allow more than one process per host.
    pub allow_same_host: bool,
    /// Job id; `None` = the daemon makes one.
    pub job: Option<String>,
    /// Who receives Started / Exited / Lost events (a relay id from `RemClient::attach`).
    pub owner: Option<ProcId>,
    /// Place every process on this host only; `None` = the least-loaded hosts.
    pub host: Option<String>,
    /// Hosts left out of the placement (where the caller's other processes run).
    pub avoid_hosts: Vec<String>,
    /// Render slots each process holds: at least `slots_min` (0: none, not counted), at most
    /// `slots_max` (0: all its host has free); it learns its grant from `REM_SLOTS`.
    pub slots_min: u32,
    /// See `slots_min`.
    pub slots_max: u32,
    /// Start as many of `count` as there are hosts with free slots (at least one).
    pub up_to: bool,
}

impl SpawnRequest {
    /// The request as sent.
    pub fn to_proto(&self) -> proto::SpawnRequest {
        proto::SpawnRequest {
            program: self.program.clone(),
            args: self.args.clone(),
            env: self.env.clone().into_iter().collect(),
            nice: self.nice,
            count: self.count,
            allow_same_host: self.allow_same_host,
            job: self.job.clone().unwrap_or_default(),
            owner: self
                .owner
                .as_ref()
                .map(|o| o.to_string())
                .unwrap_or_default(),
            host: self.host.clone().unwrap_or_default(),
            avoid_hosts: self.avoid_hosts.clone(),
            slots_min: self.slots_min,
            slots_max: self.slots_max,
            up_to: self.up_to,
        }
    }
}

impl Default for SpawnRequest {
    fn default() -> Self {
        SpawnRequest {
            program: String::new(),
            args: Vec::new(),
            env: BTreeMap::new(),
            nice: None,
            count: 1,
            allow_same_host: false,
            job: None,
            owner: None,
            host: None,
            avoid_hosts: Vec::new(),
            slots_min: 0,
            slots_max: 0,
            up_to: false,
        }
    }
}

/// One started process.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Spawned {
    /// Its REM id (`HOST/NUMBER`).
    pub proc_id: ProcId,
    /// The host it runs on.
    pub host: String,
    /// OS process id on its host.
    pub pid: u32,
    /// Render slots it holds (0: none).
    pub slots: u32,
}

/// The result of a spawn.
#[derive(Clone, Debug)]
pub struct Job {
    /// The job id (given, or made up by the daemon).
    pub id: String,
    /// Its processes, one per placement.
    pub processes: Vec<Spawned>,
}
