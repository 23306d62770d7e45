//! Exhaustive search: test every primitive of a list.

use super::Hit;
use crate::geometry::{Primitives, RayPre, Real};
use crate::stats::Counters;

/// The closest hit among `list` in `(0, t_max)`, improving on `best`.
#[inline]
pub fn closest_in(
    prims: &Primitives,
    list: &[u32],
    r: &RayPre,
    t_max: Real,
    mut best: Option<Hit>,
    c: &mut Counters,
) -> Option<Hit> {
    c.intersection_tests += list.len() as u64;
    for &i in list {
        if let Some(t) = prims.intersect(i, r, 0.0, t_max) {
            if Hit::improves(t, i, &best) {
                best = Some(Hit { t, prim: i });
            }
        }
    }
    best
}

/// The first hit found among `list` in `(0, t_max)` that `accept` takes.
#[inline]
pub fn any_in(
    prims: &Primitives,
    list: &[u32],
    r: &RayPre,
    t_max: Real,
    accept: &dyn Fn(u32, Real) -> bool,
    c: &mut Counters,
) -> Option<Hit> {
    for &i in list {
        c.intersection_tests += 1;
        if let Some(t) = prims.intersect(i, r, 0.0, t_max) {
            if accept(i, t) {
                return Some(Hit { t, prim: i });
            }
        }
    }
    None
}
