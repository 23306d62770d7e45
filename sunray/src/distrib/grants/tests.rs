//! Unit tests of the grant table.

use super::*;

fn t(ms: u64) -> Instant {
    thread_local!(static T0: Instant = Instant::now());
    T0.with(|t0| *t0 + Duration::from_millis(ms))
}

fn lines(a: &[Assignment]) -> Vec<u32> {
    a.iter().map(|a| a.line).collect()
}

#[test]
fn assigns_round_robin_within_the_window() {
    let mut g = GrantTable::new(Strategy::Dynamic, 6, 2, &[]);
    g.set_window(0, 2);
    g.set_window(1, 1);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), vec![0, 1, 2]);
    assert_eq!(a.iter().map(|a| a.node).collect::<Vec<_>>(), vec![0, 1, 0]);
    assert_eq!(
        a.iter().map(|a| a.grant).collect::<Vec<_>>(),
        vec![1, 2, 3],
        "grant numbers are fresh"
    );
    assert!(g.assign(t(0)).is_empty(), "no credit left");
    assert_eq!((g.outstanding(0), g.outstanding(1)), (2, 1));
}

#[test]
fn the_window_is_absolute() {
    let mut g = GrantTable::new(Strategy::Dynamic, 8, 1, &[]);
    g.set_window(0, 3);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), vec![0, 1, 2]);
    g.set_window(0, 3);
    assert!(g.assign(t(0)).is_empty(), "asking again adds nothing");
    g.complete(0, a[0].grant, 0, 0);
    assert_eq!(lines(&g.assign(t(0))), vec![3], "a completion makes room");
    g.set_window(0, 1);
    g.complete(0, a[1].grant, 1, 0);
    assert!(
        g.assign(t(0)).is_empty(),
        "a smaller window: nothing until the node holds fewer lines"
    );
    g.complete(0, a[2].grant, 2, 0);
    assert!(g.assign(t(0)).is_empty(), "still holds line 3");
    g.set_window(0, 4);
    assert_eq!(lines(&g.assign(t(0))), vec![4, 5, 6], "grown: 4 held");
}

#[test]
fn a_node_holds_a_line_another_finished_until_it_reports_it() {
    let mut g = GrantTable::new(Strategy::Dynamic, 4, 2, &[]);
    g.set_window(0, 1);
    g.set_window(1, 3);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), vec![0, 1, 2, 3]);
    g.complete(1, a[1].grant, 1, 0);
    let d = g.duplicate_stragglers(t(1000), Duration::from_millis(500));
    assert_eq!(lines(&d), vec![0]);
    assert_eq!(g.complete(1, d[0].grant, 0, 0), Completion::Accepted);
    assert_eq!(g.outstanding(0), 0, "no live grant left on node 0");
    g.node_gone(1);
    assert!(
        g.assign(t(1000)).is_empty(),
        "lines 2 and 3 are back, but node 0 is still rendering line 0"
    );
    assert_eq!(g.complete(0, a[0].grant, 0, 0), Completion::Duplicate);
    assert_eq!(g.assign(t(1000)).len(), 1, "reported: room for one");
}

#[test]
fn released_lines_go_back_first_in_order() {
    let mut g = GrantTable::new(Strategy::Dynamic, 8, 2, &[]);
    g.set_window(0, 5);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), vec![0, 1, 2, 3, 4]);
    g.set_window(0, 2);
    let grants: Vec<GrantId> = a[2..].iter().map(|x| x.grant).collect();
    g.release(0, &grants);
    g.release(1, &[a[0].grant]);
    g.release(0, &[99]);
    assert_eq!(
        g.counts().released,
        3,
        "unknown and foreign grants are skipped"
    );
    assert_eq!(g.outstanding(0), 2);
    assert!(g.assign(t(1)).is_empty(), "node 0 holds its window");
    g.set_window(1, 4);
    assert_eq!(lines(&g.assign(t(1))), vec![2, 3, 4, 5]);
    assert_eq!(
        g.complete(0, a[2].grant, 2, 0),
        Completion::Accepted,
        "a late completion of a released line is still good pixels"
    );
}

