//! Faults of the controller: killed and resumed from its checkpoint, no worker left, Ctrl-C
//! on the default set-up, its remd lost, and a render to an error with a worker and the
//! controller killed mid-pass. Each still gives `sunray render`'s bytes.

use super::*;

/// Waits (a minute at most) until a checkpoint of `run`'s job holds at least `lines` lines;
/// returns how many it holds.
fn checkpointed(run: &mut SubmitRun, lines: u64) -> u64 {
    run.wait_until(Duration::from_secs(60), |seen| {
        seen.iter()
            .filter(|v| v["event"] == "checkpoint")
            .filter_map(|v| v["lines"].as_u64())
            .find(|&l| l >= lines)
    })
}

/// `c`, a `sunray submit` command line so far, resuming job `id`: quiet, its statistics
/// into the job's JSON file.
fn resume(mut c: Command, id: &str, job: &Job) -> std::process::Output {
    c.args(["--resume", id, "-q", "--stats-json"])
        .arg(&job.json);
    output(&mut c)
}

#[test]
fn a_killed_controller_resumes_from_its_checkpoint() {
    let cluster = LoopbackCluster::start(3);
    let job = job();
    let id = "resume-test-1";
    let mut run = SubmitRun::start(slow_submit(
        &cluster,
        &job,
        60,
        &["--in-process", "--job", id, "--checkpoint-ms", "100"],
    ));
    let stored = checkpointed(&mut run, 12);
    assert!(stored < LINES);
    run.child.kill().unwrap();
    run.child.wait().unwrap();
    assert!(!job.out.exists(), "no image from the killed run");

    let jobs = |state: &str| {
        let out = output(
            sunray()
                .args(["jobs", "--json", "--remd", &cluster.daemons[0].addr])
                .arg("--secret-file")
                .arg(&cluster.secret_file),
        );
        assert!(out.status.success());
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let entry = v
            .as_array()
            .unwrap()
            .iter()
            .find(|j| j["job"] == id)
            .cloned();
        let entry = entry.unwrap_or_else(|| panic!("{id} not listed: {v}"));
        assert_eq!(entry["state"], state, "{entry}");
        entry
    };
    // The killed controller's job counts the lines of its checkpoint.
    let listed = jobs("running");
    assert!(
        listed["lines_done"].as_u64().unwrap() >= stored,
        "{listed} lists fewer lines than the {stored} checkpointed"
    );

    // The checkpoint remembers the scene, the options and the output.
    let out = resume(cluster.submit(), id, &job);
    assert!(out.status.success());
    let s = check(&job, 1, "ok");
    let resumed = s["lines"]["resumed"].as_u64().unwrap();
    assert!(
        resumed >= stored,
        "resumed {resumed} < checkpointed {stored}"
    );
    assert_eq!(resumed + s["lines"]["rendered"].as_u64().unwrap(), LINES);
    jobs("finished");

    // Resuming a finished job writes the image again without starting anyone.
    std::fs::remove_file(&job.out).unwrap();
    let out = resume(cluster.submit(), id, &job);
    assert!(out.status.success());
    let s = read_json(&job.json);
    assert_eq!(s["lines"]["resumed"], LINES);
    assert!(s["nodes"].as_array().unwrap().is_empty());
    assert!(std::fs::read(&job.out).unwrap() == job.want);
}

#[test]
fn with_no_worker_left_the_job_says_so_keeps_its_checkpoint_and_resumes() {
    let cluster = LoopbackCluster::start(1);
    let job = job();
    let id = "no-workers-1";
    let mut c = cluster.submit();
    c.env("SUNRAY_WORKER_LINE_DELAY_MS", "60")
        .args(["--in-process", "--hosts", "1", "--job", id])
        .args(["--checkpoint-ms", "100"])
        .args(FLAGS)
        .arg(spd("mount6"))
        .arg("-o")
        .arg(&job.out);
    let mut run = SubmitRun::start(c);
    run.wait_lines_of(1, 4);
    signal(run.worker_pid(1), libc::SIGKILL);
    let status = run.wait(Duration::from_secs(60));
    assert_eq!(status.code(), Some(3), "exit code 3: no worker left");
    let failed = run.wait_until(Duration::ZERO, |seen| {
        seen.iter().find(|v| v["event"] == "failed").cloned()
    });
    let kept = failed["done"].as_u64().unwrap();
    assert!((4..LINES).contains(&kept), "{failed}");
    assert!(!job.out.exists(), "no image from a failed job");

    let out = resume(cluster.submit(), id, &job);
    assert!(out.status.success());
    let s = check(&job, 1, "ok");
    assert_eq!(s["lines"]["resumed"].as_u64().unwrap(), kept);
}

