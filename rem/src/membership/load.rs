//! This host's load, measured with sysinfo about once a second: cores, 1-minute load average,
//! CPU busy fraction, free memory; plus the number of live REM processes, counted exactly.
//!
//! The figure placement ranks by is `load_per_core = (load_avg_1m + rem_processes) / cores`.
//! The REM count is added because the load average lags by a minute: a host that was just
//! given work must look busier at once, or a burst of spawns would all land on it.
//!
//! In a control group with a CPU limit below the host's cores (a container with `cpus: 0.5`,
//! a systemd slice with `CPUQuota=`), the host-wide figures say nothing about this daemon's
//! share, so the group's own are used (see [`crate::membership::cgroup`]): `capacity` is the limit in
//! cores (fractional), `cores` its ceiling, `cpu_busy` the group's CPU use over the last
//! [`GROUP_WINDOW`] divided by the capacity, and
//! `load_per_core = (cores used by the group + rem_processes) / capacity`.
//! The group's use is averaged over that window, as the load average is, so that a second's
//! burst (a controller reading its scene) or a second's starvation (the host's cores taken by
//! something outside the group) does not reorder the hosts.
//! `load_avg_1m` stays the host's figure, for information.
//!
//! Beside the load, the host's render slots ([`Slots`]): how many threads it lends the farm
//! (`remd --slots`, by default its `cores` as reported here) and how many its processes hold.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::Duration;

use sysinfo::{MemoryRefreshKind, System};
use tokio::sync::watch;

use crate::membership::cgroup::{CpuGroup, UsageSample};
use crate::membership::slots::{FarmCpu, OwnerLoad, Slots};
use crate::wire::proto;

/// One sysinfo sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sample {
    pub cores: u32,
    pub load_avg_1m: f64,
    pub cpu_busy: f64,
    pub mem_free_bytes: u64,
    pub mem_total_bytes: u64,
    /// The cgroup's CPU limit in cores, when it is below the host's cores.
    pub capacity: Option<f64>,
    /// Cores the cgroup used over the last [`GROUP_WINDOW`] (with `capacity`).
    pub group_busy_cores: f64,
}

/// Cloneable view of this host's load.
#[derive(Clone, Debug)]
pub struct LoadGauge {
    sample: watch::Receiver<Sample>,
    rem_processes: Arc<AtomicU32>,
    slots: Arc<Slots>,
}

impl LoadGauge {
    /// Starts sampling every `interval` on a thread of its own (sysinfo calls block);
    /// the thread ends when every gauge is dropped. The host lends `slots` render slots
    /// (`None`: its cores as reported); with `owner_first`, fewer while its owner's own work
    /// keeps its CPUs busy ([`crate::membership::slots`]).
    pub fn start(interval: Duration, slots: Option<u32>, owner_first: bool) -> Self {
        let mut meter = Meter::new();
        let first = meter.measure();
        let lent = slots.unwrap_or_else(|| to_load(&first, 0).cores);
        let slots = Arc::new(Slots::new(lent));
        let (tx, rx) = watch::channel(first);
        let lending = owner_first.then(|| slots.clone());
        std::thread::Builder::new()
            .name("remd-load".into())
            .spawn(move || {
                let (mut farm, mut owner) = (FarmCpu::default(), OwnerLoad::default());
                loop {
                    std::thread::sleep(interval);
                    let sample = meter.measure();
                    if let Some(slots) = &lending {
                        let load = to_load(&sample, 0);
                        let busy = load.cpu_busy * load.capacity;
                        let owner_cores = owner.add(busy, farm.measure(&slots.holders()));
                        slots.lend_beside(owner_cores);
                    }
                    if tx.send(sample).is_err() {
                        break;
                    }
                }
            })
            .ok();
        LoadGauge {
            sample: rx,
            rem_processes: Arc::new(AtomicU32::new(0)),
            slots,
        }
    }

    /// The host's render slots (the process table takes and gives them back).
    pub fn slots(&self) -> &Arc<Slots> {
        &self.slots
    }

    /// The counter the process table keeps up to date.
    pub fn rem_processes(&self) -> &Arc<AtomicU32> {
        &self.rem_processes
    }

    /// The latest figures.
    pub fn current(&self) -> proto::Load {
        let s = self.sample.borrow().clone();
        proto::Load {
            slots: self.slots.lent(),
            slots_used: self.slots.used(),
            ..to_load(&s, self.rem_processes.load(Ordering::Relaxed))
        }
    }
}

/// Combines a sample and the REM process count into the reported figures.
pub fn to_load(s: &Sample, rem_processes: u32) -> proto::Load {
    let host_cores = s.cores.max(1);
    let (cores, capacity, cpu_busy, load) = match s.capacity.filter(|c| *c > 0.0) {
        Some(capacity) => (
            (capacity.ceil() as u32).clamp(1, host_cores),
            capacity,
            (s.group_busy_cores / capacity).clamp(0.0, 1.0),
            s.group_busy_cores,
        ),
        None => (host_cores, host_cores as f64, s.cpu_busy, s.load_avg_1m),
    };
    proto::Load {
        cores,
        load_avg_1m: s.load_avg_1m,
        cpu_busy,
        mem_free_bytes: s.mem_free_bytes,
        mem_total_bytes: s.mem_total_bytes,
        rem_processes,
        load_per_core: (load + rem_processes as f64) / capacity,
        capacity,
        // What this build speaks; membership announces the configured one.
        protocol: crate::wire::protocol::PROTOCOL,
        slots: 0,
        slots_used: 0,
    }
}

