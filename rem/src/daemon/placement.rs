//! Placement: which hosts get the processes of a spawn request.
//!
//! Hosts are ranked by load per core, ties broken by name. Without `allow_same_host` the
//! N lowest distinct hosts are taken; with it, each pick adds `1 / capacity` to the chosen
//! host's figure (the process it will run, on the CPUs it may use) before the next pick. Fewer eligible hosts than N is an
//! error.
//!
//! A spawn that holds render slots ([`SlotAsk`]) goes only to hosts with at least its least
//! free, each pick taking what it will hold from the host's free slots; `up_to` places as
//! many as fit (at least one) rather than all or none.

use crate::error::Error;

/// A host that could take work.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    pub name: String,
    pub load_per_core: f64,
    pub cores: u32,
    /// CPUs the host may use (a cgroup's limit, fractional); 0 when unknown (then `cores`).
    pub capacity: f64,
    /// Render slots it lends and has free now.
    pub free_slots: u32,
    /// Render slots it lends.
    pub lent_slots: u32,
}

/// The render slots each process of a spawn holds: at least `min` (0: none, the spawn is not
/// counted), at most `max` (0: all that are free).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlotAsk {
    pub min: u32,
    pub max: u32,
    /// Place as many as fit, at least one, rather than all or none.
    pub up_to: bool,
}

/// As [`place`], for processes holding slots (`ask.min > 0`): only hosts with `ask.min` free
/// are taken, and each pick holds what it will take there (`ask.max`, or all that is free).
pub fn place_with_slots(
    candidates: &[Candidate],
    count: u32,
    allow_same_host: bool,
    ask: SlotAsk,
    max: u32,
) -> Result<Vec<String>, Error> {
    if ask.min == 0 {
        return place(candidates, count, allow_same_host, max);
    }
    if count == 0 || count > max {
        return Err(Error::Invalid(format!(
            "count {count} is outside 1..={max}"
        )));
    }
    let mut free: Vec<Candidate> = candidates
        .iter()
        .filter(|c| c.free_slots >= ask.min)
        .cloned()
        .collect();
    let mut chosen = Vec::new();
    while (chosen.len() as u32) < count {
        let picks = place(&free, 1, true, max).ok();
        let Some(host) = picks.and_then(|p| p.into_iter().next()) else {
            break;
        };
        chosen.push(host.clone());
        let Some(c) = free.iter_mut().find(|c| c.name == host) else {
            break;
        };
        let take = if ask.max == 0 {
            c.free_slots
        } else {
            ask.max.min(c.free_slots)
        };
        c.free_slots -= take;
        c.load_per_core += f64::from(take) / c.cpus();
        if !allow_same_host || c.free_slots < ask.min {
            free.retain(|c| c.name != host);
        }
    }
    let short = (chosen.len() as u32) < count;
    if chosen.is_empty() || (short && !ask.up_to) {
        let with = candidates
            .iter()
            .filter(|c| c.free_slots >= ask.min)
            .count();
        let slots = |n: u32| {
            if n == 1 {
                "1 slot".to_string()
            } else {
                format!("{n} slots")
            }
        };
        return Err(Error::Limit(format!(
            "{count} processes of at least {}: {} fit on the {} live hosts ({with} with {} \
             free); the rest of the farm's slots are held",
            slots(ask.min),
            chosen.len(),
            candidates.len(),
            slots(ask.min)
        )));
    }
    Ok(chosen)
}

impl Candidate {
    /// The CPUs one more process shares: the capacity, else the core count.
    fn cpus(&self) -> f64 {
        if self.capacity.is_finite() && self.capacity > 0.0 {
            self.capacity
        } else {
            f64::from(self.cores.max(1))
        }
    }
}