#[test]
fn completes_every_line_once() {
    let mut g = GrantTable::new(Strategy::Dynamic, 3, 1, &[]);
    g.set_window(0, 1);
    let mut seen = Vec::new();
    while !g.is_finished() {
        let a = g.assign(t(0));
        assert_eq!(a.len(), 1);
        assert_eq!(
            g.complete(0, a[0].grant, a[0].line, 0),
            Completion::Accepted
        );
        seen.push(a[0].line);
    }
    assert_eq!(seen, vec![0, 1, 2]);
    assert_eq!(g.done(), 3);
}

#[test]
fn first_completion_wins() {
    let mut g = GrantTable::new(Strategy::Dynamic, 1, 2, &[]);
    g.set_window(0, 1);
    let a = g.assign(t(0))[0];
    g.set_window(1, 1);
    let d = g.duplicate_stragglers(t(1000), Duration::from_millis(500));
    assert_eq!(d.len(), 1);
    assert!(d[0].duplicate && d[0].line == a.line && d[0].node == 1);
    assert_eq!(g.complete(1, d[0].grant, 0, 0), Completion::Accepted);
    assert_eq!(g.complete(0, a.grant, 0, 0), Completion::Duplicate);
    assert_eq!(g.complete(0, a.grant, 0, 0), Completion::Duplicate);
    assert_eq!(g.done(), 1);
    assert_eq!(g.counts().dropped, 2);
    assert_eq!(
        g.outstanding(0),
        0,
        "the slow copy is no longer outstanding"
    );
}

#[test]
fn unknown_grants_are_ignored() {
    let mut g = GrantTable::new(Strategy::Dynamic, 2, 2, &[]);
    g.set_window(0, 1);
    let a = g.assign(t(0))[0];
    assert_eq!(g.complete(0, 0, 0, 0), Completion::Unknown);
    assert_eq!(g.complete(0, 99, 0, 0), Completion::Unknown);
    assert_eq!(
        g.complete(0, a.grant, 1, 0),
        Completion::Unknown,
        "wrong line"
    );
    assert_eq!(
        g.complete(1, a.grant, 0, 0),
        Completion::Unknown,
        "wrong node"
    );
    assert_eq!(g.done(), 0);
}

#[test]
fn a_gone_node_gives_its_lines_back_first() {
    let mut g = GrantTable::new(Strategy::Dynamic, 6, 2, &[]);
    g.set_window(0, 2);
    g.set_window(1, 2);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), vec![0, 1, 2, 3]);
    assert_eq!(g.node_gone(1), 2);
    assert_eq!(g.node_gone(1), 0, "only once");
    assert_eq!(g.counts().requeued, 2);
    assert_eq!(g.live_nodes(), 1);
    g.set_window(1, 5);
    assert!(
        g.assign(t(0)).is_empty(),
        "a gone node gets nothing and node 0 has no credit"
    );
    g.complete(0, a[0].grant, 0, 0);
    g.set_window(0, 4);
    let b = g.assign(t(1));
    assert_eq!(lines(&b), vec![3, 1, 4], "lost lines come first");
    // A late completion from the gone node is still good pixels.
    assert_eq!(g.complete(1, a[1].grant, 1, 0), Completion::Accepted);
    assert_eq!(g.complete(0, b[1].grant, 1, 0), Completion::Duplicate);
}

