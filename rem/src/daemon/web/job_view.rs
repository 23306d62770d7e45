//! One job in the web view: what its application published for people (`ID.web.json`, the
//! per-node table and events; `ID.web.png`, the image so far), and cancelling it.
//!
//! REM does not know what a job computes; an application that wants its jobs shown keeps
//! these two keys in REM's store, as its own checkpoints (so only the job's owner, or an
//! admin through the web view, reads them):
//! - `ID.web.json`, at most [`MAX_VIEW_JSON`] bytes: a JSON object, shown as it is:
//!   `nodes` (`{"columns": [...], "rows": [[...], ...]}`, a table), `events`
//!   (`[{"unix_ms", "kind", "text"}, ...]`, oldest first), `image`
//!   (`{"width", "height", "lines", "full"}`) and `timeline` (`[["step", seconds since
//!   submit], ...]`, the steps so far in their order, shown as one line);
//! - `ID.web.png`: a PNG of the work so far, written before the JSON that describes it;
//! - `ID.web.VIEW.png` for each name VIEW in `image.views` (at most [`MAX_VIEWS`] names of
//!   lowercase letters, [`is_view_name`]): other pictures of the same work, which the page
//!   offers beside the image (SunRay's `samples`: the samples each pixel took).

use serde::Serialize;

use crate::auth::identity::Identity;
use crate::daemon::ops::Daemon;
use crate::error::{Error, Result};
use crate::store::job_store::is_ended;
use crate::wire::ids::ProcId;
use crate::wire::proto::JobRecord;

/// The largest `ID.web.json` the page shows.
pub const MAX_VIEW_JSON: usize = 256 * 1024;

/// What a PNG file starts with.
const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// The key of job `id`'s published view.
pub fn view_key(id: &str) -> String {
    format!("{id}.web.json")
}

/// The key of job `id`'s published image.
pub fn image_key(id: &str) -> String {
    format!("{id}.web.png")
}

/// The most other pictures (`image.views`) the page offers.
pub const MAX_VIEWS: usize = 4;

/// Whether `name` may name another picture of a job: 1 to 16 lowercase ASCII letters (so
/// its key, [`view_image_key`], is never another key of the job's).
pub fn is_view_name(name: &str) -> bool {
    (1..=16).contains(&name.len()) && name.bytes().all(|b| b.is_ascii_lowercase())
}

/// The key of job `id`'s other picture `view` (a name [`is_view_name`] takes).
pub fn view_image_key(id: &str, view: &str) -> String {
    format!("{id}.web.{view}.png")
}

/// A job's published view as the page gets it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Published {
    /// The application's JSON object (`None`: nothing published, or unusable).
    pub view: Option<serde_json::Value>,
    /// Changes with every publication (the image's URL carries it, past caches).
    pub version: u64,
    /// Why `view` is missing, when something was there.
    pub problem: Option<String>,
}

/// The newest record of job `id` that `who` may see (its own; any user's for an admin).
pub async fn find(daemon: &Daemon, who: &Identity, id: &str) -> Result<Option<JobRecord>> {
    if !crate::wire::ids::is_valid_name(id) {
        return Ok(None);
    }
    let records = daemon.list_jobs(who).await?;
    // An admin may hold a job of its own by that id too: its own wins.
    let mut found: Vec<JobRecord> = records.into_iter().filter(|r| r.id == id).collect();
    found.sort_by_key(|r| r.user != who.user);
    Ok(found.into_iter().next())
}

/// The owner of `record`, as REM's store keys its checkpoints.
fn owner(record: &JobRecord) -> Identity {
    Identity::user(record.user.clone())
}

/// What the application of `user`'s job `id` published (read as its owner: the caller has
/// checked that the viewer may see it).
pub async fn published(daemon: &Daemon, user: &str, id: &str) -> Result<Published> {
    let Some(cp) = daemon
        .get_checkpoint(&Identity::user(user), view_key(id))
        .await?
    else {
        return Ok(Published {
            view: None,
            version: 0,
            problem: None,
        });
    };
    let parsed = if cp.data.len() > MAX_VIEW_JSON {
        Err(format!(
            "its view is {} bytes, over the {MAX_VIEW_JSON} shown",
            cp.data.len()
        ))
    } else {
        match serde_json::from_slice::<serde_json::Value>(&cp.data) {
            Ok(v) if v.is_object() => Ok(v),
            Ok(_) => Err("its view is not a JSON object".to_string()),
            Err(e) => Err(format!("its view is not JSON: {e}")),
        }
    };
    Ok(match parsed {
        Ok(v) => Published {
            view: Some(v),
            version: cp.version,
            problem: None,
        },
        Err(why) => Published {
            view: None,
            version: cp.version,
            problem: Some(why),
        },
    })
}

/// The PNG the application of `user`'s job `id` published; `None` when there is none.
pub async fn image(daemon: &Daemon, user: &str, id: &str) -> Result<Option<Vec<u8>>> {
    png_at(daemon, user, image_key(id)).await
}

/// The other picture `view` of `user`'s job `id`; `None` when there is none or `view` is
/// not a name [`is_view_name`] takes.
pub async fn view_image(
    daemon: &Daemon,
    user: &str,
    id: &str,
    view: &str,
) -> Result<Option<Vec<u8>>> {
    if !is_view_name(view) {
        return Ok(None);
    }
    png_at(daemon, user, view_image_key(id, view)).await
}

/// The PNG under `user`'s key `key`, if it is one.
async fn png_at(daemon: &Daemon, user: &str, key: String) -> Result<Option<Vec<u8>>> {
    let cp = daemon.get_checkpoint(&Identity::user(user), key).await?;
    Ok(cp
        .map(|cp| cp.data)
        .filter(|d| d.starts_with(PNG_SIGNATURE)))
}

/// Cancels `record`'s job for `who` (its owner or an admin): the record says cancelled (so
/// the daemons start no controller again), then its running processes are ended. Returns
/// the number of processes ended.
pub async fn cancel(daemon: &Daemon, who: &Identity, record: &JobRecord) -> Result<usize> {
    who.may_act_on(&record.user, &format!("job {}", record.id))?;
    let owner = owner(record);
    let mut current = record.clone();
    for attempt in 0..3 {
        if is_ended(&current.state) {
            return Err(Error::Refused(format!(
                "job {} has already ended ({})",
                current.id, current.state
            )));
        }
        let mut cancelled = current.clone();
        cancelled.state = "cancelled".into();
        cancelled.message = format!("cancelled by {} from the web view", who.user);
        match daemon.put_job(&owner, cancelled).await {
            Ok(_) => break,
            // The controller moved meanwhile: read the record again.
            Err(e) if e.code() == tonic::Code::Aborted && attempt < 2 => {
                current = find(daemon, &owner, &record.id)
                    .await?
                    .ok_or_else(|| Error::NotFound(format!("job {}", record.id)))?;
            }
            Err(e) => return Err(e),
        }
    }
    let prefix = format!("{}.", record.id);
    let mut ended = 0;
    for p in daemon.ps().await? {
        let of_job = p.job_record == record.id || p.job.starts_with(&prefix);
        if p.state != "running" || !of_job || p.user != record.user {
            continue;
        }
        if let Some(id) = ProcId::parse(&p.proc_id) {
            if daemon.kill(&owner, id).await.is_ok() {
                ended += 1;
            }
        }
    }
    Ok(ended)
}
