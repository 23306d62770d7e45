//! The sampler's rows: bounded load histories, rates and ETAs, who sees which job.
use super::*;
use crate::wire::proto::Load;

fn host(name: &str, alive: bool, lpc: f64) -> HostInfo {
    HostInfo {
        name: name.into(),
        addr: format!("{name}:1"),
        alive,
        accepting: alive,
        last_heard_ms: if alive { 10 } else { u64::MAX },
        load: Some(Load {
            cores: 2,
            load_per_core: lpc,
            capacity: 2.0,
            ..Load::default()
        }),
    }
}

#[test]
fn host_history_is_bounded_and_forgets_hosts_gone() {
    let mut h = History::default();
    for i in 0..(2 * HISTORY + 7) {
        let rows = h.hosts(&[host("a", true, i as f64), host("b", false, 1.0)]);
        assert!(rows[0].history.len() <= HISTORY);
        assert_eq!(rows[1].last_heard_ms, None);
        assert_eq!(
            rows[1].history.last(),
            Some(&0.0),
            "a lost host shows no load"
        );
    }
    let rows = h.hosts(&[host("a", true, 1.0)]);
    assert_eq!(rows[0].history.len(), HISTORY);
    assert_eq!(h.loads.len(), 1);
}

fn record(id: &str, user: &str, state: &str, done: u64) -> JobRecord {
    JobRecord {
        id: id.into(),
        user: user.into(),
        state: state.into(),
        progress_done: done,
        progress_total: 100,
        created_unix_ms: 5,
        ..JobRecord::default()
    }
}

fn proc(job: &str, record: &str, state: &str) -> ProcessInfo {
    ProcessInfo {
        job: job.into(),
        job_record: record.into(),
        state: state.into(),
        ..ProcessInfo::default()
    }
}

#[test]
fn rates_etas_workers_and_who_sees_what() {
    let mut h = History::default();
    let t0 = Instant::now();
    let procs = [
        proc("j1.w1", "", "running"),
        proc("j1.w1", "", "running"),
        proc("j1.w1", "", "exited"),
        proc("j1", "j1", "running"),
        proc("j1.x.w1", "", "running"),
    ];
    let rows = h.jobs(
        vec![
            record("j1", "alice", "running", 10),
            record("j2", "bob", "finished", 100),
        ],
        &procs,
        &QueueReply::default(),
        t0,
    );
    assert_eq!(rows[0].id, "j1", "running first");
    assert_eq!(
        rows[0].workers_alive, 2,
        "the controller and exited ones are not workers"
    );
    assert_eq!(rows[0].lines_per_s, None);
    let rows = h.jobs(
        vec![
            record("j1", "alice", "running", 30),
            record("j2", "bob", "finished", 100),
        ],
        &procs,
        &QueueReply::default(),
        t0 + Duration::from_secs(2),
    );
    assert_eq!(rows[0].lines_per_s, Some(10.0));
    assert_eq!(rows[0].eta_s, Some(7.0));
    assert_eq!(rows[1].lines_per_s, None, "an ended job has no rate");
    let view = FarmView {
        jobs: Some(rows),
        ..FarmView::default()
    };
    let alice = view.jobs_for(&Identity::user("alice")).unwrap();
    assert_eq!(alice.len(), 1);
    assert_eq!(alice[0].user, "alice");
    let admin = Identity {
        user: "x".into(),
        admin: true,
    };
    assert_eq!(view.jobs_for(&admin).unwrap().len(), 2);
    assert!(view.jobs_for(&Identity::user("carol")).unwrap().is_empty());
}

#[test]
fn a_waiting_job_shows_its_place_in_the_farms_queue() {
    let lend = |name: &str| HostInfo {
        load: Some(Load {
            slots: 1,
            ..Load::default()
        }),
        ..host(name, true, 0.0)
    };
    let job = |id: &str, user: &str, created, priority| JobRecord {
        created_unix_ms: created,
        priority,
        slots_wanted: 1,
        ..record(id, user, "running", 0)
    };
    // One slot: the priority-90 job runs, the older priority-50 one waits first.
    let records = vec![job("old", "alice", 1, 50), job("urgent", "bob", 2, 90)];
    let queue = queue_of(records.clone(), &[lend("a")], None);
    let rows = History::default().jobs(records, &[], &queue, Instant::now());
    let row = |id: &str| rows.iter().find(|r| r.id == id).unwrap().clone();
    assert_eq!(
        (row("old").queue_position, row("old").priority),
        (Some(1), 50)
    );
    assert_eq!(
        (row("urgent").queue_position, row("urgent").priority),
        (None, 90)
    );
    let hosts = History::default().hosts(&[lend("a")]);
    assert_eq!((hosts[0].slots, hosts[0].slots_used), (1, 0));
}