/// The host for each of `count` processes, in order; `count` is checked against `max` (the
/// daemon's spawn_count limit) before anything is allocated for it.
pub fn place(
    candidates: &[Candidate],
    count: u32,
    allow_same_host: bool,
    max: u32,
) -> Result<Vec<String>, Error> {
    if count == 0 || count > max {
        return Err(Error::Invalid(format!(
            "count {count} is outside 1..={max}"
        )));
    }
    let mut ranked: Vec<Candidate> = candidates.to_vec();
    let key = |c: &Candidate| {
        if c.load_per_core.is_finite() {
            c.load_per_core
        } else {
            f64::MAX
        }
    };
    ranked.sort_by(|a, b| key(a).total_cmp(&key(b)).then_with(|| a.name.cmp(&b.name)));
    if ranked.is_empty() || (!allow_same_host && ranked.len() < count as usize) {
        return Err(Error::NotEnoughHosts {
            wanted: count,
            eligible: ranked.len() as u32,
            detail: if allow_same_host {
                "no live host accepts work".into()
            } else {
                "at most one per host; allow_same_host to place more".into()
            },
        });
    }
    if !allow_same_host {
        return Ok(ranked
            .into_iter()
            .take(count as usize)
            .map(|c| c.name)
            .collect());
    }
    let mut chosen = Vec::with_capacity(count as usize);
    for _ in 0..count {
        let Some(best) = ranked
            .iter_mut()
            .min_by(|a, b| key(a).total_cmp(&key(b)).then_with(|| a.name.cmp(&b.name)))
        else {
            break; // no candidate at all (refused above)
        };
        chosen.push(best.name.clone());
        best.load_per_core += 1.0 / best.cpus();
    }
    Ok(chosen)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(name: &str, lpc: f64, cores: u32) -> Candidate {
        Candidate {
            name: name.into(),
            load_per_core: lpc,
            cores,
            capacity: 0.0,
            free_slots: cores,
            lent_slots: cores,
        }
    }

    #[test]
    fn processes_with_slots_go_where_slots_are_free() {
        let mut a = c("a", 0.0, 4);
        a.free_slots = 1;
        let mut b = c("b", 0.5, 4);
        b.free_slots = 4;
        let full = Candidate {
            free_slots: 0,
            ..c("f", 0.0, 4)
        };
        let hosts = [a, b, full];
        let ask = |min, max, up_to| SlotAsk { min, max, up_to };
        // One per host: a (least loaded, 1 free) and b; f has none.
        assert_eq!(
            place_with_slots(&hosts, 2, false, ask(1, 2, false), 256).unwrap(),
            ["a", "b"]
        );
        let err = place_with_slots(&hosts, 3, false, ask(1, 2, false), 256).unwrap_err();
        assert!(matches!(err, Error::Limit(_)), "{err}");
        assert_eq!(
            place_with_slots(&hosts, 3, false, ask(1, 2, true), 256).unwrap(),
            ["a", "b"]
        );
        // Needing 2 each, only b fits; with same host, b twice (2 + 2 of its 4).
        assert_eq!(
            place_with_slots(&hosts, 3, true, ask(2, 2, true), 256).unwrap(),
            ["b", "b"]
        );
        // Taking all that is free, b fits once.
        assert_eq!(
            place_with_slots(&hosts, 3, true, ask(2, 0, true), 256).unwrap(),
            ["b"]
        );
        assert!(place_with_slots(&hosts, 1, false, ask(5, 0, true), 256).is_err());
        // Not counted: as before.
        assert_eq!(
            place_with_slots(&hosts, 3, false, ask(0, 0, false), 256)
                .unwrap()
                .len(),
            3
        );
    }

    #[test]
    fn least_loaded_first_ties_by_name() {
        let hosts = [c("c", 0.5, 2), c("b", 0.1, 2), c("a", 0.5, 2)];
        assert_eq!(place(&hosts, 1, false, 256).unwrap(), ["b"]);
        assert_eq!(place(&hosts, 2, false, 256).unwrap(), ["b", "a"]);
        assert_eq!(place(&hosts, 3, false, 256).unwrap(), ["b", "a", "c"]);
    }

    #[test]
    fn too_few_hosts_is_an_error() {
        let hosts = [c("a", 0.0, 1), c("b", 0.0, 1)];
        let err = place(&hosts, 3, false, 256).unwrap_err();
        assert!(matches!(
            err,
            Error::NotEnoughHosts {
                wanted: 3,
                eligible: 2,
                ..
            }
        ));
        assert!(place(&[], 1, true, 256).is_err());
        assert!(place(&hosts, 0, true, 256).is_err());
        // A count over the limit is refused before anything is reserved for it (u32::MAX
        // placements would ask for about 100 GB).
        let err = place(&hosts, u32::MAX, true, 256).unwrap_err();
        assert!(err.to_string().contains("outside 1..=256"), "{err}");
        assert_eq!(place(&hosts, 256, true, 256).unwrap().len(), 256);
    }

    #[test]
    fn same_host_spreads_by_added_load() {
        // a has 4 cores, b has 1: four processes go a, a, b?, ...
        let hosts = [c("a", 0.0, 4), c("b", 0.1, 1)];
        let got = place(&hosts, 5, true, 256).unwrap();
        // a: 0 -> .25 -> .5 (then b at .1 wins) ...
        assert_eq!(got, ["a", "b", "a", "a", "a"]);
        assert_eq!(got.len(), 5);
    }

    #[test]
    fn same_host_weighs_a_process_by_the_cpus_a_container_may_use() {
        // Both have 8 cores, but a's cgroup may use 0.5 of a CPU: one process there adds 2.
        let mut a = c("a", 0.0, 8);
        a.capacity = 0.5;
        let mut b = c("b", 0.3, 8);
        b.capacity = 4.0;
        let got = place(&[a, b], 4, true, 256).unwrap();
        // a: 0 -> 2; b: .3 -> .55 -> .8 -> 1.05
        assert_eq!(got, ["a", "b", "b", "b"]);
    }
}
