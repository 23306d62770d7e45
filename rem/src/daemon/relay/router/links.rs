//! The router's links: one ordered queue and task per remote daemon, draining into `Forward`
//! streams in batches, bounded in items and bytes; closed when the host is lost, flushed at
//! shutdown.

use std::sync::Arc;

use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tokio_util::sync::CancellationToken;

use super::{Inner, Queued, Router};
use crate::auth::peer_auth::method;
use crate::daemon::limits::ITEM_OVERHEAD;
use crate::daemon::relay::budget::ByteBudget;
use crate::wire::proto::{peer_item, PeerBatch, PeerItem};
use crate::wire::{BATCH, BATCH_BYTES};

/// One ordered link to another daemon: its queue, byte budget and task.
pub(super) struct Link {
    pub(super) tx: mpsc::Sender<Queued<PeerItem>>,
    pub(super) budget: ByteBudget,
    pub(super) cancel: CancellationToken,
    pub(super) task: tokio::task::JoinHandle<()>,
}

impl Router {
    /// Closes every link after sending what is queued (bounded by `timeout`); used at shutdown
    /// so that the last events (children's exits) reach their owners.
    pub async fn flush_links(&self, timeout: std::time::Duration) {
        let links: Vec<Link> = self
            .inner
            .links
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .drain()
            .map(|(_, l)| l)
            .collect();
        let tasks: Vec<_> = links.into_iter().map(|l| l.task).collect();
        let _ = tokio::time::timeout(timeout, async {
            for t in tasks {
                let _ = t.await;
            }
        })
        .await;
    }

    /// Queues `item` on the link to `host` (opened on first use); waits while the link is full.
    pub(super) async fn send_remote(&self, host: &str, item: PeerItem) -> Result<(), String> {
        let (tx, budget, cancel) = self.link(host)?;
        let lost = || format!("host {host} is lost");
        let budgets = [&budget, &self.inner.total];
        let held = tokio::select! {
            r = ByteBudget::reserve(&budgets, item_cost(&item)) => r,
            _ = cancel.cancelled() => return Err(lost()),
        };
        tokio::select! {
            r = tx.send((item, held)) => r.map_err(|_| format!("link to {host} closed")),
            _ = cancel.cancelled() => Err(lost()),
        }
    }

    /// The link to `host` (opened on first use, while the host is alive): its queue, byte
    /// budget and cancellation.
    #[allow(clippy::type_complexity)]
    pub(super) fn link(
        &self,
        host: &str,
    ) -> Result<
        (
            mpsc::Sender<Queued<PeerItem>>,
            ByteBudget,
            CancellationToken,
        ),
        String,
    > {
        let mut links = self.inner.links.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(l) = links.get(host) {
            if !l.cancel.is_cancelled() {
                return Ok((l.tx.clone(), l.budget.clone(), l.cancel.clone()));
            }
        }
        let view = self.inner.membership.view();
        match view.hosts.get(host) {
            None => return Err(format!("unknown host {host}")),
            Some(e) if !e.alive => return Err(format!("host {host} is lost")),
            Some(_) => {}
        }
        let (tx, rx) = mpsc::channel(self.inner.queue);
        let budget = ByteBudget::new(self.inner.limits.link_bytes);
        let cancel = CancellationToken::new();
        let task = tokio::spawn(run_link(
            host.to_string(),
            rx,
            cancel.clone(),
            self.inner.clone(),
        ));
        links.insert(
            host.to_string(),
            Link {
                tx: tx.clone(),
                budget: budget.clone(),
                cancel: cancel.clone(),
                task,
            },
        );
        Ok((tx, budget, cancel))
    }
}

/// Drains one link's queue into `Forward` streams to the host, batching what is queued.
async fn run_link(
    host: String,
    mut rx: mpsc::Receiver<Queued<PeerItem>>,
    cancel: CancellationToken,
    inner: Arc<Inner>,
) {
    let mut stream: Option<(mpsc::Sender<PeerBatch>, tokio::task::JoinHandle<()>)> = None;
    let mut pending: Option<PeerItem> = None;
    loop {
        let first = if let Some(p) = pending.take() {
            p
        } else {
            tokio::select! {
                _ = cancel.cancelled() => return,
                item = rx.recv() => match item {
                    Some((i, _held)) => i,
                    None => {
                        // Closed: let the open stream finish sending, then end.
                        if let Some((tx, call)) = stream.take() {
                            drop(tx);
                            let _ = call.await;
                        }
                        return;
                    }
                },
            }
        };
        let mut bytes = item_bytes(&first);
        let mut items = vec![first];
        while items.len() < BATCH {
            match rx.try_recv().map(|(i, _held)| i) {
                Ok(i) if bytes + item_bytes(&i) <= BATCH_BYTES => {
                    bytes += item_bytes(&i);
                    items.push(i);
                }
                Ok(i) => {
                    pending = Some(i);
                    break;
                }
                Err(_) => break,
            }
        }
        if stream.as_ref().is_none_or(|(s, _)| s.is_closed()) {
            stream = open_stream(&host, &inner);
        }
        let batch = PeerBatch {
            from_host: inner.host.clone(),
            items,
        };
        let sent = match &stream {
            Some((s, _)) => tokio::select! {
                r = s.send(batch) => r.is_ok(),
                _ = cancel.cancelled() => return,
            },
            None => false,
        };
        if !sent {
            tracing::warn!(%host, "relay link broken; a batch was dropped");
            stream = None;
        }
    }
}

/// What a peer item is charged in a link's budget.
pub(super) fn item_cost(item: &PeerItem) -> usize {
    ITEM_OVERHEAD + item_bytes(item)
}

fn item_bytes(item: &PeerItem) -> usize {
    match &item.item {
        Some(peer_item::Item::Envelope(e)) => e.payload.len(),
        _ => 0,
    }
}

fn open_stream(
    host: &str,
    inner: &Inner,
) -> Option<(mpsc::Sender<PeerBatch>, tokio::task::JoinHandle<()>)> {
    let addr = inner.membership.live_addr(host)?;
    let mut client = inner.peers.client(&addr).ok()?;
    let (tx, rx) = mpsc::channel(4);
    let (req, _) = inner
        .peers
        .key()
        .sign(host, method::FORWARD, "-", ReceiverStream::new(rx));
    let host = host.to_string();
    let call = tokio::spawn(async move {
        if let Err(status) = client.forward(req).await {
            tracing::warn!(%host, %status, "relay link ended");
        }
    });
    Some((tx, call))
}
