//! The CPU share of the control group remd runs in (cgroup v1 and v2), so that a daemon in a
//! container with a CPU limit reports its own capacity and use instead of the host's.
//!
//! `/proc/loadavg` and `/proc/stat` are host-wide: in a container every daemon would report
//! the same load and the host's core count. Here we find:
//!
//! - **capacity** in cores: the CPU quota (`cpu.max` in v2; `cpu.cfs_quota_us /
//!   cpu.cfs_period_us` in v1), the smallest along the path from our group to the root, and
//!   no more than the cpuset's CPU count; `None` when neither limits us below the host;
//! - **usage**: the group's CPU time so far (`cpu.stat usage_usec` in v2, `cpuacct.usage` in
//!   nanoseconds in v1), from which [`CpuGroup::busy_cores`] derives the cores used between
//!   two samples.
//!
//! Our group's path comes from `/proc/self/cgroup`. In a container with a private cgroup
//! namespace (or a v1 mount of the container's own group) that path is not below the mount,
//! so each ancestor is tried and the mount root is the last resort.

use std::path::{Path, PathBuf};
use std::time::Instant;

/// Which cgroup layout a host uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Version {
    V1,
    V2,
}

/// The CPU controller files of the group this process is in.
#[derive(Clone, Debug, PartialEq)]
pub struct CpuGroup {
    pub version: Version,
    /// Cores this group may use, when that is below the host's count.
    pub capacity: Option<f64>,
    /// The file holding the group's CPU time (`cpu.stat` or `cpuacct.usage`).
    usage_file: Option<PathBuf>,
}

/// One reading of a group's CPU time.
#[derive(Clone, Copy, Debug)]
pub struct UsageSample {
    pub at: Instant,
    pub cpu_ns: u64,
}

impl CpuGroup {
    /// The group of this process under `/sys/fs/cgroup`, or `None` where there is no cgroup
    /// file system (or nothing readable in it).
    pub fn detect(host_cores: u32) -> Option<CpuGroup> {
        let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
        detect_at(Path::new("/sys/fs/cgroup"), &own, host_cores)
    }

    /// The group's CPU time now.
    pub fn usage(&self) -> Option<UsageSample> {
        let file = self.usage_file.as_ref()?;
        let text = std::fs::read_to_string(file).ok()?;
        let cpu_ns = match self.version {
            Version::V2 => parse_cpu_stat_usage_usec(&text)?.checked_mul(1000)?,
            Version::V1 => text.trim().parse().ok()?,
        };
        Some(UsageSample {
            at: Instant::now(),
            cpu_ns,
        })
    }

    /// Cores used on average between two readings (0 when the clock did not move).
    pub fn busy_cores(before: &UsageSample, after: &UsageSample) -> f64 {
        let wall = after.at.saturating_duration_since(before.at).as_nanos() as f64;
        if wall <= 0.0 {
            return 0.0;
        }
        after.cpu_ns.saturating_sub(before.cpu_ns) as f64 / wall
    }
}

/// [`CpuGroup::detect`] with the cgroup mount and `/proc/self/cgroup` text given (for tests).
pub fn detect_at(mount: &Path, proc_self_cgroup: &str, host_cores: u32) -> Option<CpuGroup> {
    let host = f64::from(host_cores.max(1));
    let capacity_below_host = |c: Option<f64>| c.filter(|&c| c > 0.0 && c < host);
    if mount.join("cgroup.controllers").exists() {
        let own = own_path(proc_self_cgroup, None)?;
        let dirs = ancestors_under(mount, &own);
        let quota = dirs
            .iter()
            .filter_map(|d| read(d, "cpu.max").and_then(|t| parse_cpu_max(&t)))
            .reduce(f64::min);
        let cpuset = dirs
            .iter()
            .find_map(|d| read(d, "cpuset.cpus.effective"))
            .and_then(|t| parse_cpu_list(&t));
        let usage_file = dirs.iter().map(|d| d.join("cpu.stat")).find(|f| f.exists());
        return Some(CpuGroup {
            version: Version::V2,
            capacity: capacity_below_host(min_opt(quota, cpuset.map(f64::from))),
            usage_file,
        });
    }
    let cpu_mount = ["cpu,cpuacct", "cpu", "cpuacct,cpu"]
        .iter()
        .map(|m| mount.join(m))
        .find(|d| d.join("cpu.cfs_quota_us").exists())?;
    let own = own_path(proc_self_cgroup, Some("cpu")).unwrap_or_else(|| "/".into());
    let dirs = ancestors_under(&cpu_mount, &own);
    let quota = dirs
        .iter()
        .filter_map(|d| {
            let q = read(d, "cpu.cfs_quota_us")?;
            let p = read(d, "cpu.cfs_period_us")?;
            parse_cfs_quota(&q, &p)
        })
        .reduce(f64::min);
    let cpuset_own = own_path(proc_self_cgroup, Some("cpuset")).unwrap_or_else(|| "/".into());
    let cpuset = ancestors_under(&mount.join("cpuset"), &cpuset_own)
        .iter()
        .find_map(|d| read(d, "cpuset.cpus"))
        .and_then(|t| parse_cpu_list(&t));
    let acct_own = own_path(proc_self_cgroup, Some("cpuacct")).unwrap_or_else(|| "/".into());
    let usage_file = ["cpu,cpuacct", "cpuacct", "cpuacct,cpu"]
        .iter()
        .flat_map(|m| ancestors_under(&mount.join(m), &acct_own))
        .map(|d| d.join("cpuacct.usage"))
        .find(|f| f.exists());
    Some(CpuGroup {
        version: Version::V1,
        capacity: capacity_below_host(min_opt(quota, cpuset.map(f64::from))),
        usage_file,
    })
}

