//! Following a farm job: Ctrl-C stops the following and not the job; losing the followed
//! remd is one line, and the job finishes in the farm; a job whose record holders are all
//! lost is reported failed.

use super::*;

#[test]
fn ctrl_c_stops_following_and_not_the_job() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let mut run = follow(&cluster, "ctrlc", 100, dir.path());
    signal(run.child.id() as i32, libc::SIGINT);
    let status = run.wait(Duration::from_secs(20));
    assert_eq!(status.code(), Some(130), "{}", run.text());
    let said = run.text();
    assert!(
        said.contains("stopped following job ctrlc")
            && said.contains("`sunray watch ctrlc`")
            && said.contains("`sunray cancel ctrlc`"),
        "{said}"
    );
    let r = check_finished(&cluster, "b", "ctrlc", dir.path());
    assert_eq!(r.epoch, 1, "the job was not disturbed: {r:?}");
}

#[test]
fn losing_the_followed_remd_is_one_line_and_the_job_finishes_in_the_farm() {
    let mut cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let mut run = follow(&cluster, "lostremd", 100, dir.path());
    // The remd `submit` talks to dies, and the controller with it.
    cluster.kill_daemon("a");
    let status = run.wait(Duration::from_secs(20));
    assert!(!status.success());
    let text = run.text();
    let errors: Vec<&str> = text.lines().filter(|l| l.contains("error")).collect();
    assert_eq!(errors.len(), 1, "one line, not a chain:\n{text}");
    assert!(
        errors[0].contains("lost remd at") && errors[0].contains("`sunray watch lostremd`"),
        "{text}"
    );
    assert!(!text.contains("h2 protocol"), "{text}");
    let r = check_finished(&cluster, "c", "lostremd", dir.path());
    assert!(r.epoch >= 2, "{r:?}");
}

#[test]
fn a_job_whose_record_holders_are_all_lost_is_reported_failed() {
    let mut cluster = LoopbackCluster::start(3);
    let job = submit(&cluster, "orphan", 150);
    wait_mid_job(&cluster, &job);
    // Every write of the record goes through daemon a (submit, controller, supervisor), so
    // it is kept on a and on the peer the job id hashes to.
    let holder = rem::store::replicas::order(&job, ["b", "c"])[0];
    let other = if holder == "b" { "c" } else { "b" };
    let mut watch = SubmitRun::start({
        let mut c = cluster.sunray_via(other);
        c.args(["watch", &job]);
        c
    });
    watch.wait_until(Duration::from_secs(20), |seen| {
        seen.iter().any(|v| v["event"] == "state").then_some(())
    });
    cluster.kill_daemon("a");
    cluster.kill_daemon(holder);
    let status = watch.wait(Duration::from_secs(20));
    assert_eq!(status.code(), Some(3), "{}", watch.text());
    let said = watch.text();
    assert!(
        said.contains("job orphan failed") && said.contains("no live host holds its record"),
        "{said}"
    );
}
