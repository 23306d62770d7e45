//! `Relay`: a process's end of the relay. Send opaque byte messages to process ids; receive
//! messages, job events and undeliverable notices, in order.

use std::collections::VecDeque;

use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::Streaming;

use crate::client::rpc::RemRpc;
use crate::error::{Error, Result};
use crate::wire::ids::ProcId;
use crate::wire::proto::{
    client_frame, server_frame, ClientFrame, Envelope, EnvelopeBatch, Hello, JobEvent, ServerFrame,
};
use crate::wire::{BATCH, BATCH_BYTES};

/// Envelopes queued on the sending side before `send` waits (back-pressure).
pub const SEND_QUEUE: usize = 1024;

/// Something the relay delivered.
#[derive(Clone, Debug, PartialEq)]
pub enum Incoming {
    /// A message from another process.
    Message {
        /// The sender's process id (`HOST/NUMBER`), as the daemons saw it.
        from: String,
        /// The message, as sent.
        payload: Vec<u8>,
    },
    /// A job event (for a job owner): Started, Exited (code / signal), Lost.
    Event(JobEvent),
    /// A message this process sent could not be delivered.
    Undeliverable {
        /// The process it was for.
        to: String,
        /// Why it could not be delivered.
        reason: String,
    },
}

/// The sending half; cheap to clone.
#[derive(Clone, Debug)]
pub struct RelaySender {
    tx: mpsc::Sender<Envelope>,
    max_message: usize,
}

impl RelaySender {
    /// Queues `payload` for process `to`; waits while the queues are full.
    pub async fn send(&self, to: &ProcId, payload: impl Into<Vec<u8>>) -> Result<()> {
        let payload = payload.into();
        if payload.len() > self.max_message {
            return Err(Error::TooLarge {
                size: payload.len(),
                limit: self.max_message,
            });
        }
        let env = Envelope {
            from: String::new(),
            to: to.to_string(),
            payload,
        };
        self.tx.send(env).await.map_err(|_| Error::Closed)
    }

    /// The largest payload accepted.
    pub fn max_message(&self) -> usize {
        self.max_message
    }
}

/// The receiving half.
#[derive(Debug)]
pub struct RelayReceiver {
    stream: Streaming<ServerFrame>,
    buffered: VecDeque<Incoming>,
}

impl RelayReceiver {
    /// The next delivery; `Err(Error::Closed)` when the stream ended normally, or the status
    /// the daemon ended it with.
    pub async fn recv(&mut self) -> Result<Incoming> {
        loop {
            if let Some(i) = self.buffered.pop_front() {
                return Ok(i);
            }
            let frame = self.stream.message().await?.ok_or(Error::Closed)?;
            match frame.frame {
                Some(server_frame::Frame::Batch(b)) => {
                    self.buffered
                        .extend(b.envelopes.into_iter().map(|e| Incoming::Message {
                            from: e.from,
                            payload: e.payload,
                        }))
                }
                Some(server_frame::Frame::Event(e)) => return Ok(Incoming::Event(e)),
                Some(server_frame::Frame::Undeliverable(u)) => {
                    return Ok(Incoming::Undeliverable {
                        to: u.to,
                        reason: u.reason,
                    })
                }
                Some(server_frame::Frame::Welcome(_)) | None => {}
            }
        }
    }
}

/// A process attached to its local remd.
#[derive(Debug)]
pub struct Relay {
    id: ProcId,
    job: String,
    host: String,
    owner: Option<ProcId>,
    sender: RelaySender,
    receiver: RelayReceiver,
}

impl Relay {
    /// Attaches through `rpc` as process `id` (a fresh id when `None`) of `job`, owned by
    /// `owner`; this side sends at most `max_message` bytes per message (less if the daemon
    /// says so). [`crate::RemClient::attach`] and [`crate::RemClient::attach_from_env`] call it.
    pub(crate) async fn open(
        rpc: RemRpc,
        max_message: usize,
        id: Option<&ProcId>,
        job: &str,
        owner: Option<ProcId>,
    ) -> Result<Relay> {
        let (frames_tx, frames_rx) = mpsc::channel::<ClientFrame>(16);
        let hello = Hello {
            proc_id: id.map(|i| i.to_string()).unwrap_or_default(),
            job: job.to_string(),
        };
        frames_tx
            .send(ClientFrame {
                frame: Some(client_frame::Frame::Hello(hello)),
            })
            .await
            .map_err(|_| Error::Closed)?;
        let mut stream = rpc
            .clone()
            .attach(ReceiverStream::new(frames_rx))
            .await?
            .into_inner();
        let welcome = match stream.message().await?.and_then(|f| f.frame) {
            Some(server_frame::Frame::Welcome(w)) => w,
            _ => {
                return Err(Error::Invalid(
                    "the daemon did not answer Hello with Welcome".into(),
                ))
            }
        };
        let id = ProcId::parse(&welcome.proc_id).ok_or_else(|| {
            Error::Invalid(format!(
                "daemon gave a bad process id {:?}",
                welcome.proc_id
            ))
        })?;
        let max_message = (welcome.max_message_bytes as usize).min(max_message);
        let (tx, rx) = mpsc::channel(SEND_QUEUE);
        tokio::spawn(batch_out(rx, frames_tx));
        Ok(Relay {
            id,
            job: welcome.job,
            host: welcome.host,
            owner,
            sender: RelaySender { tx, max_message },
            receiver: RelayReceiver {
                stream,
                buffered: VecDeque::new(),
            },
        })
    }

    /// This process's id (what others address it by).
    pub fn id(&self) -> &ProcId {
        &self.id
    }

    /// The job this process belongs to ("" for none).
    pub fn job(&self) -> &str {
        &self.job
    }

    /// The host of the daemon this process is attached to.
    pub fn host(&self) -> &str {
        &self.host
    }

    /// The job's owner (from `REM_OWNER_ID`), for a spawned process.
    pub fn owner(&self) -> Option<&ProcId> {
        self.owner.as_ref()
    }

    /// A clone of the sending half.
    pub fn sender(&self) -> RelaySender {
        self.sender.clone()
    }

    /// Sends `payload` to process `to` (see [`RelaySender::send`]).
    pub async fn send(&self, to: &ProcId, payload: impl Into<Vec<u8>>) -> Result<()> {
        self.sender.send(to, payload).await
    }

    /// The next delivery (see [`RelayReceiver::recv`]).
    pub async fn recv(&mut self) -> Result<Incoming> {
        self.receiver.recv().await
    }

    /// Splits into halves that can live in different tasks.
    pub fn split(self) -> (RelaySender, RelayReceiver) {
        (self.sender, self.receiver)
    }
}

/// Queued envelopes -> client frames, batching what is queued.
async fn batch_out(mut rx: mpsc::Receiver<Envelope>, frames: mpsc::Sender<ClientFrame>) {
    let mut pending: Option<Envelope> = None;
    loop {
        let first = match pending.take() {
            Some(e) => e,
            None => match rx.recv().await {
                Some(e) => e,
                None => return,
            },
        };
        let mut bytes = first.payload.len();
        let mut envelopes = vec![first];
        while envelopes.len() < BATCH {
            match rx.try_recv() {
                Ok(e) if bytes + e.payload.len() <= BATCH_BYTES => {
                    bytes += e.payload.len();
                    envelopes.push(e);
                }
                Ok(e) => {
                    pending = Some(e);
                    break;
                }
                Err(_) => break,
            }
        }
        let frame = ClientFrame {
            frame: Some(client_frame::Frame::Batch(EnvelopeBatch { envelopes })),
        };
        if frames.send(frame).await.is_err() {
            return;
        }
    }
}