#[test]
fn silent_nodes_time_out_and_come_back() {
    let mut g = GrantTable::new(Strategy::Dynamic, 4, 2, &[]);
    g.set_window(0, 1);
    g.set_window(1, 1);
    let a = g.assign(t(0));
    g.complete(0, a[0].grant, 0, 0);
    g.set_window(0, 1);
    let b = g.assign(t(900));
    assert_eq!(lines(&b), vec![2]);
    let timeout = Duration::from_millis(1000);
    assert!(g.expire(t(1000), timeout).is_empty());
    assert_eq!(g.expire(t(1001), timeout), vec![(1, 1)]);
    assert_eq!(g.node_state(1), Some(NodeState::Silent));
    assert_eq!(g.active_nodes(), 1);
    assert_eq!(g.live_nodes(), 2);
    g.set_window(1, 1);
    assert_eq!(g.node_state(1), Some(NodeState::Active), "heard from again");
    let c = g.assign(t(1002));
    assert_eq!(lines(&c), vec![1], "the timed-out line is handed out again");
    // The silent node's own late completion of line 1 is still accepted first.
    assert_eq!(g.complete(1, a[1].grant, 1, 0), Completion::Accepted);
    assert_eq!(g.complete(1, c[0].grant, 1, 0), Completion::Duplicate);
}

#[test]
fn a_line_finished_by_a_revoked_grant_is_not_handed_out_again() {
    let mut g = GrantTable::new(Strategy::Dynamic, 2, 1, &[]);
    g.set_window(0, 1);
    let a = g.assign(t(0))[0];
    assert_eq!(g.expire(t(10), Duration::from_millis(5)), vec![(0, 1)]);
    assert_eq!(g.complete(0, a.grant, 0, 0), Completion::Accepted);
    g.set_window(0, 2);
    assert_eq!(lines(&g.assign(t(11))), vec![1]);
}

#[test]
fn stragglers_are_duplicated_oldest_first_and_only_once() {
    let mut g = GrantTable::new(Strategy::Dynamic, 4, 3, &[]);
    g.set_window(0, 2);
    let a = g.assign(t(0));
    g.set_window(1, 2);
    let b = g.assign(t(100));
    assert_eq!((lines(&a), lines(&b)), (vec![0, 1], vec![2, 3]));
    g.set_window(2, 3);
    let min_age = Duration::from_millis(50);
    assert!(
        g.duplicate_stragglers(t(10), min_age).is_empty(),
        "too young"
    );
    let d = g.duplicate_stragglers(t(200), min_age);
    assert_eq!(lines(&d), vec![0, 1, 2], "oldest first, limited by credit");
    assert!(d.iter().all(|x| x.node == 2 && x.duplicate));
    g.set_window(1, 5);
    let e = g.duplicate_stragglers(t(300), min_age);
    assert_eq!(lines(&e), Vec::<u32>::new(), "line 3 is node 1's own");
    g.set_window(0, 3);
    let f = g.duplicate_stragglers(t(300), min_age);
    assert_eq!(lines(&f), vec![3]);
    assert!(g.duplicate_stragglers(t(400), min_age).is_empty());
    assert_eq!(g.counts().duplicated, 4);
}

#[test]
fn no_duplicates_while_lines_are_queued() {
    let mut g = GrantTable::new(Strategy::Dynamic, 3, 2, &[]);
    g.set_window(0, 1);
    g.assign(t(0));
    g.set_window(1, 1);
    // Node 1 has credit but line 1 is still queued for it: assign, not duplicate.
    assert!(g.duplicate_stragglers(t(1000), Duration::ZERO).is_empty());
}

#[test]
fn static_strategies_keep_their_order_and_survive_a_lost_node() {
    let mut g = GrantTable::new(Strategy::Blocks, 6, 2, &[]);
    g.set_window(0, 1);
    g.set_window(1, 1);
    assert_eq!(lines(&g.assign(t(0))), vec![0, 3]);
    g.node_gone(1);
    g.set_window(0, 10);
    assert_eq!(lines(&g.assign(t(1))), vec![1, 2, 3, 4, 5]);

    let mut g = GrantTable::new(Strategy::Interleaved, 6, 3, &[]);
    for n in 0..3 {
        g.set_window(n, 2);
    }
    assert_eq!(lines(&g.assign(t(0))), vec![0, 1, 2, 3, 4, 5]);
}

