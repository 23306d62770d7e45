//! Placement: which hosts get the processes of a spawn request.
//!
//! Hosts are ranked by load per core, ties broken by name. Without `allow_same_host` the
//! N lowest distinct hosts are taken; with it, each pick adds `1 / cores` to the chosen host's
//! figure (the process it will run) before the next pick. Fewer eligible hosts than N is an
//! error.

use crate::error::Error;

/// A host that could take work.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    pub name: String,
    pub load_per_core: f64,
    pub cores: u32,
}

/// The host for each of `count` processes, in order.
pub fn place(
    candidates: &[Candidate],
    count: u32,
    allow_same_host: bool,
) -> Result<Vec<String>, Error> {
    if count == 0 {
        return Err(Error::Invalid("count must be at least 1".into()));
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
        let best = ranked
            .iter_mut()
            .min_by(|a, b| key(a).total_cmp(&key(b)).then_with(|| a.name.cmp(&b.name)))
            .expect("ranked is not empty");
        chosen.push(best.name.clone());
        best.load_per_core += 1.0 / best.cores.max(1) as f64;
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
        }
    }

    #[test]
    fn least_loaded_first_ties_by_name() {
        let hosts = [c("c", 0.5, 2), c("b", 0.1, 2), c("a", 0.5, 2)];
        assert_eq!(place(&hosts, 1, false).unwrap(), ["b"]);
        assert_eq!(place(&hosts, 2, false).unwrap(), ["b", "a"]);
        assert_eq!(place(&hosts, 3, false).unwrap(), ["b", "a", "c"]);
    }

    #[test]
    fn too_few_hosts_is_an_error() {
        let hosts = [c("a", 0.0, 1), c("b", 0.0, 1)];
        let err = place(&hosts, 3, false).unwrap_err();
        assert!(matches!(
            err,
            Error::NotEnoughHosts {
                wanted: 3,
                eligible: 2,
                ..
            }
        ));
        assert!(place(&[], 1, true).is_err());
        assert!(place(&hosts, 0, true).is_err());
    }

    #[test]
    fn same_host_spreads_by_added_load() {
        // a has 4 cores, b has 1: four processes go a, a, b?, ...
        let hosts = [c("a", 0.0, 4), c("b", 0.1, 1)];
        let got = place(&hosts, 5, true).unwrap();
        // a: 0 -> .25 -> .5 (then b at .1 wins) ...
        assert_eq!(got, ["a", "b", "a", "a", "a"]);
        assert_eq!(got.len(), 5);
    }
}