/// Ctrl-C on the default set-up (the private remd, which ends with the command): one line
/// says what the checkpoint kept and how to go on, the record says `interrupted` (never
/// `running`), no worker is left, and `--resume` finishes the image byte-identical.
#[test]
fn ctrl_c_on_the_default_set_up_says_what_was_kept_and_the_job_resumes() {
    let state = tempfile::tempdir().unwrap();
    let job = job();
    let id = "interrupted-1";
    let here = || {
        let mut c = sunray();
        c.env("SUNRAY_STATE_DIR", state.path());
        c
    };
    let mut c = here();
    c.env("SUNRAY_WORKER_LINE_DELAY_MS", "60")
        .args([
            "submit",
            "--hosts",
            "2",
            "--job",
            id,
            "--checkpoint-ms",
            "100",
        ])
        .args(FLAGS)
        .arg(spd("mount6"))
        .arg("-o")
        .arg(&job.out);
    let mut run = SubmitRun::start(c);
    let stored = checkpointed(&mut run, 12);
    let workers: Vec<i32> = (1..=2).map(|n| run.worker_pid(n)).collect();
    signal(run.child.id() as i32, libc::SIGINT);
    let status = run.wait(Duration::from_secs(60));
    let said = run.text();
    assert_eq!(status.code(), Some(130), "{said}");
    let lines: Vec<&str> = said.lines().collect();
    assert_eq!(lines.len(), 1, "one line: {said}");
    assert!(
        lines[0].starts_with(&format!("sunray: job {id} interrupted: "))
            && lines[0].ends_with(&format!("`sunray submit --resume {id}` continues it")),
        "{said}"
    );
    assert!(!job.out.exists(), "no image from the interrupted run");
    for pid in workers {
        // SAFETY-free check: kill(pid, 0) fails once the worker is gone (its pid unused).
        let gone = unsafe { libc::kill(pid, 0) } != 0;
        assert!(gone, "worker {pid} outlived the interrupted job");
    }
    let out = output(here().args(["jobs", "--json"]));
    let listed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let entry = &listed[0];
    assert_eq!(
        (&entry["job"], &entry["state"]),
        (&id.into(), &"interrupted".into()),
        "{listed}"
    );
    let kept = entry["lines_done"].as_u64().unwrap();
    assert!(
        (stored..LINES).contains(&kept),
        "{entry}: {stored} were checkpointed"
    );
    assert!(
        lines[0].contains(&format!(": {kept} of {LINES} lines")),
        "{said}"
    );

    let mut c = here();
    c.arg("submit");
    let out = resume(c, id, &job);
    assert!(out.status.success());
    let s = check(&job, 1, "ok");
    assert_eq!(s["lines"]["resumed"].as_u64().unwrap(), kept);
}

/// Workers that hang before saying Ready (a worker test hook) are timed out like silent ones:
/// the job does not wait for them forever; with none left it says so (exit 3).
#[test]
fn losing_the_controllers_remd_is_one_line_and_the_job_resumes_on_the_hosts_left() {
    let cluster = LoopbackCluster::start(3);
    let job = job();
    let id = "lost-remd-1";
    let mut run = SubmitRun::start(slow_submit(
        &cluster,
        &job,
        60,
        &["--in-process", "--job", id, "--checkpoint-ms", "100"],
    ));
    checkpointed(&mut run, 12);
    // The remd the controller talks to (and every process under it) dies.
    cluster.daemon("a").signal(libc::SIGKILL);
    assert!(!run.wait(Duration::from_secs(60)).success());
    let text = run.text();
    let errors: Vec<&str> = text.lines().filter(|l| l.contains("error")).collect();
    assert_eq!(errors.len(), 1, "one line, not a chain:\n{text}");
    assert!(
        errors[0].contains("lost remd at") && errors[0].contains(&format!("--resume {id}")),
        "{text}"
    );
    assert!(!text.contains("h2 protocol"), "{text}");
    cluster.wait_alive("b", 2);
    // Resumed through another remd, with no --hosts: it goes on with the two hosts left.
    let mut c = sunray();
    c.args([
        "submit",
        "--remd",
        &cluster.daemon("b").addr,
        "--secret-file",
    ])
    .arg(&cluster.secret_file);
    let out = resume(c, id, &job);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("resuming on 2 host(s)"), "{err}");
    assert!(
        std::fs::read(&job.out).unwrap() == job.want,
        "the image differs from sunray render"
    );
    let s = read_json(&job.json);
    assert!(s["lines"]["resumed"].as_u64().unwrap() >= 12, "{s}");
}

