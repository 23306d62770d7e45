//! The connection gate between remd's listening socket and the gRPC server: caps on open
//! connections (in total and per source address), a deadline for a connection's first bytes,
//! and an accept loop that outlives accept errors (no file descriptors left, aborted
//! handshakes). Also [`raise_fd_limit`], so the caps, not the descriptor limit, bind first,
//! and [`bind_listener`], a listener with a backlog for bursts.
//!
//! A connection over a cap is accepted and closed at once (with a reset), so it leaves the
//! kernel's backlog instead of filling it; refusals are logged at most once per
//! [`WARN_EVERY`]. An admitted connection holds its slot until the server drops it.

use std::collections::HashMap;
use std::convert::Infallible;
use std::future::Future;
use std::io;
use std::net::{IpAddr, Ipv6Addr, SocketAddr};
use std::pin::Pin;
use std::sync::{Arc, Mutex, PoisonError};
use std::task::{Context, Poll};
use std::time::{Duration, Instant};

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::time::Sleep;
use tokio_stream::Stream;
use tonic::transport::server::{Connected, TcpConnectInfo};

/// How many connections remd keeps open, and how long one may stay silent at first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConnectionLimits {
    /// Open connections in total; more are closed as soon as they are accepted.
    pub max_connections: usize,
    /// Open connections from one source: one IPv4 address, or one IPv6 /64 (what a single
    /// host can usually choose addresses from). More are closed as soon as accepted.
    pub max_per_ip: usize,
    /// How long a new connection may stay silent before remd closes it. An HTTP/2 client sends
    /// its preface, a TLS client its ClientHello, at once; a socket that sends nothing is
    /// holding a slot (slowloris).
    pub preface_timeout: Duration,
}

impl Default for ConnectionLimits {
    /// 4096 connections, 512 per source, 10 s to send the first bytes.
    fn default() -> Self {
        ConnectionLimits {
            max_connections: 4096,
            max_per_ip: 512,
            preface_timeout: Duration::from_secs(10),
        }
    }
}

/// The least time between two warnings about refused connections or accept errors.
pub const WARN_EVERY: Duration = Duration::from_secs(5);
/// The pause after an accept error that is not about one connection (EMFILE, ENFILE, ENOMEM).
const ACCEPT_RETRY: Duration = Duration::from_millis(100);
/// Connections accepted (and refused) in one poll before the gate lets other tasks run.
const ACCEPTS_PER_POLL: usize = 64;
/// Completed handshakes the kernel holds for remd to accept (capped by `net.core.somaxconn`).
pub const LISTEN_BACKLOG: u32 = 1024;

/// A listener on `addr` (address reuse on, as `TcpListener::bind`) with a backlog of
/// [`LISTEN_BACKLOG`]: a burst of connections waits for the gate instead of being dropped
/// (the default backlog, 128, makes clients retry their SYN after a second).
pub fn bind_listener(addr: SocketAddr) -> io::Result<TcpListener> {
    let socket = match addr {
        SocketAddr::V4(_) => tokio::net::TcpSocket::new_v4()?,
        SocketAddr::V6(_) => tokio::net::TcpSocket::new_v6()?,
    };
    socket.set_reuseaddr(true)?;
    socket.bind(addr)?;
    socket.listen(LISTEN_BACKLOG)
}

/// Raises this process's soft limit on open files (RLIMIT_NOFILE) to its hard limit, so the
/// connection caps, not the descriptor limit, decide what remd refuses. Returns the soft limit
/// now in force.
pub fn raise_fd_limit() -> io::Result<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes one rlimit into the struct we own.
    if unsafe { libc::getrlimit(libc::RLIMIT_NOFILE, &mut limit) } != 0 {
        return Err(io::Error::last_os_error());
    }
    // An unlimited hard limit is not a valid soft limit for open files on Linux; the kernel's
    // own ceiling (fs.nr_open) defaults to 2^20.
    let target = if limit.rlim_max == libc::RLIM_INFINITY {
        1 << 20
    } else {
        limit.rlim_max
    };
    if limit.rlim_cur < target {
        let raised = libc::rlimit {
            rlim_cur: target,
            rlim_max: limit.rlim_max,
        };
        // SAFETY: setrlimit reads one rlimit we own.
        if unsafe { libc::setrlimit(libc::RLIMIT_NOFILE, &raised) } != 0 {
            let e = io::Error::last_os_error();
            tracing::debug!(soft = limit.rlim_cur, hard = limit.rlim_max, error = %e,
                "cannot raise the open-file limit");
            return Err(e);
        }
        tracing::debug!(from = limit.rlim_cur, to = target, "open-file limit raised");
        Ok(target)
    } else {
        tracing::debug!(
            soft = limit.rlim_cur,
            hard = limit.rlim_max,
            "open-file limit"
        );
        Ok(limit.rlim_cur)
    }
}

