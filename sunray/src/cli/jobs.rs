//! `sunray jobs`: the SunRay III jobs of this cluster (or of the private embedded remd) and
//! their state: running, finished, failed (no worker left; resumable) or interrupted (the
//! controller stopped answering; resumable with `sunray submit --resume JOB`).

use crate::distrib::checkpoint::unix_ms;
use crate::distrib::connection::RemConnection;
use crate::distrib::job_record;
use clap::Args;
use std::process::ExitCode;

/// The flags of `sunray jobs`.
#[derive(Args, Debug, Clone)]
pub struct JobsArgs {
    /// How to reach REM.
    #[command(flatten)]
    pub rem: super::farm::RemFlags,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Lists the jobs of the remd as a table (or JSON).
pub fn run(args: JobsArgs) -> anyhow::Result<ExitCode> {
    super::farm::runtime()?.block_on(list(args))
}

async fn list(args: JobsArgs) -> anyhow::Result<ExitCode> {
    let cluster = args.rem.open().await?;
    let result = print_jobs(&cluster, args.json).await;
    cluster.close().await;
    result.map(|()| ExitCode::SUCCESS)
}

async fn print_jobs(cluster: &RemConnection, json: bool) -> anyhow::Result<()> {
    let index = job_record::list(&cluster.client)
        .await
        .map_err(|e| cluster.rpc_error(e))?;
    // Where the waiting jobs stand in the farm's queue (every user's active jobs).
    let queue = cluster
        .client
        .queue()
        .await
        .map_err(|e| cluster.rpc_error(e))?;
    let procs = cluster
        .client
        .ps()
        .await
        .map_err(|e| cluster.rpc_error(e))?;
    let now = unix_ms();
    let rows: Vec<serde_json::Value> = index
        .iter()
        .map(|j| {
            let prefix = format!("{}.", j.job);
            let workers = procs
                .iter()
                .filter(|p| p.state == "running" && p.job.starts_with(&prefix))
                .filter(|p| p.args.first().is_some_and(|a| a == "worker"))
                .count();
            let queued = queue
                .jobs
                .iter()
                .find(|q| q.id == j.job && q.user == j.user);
            serde_json::json!({
                "job": j.job,
                "state": job_record::shown_state(j, workers, now, job_record::STALE_MS),
                "user": j.user,
                "priority": j.priority,
                "slots": j.slots,
                "share": queued.map(|q| q.share),
                "queue_position": queued.map(|q| q.queue_position).filter(|&p| p > 0),
                "lines_done": j.lines_done,
                "lines": j.height,
                "hosts": j.hosts,
                "workers": workers,
                "scene": j.scene,
                "output": j.output,
                "started_unix_ms": j.started_unix_ms,
                "updated_unix_ms": j.updated_unix_ms,
                "epoch": j.epoch,
                "controller_host": j.controller_host,
                "message": j.message,
            })
        })
        .collect();
    if json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    if rows.is_empty() {
        println!("no jobs");
        return Ok(());
    }
    println!(
        "{:<32} {:<12} {:>11} {:>5} {:>7} {:>5} {:>5} {:>5} {:<12} {:>9}  scene",
        "job",
        "state",
        "lines",
        "hosts",
        "workers",
        "slots",
        "prio",
        "epoch",
        "controller",
        "started"
    );
    for r in &rows {
        let ago = now.saturating_sub(r["started_unix_ms"].as_u64().unwrap_or(0)) / 1000;
        let state = match r["queue_position"].as_u64() {
            Some(p) => format!("queued #{p}"),
            None => r["state"].as_str().unwrap_or("").to_string(),
        };
        println!(
            "{:<32} {:<12} {:>11} {:>5} {:>7} {:>5} {:>5} {:>5} {:<12} {:>9}  {}",
            r["job"].as_str().unwrap_or(""),
            state,
            format!("{}/{}", r["lines_done"], r["lines"]),
            r["hosts"].to_string(),
            r["workers"].to_string(),
            r["slots"].to_string(),
            r["priority"].to_string(),
            r["epoch"].to_string(),
            r["controller_host"].as_str().unwrap_or(""),
            format!("{}", Ago(ago)),
            r["scene"].as_str().unwrap_or("")
        );
    }
    Ok(())
}

/// Seconds as a short age: 42s, 7m, 3h, 2d (ago).
struct Ago(u64);

impl std::fmt::Display for Ago {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self.0;
        match s {
            0..=59 => write!(f, "{s}s ago"),
            60..=3599 => write!(f, "{}m ago", s / 60),
            3600..=86399 => write!(f, "{}h ago", s / 3600),
            _ => write!(f, "{}d ago", s / 86400),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Ago;

    #[test]
    fn ages_are_short() {
        assert_eq!(Ago(5).to_string(), "5s ago");
        assert_eq!(Ago(125).to_string(), "2m ago");
        assert_eq!(Ago(7200).to_string(), "2h ago");
        assert_eq!(Ago(3 * 86400).to_string(), "3d ago");
    }
}
