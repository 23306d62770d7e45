//! Hard limits of one daemon: how many processes a request and a host may have, how many
//! bytes the relay may queue (per mailbox, per link, in all), how many bytes of checkpoints
//! a job and the whole host may keep, how many bytes of output are kept, how many ended jobs
//! and for how long, how large a chunk may be and how many bytes of chunks and of the process
//! cache are kept. Every limit is a
//! setting (`DaemonSettings::limits`, flags and TOML keys of the same names); reaching one
//! is answered with a gRPC status (`INVALID_ARGUMENT` for a request that can never be met,
//! `RESOURCE_EXHAUSTED` for one that cannot be met now), never with an abort.

/// The limits, with defaults that suit a workstation.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Processes one spawn request may ask for.
    pub spawn_count: u32,
    /// Processes REM may run at once on this host.
    pub host_processes: usize,
    /// Bytes queued for one local process (its mailbox).
    pub mailbox_bytes: usize,
    /// Bytes queued towards one other daemon (a relay link).
    pub link_bytes: usize,
    /// Bytes the whole relay of this daemon may queue (mailboxes and links together).
    pub relay_bytes: usize,
    /// Bytes of one job's checkpoint.
    pub checkpoint_bytes: usize,
    /// Bytes of checkpoints this host keeps for all jobs together.
    pub checkpoint_quota: u64,
    /// Bytes of stdout and of stderr kept per process.
    pub log_bytes: usize,
    /// Bytes of output kept for all processes of this host together (the oldest exited
    /// processes' records go first).
    pub log_quota: usize,
    /// Connections open at once (more are closed as soon as they are accepted).
    pub connections: usize,
    /// Connections open at once from one address (one IPv6 /64).
    pub connections_per_ip: usize,
    /// Records of ended jobs (finished, failed, cancelled) kept per user; older ones go,
    /// with their checkpoints.
    pub kept_jobs: usize,
    /// Seconds an ended job's record, or any checkpoint, is kept after its last change.
    pub kept_secs: u64,
    /// Milliseconds a job's controller may go without writing its record before the
    /// daemons restart it elsewhere (a stopped or stuck controller).
    pub job_lease_ms: u64,
    /// Restarts of a job's controller before the job is failed.
    pub job_restarts: u64,
    /// Bytes of one chunk (a piece of a scene, `PutChunk`).
    pub chunk_bytes: usize,
    /// Bytes of chunks this host caches (the least recently used go first).
    pub chunk_cache_bytes: u64,
    /// Bytes the host's process cache (`REM_CACHE_DIR`: what processes can rebuild, such as
    /// SunRay's accelerators) may hold; the least recently used files go first.
    pub process_cache_bytes: u64,
    /// Render slots one user's jobs may hold in the whole farm (the queue's cap; `None`: no
    /// cap). Set it alike on every daemon: whichever answers `Queue` applies its own.
    pub user_slots: Option<u32>,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            spawn_count: 256,
            host_processes: 512,
            mailbox_bytes: 64 << 20,
            link_bytes: 64 << 20,
            relay_bytes: 512 << 20,
            checkpoint_bytes: 64 << 20,
            checkpoint_quota: 1 << 30,
            log_bytes: 1 << 20,
            log_quota: 256 << 20,
            connections: 4096,
            connections_per_ip: 512,
            kept_jobs: 100,
            kept_secs: 7 * 24 * 3600,
            job_lease_ms: 10_000,
            job_restarts: 10,
            chunk_bytes: 4 << 20,
            chunk_cache_bytes: 4 << 30,
            process_cache_bytes: 2 << 30,
            user_slots: None,
        }
    }
}

/// Bytes a queued relay item is charged besides its payload (ids, framing), so that a flood
/// of empty envelopes is bounded too.
pub const ITEM_OVERHEAD: usize = 256;

impl Limits {
    /// The names of the limits, as `--limit NAME=VALUE` and the `[limits]` table take them.
    pub const NAMES: [&'static str; 19] = [
        "spawn_count",
        "host_processes",
        "mailbox_bytes",
        "link_bytes",
        "relay_bytes",
        "checkpoint_bytes",
        "checkpoint_quota",
        "log_bytes",
        "log_quota",
        "connections",
        "connections_per_ip",
        "kept_jobs",
        "kept_secs",
        "job_lease_ms",
        "job_restarts",
        "chunk_bytes",
        "chunk_cache_bytes",
        "process_cache_bytes",
        "user_slots",
    ];

