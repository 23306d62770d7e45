//! How the controller reaches its workers and keeps its checkpoint: the [`WorkerLink`] trait.
//! A real job goes through REM ([`RemLink`]: the relay to send, the client to kill and to
//! store checkpoints); the unit tests put a recording fake in its place, so the controller's
//! rules (faults, silence, duplicates, resume) are tested without processes.

use crate::distrib::checkpoint::{Fenced, Store};
use rem::{ProcId, RelaySender, RemClient};
use std::future::Future;

/// What the controller does to the world outside it, besides printing.
pub trait WorkerLink: Store + Send + Sync + 'static {
    /// Sends one encoded message to a worker. [`rem::Error::Closed`] means the relay itself
    /// is gone (the job cannot go on); any other error means this worker cannot be reached.
    fn send(
        &self,
        to: &ProcId,
        payload: Vec<u8>,
    ) -> impl Future<Output = Result<(), rem::Error>> + Send;

    /// Ends a worker's process (best effort).
    fn kill(&self, proc: &ProcId) -> impl Future<Output = ()> + Send;

    /// The most bytes one message may have (the relay's limit, the daemon's if lower).
    fn max_message(&self) -> usize;
}

/// The controller's link in a real job: REM's relay and client.
pub struct RemLink {
    /// Checkpoints and kills.
    pub client: RemClient,
    /// Messages to the workers.
    pub sender: RelaySender,
    /// The job's epoch when the farm runs the controller (0: none): every checkpoint write
    /// carries it, and REM refuses it once a newer controller has the job.
    pub epoch: u64,
    /// The job id (the record the epoch belongs to).
    pub job: String,
}

impl Store for RemLink {
    async fn put(&self, key: &str, data: Vec<u8>) -> Result<(), rem::Error> {
        let store = Fenced {
            client: &self.client,
            epoch: self.epoch,
            job: &self.job,
        };
        store.put(key, data).await
    }
    async fn get(&self, key: &str) -> Result<Option<Vec<u8>>, rem::Error> {
        Store::get(&self.client, key).await
    }
    fn max_bytes(&self) -> usize {
        Store::max_bytes(&self.client)
    }
}

impl WorkerLink for RemLink {
    async fn send(&self, to: &ProcId, payload: Vec<u8>) -> Result<(), rem::Error> {
        self.sender.send(to, payload).await
    }

    async fn kill(&self, proc: &ProcId) {
        let _ = self.client.kill(proc).await;
    }

    fn max_message(&self) -> usize {
        self.sender.max_message()
    }
}
