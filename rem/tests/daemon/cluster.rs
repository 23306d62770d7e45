//! Three real remd processes on loopback: membership, load, placement, processes.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::Duration;

use crate::common::*;
use rem::{EventKind, ProcId, SpawnRequest};

const T: Duration = Duration::from_secs(10);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn membership_converges_and_load_figures_appear() {
    let cluster = in_process(3, |_| {}).await;
    cluster.converge(T).await;
    // b and c joined through a only; they still learned each other.
    let c = cluster.client(2).await;
    let hosts = c.hosts().await.unwrap();
    let names: Vec<_> = hosts.iter().map(|h| h.name.as_str()).collect();
    assert_eq!(names, ["c", "a", "b"]);
    for h in &hosts {
        let load = h.load.expect("load figures");
        assert!(load.cores >= 1, "{h:?}");
        assert!(
            load.mem_total_bytes > 0 && load.mem_free_bytes <= load.mem_total_bytes,
            "{h:?}"
        );
        assert!((0.0..=1.0).contains(&load.cpu_busy));
        let expect = (load.load_avg_1m + load.rem_processes as f64) / load.cores as f64;
        assert!((load.load_per_core - expect).abs() < 1e-9);
        assert_eq!(
            h.addr,
            cluster
                .daemons
                .iter()
                .find(|d| d.name() == h.name)
                .unwrap()
                .addr()
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn placement_avoids_the_host_running_rem_work() {
    let cluster = in_process(3, |_| {}).await;
    cluster.converge(T).await;
    let client = cluster.client(0).await;
    let spin = |count| SpawnRequest {
        program: ECHO.into(),
        args: vec!["spin".into(), "30".into()],
        count,
        ..SpawnRequest::default()
    };
    // Load one host with a busy REM process.
    let busy = client.spawn(spin(1)).await.unwrap();
    let busy_host = busy.processes[0].host.clone();
    // Wait until the placing daemon sees that host carrying it.
    wait_hosts(&client, T, |hs| {
        hs.iter()
            .any(|h| h.name == busy_host && h.load.as_ref().is_some_and(|l| l.rem_processes == 1))
    })
    .await;
    // The next two single spawns go elsewhere, and to different hosts.
    let next = client.spawn(spin(1)).await.unwrap();
    assert_ne!(next.processes[0].host, busy_host);
    let hosts = client.spawn(spin(1)).await.unwrap().processes[0]
        .host
        .clone();
    assert_ne!(hosts, busy_host);
    // Three hosts, three more one-per-host processes: possible; four: a clear error.
    let err = client.spawn(spin(4)).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::FailedPrecondition, "{err}");
    let many = client
        .spawn(SpawnRequest {
            allow_same_host: true,
            ..spin(4)
        })
        .await
        .unwrap();
    assert_eq!(many.processes.len(), 4);
    let ps = client.ps().await.unwrap();
    assert_eq!(ps.iter().filter(|p| p.state == "running").count(), 7);
    // Hosts to avoid are left out, however lightly loaded; too few others is an error.
    let avoid = |count, hosts: &[&str]| SpawnRequest {
        avoid_hosts: hosts.iter().map(|h| h.to_string()).collect(),
        ..spin(count)
    };
    let elsewhere = client.spawn(avoid(2, &["a", "zz"])).await.unwrap();
    let mut placed: Vec<_> = elsewhere
        .processes
        .iter()
        .map(|p| p.host.as_str())
        .collect();
    placed.sort();
    assert_eq!(placed, ["b", "c"]);
    let two = client.spawn(avoid(2, &["b"])).await.unwrap();
    assert!(two.processes.iter().all(|p| p.host != "b"), "{two:?}");
    let err = client.spawn(avoid(3, &["b"])).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::FailedPrecondition, "{err}");
    let names: Vec<String> = (0..=rem::wire::MAX_AVOID_HOSTS)
        .map(|i| format!("h{i}"))
        .collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let err = client.spawn(avoid(1, &refs)).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::InvalidArgument, "{err}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn spawned_process_is_niced_and_its_output_and_exit_arrive() {
    let cluster = remds(2, &[]);
    cluster.converge(T).await;
    let client = cluster.client(0).await;
    let mut owner = client.attach(Some("job-nice")).await.unwrap();
    let job = client
        .spawn(SpawnRequest {
            program: ECHO.into(),
            args: vec!["spin".into(), "30".into()],
            nice: Some(7),
            count: 2,
            job: Some("job-nice".into()),
            owner: Some(owner.id().clone()),
            ..SpawnRequest::default()
        })
        .await
        .unwrap();
    assert_eq!(job.id, "job-nice");
    for p in &job.processes {
        next_event(&mut owner, T, |e| {
            e.proc_id == p.proc_id.as_str() && e.kind == EventKind::Started as i32
        })
        .await;
        // Field 19 of /proc/PID/stat is the nice value.
        assert_eq!(proc_stat_field(p.pid, 19), "7");
    }
    // remd itself was not reniced.
    assert_eq!(proc_stat_field(cluster.daemons[0].pid() as u32, 19), "0");
    // Kill one (on the other host, through this daemon): the owner hears SIGTERM.
    let victim = job.processes.iter().find(|p| p.host == "b").unwrap();
    client.kill(&victim.proc_id).await.unwrap();
    let ev = next_event(&mut owner, T, |e| e.kind == EventKind::Exited as i32).await;
    assert_eq!(ev.proc_id, victim.proc_id.as_str());
    assert_eq!(ev.signal, Some(libc::SIGTERM));
    assert_eq!(ev.exit_code, None);

    // A process that prints and exits with a code.
    let job = client
        .spawn(SpawnRequest {
            program: ECHO.into(),
            args: vec!["exit".into(), "3".into()],
            owner: Some(owner.id().clone()),
            ..SpawnRequest::default()
        })
        .await
        .unwrap();
    let id: &ProcId = &job.processes[0].proc_id;
    let ev = next_event(&mut owner, T, |e| {
        e.proc_id == id.as_str() && e.kind == EventKind::Exited as i32
    })
    .await;
    assert_eq!(ev.exit_code, Some(3));
    let logs = client.logs(id).await.unwrap();
    assert_eq!(
        String::from_utf8_lossy(&logs.stdout),
        format!("rem-echo stdout {id}\n")
    );
    assert_eq!(String::from_utf8_lossy(&logs.stderr), "rem-echo stderr\n");
    // A follower asks only for what is new since its last read.
    let rest = client.logs_since(id, (9, 4)).await.unwrap();
    assert_eq!((rest.stdout_start, rest.stderr_start), (9, 4));
    assert_eq!(rest.stdout, logs.stdout[9..]);
    assert_eq!(String::from_utf8_lossy(&rest.stderr), "echo stderr\n");
    let ps = client.ps().await.unwrap();
    let entry = ps.iter().find(|p| p.proc_id == id.as_str()).unwrap();
    assert_eq!((entry.state.as_str(), entry.exit_code), ("exited", Some(3)));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rem_command_lists_hosts_as_json_and_table() {
    let cluster = remds(2, &[]);
    cluster.converge(T).await;
    let rem = env!("CARGO_BIN_EXE_rem");
    let out = std::process::Command::new(rem)
        .args(["--remd", &cluster.daemons[1].addr, "hosts", "--json"])
        .env("REM_SECRET_FILE", &cluster.secret_file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let arr = v.as_array().unwrap();
    assert_eq!(arr.len(), 2);
    for h in arr {
        for key in ["name", "addr", "cores", "load_per_core"] {
            assert!(h.get(key).is_some(), "{key} missing in {h}");
        }
        assert_eq!(h["alive"], serde_json::Value::Bool(true));
    }
    let out = std::process::Command::new(rem)
        .args(["hosts"])
        .env("REM_ADDR", &cluster.daemons[0].addr)
        .env("REM_SECRET_FILE", &cluster.secret_file)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.starts_with("NAME"), "{text}");
    assert_eq!(
        text.lines().filter(|l| l.contains("alive")).count(),
        2,
        "{text}"
    );

    // spawn --wait: events printed, the exit code passed on; then logs and ps of that process.
    let rem_cmd = |args: &[&str]| {
        std::process::Command::new(rem)
            .args(args)
            .env("REM_ADDR", &cluster.daemons[0].addr)
            .env("REM_SECRET_FILE", &cluster.secret_file)
            .output()
            .unwrap()
    };
    let out = rem_cmd(&["spawn", "--wait", "--nice", "3", ECHO, "exit", "5"]);
    assert_eq!(
        out.status.code(),
        Some(5),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let id = text.split_whitespace().nth(1).unwrap().to_string();
    assert!(text.contains(&format!("{id} started on")), "{text}");
    assert!(text.contains(&format!("{id} exited with code 5")), "{text}");
    let out = rem_cmd(&["logs", &id]);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        format!("rem-echo stdout {id}\n")
    );
    assert_eq!(String::from_utf8_lossy(&out.stderr), "rem-echo stderr\n");
    let out = rem_cmd(&["ps", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let p = v
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["proc_id"] == id.as_str())
        .unwrap()
        .clone();
    assert_eq!(
        (p["exit_code"].as_i64(), p["nice"].as_i64()),
        (Some(5), Some(3))
    );
    // kill through the command; a bad id is an error with a non-zero exit.
    let out = rem_cmd(&["spawn", "--json", ECHO, "spin", "30"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let spin_id = v[0]["proc_id"].as_str().unwrap().to_string();
    assert!(rem_cmd(&["kill", &spin_id]).status.success());
    let c = cluster.client(0).await;
    let end = std::time::Instant::now() + T;
    while c
        .ps()
        .await
        .unwrap()
        .iter()
        .any(|p| p.proc_id == spin_id && p.state == "running")
    {
        assert!(std::time::Instant::now() < end, "not killed");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let out = rem_cmd(&["kill", "nonsense"]);
    assert!(!out.status.success());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn remd_takes_settings_from_environment_and_config_file() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret");
    rem::auth::secret::write_private(&secret, "env-secret\n").unwrap();
    // Environment only (no flags at all).
    let mut env_child = std::process::Command::new(REMD)
        .env("REMD_NAME", "envhost")
        .env("REMD_LISTEN", "127.0.0.1:0")
        .env("REM_SECRET_FILE", &secret)
        .env("REMD_ALLOW", ECHO)
        .env("REMD_ALLOW_ANY_ARGS", "true")
        .env("RUST_LOG", "warn")
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(env_child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let env_addr = rem::wire::listening_addr(&line).unwrap().to_string();
    // A TOML file joining the first.
    let cfg = dir.path().join("remd.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"filehost\"\nlisten = \"127.0.0.1:0\"\nsecret_file = {secret:?}\njoin = [{env_addr:?}]\nallow = [{ECHO:?}]\nallow_any_args = true\n"
        ),
    )
    .unwrap();
    let mut file_child = std::process::Command::new(REMD)
        .args(["--config", cfg.to_str().unwrap()])
        .env("RUST_LOG", "warn")
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(file_child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(line.starts_with("remd listening on 127.0.0.1:"), "{line}");
    let c = rem::RemClient::connect(&env_addr, rem::Secret::new("env-secret").unwrap())
        .await
        .unwrap();
    let hosts = wait_hosts(&c, T, |hs| hs.len() == 2 && hs.iter().all(|h| h.alive)).await;
    assert_eq!(hosts[0].name, "envhost");
    assert_eq!(hosts[1].name, "filehost");
    // The file's allow-list is in force: placement on filehost works for ECHO.
    let job = c
        .spawn(SpawnRequest {
            program: ECHO.into(),
            args: vec!["exit".into(), "0".into()],
            count: 2,
            ..SpawnRequest::default()
        })
        .await
        .unwrap();
    assert_eq!(job.processes.len(), 2);
    for child in [&mut env_child, &mut file_child] {
        let _ = child.kill();
        let _ = child.wait();
    }
}

#[test]
fn remd_refuses_a_program_without_an_argument_rule_unless_told() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret");
    rem::auth::secret::write_private(&secret, "rule-secret\n").unwrap();
    let remd = |extra: &[&str]| {
        std::process::Command::new(REMD)
            .args(["--listen", "127.0.0.1:0", "--secret-file"])
            .arg(&secret)
            .args(["--allow", "/usr/local/bin/sunray"])
            .args(extra)
            .env("RUST_LOG", "warn")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    // Any client could run `sunray spd ... -o ANYPATH` as remd's user: refused, in one line.
    let refused = remd(&[]).wait_with_output().unwrap();
    let said = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{said}");
    assert_eq!(said.trim_end().lines().count(), 1, "{said}");
    assert!(
        said.contains("--allow /usr/local/bin/sunray: no argument rule")
            && said.contains("/usr/local/bin/sunray:worker|controller"),
        "{said}"
    );
    // The administrator says it is meant: the daemon starts.
    let mut meant = remd(&["--allow-any-args"]);
    let mut line = String::new();
    std::io::BufReader::new(meant.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(rem::wire::listening_addr(&line).is_some(), "{line}");
    meant.kill().unwrap();
    meant.wait().unwrap();
}
