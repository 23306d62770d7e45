//! The farm's queue rule: how many render slots each active job may hold, and where the jobs
//! that may hold none wait. It is a pure function of the jobs' replicated records (user,
//! priority, creation, slots wanted) and of the slots the live hosts lend, so every daemon
//! that answers `Queue` computes the same shares, and the loss of any host loses no decider:
//! there is none to lose (DESIGN section 12).
//!
//! The rule, level by level from the highest priority down, with the slots the levels above
//! left:
//! 1. **Admission.** The level's jobs, oldest first, each get their first `min` slots while
//!    they fit (and their user stays under the cap); a job that does not fit waits, with its
//!    place in the queue. So a running job keeps at least one worker against jobs of its own
//!    priority, and only a higher priority can take its last slot.
//! 2. **Fair shares.** What is left goes one slot at a time to the user holding the fewest
//!    slots at this level (ties: the user of the oldest job, then the name), and within that
//!    user to their job holding the fewest (ties: the oldest), until every job has what it
//!    wants, or no slot is left.

use std::collections::BTreeMap;

/// What an active job asks of the farm.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Demand {
    /// The job record's id.
    pub id: String,
    /// Whose job it is.
    pub user: String,
    /// 0..=100, higher first.
    pub priority: u32,
    /// When it was submitted (the older first among equal priorities).
    pub created_unix_ms: u64,
    /// The most slots it could use (0 counts as 1).
    pub wanted: u32,
    /// The fewest it can run with (one worker's; 0 counts as 1, at most `wanted`).
    pub min: u32,
}

impl Demand {
    fn wanted(&self) -> u32 {
        self.wanted.max(1)
    }

    fn min(&self) -> u32 {
        self.min.clamp(1, self.wanted())
    }
}

/// A job's place under the rule.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Share {
    /// Slots it may hold.
    pub slots: u32,
    /// 0 when admitted; else its place among the waiting jobs, from 1.
    pub queue_position: u32,
}

/// The share of each of `jobs` (in their order) in a farm lending `capacity` slots, no user
/// holding more than `user_cap` (`None`: no cap).
pub fn shares(capacity: u32, user_cap: Option<u32>, jobs: &[Demand]) -> Vec<Share> {
    let mut out = vec![Share::default(); jobs.len()];
    let mut order: Vec<usize> = (0..jobs.len()).collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (&jobs[a], &jobs[b]);
        y.priority
            .cmp(&x.priority)
            .then(x.created_unix_ms.cmp(&y.created_unix_ms))
            .then(x.id.cmp(&y.id))
    });
    let cap = user_cap.unwrap_or(u32::MAX);
    let mut free = capacity;
    let mut per_user: BTreeMap<&str, u32> = BTreeMap::new();
    let mut waiting = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let level = jobs[order[start]].priority;
        let end = order[start..]
            .iter()
            .position(|&j| jobs[j].priority != level)
            .map_or(order.len(), |n| start + n);
        let mut admitted = Vec::new();
        for &j in &order[start..end] {
            let (need, user) = (jobs[j].min(), jobs[j].user.as_str());
            let held = per_user.get(user).copied().unwrap_or(0);
            if need <= free && held.saturating_add(need) <= cap {
                out[j].slots = need;
                free -= need;
                *per_user.entry(user).or_default() += need;
                admitted.push(j);
            } else {
                waiting.push(j);
            }
        }
        free = fill(jobs, &admitted, free, cap, &mut per_user, &mut out);
        start = end;
    }
    for (place, &j) in waiting.iter().enumerate() {
        out[j].queue_position = place as u32 + 1;
    }
    out
}

