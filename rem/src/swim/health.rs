//! Local health awareness (Lifeguard, Dadgar et al. 2018, section 4.2): a member that is
//! itself slow (its timers fire late because every core is busy, or the cluster declared it
//! down) should not accuse others on its own slow clock. Its score rises with each sign of
//! trouble and falls with each probe round on time; the membership's probe period, probe
//! timeout and suspicion timeout are stretched by `1 + score`.

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

    /// A probe round began `late` after it was due; `slack` is what is normal.
    pub fn probe_round(&mut self, late: Duration, slack: Duration) {
        if late > slack {
            self.worse();
        } else {
            self.score = self.score.saturating_sub(1);
        }
    }

    /// A sign of trouble (a late timer, the cluster declaring this member down).
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
}
