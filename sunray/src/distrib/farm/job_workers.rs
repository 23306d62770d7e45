//! The workers of a farm job's controller: those of its predecessors that still run, taken
//! over (REM's Adopt), and new ones started on the live hosts, never where the job's taken-over
//! workers run nor where the user said not to (`--avoid-host`).

use crate::distrib::controller::{self, WorkerProc};
use crate::distrib::job::worker_spawn;
use crate::distrib::messages::proto;
use rem::RemClient;
use std::path::Path;

/// The running workers of this job's earlier controllers (REM jobs `JOB.wE`, E < `epoch`),
/// adopted in REM by this controller (`me`): their Exited and Lost events come here now. A
/// worker that exits meanwhile is left out.
pub(super) async fn take_over_workers(
    client: &RemClient,
    job: &str,
    epoch: u64,
    me: &rem::ProcId,
    live: &[rem::HostInfo],
) -> Vec<WorkerProc> {
    let Ok(procs) = client.ps().await else {
        return Vec::new();
    };
    let prefix = format!("{job}.w");
    let mut workers = Vec::new();
    let running = procs.iter().filter(|p| p.state == "running").filter(|p| {
        p.job
            .strip_prefix(&prefix)
            .and_then(|e| e.parse::<u64>().ok())
            .is_some_and(|e| e < epoch)
    });
    for p in running {
        let Some(proc_id) = rem::ProcId::parse(&p.proc_id) else {
            continue;
        };
        match client.adopt(&proc_id, me).await {
            Ok(_) => workers.push(WorkerProc {
                proc_id,
                host: p.host.clone(),
                pid: p.pid,
                load_at_start: controller::load_per_core(live, &p.host),
                adopted: true,
                slots: p.slots,
            }),
            Err(e) => eprintln!("sunray controller: not taking over {proc_id}: {e}"),
        }
    }
    workers
}

/// Starts up to `count` workers of `spec` owned by this controller (`me`), not on
/// `avoid_hosts`, each holding at least one of the farm's slots and at most `slots_max`
/// (0: all its host has free): as many as there are hosts with a free slot, at least one.
pub(super) async fn start_workers(
    client: &RemClient,
    worker_program: &Path,
    (spec, (job, epoch), (count, slots_max), me): (
        &proto::JobSpec,
        (&str, u64),
        (u32, u32),
        &rem::ProcId,
    ),
    live: &[rem::HostInfo],
    avoid_hosts: Vec<String>,
) -> Result<Vec<WorkerProc>, rem::Error> {
    let threads = (spec.threads > 0).then_some(spec.threads as usize);
    let spawned = client
        .spawn(rem::SpawnRequest {
            count,
            allow_same_host: spec.same_host,
            job: Some(format!("{job}.w{epoch}")),
            owner: Some(me.clone()),
            avoid_hosts,
            slots_min: 1,
            slots_max,
            up_to: true,
            ..worker_spawn(worker_program, threads, spec.nice)
        })
        .await?;
    Ok(WorkerProc::placed(&spawned, live))
}