/// How far back a control group's CPU use is averaged.
pub const GROUP_WINDOW: Duration = Duration::from_secs(10);

/// The control group's usage samples of the last [`GROUP_WINDOW`], oldest first.
#[derive(Debug, Default)]
struct UsageWindow {
    samples: VecDeque<UsageSample>,
}

impl UsageWindow {
    /// Adds `now` and returns the cores used since the oldest sample kept (0 with only one).
    /// The oldest kept is the newest one at least [`GROUP_WINDOW`] old, so the average spans
    /// the whole window once the daemon has run that long.
    fn push(&mut self, now: UsageSample) -> f64 {
        while self.samples.len() >= 2
            && now.at.saturating_duration_since(self.samples[1].at) >= GROUP_WINDOW
        {
            self.samples.pop_front();
        }
        let busy = self
            .samples
            .front()
            .map_or(0.0, |oldest| CpuGroup::busy_cores(oldest, &now));
        self.samples.push_back(now);
        busy
    }
}

/// What the sampling thread keeps between samples.
struct Meter {
    sys: System,
    group: Option<CpuGroup>,
    usage: UsageWindow,
}

impl Meter {
    fn new() -> Self {
        let mut sys = System::new();
        sys.refresh_cpu_usage();
        let group = CpuGroup::detect(host_cores(&sys)).filter(|g| g.capacity.is_some());
        let mut usage = UsageWindow::default();
        if let Some(first) = group.as_ref().and_then(CpuGroup::usage) {
            usage.push(first);
        }
        Meter { sys, group, usage }
    }

    fn measure(&mut self) -> Sample {
        let sys = &mut self.sys;
        sys.refresh_cpu_usage();
        sys.refresh_memory_specifics(MemoryRefreshKind::nothing().with_ram());
        let mut group_busy_cores = 0.0;
        if let Some(now) = self.group.as_ref().and_then(CpuGroup::usage) {
            group_busy_cores = self.usage.push(now);
        }
        Sample {
            cores: host_cores(sys),
            load_avg_1m: System::load_average().one,
            cpu_busy: (sys.global_cpu_usage() as f64 / 100.0).clamp(0.0, 1.0),
            mem_free_bytes: sys.available_memory(),
            mem_total_bytes: sys.total_memory(),
            capacity: self.group.as_ref().and_then(|g| g.capacity),
            group_busy_cores,
        }
    }
}

fn host_cores(sys: &System) -> u32 {
    match sys.cpus().len() as u32 {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get() as u32),
        n => n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rem_processes_count_per_core() {
        let s = Sample {
            cores: 4,
            load_avg_1m: 1.0,
            ..Sample::default()
        };
        let l = to_load(&s, 3);
        assert_eq!(l.load_per_core, 1.0);
        assert_eq!(to_load(&Sample::default(), 1).cores, 1);
        assert_eq!(l.capacity, 4.0);
    }

    #[test]
    fn a_cpu_limit_is_the_capacity() {
        // A container limited to a quarter of a core on a 2-core host: the host's load
        // average does not count, the group's own use does.
        let s = Sample {
            cores: 2,
            load_avg_1m: 5.0,
            cpu_busy: 0.9,
            capacity: Some(0.25),
            group_busy_cores: 0.125,
            ..Sample::default()
        };
        let l = to_load(&s, 1);
        assert_eq!((l.cores, l.capacity), (1, 0.25));
        assert!((l.cpu_busy - 0.5).abs() < 1e-9);
        assert!((l.load_per_core - 4.5).abs() < 1e-9);
        assert_eq!(l.load_avg_1m, 5.0);
        let big = Sample {
            cores: 8,
            capacity: Some(2.5),
            ..Sample::default()
        };
        assert_eq!(to_load(&big, 0).cores, 3);
    }

    #[test]
    fn a_groups_use_is_averaged_over_the_window() {
        let t0 = std::time::Instant::now();
        let at = |s: u64, cpu_s: f64| UsageSample {
            at: t0 + Duration::from_secs(s),
            cpu_ns: (cpu_s * 1e9) as u64,
        };
        let mut w = UsageWindow::default();
        assert_eq!(w.push(at(0, 0.0)), 0.0);
        // Idle for 9 s, then a 1 s burst of a whole core: a tenth of a core over the window.
        let mut busy = 0.0;
        for s in 1..=9 {
            busy = w.push(at(s, 0.0));
        }
        assert_eq!(busy, 0.0);
        assert!((w.push(at(10, 1.0)) - 0.1).abs() < 1e-9);
        // Half a core from then on: after a whole window the average is exactly that.
        for s in 11..=20 {
            busy = w.push(at(s, 1.0 + 0.5 * (s - 10) as f64));
        }
        assert!((busy - 0.5).abs() < 1e-9, "{busy}");
        assert!(w.samples.len() <= 11, "{} samples kept", w.samples.len());
    }

    #[test]
    fn real_sample_has_cores_and_memory() {
        let gauge = LoadGauge::start(Duration::from_millis(50), None, false);
        let l = gauge.current();
        assert_eq!(l.slots, l.cores, "a host lends its cores by default");
        assert!(l.cores >= 1);
        assert!(l.mem_total_bytes > 0);
        assert!(l.load_avg_1m >= 0.0);
        gauge.rem_processes().store(2, Ordering::Relaxed);
        assert_eq!(gauge.current().rem_processes, 2);
        assert_eq!(
            LoadGauge::start(Duration::from_secs(1), Some(7), false)
                .current()
                .slots,
            7
        );
    }
}
