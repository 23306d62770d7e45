//! What a job starts from, resumed from its checkpoint or not: its grant table (the finished
//! lines left out; with a target error, the lines to go on with from their next pass), its
//! lines' estimates between passes ([`LinePasses`]) and the counters of what was rendered.

use super::ControllerConfig;
use crate::distrib::checkpoint::Restored;
use crate::distrib::grants::GrantTable;
use crate::distrib::line_passes::{LinePasses, LineStage};
use crate::distrib::messages::proto::FinishedLine;
use crate::stats::Counters;

/// What a job starts from: its grant table, its lines between passes, the counters of the
/// lines of its checkpoint and how many of them are finished.
pub(super) struct Resumed {
    pub(super) table: GrantTable,
    pub(super) passes: Option<LinePasses>,
    pub(super) counters: Counters,
    pub(super) resumed: u32,
    /// Decisions made while the checkpoint was read, to record (each with whether it
    /// finished its line).
    pub(super) records: Vec<(FinishedLine, bool)>,
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
    // The last pass of each line of the checkpoint, and the lines decided as they came in.
    let mut last_pass = std::collections::BTreeMap::new();
    let mut decided = Vec::new();
    for (r, l) in restored
        .iter()
        .flat_map(|r| r.lines.values().map(move |l| (r, l)))
    {
        let Some(f) = finished.get_mut(l.line as usize) else {
            continue;
        };
        counters += l.counters.as_ref().map(Counters::from).unwrap_or_default();
        match (passes.as_mut(), r.estimates(l), r.settled(l)) {
            (Some(p), Some(e), _) => {
                // Lines decided as their neighbourhoods come in: their decisions go to the
                // checkpoint again (what the interrupted run may not have written).
                decided.extend(p.pass_in(l.line, e).decided);
                last_pass.insert(l.line, l.pass);
            }
            (Some(p), None, Some(settled)) => {
                decided.extend(p.settled_in(l.line, &settled));
                last_pass.insert(l.line, l.pass);
            }
            (Some(_), None, None) => {}
            (None, ..) => *f = true,
        }
    }
    let mut records = Vec::new();
    let mut resumed = finished.iter().filter(|f| **f).count() as u32;
    if let Some(p) = &passes {
        for (&line, &pass) in &last_pass {
            match p.stage(line) {
                LineStage::Pass => resume_at.push((line, pass + 1)),
                LineStage::Settled => {
                    finished[line as usize] = true;
                    resumed += 1;
                }
                // Not granted until its neighbours' first samples are in (they are lines
                // still to render, so the job cannot end before).
                LineStage::Waiting => finished[line as usize] = true,
            }
        }
        for d in decided {
            let pass = last_pass.get(&d.line).copied().unwrap_or(0);
            let finished = !d.more;
            records.push((d.record(pass), finished));
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
        resumed,
        records,
    }
}