/// The source a per-address cap counts against: an IPv4 address (IPv4-mapped IPv6 included),
/// or the /64 an IPv6 address is in.
fn source_key(ip: IpAddr) -> IpAddr {
    match ip.to_canonical() {
        IpAddr::V4(v4) => IpAddr::V4(v4),
        IpAddr::V6(v6) => {
            let prefix = v6.to_bits() & !u128::from(u64::MAX);
            IpAddr::V6(Ipv6Addr::from_bits(prefix))
        }
    }
}

/// Why a connection was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Refusal {
    /// `max_connections` are open.
    Total,
    /// `max_per_ip` are open from this source.
    PerSource(IpAddr),
}

/// Open connections, counted in total and per source.
#[derive(Debug, Default)]
struct Counts {
    total: usize,
    per_source: HashMap<IpAddr, usize>,
}

/// The slots the caps allow; shared by the gate and the [`Slot`]s it handed out.
#[derive(Debug)]
struct Slots {
    max_total: usize,
    max_per_source: usize,
    counts: Mutex<Counts>,
}

impl Slots {
    fn new(limits: &ConnectionLimits) -> Arc<Slots> {
        Arc::new(Slots {
            max_total: limits.max_connections,
            max_per_source: limits.max_per_ip,
            counts: Mutex::new(Counts::default()),
        })
    }

    fn counts(&self) -> std::sync::MutexGuard<'_, Counts> {
        // The counts stay consistent under a panic elsewhere: every update is one step.
        self.counts.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// A slot for a connection from `ip`, unless a cap is reached.
    fn take(self: &Arc<Self>, ip: IpAddr) -> Result<Slot, Refusal> {
        let key = source_key(ip);
        let mut counts = self.counts();
        if counts.total >= self.max_total {
            return Err(Refusal::Total);
        }
        if counts.per_source.get(&key).copied().unwrap_or(0) >= self.max_per_source {
            return Err(Refusal::PerSource(key));
        }
        *counts.per_source.entry(key).or_insert(0) += 1;
        counts.total += 1;
        Ok(Slot {
            slots: self.clone(),
            key,
        })
    }

    /// Open connections in total.
    fn open(&self) -> usize {
        self.counts().total
    }
}

/// One open connection's place under the caps; given back when dropped.
#[derive(Debug)]
struct Slot {
    slots: Arc<Slots>,
    key: IpAddr,
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut counts = self.slots.counts();
        counts.total = counts.total.saturating_sub(1);
        if let Some(n) = counts.per_source.get_mut(&self.key) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                counts.per_source.remove(&self.key);
            }
        }
    }
}

/// Lets one log line through per [`WARN_EVERY`], counting the events in between.
#[derive(Debug, Default)]
struct Throttle {
    last: Option<Instant>,
    since_last: u64,
}

impl Throttle {
    /// Records one event; `Some(n)` when it is time to log, `n` the events since the last log.
    fn hit(&mut self) -> Option<u64> {
        self.since_last += 1;
        let now = Instant::now();
        if self
            .last
            .is_some_and(|t| now.duration_since(t) < WARN_EVERY)
        {
            return None;
        }
        self.last = Some(now);
        Some(std::mem::take(&mut self.since_last))
    }
}

/// Accepted connections that passed the caps: the stream tonic serves. It never ends and
/// never yields an error; accept errors are logged and retried.
pub(crate) struct Gate {
    listener: TcpListener,
    slots: Arc<Slots>,
    limits: ConnectionLimits,
    /// Set after an accept error: no accept until it fires.
    pause: Option<Pin<Box<Sleep>>>,
    refused: Throttle,
    accept_errors: Throttle,
}

impl Gate {
    /// A gate on `listener` enforcing `limits`.
    pub(crate) fn new(listener: TcpListener, limits: ConnectionLimits) -> Gate {
        Gate {
            listener,
            slots: Slots::new(&limits),
            limits,
            pause: None,
            refused: Throttle::default(),
            accept_errors: Throttle::default(),
        }
    }

