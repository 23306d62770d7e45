//! The render slots of this host: how many threads it lends the farm, and how many the
//! processes it runs hold. Only the process table takes and gives back slots; the load
//! gauge reports them.
//!
//! **The owner first** (`remd --owner-first`): a workstation whose owner's own work keeps its
//! cores busy lends fewer slots, as the thesis's nice did for workstation owners. The owner's
//! load is what the host's (or its control group's) CPUs are busy with besides the processes
//! holding slots, whose CPU time is read from `/proc` ([`FarmCpu`]), averaged over a few
//! seconds ([`OwnerLoad`]); the host lends a slot less for each whole core of it (rounded).
//! Slots held beyond
//! what it lends are not taken back here: REM's queue then counts fewer slots in the farm,
//! and the jobs above their share give theirs back at a line's end.

use std::collections::{BTreeSet, HashMap};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// The render slots of this host.
#[derive(Debug, Default)]
pub struct Slots {
    /// What `--slots` (or the cores) says.
    configured: u32,
    /// What it lends now (less than `configured` while its owner's work keeps it busy).
    lent: AtomicU32,
    used: AtomicU32,
    /// The processes holding slots (their pids).
    holders: Mutex<BTreeSet<u32>>,
}

impl Slots {
    /// A host lending `lent` slots, none held.
    pub fn new(lent: u32) -> Self {
        Slots {
            configured: lent,
            lent: AtomicU32::new(lent),
            used: AtomicU32::new(0),
            holders: Mutex::new(BTreeSet::new()),
        }
    }

    /// Slots lent now.
    pub fn lent(&self) -> u32 {
        self.lent.load(Ordering::Relaxed)
    }

    /// Slots held by running processes.
    pub fn used(&self) -> u32 {
        self.used.load(Ordering::Relaxed)
    }

    /// Takes as many free slots as there are, at least `min` and at most `max` (0: no most);
    /// `None` (nothing taken) when fewer than `min` are free.
    pub fn take(&self, min: u32, max: u32) -> Option<u32> {
        let max = if max == 0 { u32::MAX } else { max };
        let mut got = 0;
        self.used
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |used| {
                let free = self.lent().saturating_sub(used);
                got = free.min(max);
                (got >= min.max(1)).then_some(used + got)
            })
            .ok()
            .map(|_| got)
    }

    /// Gives back `n` slots a process held.
    pub fn give_back(&self, n: u32) {
        let _ = self
            .used
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |u| {
                Some(u.saturating_sub(n))
            });
    }

    /// Process `pid` holds slots (until [`Slots::left`]).
    pub fn holds(&self, pid: u32) {
        self.lock().insert(pid);
    }

    /// Process `pid` exited.
    pub fn left(&self, pid: u32) {
        self.lock().remove(&pid);
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeSet<u32>> {
        self.holders.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Lends what the owner's work on `owner_cores` CPUs leaves (the owner first).
    pub(crate) fn lend_beside(&self, owner_cores: f64) {
        let n = lendable(self.configured, owner_cores);
        self.lent.store(n, Ordering::Relaxed);
    }

    /// The processes holding slots.
    pub(crate) fn holders(&self) -> Vec<u32> {
        self.lock().iter().copied().collect()
    }
}

/// The slots a host configured to lend `configured` lends while its owner's own work keeps
/// `owner_cores` CPUs busy: a slot less for each whole core of it, rounded (a quarter-CPU
/// container lends its one slot while its owner is idle).
pub fn lendable(configured: u32, owner_cores: f64) -> u32 {
    let owner = owner_cores.max(0.0).round();
    configured.saturating_sub(if owner >= f64::from(u32::MAX) {
        u32::MAX
    } else {
        owner as u32
    })
}

/// The CPU time the processes holding slots use, from `/proc/PID/stat` (user and system
/// time of every thread of each), between one measure and the next.
#[derive(Debug, Default)]
pub struct FarmCpu {
    last: HashMap<u32, u64>,
    at: Option<Instant>,
}

impl FarmCpu {
    /// Cores the processes `pids` used since the last measure (those seen both times).
    pub fn measure(&mut self, pids: &[u32]) -> f64 {
        let now = Instant::now();
        let ticks: HashMap<u32, u64> = pids
            .iter()
            .filter_map(|&p| cpu_ticks(p).map(|t| (p, t)))
            .collect();
        let used: u64 = ticks
            .iter()
            .filter_map(|(p, t)| self.last.get(p).map(|l| t.saturating_sub(*l)))
            .sum();
        let secs = self
            .at
            .map_or(0.0, |at| now.saturating_duration_since(at).as_secs_f64());
        self.last = ticks;
        self.at = Some(now);
        if secs <= 0.0 {
            return 0.0;
        }
        used as f64 / clock_ticks_per_second() / secs
    }
}

/// The owner's load, smoothed: one busy second does not take a slot away, a busy minute does.
#[derive(Debug, Default)]
pub struct OwnerLoad {
    cores: Option<f64>,
}

impl OwnerLoad {
    /// Weight of the newest measure.
    const NEW: f64 = 0.3;

    /// Adds a measure (the CPUs busy, those the farm's processes used) and returns the owner's
    /// cores, averaged.
    pub fn add(&mut self, busy_cores: f64, farm_cores: f64) -> f64 {
        let now = (busy_cores - farm_cores).max(0.0);
        let avg = match self.cores {
            Some(c) => c + Self::NEW * (now - c),
            None => now,
        };
        self.cores = Some(avg);
        avg
    }
}

/// User and system time of process `pid`, in clock ticks (fields 14 and 15 of its stat).
fn cpu_ticks(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) may hold spaces: the fields after it follow the last ')'.
    let rest = stat.get(stat.rfind(')')? + 2..)?;
    let mut f = rest.split_whitespace().skip(11);
    let utime: u64 = f.next()?.parse().ok()?;
    let stime: u64 = f.next()?.parse().ok()?;
    Some(utime + stime)
}

