//! Security: secret, allow-list, size limit, malformed requests, health without a secret, TLS.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::Duration;

use crate::common::*;
use rem::client::rem_client::ConnectOptions;
use rem::wire::proto::{
    self, client_frame, rem_client::RemClient as RawClient, ClientFrame, Envelope, EnvelopeBatch,
    Hello,
};
use rem::wire::transport::ClientTls;
use rem::{Error, RemClient, Secret, SpawnRequest};
use tokio_stream::wrappers::ReceiverStream;
use tonic::Code;

const T: Duration = Duration::from_secs(10);

fn code<T: std::fmt::Debug>(r: Result<T, Error>) -> Code {
    r.unwrap_err().code()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wrong_or_missing_secret_is_unauthenticated_and_health_is_open() {
    let cluster = in_process(1, |_| {}).await;
    let addr = &cluster.addrs()[0];
    let wrong = RemClient::connect(addr, Secret::new("not-the-secret").unwrap())
        .await
        .unwrap();
    assert_eq!(code(wrong.hosts().await), Code::Unauthenticated);
    let spawn = SpawnRequest {
        program: ECHO.into(),
        args: vec!["spin".into(), "5".into()],
        ..SpawnRequest::default()
    };
    assert_eq!(
        code(wrong.spawn(spawn.clone()).await),
        Code::Unauthenticated
    );
    assert_eq!(
        code(wrong.put_checkpoint("j", b"x".to_vec()).await),
        Code::Unauthenticated
    );
    assert_eq!(code(wrong.attach(None).await), Code::Unauthenticated);
    // No secret at all (raw client without the interceptor).
    let mut raw = RawClient::connect(format!("http://{addr}")).await.unwrap();
    let status = raw.hosts(proto::HostsRequest {}).await.unwrap_err();
    assert_eq!(status.code(), Code::Unauthenticated);
    let status = raw
        .spawn(proto::SpawnRequest {
            program: ECHO.into(),
            count: 1,
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::Unauthenticated);
    // ... and nothing was started.
    let good = cluster.client(0).await;
    assert!(good.ps().await.unwrap().is_empty());
    // Health answers without the secret.
    let channel = tonic::transport::Endpoint::from_shared(format!("http://{addr}"))
        .unwrap()
        .connect()
        .await
        .unwrap();
    let mut health = tonic_health::pb::health_client::HealthClient::new(channel);
    let reply = health
        .check(tonic_health::pb::HealthCheckRequest {
            service: "rem.v1.Rem".into(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(
        reply.status,
        tonic_health::pb::health_check_response::ServingStatus::Serving as i32
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn only_allow_listed_absolute_programs_are_spawned() {
    let cluster = in_process(2, |_| {}).await;
    cluster.converge(T).await;
    let c = cluster.client(0).await;
    let req = |program: &str| SpawnRequest {
        program: program.into(),
        ..SpawnRequest::default()
    };
    assert_eq!(code(c.spawn(req("/bin/sh")).await), Code::PermissionDenied);
    assert_eq!(code(c.spawn(req("rem-echo")).await), Code::InvalidArgument);
    assert_eq!(
        code(
            c.spawn(SpawnRequest {
                count: 0,
                ..req(ECHO)
            })
            .await
        ),
        Code::InvalidArgument
    );
    assert_eq!(
        code(
            c.spawn(SpawnRequest {
                nice: Some(40),
                ..req(ECHO)
            })
            .await
        ),
        Code::InvalidArgument
    );
    assert_eq!(
        code(
            c.spawn(SpawnRequest {
                job: Some("a b".into()),
                ..req(ECHO)
            })
            .await
        ),
        Code::InvalidArgument
    );
    assert!(c.ps().await.unwrap().is_empty());
    // Malformed ids.
    let mut raw = c.rpc();
    let status = raw
        .kill(proto::KillRequest {
            proc_id: "no-slash".into(),
        })
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::InvalidArgument);
    let status = raw
        .logs(proto::LogsRequest {
            proc_id: "a/12345".into(),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::NotFound);
    // Attaching as someone else's process (without its token), or without Hello, is refused.
    assert_eq!(
        code(c.attach_as(&"a/99".parse().unwrap(), "").await),
        Code::PermissionDenied
    );
    let (tx, rx) = tokio::sync::mpsc::channel(1);
    tx.send(ClientFrame {
        frame: Some(client_frame::Frame::Batch(EnvelopeBatch::default())),
    })
    .await
    .unwrap();
    let status = raw.attach(ReceiverStream::new(rx)).await.unwrap_err();
    assert_eq!(status.code(), Code::InvalidArgument);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn oversized_messages_are_refused() {
    let cluster = in_process(1, |s| s.max_message = 1024).await;
    let c = cluster.client(0).await;
    let relay = c.attach(None).await.unwrap();
    // The library refuses before sending (the daemon told it the limit).
    let me = relay.id().clone();
    assert!(matches!(
        relay.send(&me, vec![0u8; 1025]).await,
        Err(Error::TooLarge {
            size: 1025,
            limit: 1024
        })
    ));
    relay.send(&me, vec![0u8; 1024]).await.unwrap();
    // A raw client that ignores the limit gets RESOURCE_EXHAUSTED and the stream ends.
    let mut raw = c.rpc();
    let (tx, rx) = tokio::sync::mpsc::channel(4);
    tx.send(ClientFrame {
        frame: Some(client_frame::Frame::Hello(Hello::default())),
    })
    .await
    .unwrap();
    let mut stream = raw
        .attach(ReceiverStream::new(rx))
        .await
        .unwrap()
        .into_inner();
    let welcome = stream.message().await.unwrap().unwrap();
    let Some(proto::server_frame::Frame::Welcome(w)) = welcome.frame else {
        panic!("{welcome:?}")
    };
    assert_eq!(w.max_message_bytes, 1024);
    let big = Envelope {
        from: String::new(),
        to: w.proc_id.clone(),
        payload: vec![1u8; 2048],
    };
    tx.send(ClientFrame {
        frame: Some(client_frame::Frame::Batch(EnvelopeBatch {
            envelopes: vec![big],
        })),
    })
    .await
    .unwrap();
    let status = loop {
        match stream.message().await {
            Ok(Some(_)) => continue,
            Ok(None) => panic!("stream ended without a status"),
            Err(s) => break s,
        }
    };
    assert_eq!(status.code(), Code::ResourceExhausted, "{status:?}");
    // Checkpoints have the same limit.
    let status = raw
        .put_checkpoint(proto::PutCheckpointRequest {
            job: "j".into(),
            data: vec![0; 2048],
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::ResourceExhausted);
    assert_eq!(c.get_checkpoint("j").await.unwrap(), None);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tls_cluster_works_and_plain_clients_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cert =
        rcgen::generate_simple_self_signed(vec!["localhost".to_string(), "127.0.0.1".to_string()])
            .unwrap();
    let cert_path = dir.path().join("cert.pem");
    let key_path = dir.path().join("key.pem");
    std::fs::write(&cert_path, cert.cert.pem()).unwrap();
    std::fs::write(&key_path, cert.signing_key.serialize_pem()).unwrap();
    let cluster = in_process(2, |s| {
        s.tls = Some(rem::wire::transport::ServerTlsFiles {
            cert: cert_path.clone(),
            key: key_path.clone(),
            ca: None,
            domain: None,
        })
    })
    .await;
    let tls = ClientTls::from_file(&cert_path, Some("localhost".into())).unwrap();
    let mut opts = ConnectOptions::new(cluster.addrs()[0].clone(), cluster.secret());
    opts.tls = Some(tls);
    let c = RemClient::connect_with(opts).await.unwrap();
    // Peers talk TLS to each other: membership converges.
    wait_hosts(&c, T, |hs| hs.len() == 2 && hs.iter().all(|h| h.alive)).await;
    // A spawned process attaches over TLS too (it gets REM_TLS_CA in its environment).
    let mut owner = c.attach(None).await.unwrap();
    let job = c
        .spawn(SpawnRequest {
            program: ECHO.into(),
            args: vec!["echo".into()],
            count: 2,
            owner: Some(owner.id().clone()),
            ..SpawnRequest::default()
        })
        .await
        .unwrap();
    let echo = job
        .processes
        .iter()
        .find(|p| p.host == "b")
        .unwrap()
        .proc_id
        .clone();
    owner.send(&echo, b"over tls".to_vec()).await.unwrap();
    let got = tokio::time::timeout(T, async {
        loop {
            if let rem::Incoming::Message { payload, .. } = owner.recv().await.unwrap() {
                return payload;
            }
        }
    })
    .await
    .unwrap();
    assert_eq!(got, b"over tls");
    // Plain HTTP/2 to a TLS daemon fails.
    let plain = RemClient::connect(&cluster.addrs()[0], cluster.secret()).await;
    match plain {
        Err(_) => {}
        Ok(p) => assert!(p.hosts().await.is_err()),
    }
}
