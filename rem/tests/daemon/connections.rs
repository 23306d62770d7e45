//! Connection caps: a flood of idle connections from one address leaves remd answering others.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::net::SocketAddr;
use std::os::fd::AsRawFd;
use std::time::{Duration, Instant};

use crate::common::*;
use tokio::net::{TcpSocket, TcpStream};
use tokio::task::JoinSet;

/// Idle connections the test holds open.
const IDLE: usize = 10_000;
/// Connections opened at once (under even the smallest usual listen backlog, 128).
const BATCH: usize = 100;

/// `n` connections to `to`, each from `from` (port chosen by the OS), opened `BATCH` at a
/// time: those established, and how many the peer reset before `connect` returned (remd resets
/// a connection over its caps as soon as it accepts it).
async fn open_idle(to: SocketAddr, from: SocketAddr, n: usize) -> (Vec<TcpStream>, usize) {
    let mut conns = Vec::with_capacity(n);
    let mut reset = 0;
    while conns.len() + reset < n {
        let mut batch = JoinSet::new();
        for _ in 0..BATCH.min(n - conns.len() - reset) {
            batch.spawn(async move {
                let socket = TcpSocket::new_v4().unwrap();
                socket.bind(from).unwrap();
                tokio::time::timeout(Duration::from_secs(10), socket.connect(to))
                    .await
                    .expect("connect timed out")
            });
        }
        while let Some(conn) = batch.join_next().await {
            match conn.unwrap() {
                Ok(conn) => conns.push(conn),
                Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => reset += 1,
                Err(e) => panic!("connect: {e}"),
            }
        }
    }
    (conns, reset)
}

/// How many of `conns` the peer has closed (EOF or reset), without reading data.
fn closed_by_peer(conns: &[TcpStream]) -> usize {
    conns
        .iter()
        .filter(|c| {
            let mut byte = 0u8;
            // SAFETY: a non-blocking peek of one byte into a local on a socket we own.
            let n = unsafe {
                libc::recv(
                    c.as_raw_fd(),
                    (&mut byte as *mut u8).cast(),
                    1,
                    libc::MSG_PEEK | libc::MSG_DONTWAIT,
                )
            };
            n == 0
                || (n < 0
                    && std::io::Error::last_os_error().kind() != std::io::ErrorKind::WouldBlock)
        })
        .count()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ten_thousand_idle_connections_leave_rem_hosts_answering() {
    // remd inherits the raised limit too (and raises its own).
    let fd_limit = rem::raise_fd_limit().unwrap();
    if fd_limit < IDLE as u64 + 500 {
        eprintln!(
            "skipped: the open-file limit is {fd_limit}; this test needs {}",
            IDLE + 500
        );
        return;
    }
    let mut cluster = remds(1, &[]);
    let addr: SocketAddr = cluster.addrs()[0].parse().unwrap();
    // remd runs with the default limits.
    let limits = rem::ConnectionLimits::default();

    let start = Instant::now();
    let (idle, reset) = open_idle(addr, "127.0.0.2:0".parse().unwrap(), IDLE).await;
    let opened = start.elapsed();

    // While they are held open, a client from another address is served.
    let hosts = tokio::time::timeout(Duration::from_secs(5), async {
        cluster.client(0).await.hosts().await.unwrap()
    })
    .await
    .expect("`rem hosts` did not answer within 5 s");
    assert_eq!(hosts.len(), 1);
    assert!(
        cluster.daemons[0].child.try_wait().unwrap().is_none(),
        "remd exited"
    );

    // remd closed those over its per-address cap at once, before any preface timeout.
    let refused = IDLE - limits.max_per_ip;
    let mut closed = reset + closed_by_peer(&idle);
    while closed < refused && start.elapsed() < limits.preface_timeout {
        tokio::time::sleep(Duration::from_millis(50)).await;
        closed = reset + closed_by_peer(&idle);
    }
    eprintln!(
        "{IDLE} connections opened in {opened:?} ({reset} reset during connect); \
         {closed} closed by remd after {:?}",
        start.elapsed()
    );
    assert!(
        closed >= refused,
        "remd closed {closed} of {IDLE} connections from one address, expected {refused}"
    );
    assert!(
        start.elapsed() < limits.preface_timeout,
        "closed by the cap, not the timeout"
    );

    drop(idle);
    assert!(cluster.daemons[0].child.try_wait().unwrap().is_none());
}