    /// The connection, wrapped, if the caps admit it; otherwise it is closed here.
    fn admit(&mut self, stream: TcpStream, peer: SocketAddr) -> Option<GatedStream> {
        let slot = match self.slots.take(peer.ip()) {
            Ok(slot) => slot,
            Err(why) => {
                // A reset frees the socket at once (no TIME_WAIT on remd's side).
                let _ = stream.set_zero_linger();
                drop(stream);
                if let Some(refused) = self.refused.hit() {
                    let open = self.slots.open();
                    match why {
                        Refusal::Total => tracing::warn!(
                            refused,
                            open,
                            max = self.limits.max_connections,
                            "too many connections: refusing new ones"
                        ),
                        Refusal::PerSource(source) => tracing::warn!(
                            refused, open, %source, max_per_ip = self.limits.max_per_ip,
                            "too many connections from one source: refusing new ones"
                        ),
                    }
                }
                return None;
            }
        };
        // Small relay frames must not wait for Nagle's algorithm.
        if let Err(e) = stream.set_nodelay(true) {
            tracing::debug!(%peer, error = %e, "dropping a connection: cannot set TCP_NODELAY");
            return None;
        }
        Some(GatedStream::new(stream, slot, self.limits.preface_timeout))
    }

    /// Logs an accept error; pauses accepting when it is about the process, not the peer.
    fn accept_failed(&mut self, e: io::Error) {
        use io::ErrorKind::*;
        if matches!(
            e.kind(),
            ConnectionAborted | ConnectionReset | Interrupted | WouldBlock | TimedOut
        ) {
            tracing::debug!(error = %e, "accept: connection gone before it was accepted");
            return;
        }
        if let Some(errors) = self.accept_errors.hit() {
            tracing::warn!(error = %e, errors, open = self.slots.open(),
                "accept failed; retrying shortly");
        }
        self.pause = Some(Box::pin(tokio::time::sleep(ACCEPT_RETRY)));
    }
}

impl Stream for Gate {
    type Item = Result<GatedStream, Infallible>;

    fn poll_next(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        let gate = self.get_mut();
        for _ in 0..ACCEPTS_PER_POLL {
            if let Some(pause) = &mut gate.pause {
                if pause.as_mut().poll(cx).is_pending() {
                    return Poll::Pending;
                }
                gate.pause = None;
            }
            match gate.listener.poll_accept(cx) {
                Poll::Pending => return Poll::Pending,
                Poll::Ready(Ok((stream, peer))) => {
                    if let Some(admitted) = gate.admit(stream, peer) {
                        return Poll::Ready(Some(Ok(admitted)));
                    }
                }
                Poll::Ready(Err(e)) => gate.accept_failed(e),
            }
        }
        // A flood of refusals: let other tasks run, then come back.
        cx.waker().wake_by_ref();
        Poll::Pending
    }
}

/// An admitted connection: the TCP stream, its slot (given back when this is dropped), and
/// until the first bytes arrive, the preface deadline (a read past it fails with `TimedOut`,
/// which ends the connection).
pub(crate) struct GatedStream {
    stream: TcpStream,
    preface_deadline: Option<Pin<Box<Sleep>>>,
    _slot: Slot,
}

impl GatedStream {
    fn new(stream: TcpStream, slot: Slot, preface_timeout: Duration) -> GatedStream {
        GatedStream {
            stream,
            preface_deadline: Some(Box::pin(tokio::time::sleep(preface_timeout))),
            _slot: slot,
        }
    }
}

impl AsyncRead for GatedStream {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        let before = buf.filled().len();
        match Pin::new(&mut this.stream).poll_read(cx, buf) {
            Poll::Ready(Ok(())) => {
                if buf.filled().len() > before {
                    this.preface_deadline = None;
                }
                Poll::Ready(Ok(()))
            }
            Poll::Ready(Err(e)) => Poll::Ready(Err(e)),
            Poll::Pending => {
                let expired = this
                    .preface_deadline
                    .as_mut()
                    .is_some_and(|deadline| deadline.as_mut().poll(cx).is_ready());
                if expired {
                    return Poll::Ready(Err(io::Error::new(
                        io::ErrorKind::TimedOut,
                        "the client sent nothing within the preface timeout",
                    )));
                }
                Poll::Pending
            }
        }
    }
}

impl AsyncWrite for GatedStream {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.get_mut().stream).poll_write(cx, buf)
    }

    fn poll_write_vectored(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.get_mut().stream).poll_write_vectored(cx, bufs)
    }

    fn is_write_vectored(&self) -> bool {
        self.stream.is_write_vectored()
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().stream).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().stream).poll_shutdown(cx)
    }
}

impl Connected for GatedStream {
    type ConnectInfo = TcpConnectInfo;

    /// The TCP stream's addresses, so `Request::remote_addr` works as without the gate.
    fn connect_info(&self) -> TcpConnectInfo {
        self.stream.connect_info()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)] // tests: a failed unwrap is a failed test
mod tests;
