//! The grant table's passes: a job rendered to an error hands out a (line, pass) at a time
//! (see the rules in [`super`]).

use super::{GrantTable, LineState};

impl GrantTable {
    /// The pass `line` is on (0 for a line outside the image).
    pub fn pass(&self, line: u32) -> u32 {
        self.passes.get(line as usize).copied().unwrap_or(0)
    }

    /// Whether pass `pass` of `line` is still to come in: a completion of it would be
    /// accepted (the first in of the line's current pass).
    pub fn awaits(&self, line: u32, pass: u32) -> bool {
        self.passes.get(line as usize) == Some(&pass)
            && self.lines.get(line as usize) != Some(&LineState::Done)
    }

    /// A resumed line not done: it goes on from pass `pass`.
    pub fn resume_at(&mut self, line: u32, pass: u32) {
        if let Some(p) = self.passes.get_mut(line as usize) {
            *p = pass;
        }
    }

    /// `line`'s pass is in (its completion was [`Completion::Accepted`]) and the line needs
    /// another: it is queued again, on its next pass, behind every line waiting now, or
    /// `first`, ahead of them (when the lines between passes hold too much).
    pub fn another_pass(&mut self, line: u32, first: bool) {
        let Some(state) = self.lines.get_mut(line as usize) else {
            return;
        };
        if *state != LineState::Done {
            return;
        }
        *state = LineState::Queued;
        self.passes[line as usize] += 1;
        self.done -= 1;
        if first {
            self.queue.push_first(line);
        } else {
            self.queue.push_back(line);
        }
    }
}