#[test]
fn static_nodes_do_not_take_queued_lines_of_a_slow_node() {
    let mut g = GrantTable::new(Strategy::Blocks, 4, 2, &[]);
    g.set_window(0, 2);
    g.set_window(1, 1);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), vec![0, 2, 1]);
    g.complete(0, a[0].grant, 0, 0);
    g.complete(0, a[2].grant, 1, 0);
    g.set_window(0, 2);
    // Node 1 still owns line 3 (queued): node 0 only duplicates what is outstanding.
    assert!(g.assign(t(1)).is_empty());
    let d = g.duplicate_stragglers(t(1000), Duration::ZERO);
    assert_eq!(lines(&d), vec![2]);
}

#[test]
fn resume_skips_finished_lines() {
    let finished = [true, false, true, false];
    let mut g = GrantTable::new(Strategy::Dynamic, 4, 1, &finished);
    assert_eq!(g.done(), 2);
    g.set_window(0, 4);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), vec![1, 3]);
    for x in &a {
        assert_eq!(g.complete(0, x.grant, x.line, 0), Completion::Accepted);
    }
    assert!(g.is_finished());
    let all = GrantTable::new(Strategy::Interleaved, 2, 2, &[true, true]);
    assert!(all.is_finished());
}

#[test]
fn lines_granted_by_a_previous_controller_are_kept_once() {
    let mut g = GrantTable::new(Strategy::Dynamic, 4, 2, &[]);
    // Node 1, taken over, reports line 2 (never granted here) before asking for work.
    assert_eq!(g.complete_inherited(1, 2, 0), Completion::Accepted);
    assert_eq!(g.done(), 1);
    g.set_window(0, 4);
    assert_eq!(
        lines(&g.assign(t(0))),
        vec![0, 1, 3],
        "line 2 is not handed out"
    );
    // Line 0 is out on node 0; the inherited copy wins and node 0's is dropped.
    assert_eq!(g.complete_inherited(1, 0, 0), Completion::Accepted);
    assert_eq!(g.complete(0, 1, 0, 0), Completion::Duplicate);
    assert_eq!(g.complete_inherited(1, 0, 0), Completion::Duplicate);
    assert_eq!(
        g.complete_inherited(1, 9, 0),
        Completion::Unknown,
        "beyond the image"
    );
    assert_eq!(
        g.complete_inherited(5, 1, 0),
        Completion::Unknown,
        "no such node"
    );
    assert_eq!(g.done(), 2);
}

/// A next pass queued first goes ahead of the lines still on their first pass, a node's
/// own set under a static strategy included.
#[test]
fn a_next_pass_queued_first_goes_ahead() {
    for strategy in [Strategy::Dynamic, Strategy::Blocks] {
        let mut g = GrantTable::new(strategy, 4, 1, &[]);
        g.set_window(0, 1);
        let a = g.assign(t(0));
        assert_eq!(lines(&a), [0]);
        assert_eq!(g.complete(0, a[0].grant, 0, 0), Completion::Accepted);
        g.another_pass(0, true);
        let b = g.assign(t(1));
        let ahead = format!("{strategy}: ahead of lines 1 to 3");
        assert_eq!((lines(&b), b[0].pass), (vec![0], 1), "{ahead}");
        assert_eq!(g.complete(0, b[0].grant, 0, 1), Completion::Accepted);
        g.another_pass(0, false);
        let c = g.assign(t(2));
        assert_eq!(
            (lines(&c), c[0].pass),
            (vec![1], 0),
            "{strategy}: behind them"
        );
    }
}