/// Hands `free` slots to the `admitted` jobs of one level, fairly between users and then
/// between each user's jobs; returns the slots left.
fn fill<'a>(
    jobs: &'a [Demand],
    admitted: &[usize],
    mut free: u32,
    cap: u32,
    per_user: &mut BTreeMap<&'a str, u32>,
    out: &mut [Share],
) -> u32 {
    // Slots each user holds at this level, and the age of their oldest job here.
    let mut level: BTreeMap<&str, (u32, usize)> = BTreeMap::new();
    for (rank, &j) in admitted.iter().enumerate() {
        let e = level.entry(jobs[j].user.as_str()).or_insert((0, rank));
        e.0 += out[j].slots;
    }
    while free > 0 {
        let wants = |j: usize| out[j].slots < jobs[j].wanted();
        let user = level
            .iter()
            .filter(|(u, _)| per_user.get(*u).copied().unwrap_or(0) < cap)
            .filter(|(u, _)| admitted.iter().any(|&j| jobs[j].user == **u && wants(j)))
            .min_by_key(|(u, (held, oldest))| (*held, *oldest, **u))
            .map(|(u, _)| *u);
        let Some(user) = user else { break };
        let Some(&job) = admitted
            .iter()
            .filter(|&&j| jobs[j].user == user && wants(j))
            .min_by_key(|&&j| out[j].slots)
        else {
            break;
        };
        out[job].slots += 1;
        free -= 1;
        *per_user.entry(user).or_default() += 1;
        if let Some(e) = level.get_mut(user) {
            e.0 += 1;
        }
    }
    free
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(id: &str, user: &str, priority: u32, created: u64, wanted: u32) -> Demand {
        Demand {
            id: id.into(),
            user: user.into(),
            priority,
            created_unix_ms: created,
            wanted,
            min: 1,
        }
    }

    fn slots(capacity: u32, cap: Option<u32>, jobs: &[Demand]) -> Vec<(u32, u32)> {
        shares(capacity, cap, jobs)
            .into_iter()
            .map(|s| (s.slots, s.queue_position))
            .collect()
    }

    #[test]
    fn a_job_alone_takes_what_it_wants_up_to_the_farm() {
        assert_eq!(slots(6, None, &[job("a", "alice", 50, 1, 4)]), [(4, 0)]);
        assert_eq!(slots(6, None, &[job("a", "alice", 50, 1, 60)]), [(6, 0)]);
        assert_eq!(slots(0, None, &[job("a", "alice", 50, 1, 6)]), [(0, 1)]);
    }

    #[test]
    fn users_of_equal_priority_share_equally_and_a_users_jobs_share_theirs() {
        let a = job("a", "alice", 50, 1, 6);
        let b = job("b", "bob", 50, 2, 6);
        assert_eq!(slots(6, None, &[a.clone(), b.clone()]), [(3, 0), (3, 0)]);
        // Alice's second job halves her share, not Bob's.
        let a2 = job("a2", "alice", 50, 3, 6);
        assert_eq!(
            slots(8, None, &[a.clone(), b.clone(), a2]),
            [(2, 0), (4, 0), (2, 0)]
        );
        // An odd slot goes to the user of the oldest job.
        assert_eq!(slots(7, None, &[b.clone(), a.clone()]), [(3, 0), (4, 0)]);
        // What one user cannot use goes to the other.
        let small = job("s", "bob", 50, 2, 1);
        assert_eq!(slots(6, None, &[a, small]), [(5, 0), (1, 0)]);
    }

    #[test]
    fn a_higher_priority_is_served_first_and_others_keep_one_worker_if_they_can() {
        let a = job("a", "alice", 50, 1, 4);
        let b = job("b", "bob", 50, 2, 4);
        let p = job("p", "carol", 90, 3, 2);
        assert_eq!(
            slots(4, None, &[a.clone(), b.clone(), p.clone()]),
            [(1, 0), (1, 0), (2, 0)]
        );
        // When the higher priority needs more, the youngest lower job waits.
        let big = job("p", "carol", 90, 3, 3);
        assert_eq!(
            slots(4, None, &[a.clone(), b.clone(), big]),
            [(1, 0), (0, 1), (3, 0)]
        );
        // With every slot held at its minimum, a new job of equal priority waits first in line.
        let d = job("d", "dave", 50, 4, 4);
        assert_eq!(
            slots(4, None, &[a.clone(), b.clone(), p.clone(), d.clone()]),
            [(1, 0), (1, 0), (2, 0), (0, 1)]
        );
        // And starts when one frees (p ends).
        assert_eq!(slots(4, None, &[a, b, d]), [(2, 0), (1, 0), (1, 0)]);
    }

    #[test]
    fn a_user_cap_bounds_a_users_slots_and_others_are_not_blocked() {
        let a = job("a", "alice", 50, 1, 6);
        let a2 = job("a2", "alice", 50, 2, 6);
        let b = job("b", "bob", 50, 3, 6);
        assert_eq!(
            slots(8, Some(2), &[a.clone(), a2.clone(), b.clone()]),
            [(1, 0), (1, 0), (2, 0)]
        );
        // The cap is every user's: bob too holds at most 1, and the rest stays free.
        assert_eq!(slots(8, Some(1), &[a, a2, b]), [(1, 0), (0, 1), (1, 0)]);
    }

    #[test]
    fn the_rule_depends_on_the_jobs_not_on_their_order_in_the_list() {
        let jobs = [
            job("a", "alice", 50, 1, 5),
            job("b", "bob", 70, 2, 3),
            job("c", "carol", 50, 3, 2),
            job("d", "alice", 50, 4, 9),
        ];
        let forward = shares(7, None, &jobs);
        let mut reversed = jobs.to_vec();
        reversed.reverse();
        let mut back = shares(7, None, &reversed);
        back.reverse();
        assert_eq!(forward, back);
        assert_eq!(forward.iter().map(|s| s.slots).sum::<u32>(), 7);
    }
}
