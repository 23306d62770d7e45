//! Bad input to `sunray submit`: each a clear error and a non-zero exit, and nothing
//! started. A scene with errors is refused, with its diagnostics, before any worker starts.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use sunray_e2e::bins::sunray;
use sunray_e2e::fixtures::spd;
use sunray_e2e::remd::LoopbackCluster;

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_bad_scene_is_refused_with_diagnostics_before_any_worker_starts() {
    let cluster = LoopbackCluster::start(1);
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.yari");
    std::fs::write(
        &scene,
        "resolution(32, 32);\nbegin\n  sphere(center = 0,0,0 ; radius = );\nend\n",
    )
    .unwrap();
    let out = cluster
        .submit()
        .args(["--hosts", "1"])
        .arg(&scene)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("bad.yari:3:"), "no file:line:col in {err}");
    assert!(err.contains('^'), "no caret in {err}");
    assert!(cluster.processes().is_empty(), "a worker was started");
    assert!(!dir.path().join("bad.png").exists());
}

#[test]
fn zero_hosts_too_many_hosts_unreachable_and_wrong_secret_are_clear_errors() {
    let cluster = LoopbackCluster::start(2);
    let scene = spd("tetra6");
    let run = |cmd: &mut std::process::Command| {
        let out = cmd
            .args(["--resolution", "16x16"])
            .arg(&scene)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{}", stderr(&out));
        stderr(&out)
    };

    let err = run(cluster.submit().args(["--hosts", "0"]));
    assert!(err.contains("--hosts must be at least 1"), "{err}");

    let err = run(cluster.submit().args(["--hosts", "3"]));
    assert!(
        err.contains("asked for 3 hosts") && err.contains("2 live host"),
        "{err}"
    );

    let dir = tempfile::tempdir().unwrap();
    let wrong = dir.path().join("wrong");
    std::fs::write(&wrong, "not-the-secret").unwrap();
    let err = run(sunray()
        .args(["submit", "--remd", &cluster.daemons[0].addr])
        .arg("--secret-file")
        .arg(&wrong));
    assert!(err.contains("refused the cluster secret"), "{err}");

    // A port nobody listens on (bound, then released).
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let err = run(sunray()
        .args(["submit", "--remd", &port.to_string()])
        .arg("--secret-file")
        .arg(&cluster.secret_file));
    assert!(err.contains("cannot reach remd at"), "{err}");

    let err = run(sunray().args(["submit", "--remd", &cluster.daemons[0].addr]));
    assert!(err.contains("no cluster secret"), "{err}");

    assert!(cluster.processes().is_empty(), "a worker was started");
}