/// Rendering to an error through the farm, a (line, pass) at a time: a worker killed -9 once
/// it has rendered a later pass, then the controller killed once a checkpoint holds lines
/// between their passes; `--resume` goes on from each line's last pass and the image is
/// still byte-identical to `sunray render`, with the same error statistics.
#[test]
fn a_render_to_an_error_survives_a_worker_and_its_controller_killed_mid_pass() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let to_error = ["--target-error", "0.02", "--max-samples", "64"];
    let flags = [&FLAGS[..], &to_error[..]].concat();
    let (want, want_stats) = reference(dir.path(), &spd("mount6"), &flags);
    assert!(want_stats["error"]["rms"].as_f64().unwrap() > 0.0);
    let job = Job {
        out: dir.path().join("submit.png"),
        json: dir.path().join("submit.json"),
        _dir: dir,
        want,
    };
    let id = "resume-to-error-1";
    let mut run = SubmitRun::start(slow_submit(
        &cluster,
        &job,
        40,
        &[
            &to_error[..],
            // The checkpoint compacted at every save that finds a pass superseded.
            &["--in-process", "--job", id, "--checkpoint-ms", "100"],
            &["--compact-every-save"],
        ]
        .concat(),
    ));
    let later_pass = |node: u64| {
        move |seen: &[serde_json::Value]| {
            seen.iter()
                .position(|v| v["event"] == "line" && v["node"] == node && v["pass"] != 0)
        }
    };
    run.wait_until(Duration::from_secs(60), later_pass(2));
    signal(run.worker_pid(2), libc::SIGKILL);
    // The controller hears of the kill (a fault event) before it is killed itself, and
    // another worker renders a later pass after it.
    let fault = run.wait_until(Duration::from_secs(60), |seen| {
        seen.iter()
            .position(|v| v["event"] == "fault" && v["node"] == 2)
    });
    let after = run.wait_until(Duration::from_secs(60), |seen| {
        later_pass(1)(&seen[fault..]).map(|i| fault + i)
    });
    let stored = run.wait_until(Duration::from_secs(60), |seen| {
        seen[after..]
            .iter()
            .filter(|v| v["event"] == "checkpoint")
            .find_map(|v| v["lines"].as_u64())
    });
    run.child.kill().unwrap();
    run.child.wait().unwrap();
    assert!(stored < LINES, "the job was not stopped mid-way");
    assert!(!job.out.exists(), "no image from the killed run");
    // The checkpoint was compacted: segments emptied to their envelope beside live ones.
    let sizes = segment_sizes(cluster.dir.path(), id);
    assert!(
        sizes.iter().any(|&n| n < 512) && sizes.iter().any(|&n| n > 4096),
        "{sizes:?}"
    );
    assert!(run
        .seen
        .iter()
        .any(|v| v["event"] == "fault" && v["node"] == 2));

    let out = resume(cluster.submit(), id, &job);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read(&job.out).unwrap() == job.want,
        "resumed mid-pass: the image differs from sunray render"
    );
    let s = read_json(&job.json);
    assert!(s["lines"]["resumed"].as_u64().unwrap() >= stored);
    assert_eq!(s["totals"]["error"], want_stats["error"], "{s}");
}

/// The sizes of job `id`'s checkpoint segment files (`ID.sN.ckpt`) in every state directory
/// under `dir`.
fn segment_sizes(dir: &std::path::Path, id: &str) -> Vec<u64> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            out.extend(segment_sizes(&path, id));
        } else if name.starts_with(&format!("{id}.s")) && name.ends_with(".ckpt") {
            out.push(e.metadata().map_or(0, |m| m.len()));
        }
    }
    out
}