    /// Sets the limit `name` from `value`: a whole number, for bytes optionally followed by
    /// `K`, `M` or `G` (powers of 1024). Zero is refused (a limit of nothing is no setting).
    pub fn set(&mut self, name: &str, value: &str) -> Result<(), String> {
        let n = parse_size(value)
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("limit {name}: {value:?} is not a positive number"))?;
        let small = |n: u64| usize::try_from(n).map_err(|_| format!("limit {name}: too large"));
        match name {
            "spawn_count" => {
                self.spawn_count =
                    u32::try_from(n).map_err(|_| format!("limit {name}: too large"))?
            }
            "host_processes" => self.host_processes = small(n)?,
            "mailbox_bytes" => self.mailbox_bytes = small(n)?,
            "link_bytes" => self.link_bytes = small(n)?,
            "relay_bytes" => self.relay_bytes = small(n)?,
            "checkpoint_bytes" => self.checkpoint_bytes = small(n)?,
            "checkpoint_quota" => self.checkpoint_quota = n,
            "log_bytes" => self.log_bytes = small(n)?,
            "log_quota" => self.log_quota = small(n)?,
            "connections" => self.connections = small(n)?,
            "connections_per_ip" => self.connections_per_ip = small(n)?,
            "kept_jobs" => self.kept_jobs = small(n)?,
            "kept_secs" => self.kept_secs = n,
            "job_lease_ms" => self.job_lease_ms = n,
            "job_restarts" => self.job_restarts = n,
            "chunk_bytes" => self.chunk_bytes = small(n)?,
            "chunk_cache_bytes" => self.chunk_cache_bytes = n,
            "process_cache_bytes" => self.process_cache_bytes = n,
            "user_slots" => {
                self.user_slots =
                    Some(u32::try_from(n).map_err(|_| format!("limit {name}: too large"))?)
            }
            _ => {
                return Err(format!(
                    "unknown limit {name:?} (known: {})",
                    Self::NAMES.join(", ")
                ))
            }
        }
        Ok(())
    }

    /// The connection gate's settings.
    pub fn connection_limits(&self) -> crate::daemon::listener::ConnectionLimits {
        crate::daemon::listener::ConnectionLimits {
            max_connections: self.connections,
            max_per_ip: self.connections_per_ip,
            ..crate::daemon::listener::ConnectionLimits::default()
        }
    }

    /// Sets one `NAME=VALUE` pair.
    pub fn set_pair(&mut self, pair: &str) -> Result<(), String> {
        let (name, value) = pair
            .split_once('=')
            .ok_or_else(|| format!("--limit {pair:?}: expected NAME=VALUE"))?;
        self.set(name.trim(), value.trim())
    }
}

/// `123`, `64K`, `16M`, `1G` (binary multiples); `None` when malformed or too large.
fn parse_size(s: &str) -> Option<u64> {
    let s = s.trim();
    let (digits, shift) = match s.as_bytes().last()? {
        b'K' | b'k' => (&s[..s.len() - 1], 10),
        b'M' | b'm' => (&s[..s.len() - 1], 20),
        b'G' | b'g' => (&s[..s.len() - 1], 30),
        _ => (s, 0),
    };
    let n: u64 = digits.trim().parse().ok()?;
    n.checked_mul(1 << shift)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_are_set_by_name_with_size_suffixes() {
        let mut l = Limits::default();
        l.set_pair("mailbox_bytes=8M").unwrap();
        l.set_pair("spawn_count = 16").unwrap();
        l.set("checkpoint_quota", "2G").unwrap();
        assert_eq!(l.mailbox_bytes, 8 << 20);
        assert_eq!(l.spawn_count, 16);
        assert_eq!(l.checkpoint_quota, 2 << 30);
        assert!(l.set("spawn_count", "0").is_err());
        assert!(l.set("spawn_count", "5000000000").is_err());
        assert!(l.set("nonsense", "1").is_err());
        assert!(l.set_pair("log_bytes").is_err());
        assert!(l.set("log_bytes", "-1").is_err());
        assert!(l.set("log_bytes", "99999999999G").is_err());
        for name in Limits::NAMES {
            assert!(l.clone().set(name, "7").is_ok(), "{name}");
        }
    }
}
