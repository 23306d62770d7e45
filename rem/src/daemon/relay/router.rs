//! The relay's router: local mailboxes of attached (or about to attach) processes, and one
//! ordered link per remote daemon.
//!
//! Order per sender and receiver holds because every hop is a single FIFO: the sender's attach
//! stream, one link task and one `Forward` stream per daemon pair, the receiver's mailbox.
//! Queues are bounded in items (`DaemonSettings::queue`) and in bytes ([`Limits`]: per
//! mailbox, per link, and for the whole daemon): a full mailbox of an attached process holds
//! the link, which holds the sender (back-pressure). A mailbox whose process has not attached
//! yet buffers up to its bounds and then drops, so a process that never attaches can neither
//! stall the link nor fill the daemon's memory. Envelopes to a lost or unknown host come back
//! to the sender as `Undeliverable`.
//!
//! - `links`: one ordered queue and task per remote daemon, drained into `Forward` streams.

mod links;

use links::{item_cost, Link};

use std::collections::HashMap;
use std::sync::{Arc, Mutex, RwLock};

use tokio::sync::mpsc;

use crate::auth::token::Token;
use crate::daemon::limits::{Limits, ITEM_OVERHEAD};
use crate::daemon::relay::budget::{ByteBudget, Reservation};
use crate::membership::driver::{MemberEvent, Membership};
use crate::membership::peers::PeerPool;
use crate::wire::ids::{shown, ProcId};
use crate::wire::proto::{peer_item, Envelope, JobEvent, PeerItem, Undeliverable};

/// What a mailbox holds.
#[derive(Clone, Debug)]
pub enum Delivery {
    Envelope(Envelope),
    Event(JobEvent),
    Undeliverable(Undeliverable),
}

impl Delivery {
    /// The bytes this item is charged in the queues.
    fn bytes(&self) -> usize {
        ITEM_OVERHEAD
            + match self {
                Delivery::Envelope(e) => e.payload.len(),
                Delivery::Event(e) => e.message.len(),
                Delivery::Undeliverable(u) => u.reason.len(),
            }
    }
}

/// An item in a queue, with the bytes it holds in the queue's budgets.
pub type Queued<T> = (T, Reservation);

/// The sending side of a mailbox.
pub type MailboxSender = mpsc::Sender<Queued<Delivery>>;
/// The receiving side of a mailbox.
pub type MailboxReceiver = mpsc::Receiver<Queued<Delivery>>;

struct ProcessMailbox {
    tx: MailboxSender,
    rx: Option<MailboxReceiver>,
    attached: bool,
    budget: ByteBudget,
    /// What a spawned process must present to attach (`None`: an owner's mailbox, made by
    /// its own attach stream).
    token: Option<Token>,
    /// The user the process belongs to.
    user: String,
}

/// Cloneable handle to the router.
#[derive(Clone)]
pub struct Router {
    inner: Arc<Inner>,
}

struct Inner {
    host: String,
    queue: usize,
    limits: Limits,
    /// Bytes queued by the whole relay (every mailbox and link).
    total: ByteBudget,
    mailboxes: RwLock<HashMap<String, ProcessMailbox>>,
    links: Mutex<HashMap<String, Link>>,
    membership: Membership,
    peers: PeerPool,
    /// Every job event delivered here is also shown to the job table.
    observer: mpsc::UnboundedSender<JobEvent>,
}

impl Router {
    pub fn new(
        queue: usize,
        limits: Limits,
        membership: Membership,
        peers: PeerPool,
        observer: mpsc::UnboundedSender<JobEvent>,
    ) -> Self {
        let router = Router {
            inner: Arc::new(Inner {
                host: membership.name().to_string(),
                queue: queue.max(1),
                total: ByteBudget::new(limits.relay_bytes),
                limits,
                mailboxes: RwLock::default(),
                links: Mutex::default(),
                membership: membership.clone(),
                peers,
                observer,
            }),
        };
        let mut events = membership.subscribe();
        let weak = Arc::downgrade(&router.inner);
        tokio::spawn(async move {
            while let Ok(ev) = events.recv().await {
                let Some(inner) = weak.upgrade() else { break };
                if let MemberEvent::Lost(host) = ev {
                    let link = inner
                        .links
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .remove(&host);
                    if let Some(link) = link {
                        link.cancel.cancel();
                    }
                }
            }
        });
        router
    }

