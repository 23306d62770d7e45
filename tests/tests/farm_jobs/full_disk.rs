//! The state directory of the controller's host is full (its checkpoints and job records on
//! a tmpfs with no byte left): REM keeps what the controller writes on two peers instead,
//! says so in its log, and the job finishes byte-identical; nothing half-written is left.

use super::*;
use sunray_e2e::small_fs::SmallFs;

#[test]
fn a_full_state_directory_on_the_controllers_host_moves_its_writes_to_two_peers() {
    let Some(fs) = SmallFs::mount_as_root("1m") else {
        return;
    };
    let cluster = LoopbackCluster::start_with(4, |name, state| {
        if name == "a" {
            std::fs::create_dir_all(state).unwrap();
            for store in ["checkpoints", "jobs"] {
                std::fs::create_dir_all(fs.path().join(store)).unwrap();
                std::os::unix::fs::symlink(fs.path().join(store), state.join(store)).unwrap();
            }
        }
    });
    fs.fill();
    let dir = tempfile::tempdir().unwrap();
    // The controller runs on a, where the job is submitted.
    let mut run = follow(&cluster, "fulldisk", 20, dir.path());
    let status = run.wait(Duration::from_secs(120));
    assert!(status.success(), "{}", run.text());
    let r = check_finished(&cluster, "c", "fulldisk", dir.path());
    assert_eq!(r.controller_host, "a", "{r:?}");
    let log = cluster.log("a");
    assert!(
        log.contains("two peers keep it instead"),
        "a said nothing of its full disk: {log}"
    );
    // Only the filler is there: no write cut short by the full disk is left behind.
    let mut left = Vec::new();
    for store in ["checkpoints", "jobs"] {
        for e in walk(&fs.path().join(store)) {
            left.push(e);
        }
    }
    assert!(left.is_empty(), "{left:?}");
    drop(cluster);
}

/// The files under `dir`, in every folder.
fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        if e.file_type().unwrap().is_dir() {
            out.extend(walk(&e.path()));
        } else {
            out.push(e.path());
        }
    }
    out
}
