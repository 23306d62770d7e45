//! What a job starts from, resumed from its checkpoint or not: its grant table (the finished
//! lines left out; with a target error, the lines to go on with from their next pass), its
//! lines' estimates between passes ([`LinePasses`]) and the counters of what was rendered.

use super::ControllerConfig;
use crate::distrib::checkpoint::Restored;
use crate::distrib::grants::GrantTable;
use crate::distrib::line_passes::LinePasses;
use crate::stats::Counters;

/// What a job starts from: its grant table, its lines between passes, the counters of the
/// lines of its checkpoint and how many of them are finished.
pub(super) struct Resumed {
    pub(super) table: GrantTable,
    pub(super) passes: Option<LinePasses>,
    pub(super) counters: Counters,
    pub(super) resumed: u32,
}

/// The job of `cfg` for `nodes` workers, going on from `restored` if there is one.
pub(super) fn resumed(
    cfg: &ControllerConfig,
    nodes: usize,
    restored: Option<&Restored>,
) -> Resumed {
    let mut passes = cfg
        .adaptive
        .map(|a| LinePasses::new(a, cfg.width, cfg.height));
    let mut finished = vec![false; cfg.height as usize];
    let mut counters = Counters::default();
    // Lines whose last pass left pixels above the target: their next pass.
    let mut resume_at = Vec::new();
    for (r, l) in restored
        .iter()
        .flat_map(|r| r.lines.values().map(move |l| (r, l)))
    {
        let Some(f) = finished.get_mut(l.line as usize) else {
            continue;
        };
        counters += l.counters.as_ref().map(Counters::from).unwrap_or_default();
        match (passes.as_mut(), r.estimates(l)) {
            (Some(p), Some(e)) => match p.pass_in(l.line, e) {
                (_, true) => resume_at.push((l.line, l.pass + 1)),
                (_, false) => *f = true,
            },
            (Some(_), None) => {}
            (None, _) => *f = true,
        }
    }
    let mut table = GrantTable::new(cfg.strategy, cfg.height, nodes, &finished);
    for (line, pass) in resume_at {
        table.resume_at(line, pass);
    }
    Resumed {
        table,
        passes,
        counters,
        resumed: finished.iter().filter(|f| **f).count() as u32,
    }
}
