//! The daemon's operations, in library terms (typed errors): what the gRPC services call.
//!
//! # Layout
//! - this module: the daemon's shared state ([`Daemon`]) and what its operations share
//!   (accepting calls, asking every live peer, new process ids);
//! - [`processes`]: spawning, placing and starting processes, and killing, adopting,
//!   listing them and reading their output, wherever they run;
//! - [`records`]: checkpoints and job records, each kept here and on one more live host.
//! - [`chunk_sharing`]: putting chunks on two hosts and fetching them from peers.
//! - [`job_control`]: jobs the farm keeps running (`StartJob`, the supervisor, restarts).
//! - [`queue`]: the farm's queue (every active job's share of the slots).

mod chunk_sharing;
pub(crate) mod job_control;
mod processes;
pub(crate) mod queue;
mod records;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

use crate::daemon::limits::Limits;
use crate::daemon::policy::SpawnPolicy;
use crate::daemon::process::table::ProcessTable;
use crate::daemon::relay::jobs::Jobs;
use crate::daemon::relay::router::Router;
use crate::error::{Error, Result};
use crate::membership::driver::Membership;
use crate::membership::peers::PeerPool;
use crate::store::checkpoint::CheckpointStore;
use crate::store::job_store::JobStore;
use crate::wire::ids::ProcId;

/// How often a call to a peer looks whether the peer is still live ([`Daemon::while_live`]).
const LIVENESS_POLL: std::time::Duration = std::time::Duration::from_millis(200);

/// The job epoch a checkpoint write carries (0: none), and the job record it belongs to
/// (empty: the checkpoint's own key).
#[derive(Clone, Debug, Default)]
pub struct Fence {
    pub epoch: u64,
    pub job: String,
}

/// Which job record and epoch a spawned controller runs (empty for other processes).
#[derive(Clone, Debug, Default)]
pub struct JobTag {
    pub record: String,
    pub epoch: u64,
}

/// Shared state of one running daemon.
pub struct Daemon {
    pub name: String,
    pub max_message: usize,
    pub policy: SpawnPolicy,
    pub limits: Limits,
    pub membership: Membership,
    pub router: Router,
    pub processes: ProcessTable,
    pub jobs: Jobs,
    pub checkpoints: CheckpointStore,
    pub chunks: crate::store::chunks::ChunkStore,
    pub job_store: JobStore,
    pub peers: PeerPool,
    pub accepting: Arc<AtomicBool>,
    /// Numbers process ids (spawned and attached-only alike).
    pub seq: Arc<AtomicU64>,
    /// Fires when the daemon shuts down (ends relay streams).
    pub stop: CancellationToken,
    /// The farm's queue as last computed here (the controllers of this host ask often).
    pub queue_memo: queue::QueueMemo,
}

impl Daemon {
    fn check_accepting(&self) -> Result<()> {
        if self.accepting.load(Ordering::Relaxed) {
            Ok(())
        } else {
            Err(Error::ShuttingDown)
        }
    }

    /// The other hosts alive now.
    pub(crate) fn live_peers(&self) -> impl Iterator<Item = crate::wire::proto::HostInfo> {
        self.membership
            .hosts()
            .into_iter()
            .skip(1)
            .filter(|h| h.alive)
    }

    /// `call` to peer `name`, given up as soon as the membership no longer counts `name`
    /// live (a host stopped answers no call, and the peer timeout is longer than SWIM takes
    /// to find it out): a write that waits for a replica waits for a live one.
    pub(crate) async fn while_live<R>(
        &self,
        name: &str,
        call: impl std::future::Future<Output = Result<R>>,
    ) -> Result<R> {
        tokio::pin!(call);
        loop {
            tokio::select! {
                r = &mut call => return r,
                () = tokio::time::sleep(LIVENESS_POLL) => {
                    if !self.live_peers().any(|h| h.name == name) {
                        return Err(Error::Unreachable {
                            host: name.to_string(),
                            reason: "no longer live in the membership".into(),
                        });
                    }
                }
            }
        }
    }

    /// Asks every live peer the same thing at once; the replies of those that answered.
    async fn ask_live_peers<T, R, F, Fut>(&self, method: &'static str, msg: T, call: F) -> Vec<R>
    where
        T: prost::Message + Clone + 'static,
        R: prost::Message + 'static,
        F: FnOnce(crate::membership::peers::PeerRpc, tonic::Request<T>) -> Fut
            + Clone
            + Send
            + 'static,
        Fut: std::future::Future<Output = std::result::Result<tonic::Response<R>, tonic::Status>>
            + Send,
    {
        let mut tasks = JoinSet::new();
        for h in self.live_peers() {
            let (peers, msg, call) = (self.peers.clone(), msg.clone(), call.clone());
            tasks.spawn(async move { peers.call(&h.name, &h.addr, method, msg, call).await });
        }
        let mut replies = Vec::new();
        while let Some(r) = tasks.join_next().await {
            if let Ok(Ok(reply)) = r {
                replies.push(reply);
            }
        }
        replies
    }

    /// A fresh process id on this host.
    pub fn new_proc_id(&self) -> ProcId {
        ProcId::new(&self.name, self.seq.fetch_add(1, Ordering::Relaxed))
    }
}