    /// Creates the mailbox of a local process (before it starts, so nothing sent early is
    /// lost); a spawned process attaches to it with `token`. It belongs to `user`.
    pub fn register(&self, id: &ProcId, token: Option<Token>, user: &str) {
        let (tx, rx) = mpsc::channel(self.inner.queue);
        self.mailboxes_mut().insert(
            id.to_string(),
            ProcessMailbox {
                tx,
                rx: Some(rx),
                attached: false,
                budget: ByteBudget::new(self.inner.limits.mailbox_bytes),
                token,
                user: user.to_string(),
            },
        );
    }

    /// Hands the mailbox to the process attaching as `id` with `token` (none for an owner's
    /// own new mailbox); `None` if unknown, taken, or the token is not the process's.
    pub fn take_mailbox(
        &self,
        id: &ProcId,
        token: Option<&str>,
    ) -> Option<(MailboxSender, MailboxReceiver)> {
        let mut map = self.mailboxes_mut();
        let mb = map.get_mut(id.as_str())?;
        let proven = match (&mb.token, token) {
            (Some(want), Some(given)) => want.matches(given),
            (None, None) => true,
            _ => false,
        };
        if !proven {
            return None;
        }
        let rx = mb.rx.take()?;
        mb.attached = true;
        Some((mb.tx.clone(), rx))
    }

    /// Gives a detached process's queue back, so it can attach again (if it still exists).
    pub fn give_back(&self, id: &ProcId, rx: MailboxReceiver) {
        if let Some(mb) = self.mailboxes_mut().get_mut(id.as_str()) {
            mb.rx = Some(rx);
            mb.attached = false;
        }
    }

    /// True while process `id` is attached here.
    pub fn is_attached(&self, id: &str) -> bool {
        let map = self
            .inner
            .mailboxes
            .read()
            .unwrap_or_else(|e| e.into_inner());
        map.get(id).is_some_and(|mb| mb.attached)
    }

    /// The user a local process belongs to (`None`: no such process here).
    pub fn user_of(&self, id: &str) -> Option<String> {
        let map = self
            .inner
            .mailboxes
            .read()
            .unwrap_or_else(|e| e.into_inner());
        map.get(id).map(|mb| mb.user.clone())
    }

    /// The user of the local spawned process whose token is `token` (compared in constant
    /// time with each); `None` when no process here has it.
    pub fn user_of_token(&self, token: &str) -> Option<String> {
        let map = self
            .inner
            .mailboxes
            .read()
            .unwrap_or_else(|e| e.into_inner());
        map.values()
            .find(|mb| mb.token.as_ref().is_some_and(|t| t.matches(token)))
            .map(|mb| mb.user.clone())
    }

    /// Removes a local mailbox (process exited or owner detached).
    pub fn unregister(&self, id: &ProcId) {
        self.mailboxes_mut().remove(id.as_str());
    }

