//! This host's load, measured with sysinfo about once a second: cores, 1-minute load average,
//! CPU busy fraction, free memory; plus the number of live REM processes, counted exactly.
//!
//! The figure placement ranks by is `load_per_core = (load_avg_1m + rem_processes) / cores`.
//! The REM count is added because the load average lags by a minute: a host that was just
//! given work must look busier at once, or a burst of spawns would all land on it.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::Duration;

use sysinfo::{MemoryRefreshKind, System};
use tokio::sync::watch;

use crate::proto;

/// One sysinfo sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sample {
    pub cores: u32,
    pub load_avg_1m: f64,
    pub cpu_busy: f64,
    pub mem_free_bytes: u64,
    pub mem_total_bytes: u64,
}

/// Cloneable view of this host's load.
#[derive(Clone, Debug)]
pub struct LoadGauge {
    sample: watch::Receiver<Sample>,
    rem_processes: Arc<AtomicU32>,
}

impl LoadGauge {
    /// Starts sampling every `interval` on a thread of its own (sysinfo calls block);
    /// the thread ends when every gauge is dropped.
    pub fn start(interval: Duration) -> Self {
        let mut sys = System::new();
        let first = measure(&mut sys);
        let (tx, rx) = watch::channel(first);
        std::thread::Builder::new()
            .name("remd-load".into())
            .spawn(move || loop {
                std::thread::sleep(interval);
                if tx.send(measure(&mut sys)).is_err() {
                    break;
                }
            })
            .ok();
        LoadGauge {
            sample: rx,
            rem_processes: Arc::new(AtomicU32::new(0)),
        }
    }

    /// The counter the process table keeps up to date.
    pub fn rem_processes(&self) -> &Arc<AtomicU32> {
        &self.rem_processes
    }

    /// The latest figures.
    pub fn current(&self) -> proto::Load {
        let s = self.sample.borrow().clone();
        to_load(&s, self.rem_processes.load(Ordering::Relaxed))
    }
}

/// Combines a sample and the REM process count into the reported figures.
pub fn to_load(s: &Sample, rem_processes: u32) -> proto::Load {
    let cores = s.cores.max(1);
    proto::Load {
        cores,
        load_avg_1m: s.load_avg_1m,
        cpu_busy: s.cpu_busy,
        mem_free_bytes: s.mem_free_bytes,
        mem_total_bytes: s.mem_total_bytes,
        rem_processes,
        load_per_core: (s.load_avg_1m + rem_processes as f64) / cores as f64,
    }
}

fn measure(sys: &mut System) -> Sample {
    sys.refresh_cpu_usage();
    sys.refresh_memory_specifics(MemoryRefreshKind::nothing().with_ram());
    let cores = sys.cpus().len() as u32;
    let cores = if cores == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get() as u32)
    } else {
        cores
    };
    Sample {
        cores,
        load_avg_1m: System::load_average().one,
        cpu_busy: (sys.global_cpu_usage() as f64 / 100.0).clamp(0.0, 1.0),
        mem_free_bytes: sys.available_memory(),
        mem_total_bytes: sys.total_memory(),
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
    }

    #[test]
    fn real_sample_has_cores_and_memory() {
        let gauge = LoadGauge::start(Duration::from_millis(50));
        let l = gauge.current();
        assert!(l.cores >= 1);
        assert!(l.mem_total_bytes > 0);
        assert!(l.load_avg_1m >= 0.0);
        gauge.rem_processes().store(2, Ordering::Relaxed);
        assert_eq!(gauge.current().rem_processes, 2);
    }
}
