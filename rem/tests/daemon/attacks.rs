//! The attack battery (issue "Security"): each test is written as the attacker would try it,
//! and checks that it does no harm. docs/rem.md's security section lists them with their
//! results before and after.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::Duration;

use crate::common::*;
use rem::wire::proto::{self, peer_client::PeerClient, peer_item, PeerBatch, PeerItem};
use rem::{ConnectOptions, Error, RemClient, Secret, SpawnRequest};
use tonic::Code;

const T: Duration = Duration::from_secs(10);

fn code<T: std::fmt::Debug>(r: Result<T, Error>) -> Code {
    r.unwrap_err().code()
}

fn spin(seconds: u32) -> SpawnRequest {
    SpawnRequest {
        program: ECHO.into(),
        args: vec!["spin".into(), seconds.to_string()],
        ..SpawnRequest::default()
    }
}

async fn running(c: &RemClient, id: &rem::ProcId) -> bool {
    c.ps()
        .await
        .unwrap()
        .iter()
        .any(|p| p.proc_id == id.as_str() && p.state == "running")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_spawn_of_u32_max_processes_is_refused_and_harms_nobody() {
    let cluster = remds(1, &[]);
    let c = cluster.client(0).await;
    let victim = c.spawn(spin(30)).await.unwrap().processes[0]
        .proc_id
        .clone();
    let huge = SpawnRequest {
        count: u32::MAX,
        allow_same_host: true,
        ..spin(1)
    };
    assert_eq!(code(c.spawn(huge).await), Code::InvalidArgument);
    // Just over the per-request limit is refused too, and so is passing the host's limit.
    let over = SpawnRequest {
        count: rem::daemon::limits::Limits::default().spawn_count + 1,
        allow_same_host: true,
        ..spin(1)
    };
    assert_eq!(code(c.spawn(over).await), Code::InvalidArgument);
    assert!(c.hosts().await.is_ok(), "remd answers");
    assert!(running(&c, &victim).await, "the other job's process lives");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_host_process_limit_is_a_status() {
    let cluster = in_process(1, |s| s.limits.host_processes = 2).await;
    let c = cluster.client(0).await;
    let two = SpawnRequest {
        count: 2,
        allow_same_host: true,
        ..spin(30)
    };
    c.spawn(two.clone()).await.unwrap();
    assert_eq!(code(c.spawn(spin(30)).await), Code::ResourceExhausted);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn clients_cannot_choose_a_childs_environment_and_children_never_see_the_secret() {
    let cluster = in_process(1, |_| {}).await;
    let c = cluster.client(0).await;
    for name in [
        "LD_PRELOAD",
        "LD_LIBRARY_PATH",
        "PATH",
        "REM_SECRET",
        "REM_PROC_ID",
        "HOME",
    ] {
        let req = SpawnRequest {
            env: [(name.to_string(), "/tmp/evil.so".to_string())].into(),
            ..spin(1)
        };
        assert_eq!(code(c.spawn(req).await), Code::PermissionDenied, "{name}");
    }
    assert!(c.ps().await.unwrap().is_empty(), "nothing was started");
    // What a child does get: PATH, REM_* of remd's making, and allowed names only.
    let allowed = SpawnRequest {
        env: [("SUNRAY_WORKER_LINE_DELAY_MS".to_string(), "1".to_string())].into(),
        ..spin(1)
    };
    c.spawn(allowed).await.unwrap();
    let (_, env) = spawn_env_printer(&c, "env-job", 5).await;
    let secret = cluster.secret();
    let secret_text = String::from_utf8_lossy(secret.as_bytes()).to_string();
    for (k, v) in &env {
        assert!(
            k == "PATH" || k == "uid" || k.starts_with("REM_"),
            "unexpected variable {k} in a child's environment"
        );
        assert!(!v.contains(&secret_text), "{k} holds the secret");
    }
    assert!(!env.contains_key("REM_SECRET") && !env.contains_key("REM_SECRET_FILE"));
    assert_eq!(env["REM_PROC_TOKEN"].len(), 64);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn children_of_a_root_remd_run_as_the_configured_user() {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        println!("skipped: this test needs root (remd as root, children as nobody)");
        return;
    }
    // A copy of rem-echo that user 65534 may execute, whatever the checkout's permissions.
    let dir = tempfile::tempdir().unwrap();
    let echo = dir.path().join("rem-echo");
    std::fs::copy(ECHO, &echo).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::set_permissions(&echo, std::fs::Permissions::from_mode(0o755)).unwrap();
    let program = echo.to_str().unwrap().to_string();
    let allowed = program.clone();
    let cluster = in_process(1, move |s| {
        s.allow_program(&allowed);
        s.run_as = Some(rem::RunAs {
            uid: 65534,
            gid: 65534,
        });
    })
    .await;
    let c = cluster.client(0).await;
    let (_, env) = spawn_env_printer_of(&c, &program, "as-nobody", 5).await;
    assert_eq!(env["uid"], "65534");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_argument_rule_keeps_a_multi_tool_to_its_allowed_subcommands() {
    // As `sunray:worker|controller` keeps `sunray spd -o ANYPATH` out, this rule lets
    // rem-echo run only as `echo`, `env` or `spin`.
    let rule = format!("{ECHO}:echo|env|spin");
    let cluster = remds_allowing(1, &[&rule], &[]);
    let c = cluster.client(0).await;
    let exit = SpawnRequest {
        program: ECHO.into(),
        args: vec!["exit".into(), "3".into()],
        ..SpawnRequest::default()
    };
    assert_eq!(code(c.spawn(exit).await), Code::PermissionDenied);
    let bare = SpawnRequest {
        args: Vec::new(),
        ..spin(1)
    };
    assert_eq!(code(c.spawn(bare).await), Code::PermissionDenied);
    assert!(c.spawn(spin(1)).await.is_ok());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fake_member_on_a_dead_members_port_learns_nothing_and_is_not_believed() {
    use rem::membership::swim::{MemberId, SwimConfig, SwimNode};
    // Three: a and c keep asking the lost b to rejoin (a member alone has nobody to ask).
    let mut cluster = in_process(3, |_| {}).await;
    cluster.converge(T).await;
    let a_addr: std::net::SocketAddr = cluster.addrs()[0].parse().unwrap();
    let b = cluster.daemons.remove(1);
    let b_addr = b.addr().to_string();
    b.stop().await;
    let c = cluster.client(0).await;
    wait_hosts(&c, T, |hs| hs.iter().any(|h| h.name == "b" && !h.alive)).await;
    // The attacker takes b's (UDP) port: a and c ask their lost member to rejoin every 2 s.
    let socket = tokio::net::UdpSocket::bind(&b_addr).await.unwrap();
    let mut captured = Vec::new();
    let mut buf = vec![0u8; 2048];
    while captured.len() < 2 {
        let (n, _) = tokio::time::timeout(T, socket.recv_from(&mut buf))
            .await
            .expect("no datagram reached the fake member")
            .unwrap();
        captured.push(buf[..n].to_vec());
    }
    // They carry no secret and no key: only a tag bound to each datagram.
    let secret = cluster.secret();
    let keys = [
        secret.user_root().unwrap(),
        secret.client_credential(None).unwrap().1,
        secret.admin_key().unwrap(),
        secret.daemon_key().unwrap(),
    ];
    for d in &captured {
        assert!(
            !String::from_utf8_lossy(d).contains(SECRET),
            "the secret was sent"
        );
        for key in &keys {
            assert!(!d.windows(32).any(|w| w == key), "a key was sent");
        }
    }
    // It answers as "b" and as "evil", sealed with what it could get: a made-up secret, or
    // a user's client key (users cannot speak the membership protocol), and replays what
    // it captured. None of it is believed: b stays lost, "evil" is unknown.
    let now = || {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_millis() as u64
    };
    let user_key = secret.client_credential(None).unwrap().1;
    for (i, key) in [b"made-up".to_vec(), user_key.to_vec()].iter().enumerate() {
        for name in ["b", "evil"] {
            let me = MemberId {
                name: name.into(),
                addr: socket.local_addr().unwrap(),
                grpc: b_addr.clone(),
                stamp: now() + i as u64,
            };
            let mut node = SwimNode::new(me, key, SwimConfig::default(), 7 + i as u64);
            node.announce(a_addr, now());
            for (to, d) in node.drain().datagrams {
                socket.send_to(&d, to).await.unwrap();
            }
        }
    }
    for d in &captured {
        socket.send_to(d, a_addr).await.unwrap();
    }
    tokio::time::sleep(Duration::from_millis(800)).await;
    let hosts = c.hosts().await.unwrap();
    assert!(hosts.iter().all(|h| h.name != "evil"), "{hosts:?}");
    assert!(hosts.iter().any(|h| h.name == "b" && !h.alive), "{hosts:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn identities_cannot_be_forged() {
    let cluster = in_process(1, |_| {}).await;
    let admin = cluster.client(0).await;
    let addr = cluster.addrs()[0].clone();
    // A user holding only the client key (`rem client-key`).
    let user_key = Secret::new(cluster.secret().client_key_line("mallory").unwrap()).unwrap();
    let user = RemClient::connect(&addr, user_key.clone()).await.unwrap();
    assert!(user.hosts().await.is_ok());
    let mut victim = admin.attach(Some("victim")).await.unwrap();
    // Forward with a forged `from` (and a forged job event): the Peer service wants a daemon's
    // proof, which a client key cannot make.
    let channel = tonic::transport::Endpoint::from_shared(format!("http://{addr}"))
        .unwrap()
        .connect()
        .await
        .unwrap();
    let mut peer = PeerClient::with_interceptor(
        channel,
        rem::auth::secret::SendSecret::new(&user_key, None, false).unwrap(),
    );
    let forged = PeerBatch {
        from_host: "a".into(),
        items: vec![
            PeerItem {
                item: Some(peer_item::Item::Envelope(proto::Envelope {
                    from: "a/1".into(),
                    to: victim.id().to_string(),
                    payload: b"forged pixels".to_vec(),
                })),
            },
            PeerItem {
                item: Some(peer_item::Item::Event(proto::JobEvent {
                    job: "victim".into(),
                    proc_id: "a/1".into(),
                    kind: proto::job_event::Kind::Lost as i32,
                    owner: victim.id().to_string(),
                    ..proto::JobEvent::default()
                })),
            },
        ],
    };
    let status = peer
        .forward(tokio_stream::iter(vec![forged]))
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::Unauthenticated);
    let status = peer
        .store_replica(proto::Checkpoint {
            job: "victim".into(),
            data: b"poison".to_vec(),
            version: u64::MAX,
            written_by: "a".into(),
            mac: vec![0; 32],
            user: rem::auth::identity::default_user(),
            epoch: u64::MAX,
        })
        .await
        .unwrap_err();
    assert_eq!(status.code(), Code::Unauthenticated);
    assert!(admin.get_checkpoint("victim").await.unwrap().is_none());
    // Nothing reached the victim.
    let got = tokio::time::timeout(Duration::from_millis(300), victim.recv()).await;
    assert!(got.is_err(), "the victim received {got:?}");
    // A stolen process id, without its token or with another's, does not attach.
    let (id, env) = spawn_env_printer(&admin, "job", 10).await;
    assert_eq!(
        code(user.attach_as(&id, "job").await),
        Code::PermissionDenied
    );
    let (_, other) = spawn_env_printer(&admin, "job2", 10).await;
    let thief = process_client(&addr, &other["REM_PROC_TOKEN"]).await;
    assert_eq!(
        code(thief.attach_as(&id, "job").await),
        Code::FailedPrecondition
    );
    // A process token acts for its process's user on its own host (as a job controller REM
    // started does), never for another user and never as admin.
    let owner = process_client(&addr, &env["REM_PROC_TOKEN"]).await;
    assert!(owner.attach_as(&id, "job").await.is_ok());
    assert_eq!(code(owner.attach(None).await), Code::PermissionDenied);
    let (_, mallorys) = spawn_env_printer(&user, "mjob", 10).await;
    let hers = process_client(&addr, &mallorys["REM_PROC_TOKEN"]).await;
    assert!(hers.hosts().await.is_ok());
    assert_eq!(code(hers.kill(&id).await), Code::PermissionDenied);
    assert_eq!(code(hers.logs(&id).await), Code::PermissionDenied);
    admin
        .put_checkpoint("job", b"admin's".to_vec())
        .await
        .unwrap();
    assert!(hers.get_checkpoint("job").await.unwrap().is_none());
    let spawned = hers.spawn(spin(1)).await.unwrap();
    let ps = admin.ps().await.unwrap();
    let theirs = ps
        .iter()
        .find(|p| p.proc_id == spawned.processes[0].proc_id.to_string())
        .unwrap();
    assert_eq!(theirs.user, "mallory");
    // A made-up token is nobody's (the fuzz run found one listed the hosts).
    let stranger = process_client(&addr, "made-up-token").await;
    assert_eq!(code(stranger.hosts().await), Code::Unauthenticated);
    assert_eq!(code(stranger.spawn(spin(1)).await), Code::Unauthenticated);
}

/// Resident set size of a process, in bytes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_user_cannot_kill_read_or_overwrite_the_first_users_job() {
    let cluster = in_process(2, |_| {}).await;
    cluster.converge(T).await;
    let addrs = cluster.addrs();
    let secret = cluster.secret();
    // Each user holds only a client-key file of its own (`rem client-key --user NAME`).
    let connect = |i: usize, user: &str| {
        let key = Secret::new(secret.client_key_line(user).unwrap()).unwrap();
        RemClient::connect_with(ConnectOptions::new(addrs[i].clone(), key))
    };
    let alice = connect(0, "alice").await.unwrap();
    let mallory = connect(1, "mallory").await.unwrap();
    let mallory_on_a = connect(0, "mallory").await.unwrap();
    // Alice's job: an owner, a process on each host, a checkpoint.
    let owner = alice.attach(Some("render")).await.unwrap();
    let job = alice
        .spawn(SpawnRequest {
            count: 2,
            job: Some("render".into()),
            owner: Some(owner.id().clone()),
            ..spin(30)
        })
        .await
        .unwrap();
    alice
        .put_checkpoint("render", b"alice's pixels".to_vec())
        .await
        .unwrap();
    let ps = mallory.ps().await.unwrap();
    for p in &job.processes {
        let info = ps.iter().find(|i| i.proc_id == p.proc_id.as_str()).unwrap();
        assert_eq!(info.user, "alice");
        // Mallory can neither end it nor read its output, on either host.
        assert_eq!(code(mallory.kill(&p.proc_id).await), Code::PermissionDenied);
        assert_eq!(code(mallory.logs(&p.proc_id).await), Code::PermissionDenied);
        // Nor have its events sent to a process of hers, nor to Alice's owner.
        let hers = mallory_on_a.attach(Some("hers")).await.unwrap();
        assert_eq!(
            code(mallory_on_a.adopt(&p.proc_id, hers.id()).await),
            Code::PermissionDenied
        );
        assert_eq!(
            code(mallory_on_a.adopt(&p.proc_id, owner.id()).await),
            Code::PermissionDenied
        );
        assert!(running(&alice, &p.proc_id).await, "{} was ended", p.proc_id);
    }
    // She cannot read Alice's checkpoint; her own, newer, of the same job id shadows nothing.
    assert!(mallory.get_checkpoint("render").await.unwrap().is_none());
    mallory
        .put_checkpoint("render", b"poison".to_vec())
        .await
        .unwrap();
    assert_eq!(
        alice.get_checkpoint("render").await.unwrap().unwrap(),
        b"alice's pixels"
    );
    assert_eq!(
        mallory.get_checkpoint("render").await.unwrap().unwrap(),
        b"poison"
    );
    // She cannot send job events to Alice's owner by naming it as her processes' owner.
    let hijack = SpawnRequest {
        owner: Some(owner.id().clone()),
        ..spin(1)
    };
    assert_eq!(
        code(mallory_on_a.spawn(hijack).await),
        Code::PermissionDenied
    );
    // Her key under Alice's name is not Alice's key.
    let mut as_alice = ConnectOptions::new(
        addrs[0].clone(),
        Secret::new(secret.client_key_line("mallory").unwrap()).unwrap(),
    );
    as_alice.user = Some("alice".into());
    assert!(RemClient::connect_with(as_alice).await.is_err());
    // An admin (the cluster secret, `--admin`) may read and end it; so may Alice.
    let mut opts = ConnectOptions::new(addrs[1].clone(), secret.clone()).as_user("root-admin");
    opts.admin = true;
    let admin = RemClient::connect_with(opts).await.unwrap();
    let [first, second] = &job.processes[..] else {
        panic!("two processes")
    };
    admin.logs(&first.proc_id).await.unwrap();
    admin.kill(&first.proc_id).await.unwrap();
    alice.kill(&second.proc_id).await.unwrap();
}

fn rss(pid: i32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let kb: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap();
    kb * 1024
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flood_into_an_unattached_mailbox_is_bounded_in_bytes() {
    let cluster = remds(1, &[]);
    let c = cluster.client(0).await;
    // A process that never attaches: its mailbox only fills.
    let target = c.spawn(spin(60)).await.unwrap().processes[0]
        .proc_id
        .clone();
    let attacker = c.attach(None).await.unwrap();
    let before = rss(cluster.daemons[0].pid());
    let (sender, mut receiver) = attacker.split();
    let drain = tokio::spawn(async move {
        let mut refused = 0u32;
        while let Ok(Ok(item)) = tokio::time::timeout(Duration::from_secs(5), receiver.recv()).await
        {
            if matches!(item, rem::Incoming::Undeliverable { .. }) {
                refused += 1;
            }
        }
        refused
    });
    let mut peak = before;
    let payload = vec![0xA5u8; 1 << 20];
    for i in 0..4096 {
        sender.send(&target, payload.clone()).await.unwrap();
        if i % 256 == 0 {
            peak = peak.max(rss(cluster.daemons[0].pid()));
        }
    }
    peak = peak.max(rss(cluster.daemons[0].pid()));
    let refused = drain.await.unwrap();
    let growth = peak.saturating_sub(before);
    println!("flood: RSS {before} -> peak {peak} (growth {growth} bytes); {refused} refused");
    assert!(growth < 256 << 20, "remd grew by {growth} bytes");
    assert!(refused > 3000, "only {refused} envelopes were refused");
    assert!(c.hosts().await.is_ok());
}
