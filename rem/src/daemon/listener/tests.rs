use super::*;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::mpsc;
use tokio_stream::StreamExt;

const A: IpAddr = IpAddr::V4(std::net::Ipv4Addr::new(10, 0, 0, 1));
const B: IpAddr = IpAddr::V4(std::net::Ipv4Addr::new(10, 0, 0, 2));

fn limits(max_connections: usize, max_per_ip: usize) -> ConnectionLimits {
    ConnectionLimits {
        max_connections,
        max_per_ip,
        ..ConnectionLimits::default()
    }
}

#[test]
fn total_cap_refuses_the_connection_past_it() {
    let slots = Slots::new(&limits(2, 10));
    let _a = slots.take(A).unwrap();
    let _b = slots.take(B).unwrap();
    assert_eq!(slots.take(A).unwrap_err(), Refusal::Total);
    assert_eq!(slots.open(), 2);
}

#[test]
fn per_source_cap_refuses_only_that_source() {
    let slots = Slots::new(&limits(10, 2));
    let _a1 = slots.take(A).unwrap();
    let _a2 = slots.take(A).unwrap();
    assert_eq!(slots.take(A).unwrap_err(), Refusal::PerSource(A));
    let _b = slots.take(B).unwrap();
    assert_eq!(slots.open(), 3);
}

#[test]
fn dropping_a_slot_frees_it() {
    let slots = Slots::new(&limits(2, 1));
    let a = slots.take(A).unwrap();
    assert!(slots.take(A).is_err());
    drop(a);
    let a = slots.take(A).unwrap();
    let b = slots.take(B).unwrap();
    assert_eq!(slots.take(A).unwrap_err(), Refusal::Total);
    drop((a, b));
    let counts = slots.counts();
    assert_eq!(counts.total, 0);
    assert!(counts.per_source.is_empty(), "no entry left per source");
}

#[test]
fn zero_caps_refuse_everything_and_leave_no_entry() {
    let slots = Slots::new(&limits(10, 0));
    assert_eq!(slots.take(A).unwrap_err(), Refusal::PerSource(A));
    assert!(slots.counts().per_source.is_empty());
    let slots = Slots::new(&limits(0, 10));
    assert_eq!(slots.take(A).unwrap_err(), Refusal::Total);
}

#[test]
fn ipv6_counts_per_64_and_mapped_ipv4_as_ipv4() {
    let one: IpAddr = "2001:db8:1:2::1".parse().unwrap();
    let other: IpAddr = "2001:db8:1:2:ffff::9".parse().unwrap();
    let elsewhere: IpAddr = "2001:db8:1:3::1".parse().unwrap();
    let slots = Slots::new(&limits(10, 1));
    let _one = slots.take(one).unwrap();
    assert!(slots.take(other).is_err(), "same /64");
    let _elsewhere = slots.take(elsewhere).unwrap();
    let _a = slots.take(A).unwrap();
    let mapped: IpAddr = "::ffff:10.0.0.1".parse().unwrap();
    assert_eq!(slots.take(mapped).unwrap_err(), Refusal::PerSource(A));
}

#[test]
fn throttle_lets_one_through_then_counts() {
    let mut t = Throttle::default();
    assert_eq!(t.hit(), Some(1));
    assert_eq!(t.hit(), None);
    assert_eq!(t.hit(), None);
    t.last = Instant::now().checked_sub(WARN_EVERY);
    assert_eq!(t.hit(), Some(3));
}

#[test]
fn fd_limit_is_raised_to_the_hard_limit() {
    let before = unsafe {
        let mut l = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        assert_eq!(libc::getrlimit(libc::RLIMIT_NOFILE, &mut l), 0);
        l
    };
    let now = raise_fd_limit().unwrap();
    assert!(now >= before.rlim_cur);
    if before.rlim_max != libc::RLIM_INFINITY {
        assert_eq!(now, before.rlim_max);
    }
}

/// A gate on 127.0.0.1:0 whose admitted streams are sent to the test.
async fn gate(limits: ConnectionLimits) -> (SocketAddr, mpsc::UnboundedReceiver<GatedStream>) {
    let listener = bind_listener("127.0.0.1:0".parse().unwrap()).unwrap();
    let addr = listener.local_addr().unwrap();
    let (tx, rx) = mpsc::unbounded_channel();
    tokio::spawn(async move {
        let mut gate = Gate::new(listener, limits);
        while let Some(Ok(stream)) = gate.next().await {
            if tx.send(stream).is_err() {
                break;
            }
        }
    });
    (addr, rx)
}

/// True when the peer closed `client` (EOF or reset) within `within`.
async fn closed_by_peer(client: &mut TcpStream, within: Duration) -> bool {
    let mut byte = [0u8; 1];
    matches!(
        tokio::time::timeout(within, client.read(&mut byte)).await,
        Ok(Ok(0) | Err(_))
    )
}

#[tokio::test]
async fn gate_closes_connections_over_the_cap_and_admits_again_when_one_ends() {
    let (addr, mut admitted) = gate(limits(10, 1)).await;
    let mut first = TcpStream::connect(addr).await.unwrap();
    let served = admitted.recv().await.unwrap();
    let info = served.connect_info();
    assert_eq!(info.remote_addr(), Some(first.local_addr().unwrap()));
    assert!(served.stream.nodelay().unwrap());

    let mut second = TcpStream::connect(addr).await.unwrap();
    assert!(closed_by_peer(&mut second, Duration::from_secs(5)).await);
    assert!(admitted.try_recv().is_err(), "the second was not admitted");

    drop(served);
    assert!(closed_by_peer(&mut first, Duration::from_secs(5)).await);
    let _third = TcpStream::connect(addr).await.unwrap();
    let third = tokio::time::timeout(Duration::from_secs(5), admitted.recv()).await;
    assert!(matches!(third, Ok(Some(_))), "a freed slot admits again");
}

#[tokio::test]
async fn silent_connection_is_closed_after_the_preface_timeout() {
    let timeout = Duration::from_millis(200);
    let (addr, mut admitted) = gate(ConnectionLimits {
        preface_timeout: timeout,
        ..ConnectionLimits::default()
    })
    .await;
    // The server side reads like hyper does, and drops the connection on EOF or error.
    tokio::spawn(async move {
        while let Some(mut served) = admitted.recv().await {
            tokio::spawn(async move {
                let mut buf = [0u8; 64];
                while let Ok(n) = served.read(&mut buf).await {
                    if n == 0 {
                        break;
                    }
                }
            });
        }
    });
    let start = Instant::now();
    let mut silent = TcpStream::connect(addr).await.unwrap();
    let mut talker = TcpStream::connect(addr).await.unwrap();
    talker.write_all(b"PRI * HTTP/2.0").await.unwrap();

    assert!(closed_by_peer(&mut silent, Duration::from_secs(5)).await);
    assert!(start.elapsed() >= timeout, "not closed before the timeout");
    assert!(
        !closed_by_peer(&mut talker, timeout * 4).await,
        "a client that spoke is kept past the timeout"
    );
}
