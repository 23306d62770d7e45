//! One relay attachment: a process's bidirectional stream to its local remd.
//!
//! The first client frame must be `Hello`. A spawned process names itself (`REM_PROC_ID`),
//! proves it with the token it was given (`REM_PROC_TOKEN`, in the call's metadata) and gets
//! the mailbox made for it at spawn; a client (client key) with an empty id attaches a new
//! relay-only process (a job owner), whose mailbox lives as long as the stream. Envelopes from the process get
//! their `from` set here (a process cannot forge it); one over the size limit ends the
//! stream with `RESOURCE_EXHAUSTED`.

use std::sync::Arc;

use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Status, Streaming};

use crate::auth::secret::Caller;
use crate::daemon::ops::Daemon;
use crate::daemon::relay::budget::Reservation;
use crate::daemon::relay::router::{Delivery, MailboxReceiver, MailboxSender};
use crate::wire::ids::{is_valid_name, shown, ProcId};
use crate::wire::proto::{
    client_frame, server_frame, ClientFrame, EnvelopeBatch, ServerFrame, Undeliverable, Welcome,
};
use crate::wire::{BATCH, BATCH_BYTES};

pub type FrameStream = ReceiverStream<Result<ServerFrame, Status>>;

/// Runs the handshake and starts the two pumps; returns the stream to the process.
pub async fn attach(
    daemon: Arc<Daemon>,
    caller: Caller,
    mut inbound: Streaming<ClientFrame>,
) -> Result<FrameStream, Status> {
    let hello = match inbound.message().await? {
        Some(ClientFrame {
            frame: Some(client_frame::Frame::Hello(h)),
        }) => h,
        _ => return Err(Status::invalid_argument("the first frame must be Hello")),
    };
    if !hello.job.is_empty() && !is_valid_name(&hello.job) {
        return Err(Status::invalid_argument(format!(
            "bad job id {}",
            shown(&hello.job)
        )));
    }
    let (id, external, token) = match (hello.proc_id.is_empty(), caller) {
        (true, Caller::Client(who)) => {
            let id = daemon.new_proc_id();
            daemon.router.register(&id, None, &who.user);
            (id, true, None)
        }
        (true, Caller::Process(_)) => {
            return Err(Status::permission_denied(
                "a process token only lets a process attach as itself",
            ))
        }
        (false, caller) => {
            let id = ProcId::parse(&hello.proc_id).ok_or_else(|| {
                Status::invalid_argument(format!("bad process id {}", shown(&hello.proc_id)))
            })?;
            let Caller::Process(token) = caller else {
                return Err(Status::permission_denied(format!(
                    "attaching as {id} needs that process's token (REM_PROC_TOKEN)"
                )));
            };
            (id, false, Some(token))
        }
    };
    let taken = daemon.router.take_mailbox(&id, token.as_deref());
    let (mailbox_tx, mailbox_rx) = taken.ok_or_else(|| {
        Status::failed_precondition(format!(
            "{id} is not a process of this host waiting to attach with this token"
        ))
    })?;
    // Few frames wait here: the bytes they hold are no longer counted by the mailbox.
    let (out_tx, out_rx) = mpsc::channel(4);
    let welcome = Welcome {
        proc_id: id.to_string(),
        job: hello.job,
        host: daemon.name.clone(),
        max_message_bytes: daemon.max_message as u64,
    };
    let _ = out_tx
        .send(Ok(frame(server_frame::Frame::Welcome(welcome))))
        .await;
    let router = daemon.router.clone();
    let (out_id, stop) = (id.clone(), daemon.stop.clone());
    let out_tx2 = out_tx.clone();
    tokio::spawn(async move {
        let rx = pump_out(mailbox_rx, out_tx2, stop).await;
        if !external {
            // A spawned process may attach again (after a broken connection).
            router.give_back(&out_id, rx);
        }
    });
    tokio::spawn(async move {
        pump_in(&daemon, &id, inbound, mailbox_tx, out_tx).await;
        if external {
            daemon.router.unregister(&id);
        }
    });
    Ok(ReceiverStream::new(out_rx))
}

fn frame(f: server_frame::Frame) -> ServerFrame {
    ServerFrame { frame: Some(f) }
}

/// Mailbox -> process, batching queued envelopes; returns the mailbox when the process is gone.
async fn pump_out(
    mut mailbox: MailboxReceiver,
    out: mpsc::Sender<Result<ServerFrame, Status>>,
    stop: tokio_util::sync::CancellationToken,
) -> MailboxReceiver {
    let mut pending: Option<Delivery> = None;
    loop {
        let first = match pending.take() {
            Some(d) => d,
            None => tokio::select! {
                d = mailbox.recv() => match d { Some((d, _held)) => d, None => break },
                _ = out.closed() => break,
                _ = stop.cancelled() => {
                    let _ = out.send(Err(Status::unavailable("remd is shutting down"))).await;
                    break;
                }
            },
        };
        let f = match first {
            Delivery::Event(e) => server_frame::Frame::Event(e),
            Delivery::Undeliverable(u) => server_frame::Frame::Undeliverable(u),
            Delivery::Envelope(env) => {
                let mut bytes = env.payload.len();
                let mut envelopes = vec![env];
                while envelopes.len() < BATCH {
                    match mailbox.try_recv().map(|(d, _held)| d) {
                        Ok(Delivery::Envelope(e)) if bytes + e.payload.len() <= BATCH_BYTES => {
                            bytes += e.payload.len();
                            envelopes.push(e);
                        }
                        Ok(other) => {
                            pending = Some(other);
                            break;
                        }
                        Err(_) => break,
                    }
                }
                server_frame::Frame::Batch(EnvelopeBatch { envelopes })
            }
        };
        if out.send(Ok(frame(f))).await.is_err() {
            break;
        }
    }
    mailbox
}

/// Process -> router.
async fn pump_in(
    daemon: &Daemon,
    id: &ProcId,
    mut inbound: Streaming<ClientFrame>,
    mailbox: MailboxSender,
    out: mpsc::Sender<Result<ServerFrame, Status>>,
) {
    loop {
        let msg = tokio::select! {
            m = inbound.message() => m,
            _ = daemon.stop.cancelled() => return,
        };
        let batch = match msg {
            Ok(Some(ClientFrame {
                frame: Some(client_frame::Frame::Batch(b)),
            })) => b,
            Ok(Some(_)) => {
                let _ = out
                    .send(Err(Status::invalid_argument(
                        "unexpected frame after Hello",
                    )))
                    .await;
                return;
            }
            Ok(None) => return,
            Err(status) => {
                let _ = out.send(Err(status)).await;
                return;
            }
        };
        for mut env in batch.envelopes {
            if env.payload.len() > daemon.max_message {
                let msg = format!(
                    "message of {} bytes exceeds the limit of {} bytes",
                    env.payload.len(),
                    daemon.max_message
                );
                let _ = out.send(Err(Status::resource_exhausted(msg))).await;
                return;
            }
            env.from = id.to_string();
            let to = env.to.clone();
            if let Err(reason) = daemon.router.route(env).await {
                let notice = Undeliverable {
                    to,
                    reason,
                    sender: id.to_string(),
                };
                // A notice to the sender itself: small, and bounded by the queue's length.
                let _ = mailbox.try_send((Delivery::Undeliverable(notice), Reservation::default()));
            }
        }
    }
}
