//! `rem hosts`, `rem queue` and `rem ps`: the cluster's listings, as tables or JSON.

use std::io::Write;

use rem::RemClient;
use serde_json::json;

/// `rem hosts`.
pub(crate) async fn hosts(
    client: &RemClient,
    out: &mut impl Write,
    json: bool,
) -> anyhow::Result<()> {
    let hosts = client.hosts().await?;
    if json {
        let v: Vec<_> = hosts.iter().map(host_json).collect();
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        print_hosts(out, &hosts)?;
    }
    Ok(())
}

/// `rem queue`.
pub(crate) async fn queue(
    client: &RemClient,
    out: &mut impl Write,
    json: bool,
) -> anyhow::Result<()> {
    let q = client.queue().await?;
    if json {
        let jobs: Vec<_> = q
            .jobs
            .iter()
            .map(|j| {
                json!({"id": j.id, "user": j.user, "state": j.state, "priority": j.priority,
                "slots": j.slots, "slots_wanted": j.slots_wanted, "share": j.share,
                "queue_position": (j.queue_position > 0).then_some(j.queue_position),
                "created_unix_ms": j.created_unix_ms, "title": j.title})
            })
            .collect();
        let v = json!({"slots": q.slots, "user_slots": (q.user_slots > 0).then_some(q.user_slots),
            "jobs": jobs});
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{:<24} {:<12} {:<11} {:>4} {:>6} {:>6} {:>6} {:>5}  title",
        "JOB", "USER", "STATE", "PRIO", "SLOTS", "SHARE", "WANTS", "QUEUE"
    )?;
    for j in &q.jobs {
        let place = match j.queue_position {
            0 => "-".to_string(),
            n => n.to_string(),
        };
        writeln!(
            out,
            "{:<24} {:<12} {:<11} {:>4} {:>6} {:>6} {:>6} {:>5}  {}",
            j.id, j.user, j.state, j.priority, j.slots, j.share, j.slots_wanted, place, j.title
        )?;
    }
    writeln!(out, "{} slots lent by the live hosts", q.slots)?;
    Ok(())
}

/// `rem ps`.
pub(crate) async fn ps(client: &RemClient, out: &mut impl Write, json: bool) -> anyhow::Result<()> {
    let procs = client.ps().await?;
    if json {
        let v: Vec<_> = procs.iter().map(proc_json).collect();
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "{:<24} {:<12} {:<12} {:<20} {:>8} {:>5} {:<10} program",
        "PROCESS", "HOST", "USER", "JOB", "PID", "NICE", "STATE"
    )?;
    for p in &procs {
        let state = match (p.state.as_str(), p.exit_code, p.signal) {
            ("exited", Some(c), _) => format!("exit {c}"),
            ("exited", None, Some(s)) => format!("signal {s}"),
            (s, _, _) => s.to_string(),
        };
        let nice = p.nice.map_or("-".to_string(), |n| n.to_string());
        writeln!(
            out,
            "{:<24} {:<12} {:<12} {:<20} {:>8} {:>5} {:<10} {} {}",
            p.proc_id,
            p.host,
            p.user,
            p.job,
            p.pid,
            nice,
            state,
            p.program,
            p.args.join(" ")
        )?;
    }
    Ok(())
}

fn host_json(h: &rem::HostInfo) -> serde_json::Value {
    let l = h.load.unwrap_or_default();
    json!({
        "name": h.name, "addr": h.addr, "cores": l.cores, "capacity": l.capacity, "load_avg_1m": l.load_avg_1m,
        "load_per_core": l.load_per_core, "cpu_busy": l.cpu_busy, "mem_free_bytes": l.mem_free_bytes,
        "mem_total_bytes": l.mem_total_bytes, "rem_processes": l.rem_processes,
        "slots": l.slots, "slots_used": l.slots_used, "alive": h.alive,
        "accepting": h.accepting,
        // The protocol the host announces (1: a remd from before it was announced).
        "protocol": h.load.map(|l| rem::wire::protocol::announced(l.protocol)),
        "last_heard_ms": if h.last_heard_ms == u64::MAX { None } else { Some(h.last_heard_ms) },
    })
}

fn proc_json(p: &rem::ProcessInfo) -> serde_json::Value {
    json!({
        "proc_id": p.proc_id, "host": p.host, "user": p.user, "job": p.job, "owner": p.owner, "program": p.program,
        "args": p.args, "pid": p.pid, "nice": p.nice, "state": p.state, "exit_code": p.exit_code,
        "signal": p.signal, "started_unix_ms": p.started_unix_ms,
        "job_record": p.job_record, "job_epoch": p.job_epoch,
    })
}

fn print_hosts(out: &mut impl Write, hosts: &[rem::HostInfo]) -> std::io::Result<()> {
    writeln!(
        out,
        "{:<14} {:<22} {:>5} {:>6} {:>6} {:>10} {:>5} {:>7} {:<9} {:>10} PROTOCOL",
        "NAME",
        "ADDRESS",
        "CPUS",
        "LOAD",
        "BUSY%",
        "MEM FREE",
        "PROCS",
        "SLOTS",
        "STATE",
        "LAST HEARD"
    )?;
    for h in hosts {
        let l = h.load.unwrap_or_default();
        let state = match (h.alive, h.accepting, h.last_heard_ms) {
            (true, true, _) => "alive",
            (true, false, _) => "draining",
            (false, _, u64::MAX) => "joining",
            (false, _, _) => "lost",
        };
        let heard = match h.last_heard_ms {
            0 => "self".to_string(),
            u64::MAX => "never".to_string(),
            ms => format!("{:.1}s ago", ms as f64 / 1000.0),
        };
        let protocol = match h.load {
            Some(l) => rem::wire::protocol::announced(l.protocol).to_string(),
            None => "-".to_string(),
        };
        writeln!(
            out,
            "{:<14} {:<22} {:>5} {:>6.2} {:>6.1} {:>10} {:>5} {:>7} {:<9} {:>10} {:>8}",
            h.name,
            h.addr,
            cpus(&l),
            l.load_per_core,
            l.cpu_busy * 100.0,
            mib(l.mem_free_bytes),
            l.rem_processes,
            format!("{}/{}", l.slots_used, l.slots),
            state,
            heard,
            protocol
        )?;
    }
    Ok(())
}

/// The CPUs a host offers: its cgroup's limit when it has one (e.g. "0.25"), else its cores.
fn cpus(l: &rem::wire::proto::Load) -> String {
    if l.capacity > 0.0 && l.capacity != f64::from(l.cores) {
        format!("{:.2}", l.capacity)
    } else {
        l.cores.to_string()
    }
}

fn mib(bytes: u64) -> String {
    format!("{} MiB", bytes >> 20)
}