fn clock_ticks_per_second() -> f64 {
    // SAFETY: sysconf has no preconditions.
    match unsafe { libc::sysconf(libc::_SC_CLK_TCK) } {
        n if n > 0 => n as f64,
        _ => 100.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_taken_while_free_and_given_back() {
        let s = Slots::new(5);
        assert_eq!(s.take(1, 2), Some(2));
        assert_eq!(s.take(1, 0), Some(3), "0: all that is free");
        assert_eq!(s.take(1, 1), None);
        s.give_back(3);
        assert_eq!(s.take(4, 0), None, "fewer than the least free");
        assert_eq!(s.take(0, 0), Some(3), "a least of 0 counts as 1");
        s.give_back(9);
        assert_eq!(s.used(), 0);
        assert_eq!(Slots::new(0).take(1, 1), None);
    }

    #[test]
    fn a_busy_owner_takes_slots_back_and_the_farms_own_work_does_not() {
        assert_eq!(lendable(4, 0.0), 4);
        assert_eq!(lendable(4, 1.4), 3, "rounded");
        assert_eq!(lendable(4, 1.6), 2);
        assert_eq!(lendable(4, 9.0), 0);
        assert_eq!(lendable(1, 0.1), 1, "a quarter-CPU container's one slot");
        assert_eq!(lendable(4, f64::INFINITY), 0);
        // The CPUs busy with the farm's processes are not the owner's.
        let mut owner = OwnerLoad::default();
        assert_eq!(owner.add(4.0, 4.0), 0.0);
        // The owner starts two cores' work: the average follows within a few seconds.
        let mut last = 0.0;
        for _ in 0..10 {
            last = owner.add(4.0, 2.0);
        }
        assert!((last - 2.0).abs() < 0.1, "{last}");
        let s = Slots::new(4);
        s.lend_beside(last);
        assert_eq!(s.lent(), 2);
        assert_eq!(s.take(3, 0), None, "what the owner uses is not lent");
    }

    #[test]
    fn the_farms_cpu_is_read_from_proc() {
        let me = std::process::id();
        let mut farm = FarmCpu::default();
        assert_eq!(farm.measure(&[me]), 0.0, "nothing to compare with yet");
        let spin = Instant::now();
        let mut x = 0u64;
        while spin.elapsed() < std::time::Duration::from_millis(300) {
            x = std::hint::black_box(x.wrapping_add(1));
        }
        let used = farm.measure(&[me, u32::MAX]);
        assert!(used > 0.3, "a spinning thread uses a core: {used}");
    }

    #[test]
    fn the_holders_are_kept_until_they_leave() {
        let s = Slots::new(1);
        s.holds(7);
        s.holds(9);
        s.left(7);
        assert_eq!(s.holders(), [9]);
    }
}
