//! Local health awareness (Lifeguard, Dadgar et al. 2018, section 4.2): a member that is
//! itself slow (its timers fire late because every core is busy, or the cluster declared it
//! down) should not accuse others on its own slow clock. Its score rises with each sign of
//! trouble and falls with each probe round on time; the membership's probe period, probe
//! timeout and suspicion timeout are stretched by `1 + score`.
//!
//! Lifeguard raises the score by one per sign. A timer that fires late says more than that:
//! how late it was is how slow this member is now, so the score rises at once to the
//! lateness in units of the normal slack (a member descheduled for 150 ms, with 40 ms of
//! slack, goes to 3 at once), and then by one per further late timer. Only probe rounds on
//! time lower it, one at a time, so timeouts stay stretched for a while after a busy spell.

use std::time::Duration;

/// Highest score (timeouts at most this plus one times their configured length).
pub const MAX_SCORE: u32 = 8;

/// This member's health score.
#[derive(Clone, Debug, Default)]
pub struct Health {
    score: u32,
}

impl Health {
    /// The score now (0 = healthy).
    pub fn score(&self) -> u32 {
        self.score
    }

    /// How much timeouts are stretched now.
    pub fn stretch(&self, d: Duration) -> Duration {
        d * (1 + self.score)
    }

    /// A timer fired `late` after it was due; `slack` is what is normal. Returns whether it
    /// was late.
    pub fn timer_fired(&mut self, late: Duration, slack: Duration) -> bool {
        if late <= slack {
            return false;
        }
        let units = (late.as_micros() / slack.as_micros().max(1)).min(u128::from(MAX_SCORE));
        self.score = (self.score + 1).max(units as u32).min(MAX_SCORE);
        true
    }

    /// A probe round began `late` after it was due; `slack` is what is normal.
    pub fn probe_round(&mut self, late: Duration, slack: Duration) {
        if !self.timer_fired(late, slack) {
            self.score = self.score.saturating_sub(1);
        }
    }

    /// A sign of trouble (the cluster declaring this member down).
    pub fn worse(&mut self) {
        self.score = (self.score + 1).min(MAX_SCORE);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn late_rounds_stretch_timeouts_and_rounds_on_time_undo_it() {
        let mut h = Health::default();
        let ms = Duration::from_millis;
        assert_eq!(h.stretch(ms(100)), ms(100));
        for _ in 0..20 {
            h.probe_round(ms(300), ms(50));
        }
        assert_eq!(h.score(), MAX_SCORE);
        assert_eq!(h.stretch(ms(100)), ms(900));
        h.probe_round(ms(10), ms(50));
        assert_eq!(h.score(), MAX_SCORE - 1);
        for _ in 0..20 {
            h.probe_round(ms(0), ms(50));
        }
        assert_eq!(h.stretch(ms(100)), ms(100));
    }

    #[test]
    fn one_very_late_timer_raises_the_score_by_how_late_it_was() {
        let ms = Duration::from_millis;
        let mut h = Health::default();
        assert!(!h.timer_fired(ms(40), ms(40)), "on time within the slack");
        assert_eq!(h.score(), 0);
        assert!(h.timer_fired(ms(150), ms(40)));
        assert_eq!(h.score(), 3, "150 ms late is three slacks");
        assert!(h.timer_fired(ms(41), ms(40)));
        assert_eq!(h.score(), 4, "a further late timer adds one");
        assert!(h.timer_fired(ms(10_000), ms(40)));
        assert_eq!(h.score(), MAX_SCORE, "bounded");
        // Other timers on time do not lower it: only probe rounds do.
        assert!(!h.timer_fired(ms(0), ms(40)));
        assert_eq!(h.score(), MAX_SCORE);
    }
}