fn min_opt(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

fn read(dir: &Path, file: &str) -> Option<String> {
    std::fs::read_to_string(dir.join(file)).ok()
}

/// The existing directories for `own` and each of its ancestors under `mount`, deepest
/// first, ending with the mount itself.
fn ancestors_under(mount: &Path, own: &str) -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    let mut path = Path::new(own);
    loop {
        let rel = path.strip_prefix("/").unwrap_or(path);
        let dir = mount.join(rel);
        if dir.is_dir() && !dirs.contains(&dir) {
            dirs.push(dir);
        }
        match path.parent() {
            Some(parent) => path = parent,
            None => break,
        }
    }
    if mount.is_dir() && !dirs.iter().any(|d| d == mount) {
        dirs.push(mount.to_path_buf());
    }
    dirs
}

/// This process's group path from `/proc/self/cgroup`: the v2 line (`0::/path`) when
/// `controller` is `None`, else the v1 line whose controller list names it.
pub fn own_path(proc_self_cgroup: &str, controller: Option<&str>) -> Option<String> {
    proc_self_cgroup.lines().find_map(|line| {
        let mut parts = line.splitn(3, ':');
        let (_id, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let wanted = match controller {
            None => controllers.is_empty(),
            Some(c) => controllers.split(',').any(|x| x == c),
        };
        wanted.then(|| path.trim().to_string())
    })
}

/// v2 `cpu.max`: `"QUOTA PERIOD"` in microseconds, or `"max PERIOD"` for no limit.
pub fn parse_cpu_max(text: &str) -> Option<f64> {
    let mut parts = text.split_whitespace();
    let quota = parts.next()?;
    let period: f64 = parts.next().map_or(Some(100_000.0), |p| p.parse().ok())?;
    if quota == "max" || period <= 0.0 {
        return None;
    }
    let quota: f64 = quota.parse().ok()?;
    (quota > 0.0).then(|| quota / period)
}

/// v1 `cpu.cfs_quota_us` and `cpu.cfs_period_us`; a quota of -1 means no limit.
pub fn parse_cfs_quota(quota: &str, period: &str) -> Option<f64> {
    let quota: i64 = quota.trim().parse().ok()?;
    let period: i64 = period.trim().parse().ok()?;
    (quota > 0 && period > 0).then(|| quota as f64 / period as f64)
}

/// `usage_usec` from v2 `cpu.stat`.
pub fn parse_cpu_stat_usage_usec(text: &str) -> Option<u64> {
    text.lines().find_map(|line| {
        let (key, value) = line.split_once(char::is_whitespace)?;
        (key == "usage_usec").then(|| value.trim().parse().ok())?
    })
}

/// The number of CPUs in a list such as `0-3,6,8-9`; `None` when empty or malformed.
pub fn parse_cpu_list(text: &str) -> Option<u32> {
    let mut count = 0u32;
    for part in text.trim().split(',').filter(|p| !p.is_empty()) {
        count += match part.split_once('-') {
            Some((a, b)) => {
                let (a, b): (u32, u32) = (a.parse().ok()?, b.parse().ok()?);
                b.checked_sub(a)? + 1
            }
            None => {
                part.parse::<u32>().ok()?;
                1
            }
        };
    }
    (count > 0).then_some(count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    const V1_DOCKER: &str = "12:cpuset:/docker/abc\n4:cpu,cpuacct:/docker/abc\n\
                             3:memory:/docker/abc\n1:name=systemd:/docker/abc\n0::/system.slice\n";

    #[test]
    fn quota_files_parse() {
        assert_eq!(parse_cpu_max("25000 100000\n"), Some(0.25));
        assert_eq!(parse_cpu_max("150000 100000"), Some(1.5));
        assert_eq!(parse_cpu_max("max 100000\n"), None);
        assert_eq!(parse_cpu_max(""), None);
        assert_eq!(parse_cpu_max("abc 100000"), None);
        assert_eq!(parse_cfs_quota("50000\n", "100000\n"), Some(0.5));
        assert_eq!(parse_cfs_quota("-1\n", "100000\n"), None);
        assert_eq!(parse_cfs_quota("x", "100000"), None);
    }

    #[test]
    fn usage_and_cpu_lists_parse() {
        let stat = "usage_usec 123456\nuser_usec 100000\nsystem_usec 23456\nnr_periods 0\n";
        assert_eq!(parse_cpu_stat_usage_usec(stat), Some(123_456));
        assert_eq!(parse_cpu_stat_usage_usec("user_usec 5\n"), None);
        assert_eq!(parse_cpu_list("0-3,6,8-9\n"), Some(7));
        assert_eq!(parse_cpu_list("0\n"), Some(1));
        assert_eq!(parse_cpu_list("\n"), None);
        assert_eq!(parse_cpu_list("3-1"), None);
        assert_eq!(parse_cpu_list("a-b"), None);
    }

    #[test]
    fn own_path_picks_the_right_line() {
        assert_eq!(
            own_path(V1_DOCKER, Some("cpu")).as_deref(),
            Some("/docker/abc")
        );
        assert_eq!(
            own_path(V1_DOCKER, Some("cpuacct")).as_deref(),
            Some("/docker/abc")
        );
        assert_eq!(own_path(V1_DOCKER, None).as_deref(), Some("/system.slice"));
        assert_eq!(own_path("0::/\n", Some("cpu")), None);
    }

    fn write(dir: &Path, file: &str, text: &str) {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join(file), text).unwrap();
    }

    #[test]
    fn v1_container_mount_uses_the_mount_root() {
        // Docker on cgroup v1 mounts the container's own group at /sys/fs/cgroup/cpu,cpuacct,
        // so /docker/abc is not found below it.
        let root = tempfile::tempdir().unwrap();
        let cpu = root.path().join("cpu,cpuacct");
        write(&cpu, "cpu.cfs_quota_us", "25000\n");
        write(&cpu, "cpu.cfs_period_us", "100000\n");
        write(&cpu, "cpuacct.usage", "5000000000\n");
        write(&root.path().join("cpuset"), "cpuset.cpus", "0-1\n");
        let g = detect_at(root.path(), V1_DOCKER, 2).unwrap();
        assert_eq!(g.version, Version::V1);
        assert_eq!(g.capacity, Some(0.25));
        assert_eq!(g.usage().unwrap().cpu_ns, 5_000_000_000);
    }

    #[test]
    fn v1_host_takes_the_smallest_quota_on_the_path_and_the_cpuset() {
        let root = tempfile::tempdir().unwrap();
        let cpu = root.path().join("cpu");
        write(&cpu, "cpu.cfs_quota_us", "-1\n");
        write(&cpu, "cpu.cfs_period_us", "100000\n");
        let docker = cpu.join("docker");
        write(&docker, "cpu.cfs_quota_us", "300000\n");
        write(&docker, "cpu.cfs_period_us", "100000\n");
        write(&docker.join("abc"), "cpu.cfs_quota_us", "-1\n");
        write(&docker.join("abc"), "cpu.cfs_period_us", "100000\n");
        write(
            &root.path().join("cpuset/docker/abc"),
            "cpuset.cpus",
            "0-1\n",
        );
        let g = detect_at(root.path(), V1_DOCKER, 8).unwrap();
        assert_eq!(g.capacity, Some(2.0), "cpuset 2 CPUs is below quota 3");
        // Without any limit below the host's 2 cores there is no capacity figure.
        assert_eq!(detect_at(root.path(), V1_DOCKER, 2).unwrap().capacity, None);
    }

    #[test]
    fn v2_private_namespace_and_nested_groups() {
        let root = tempfile::tempdir().unwrap();
        write(
            root.path(),
            "cgroup.controllers",
            "cpuset cpu io memory pids\n",
        );
        write(root.path(), "cpu.max", "max 100000\n");
        write(root.path(), "cpu.stat", "usage_usec 7\n");
        // A private namespace: "0::/" is the container's group, the mount root.
        let g = detect_at(root.path(), "0::/\n", 4).unwrap();
        assert_eq!((g.version, g.capacity), (Version::V2, None));
        let leaf = root.path().join("a.slice/b.scope");
        write(&root.path().join("a.slice"), "cpu.max", "50000 100000\n");
        write(&leaf, "cpu.max", "max 100000\n");
        write(&leaf, "cpu.stat", "usage_usec 2500\nuser_usec 2000\n");
        write(&leaf, "cpuset.cpus.effective", "0-3\n");
        let g = detect_at(root.path(), "0::/a.slice/b.scope\n", 4).unwrap();
        assert_eq!(g.capacity, Some(0.5));
        assert_eq!(g.usage().unwrap().cpu_ns, 2_500_000);
    }

    #[test]
    fn no_cgroup_file_system_is_none() {
        let root = tempfile::tempdir().unwrap();
        assert_eq!(detect_at(root.path(), V1_DOCKER, 2), None);
    }

    #[test]
    fn busy_cores_is_cpu_time_over_wall_time() {
        let t0 = Instant::now();
        let a = UsageSample {
            at: t0,
            cpu_ns: 1_000_000_000,
        };
        let b = UsageSample {
            at: t0 + Duration::from_secs(2),
            cpu_ns: 1_500_000_000,
        };
        assert!((CpuGroup::busy_cores(&a, &b) - 0.25).abs() < 1e-9);
        assert_eq!(CpuGroup::busy_cores(&b, &a), 0.0);
    }
}
