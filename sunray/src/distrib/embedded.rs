//! The embedded default: with no remd configured, `sunray submit` runs a private remd inside
//! its own process, on loopback, with a fresh secret, allowed to start only this program's
//! `worker`. So the README's main command works on a fresh machine with nothing installed.
//!
//! Its checkpoints live in a state directory that outlives the process (so `--resume` and
//! `sunray jobs` work here too): `$SUNRAY_STATE_DIR`, else `$XDG_STATE_HOME/sunray`, else
//! `~/.local/state/sunray`.

use rem::daemon::config::DaemonSettings;
use rem::daemon::embedded::{fresh_secret, kept_secret, EmbeddedRemd};
use rem::daemon::policy::ProgramRule;
use std::path::PathBuf;

/// The host name the private daemon goes by.
pub const HOST: &str = "local";

/// Starts the private daemon on loopback, allowed to start only `program` as a worker or
/// controller, keeping checkpoints in `state_dir` (a temporary directory when `None`) with
/// the secret kept there (a fresh one when `None`).
pub async fn start(program: PathBuf, state_dir: Option<PathBuf>) -> rem::Result<EmbeddedRemd> {
    let secret = match &state_dir {
        Some(dir) => kept_secret(dir)?,
        None => fresh_secret()?,
    };
    let mut settings = DaemonSettings::new(HOST, secret);
    settings.policy.programs = vec![ProgramRule {
        path: program,
        first_args: Some(vec!["worker".into(), "controller".into()]),
    }];
    settings.state_dir = state_dir;
    EmbeddedRemd::start(settings).await
}

/// Where the embedded daemon keeps checkpoints.
pub fn state_dir() -> Option<PathBuf> {
    let env = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = env("SUNRAY_STATE_DIR") {
        return Some(d);
    }
    if let Some(d) = env("XDG_STATE_HOME") {
        return Some(d.join("sunray"));
    }
    env("HOME").map(|h| h.join(".local/state/sunray"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_private_daemon_answers_with_its_secret_only() {
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async {
            let dir = std::env::temp_dir().join(format!("sunray-emb-{}", std::process::id()));
            let rem = start(PathBuf::from("/bin/true"), Some(dir.clone()))
                .await
                .unwrap();
            let client = rem.client().await.unwrap();
            let hosts = client.hosts().await.unwrap();
            assert_eq!(hosts[0].name, HOST);
            let wrong = rem::RemClient::connect(rem.addr(), rem::Secret::new("nope").unwrap())
                .await
                .unwrap();
            assert!(wrong.hosts().await.is_err());
            rem.stop().await;
            let _ = std::fs::remove_dir_all(dir);
        });
    }

    #[test]
    fn a_job_left_running_by_a_command_that_ended_is_recorded_interrupted() {
        use crate::distrib::job_record::{self, close_abandoned, STALE_MS};
        let rt = tokio::runtime::Runtime::new().unwrap();
        rt.block_on(async {
            let dir = tempfile::tempdir().unwrap();
            let rem = start(PathBuf::from("/bin/true"), Some(dir.path().to_path_buf()))
                .await
                .unwrap();
            let client = rem.client().await.unwrap();
            for (job, state) in [("gone", "running"), ("done", "finished")] {
                let entry = crate::distrib::messages::proto::JobEntry {
                    job: job.into(),
                    state: state.into(),
                    height: 64,
                    lines_done: 9,
                    ..Default::default()
                };
                job_record::update(&client, &entry, 64, 1).await.unwrap();
            }
            let states = || async {
                let mut s: Vec<(String, String)> = job_record::list(&client)
                    .await
                    .unwrap()
                    .into_iter()
                    .map(|e| (e.job, e.state))
                    .collect();
                s.sort();
                s
            };
            let now = crate::distrib::checkpoint::unix_ms();
            // Written a moment ago: its command may still be running it.
            close_abandoned(&client, now).await;
            assert_eq!(states().await[1], ("gone".into(), "running".into()));
            // Unwritten for longer than STALE_MS: its command is gone.
            close_abandoned(&client, now + STALE_MS + 1_000).await;
            let after = states().await;
            assert_eq!(after[0], ("done".into(), "finished".into()));
            assert_eq!(after[1], ("gone".into(), "interrupted".into()));
            rem.stop().await;
        });
    }
}