    fn mailboxes_mut(&self) -> std::sync::RwLockWriteGuard<'_, HashMap<String, ProcessMailbox>> {
        self.inner
            .mailboxes
            .write()
            .unwrap_or_else(|e| e.into_inner())
    }

    /// Sends an envelope towards `env.to`. `Err` = why it cannot be delivered.
    pub async fn route(&self, env: Envelope) -> Result<(), String> {
        let to =
            ProcId::parse(&env.to).ok_or_else(|| format!("bad process id {}", shown(&env.to)))?;
        if to.host() == self.inner.host {
            self.deliver_local(to.as_str(), Delivery::Envelope(env))
                .await
        } else {
            self.send_remote(
                to.host(),
                PeerItem {
                    item: Some(peer_item::Item::Envelope(env)),
                },
            )
            .await
        }
    }

    /// Sends a job event to its owner.
    pub async fn route_event(&self, event: JobEvent) -> Result<(), String> {
        let owner =
            ProcId::parse(&event.owner).ok_or_else(|| "the job has no owner".to_string())?;
        if owner.host() == self.inner.host {
            let _ = self.inner.observer.send(event.clone());
            self.deliver_local(owner.as_str(), Delivery::Event(event))
                .await
        } else {
            self.send_remote(
                owner.host(),
                PeerItem {
                    item: Some(peer_item::Item::Event(event)),
                },
            )
            .await
        }
    }

    /// Delivers an item that came in from daemon `peer` (authenticated). An envelope that
    /// cannot be delivered is answered with an `Undeliverable` notice to its sender (dropped
    /// if the link back is full, so a flood cannot pile up notices). A daemon may forward only
    /// envelopes of its own processes, and notices about them: anything else ends the link
    /// with `PERMISSION_DENIED`.
    pub async fn deliver_from_peer(&self, peer: &str, item: PeerItem) -> Result<(), tonic::Status> {
        let from_peer = |id: &str| ProcId::parse(id).is_some_and(|p| p.host() == peer);
        let result = match item.item {
            Some(peer_item::Item::Envelope(env)) => {
                if !from_peer(&env.from) {
                    return Err(tonic::Status::permission_denied(format!(
                        "daemon {peer} forwarded an envelope from {}, not one of its processes",
                        shown(&env.from)
                    )));
                }
                let (to, sender) = (env.to.clone(), env.from.clone());
                let r = self.deliver_local(&to, Delivery::Envelope(env)).await;
                if let Err(reason) = &r {
                    self.bounce(Undeliverable {
                        to,
                        reason: reason.clone(),
                        sender,
                    });
                }
                r
            }
            Some(peer_item::Item::Undeliverable(u)) => {
                if !from_peer(&u.to) {
                    return Err(tonic::Status::permission_denied(format!(
                        "daemon {peer} sent a notice about {}, not one of its processes",
                        shown(&u.to)
                    )));
                }
                let sender = u.sender.clone();
                self.deliver_local(&sender, Delivery::Undeliverable(u))
                    .await
            }
            Some(peer_item::Item::Event(ev)) => {
                let _ = self.inner.observer.send(ev.clone());
                let owner = ev.owner.clone();
                self.deliver_local(&owner, Delivery::Event(ev)).await
            }
            None => Ok(()),
        };
        if let Err(reason) = result {
            tracing::debug!(%reason, "dropped an item from a peer");
        }
        Ok(())
    }

    fn bounce(&self, notice: Undeliverable) {
        // A notice about a malformed id would be refused by the sender's daemon.
        let Some(sender) =
            ProcId::parse(&notice.sender).filter(|_| ProcId::parse(&notice.to).is_some())
        else {
            return;
        };
        let item = PeerItem {
            item: Some(peer_item::Item::Undeliverable(notice)),
        };
        if let Ok((tx, budget, _)) = self.link(sender.host()) {
            if let Some(r) =
                ByteBudget::try_reserve(&[&budget, &self.inner.total], item_cost(&item))
            {
                let _ = tx.try_send((item, r));
            }
        }
    }

    async fn deliver_local(&self, to: &str, d: Delivery) -> Result<(), String> {
        let (tx, attached, budget) = {
            let map = self
                .inner
                .mailboxes
                .read()
                .unwrap_or_else(|e| e.into_inner());
            let mb = map
                .get(to)
                .ok_or_else(|| format!("no process {to} on {}", self.inner.host))?;
            (mb.tx.clone(), mb.attached, mb.budget.clone())
        };
        let budgets = [&budget, &self.inner.total];
        if attached {
            let held = ByteBudget::reserve(&budgets, d.bytes()).await;
            tx.send((d, held))
                .await
                .map_err(|_| format!("process {to} has detached"))
        } else {
            let full = || format!("process {to} has not attached and its queue is full");
            let held = ByteBudget::try_reserve(&budgets, d.bytes()).ok_or_else(full)?;
            tx.try_send((d, held)).map_err(|_| full())
        }
    }
}