#[test]
fn a_line_in_passes_goes_to_the_back_and_only_its_current_pass_counts() {
    let mut g = GrantTable::new(Strategy::Blocks, 3, 2, &[]);
    g.set_window(0, 1);
    g.set_window(1, 1);
    let a = g.assign(t(0));
    assert_eq!((lines(&a), a[0].pass), (vec![0, 2], 0));
    assert_eq!(g.complete(0, a[0].grant, 0, 0), Completion::Accepted);
    g.another_pass(0, false);
    assert_eq!((g.done(), g.pass(0)), (0, 1));
    let b = g.assign(t(1));
    assert_eq!((lines(&b), b[0].pass), (vec![1], 0), "its own lines first");
    assert_eq!(g.complete(0, b[0].grant, 1, 0), Completion::Accepted);
    let c = g.assign(t(2));
    assert_eq!((lines(&c), c[0].pass), (vec![0], 1), "then the next pass");
    // The node that had pass 0 of line 0 times out, yet its copy comes in late: the line
    // is on pass 1 now (and only a pass still awaited would be accepted).
    assert!(g.awaits(0, 1) && !g.awaits(0, 0) && !g.awaits(0, 2) && !g.awaits(9, 0));
    assert_eq!(
        g.complete_inherited(1, 0, 0),
        Completion::Duplicate,
        "an earlier pass"
    );
    assert_eq!(
        g.complete(0, c[0].grant, 0, 0),
        Completion::Unknown,
        "not the grant's pass"
    );
    g.set_window(1, 2);
    let dup = g.duplicate_stragglers(t(10), Duration::ZERO);
    assert!(dup.iter().any(|d| d.line == 0 && d.pass == 1), "{dup:?}");
    assert_eq!(g.complete(0, c[0].grant, 0, 1), Completion::Accepted);
    assert!(!g.awaits(0, 1), "its copy would be a duplicate");
    assert_eq!(g.complete(1, a[1].grant, 2, 0), Completion::Accepted);
    assert!(g.is_finished());
    let (dropped, resumed) = (g.counts().dropped, {
        let mut r = GrantTable::new(Strategy::Dynamic, 2, 1, &[true, false]);
        r.resume_at(1, 3);
        r.set_window(0, 2);
        r.assign(t(0))
            .iter()
            .map(|a| (a.line, a.pass))
            .collect::<Vec<_>>()
    });
    assert_eq!(dropped, 1);
    assert_eq!(
        resumed,
        vec![(1, 3)],
        "a resumed line goes on from its pass"
    );
}

#[test]
fn a_node_that_joins_takes_lines_and_a_retired_one_gives_its_back() {
    for strategy in [Strategy::Dynamic, Strategy::Interleaved] {
        let mut g = GrantTable::new(strategy, 6, 1, &[]);
        g.set_window(0, 2);
        let first = g.assign(t(0));
        assert_eq!(first.len(), 2);
        // Node 0 retires: its two lines go back; node 1, new, renders the whole image.
        assert_eq!(g.node_gone(0), 2);
        let n = g.add_node();
        assert_eq!(n, 1);
        g.set_window(n, 6);
        let mut got = lines(&g.assign(t(1)));
        got.sort_unstable();
        assert_eq!(got, [0, 1, 2, 3, 4, 5], "{strategy:?}");
        assert_eq!(g.live_nodes(), 1);
    }
}

#[test]
fn a_closed_node_gets_no_more_lines_but_its_own_still_count() {
    let mut g = GrantTable::new(Strategy::Dynamic, 4, 2, &[]);
    g.set_window(0, 2);
    let a = g.assign(t(0));
    assert_eq!(lines(&a), [0, 1]);
    g.close(0);
    g.set_window(0, 3);
    assert!(g.assign(t(1)).is_empty(), "a retiring node asks in vain");
    // What it finishes is taken; what it hands back goes to the others.
    assert_eq!(g.complete(0, a[0].grant, 0, 0), Completion::Accepted);
    g.release(0, &[a[1].grant]);
    g.set_window(1, 4);
    assert_eq!(lines(&g.assign(t(2))), [1, 2, 3]);
}
