//! A worker's window: how many lines it asks to hold (rendering, queued, or on their way from
//! the controller), so its render threads do not wait for the network.
//!
//! When a thread finishes a line, the worker reports it and the controller sends a new one;
//! until that line arrives (the delay), the threads live on the queued lines. So the worker
//! needs one line per thread plus what its threads render in a delay: `threads + threads *
//! delay / line`. It measures both. The delay is timed from the moment the line was finished
//! (the worker stamps each Request and Done with its clock, and the controller echoes the
//! stamp in the Assign that answers it) to the moment the new line is queued, so it holds the
//! whole loop: the worker's own scheduling, the relay daemons, the controller. Its mean is
//! small (one to three milliseconds on loopback) but it has a tail: on a loaded host any of
//! those processes may not be scheduled for several milliseconds now and then. So the queue
//! covers the longest delay seen lately (a peak that halves every [`PEAK_HALF_LIFE_S`]) and
//! never less than [`MIN_COVER_S`] of rendering. The line time is a moving average of the
//! render threads' cycle (lines get dearer or cheaper down the image).
//!
//! The window is counted in time, so a slow host (whose lines take longer than the delay)
//! holds one line per thread plus one, and a fast host with cheap lines holds more, up to
//! [`MAX_QUEUED`] queued lines. A line's cost is known only once it is rendered, so the
//! window can be too large: before the first line is done it is the largest (the first
//! lines must last until the second batch comes back, a round trip later), and a host that
//! sized it on cheap lines (the sky at the top of an image) may next get dear ones. The
//! worker then hands back the queued lines beyond the window ([`Window::excess`]); until a
//! line is done, the time the first lines have taken so far bounds the line time. The window
//! is absolute (the controller hands out lines while the worker holds fewer), so a smaller
//! window just means fewer new lines.

/// Queued lines (beyond one per render thread) a worker asks for at most.
pub const MAX_QUEUED: u32 = 128;

/// The queued lines cover at least this much rendering, seconds.
pub const MIN_COVER_S: f64 = 0.020;

/// The longest delay seen counts for half as much after this many seconds.
pub const PEAK_HALF_LIFE_S: f64 = 1.0;

/// Weight of a new line time in its moving average.
const LINE_WEIGHT: f64 = 0.125;

/// The window of a worker with `threads` render threads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    threads: u32,
    /// The longest delay seen and when (the worker's clock), seconds.
    peak: Option<(f64, f64)>,
    line_s: Option<f64>,
    /// How long the first lines have been rendering with none done: the least a line takes.
    first_running_s: f64,
}

impl Window {
    /// A window for `threads` render threads (at least 1), before any line is timed.
    pub fn new(threads: usize) -> Window {
        Window {
            threads: u32::try_from(threads.max(1)).unwrap_or(u32::MAX),
            peak: None,
            line_s: None,
            first_running_s: 0.0,
        }
    }

    /// The first lines have been rendering for `seconds` and none is done yet.
    pub fn first_lines_running(&mut self, seconds: f64) {
        if self.line_s.is_none() && seconds.is_finite() && seconds > self.first_running_s {
            self.first_running_s = seconds;
        }
    }

    /// True once a line is done.
    pub fn has_line_time(&self) -> bool {
        self.line_s.is_some()
    }

    /// A delay measured at `now` (seconds on the worker's clock): from a finished line (or
    /// a Request) to the new line it brought.
    pub fn delay(&mut self, now: f64, seconds: f64) {
        if seconds.is_finite() && seconds >= 0.0 && now.is_finite() {
            let peak = self.peak_at(now).max(seconds);
            self.peak = Some((peak, now));
        }
    }

    /// A render thread's wall time per line (its cycle: see [`super::pool::Rendered`]).
    pub fn line_done(&mut self, seconds: f64) {
        if seconds.is_finite() && seconds >= 0.0 {
            self.line_s = Some(match self.line_s {
                None => seconds,
                Some(old) => old + LINE_WEIGHT * (seconds - old),
            });
        }
    }

    /// The longest delay seen, decayed to `now`.
    fn peak_at(&self, now: f64) -> f64 {
        self.peak.map_or(0.0, |(peak, at)| {
            peak * (-(now - at).max(0.0) / PEAK_HALF_LIFE_S).exp2()
        })
    }

    /// The rendering time the queued lines cover at `now`.
    pub fn cover_s(&self, now: f64) -> f64 {
        self.peak_at(now).max(MIN_COVER_S)
    }

    /// The lines to keep queued at `now`, besides one per thread: what the threads render in
    /// the covered time (at least 1, at most [`MAX_QUEUED`]). Before a line is done, the
    /// most, or what the time the first lines have taken so far allows.
    pub fn queued(&self, now: f64) -> u32 {
        let line = match self.line_s {
            Some(line) => line,
            None if self.first_running_s > 0.0 => self.first_running_s,
            None => return MAX_QUEUED,
        };
        let lines = self.cover_s(now) * f64::from(self.threads) / line.max(1e-9);
        lines.ceil().clamp(1.0, f64::from(MAX_QUEUED)) as u32
    }

    /// How many of `queued` lines (queued, not started) to hand back at `now`: those beyond
    /// [`Window::queued`] once there are more than twice as many (a margin, so a window that
    /// wavers does not send lines back and forth at every line).
    pub fn excess(&self, queued: usize, now: f64) -> usize {
        let keep = self.queued(now) as usize;
        if queued > 2 * keep {
            queued - keep
        } else {
            0
        }
    }

    /// The lines to hold at `now`: one per thread plus [`Window::queued`].
    pub fn lines(&self, now: f64) -> u32 {
        self.threads.saturating_add(self.queued(now))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn until_a_line_is_done_the_window_is_the_largest_or_what_the_first_lines_allow() {
        let mut w = Window::new(2);
        assert_eq!(w.lines(0.0), 2 + MAX_QUEUED);
        w.delay(0.0, 0.002);
        assert_eq!(w.lines(0.0), 2 + MAX_QUEUED, "no line time yet");
        w.first_lines_running(0.010);
        // Lines take 10 ms or more: two threads render at most 4 in 20 ms.
        assert_eq!(w.lines(0.0), 2 + 4);
        w.first_lines_running(0.005);
        assert_eq!(w.lines(0.0), 2 + 4, "the bound only grows");
        w.line_done(0.0004);
        w.first_lines_running(1.0);
        assert_eq!(w.lines(0.0), 2 + 100, "a line time replaces the bound");
        assert_eq!(
            Window::new(0).lines(0.0),
            1 + MAX_QUEUED,
            "at least one thread"
        );
    }

    #[test]
    fn lines_beyond_twice_the_queue_are_handed_back() {
        let mut w = Window::new(1);
        w.line_done(0.004);
        assert_eq!(w.queued(0.0), 5);
        assert_eq!(w.excess(10, 0.0), 0, "within the margin");
        assert_eq!(w.excess(11, 0.0), 6, "down to the queue");
        assert_eq!(w.excess(0, 0.0), 0);
    }

    #[test]
    fn the_queue_covers_the_minimum_in_rendering_time() {
        let mut w = Window::new(2);
        w.line_done(0.0015);
        // Two threads render 26.7 lines of 1.5 ms in 20 ms.
        assert_eq!(w.lines(0.0), 2 + 27);
        w.delay(0.0, 0.001);
        assert_eq!(w.lines(0.0), 2 + 27, "a short delay: the minimum");
        let mut slow = Window::new(1);
        slow.line_done(0.2);
        assert_eq!(
            slow.lines(0.0),
            2,
            "lines longer than the cover: one queued"
        );
    }

    #[test]
    fn the_longest_delay_counts_until_it_fades() {
        let mut w = Window::new(1);
        w.line_done(0.0013);
        w.delay(0.0, 0.001);
        w.delay(0.0, 0.090);
        w.delay(0.0, 0.001);
        assert_eq!(w.cover_s(0.0), 0.090, "a stall is remembered");
        assert_eq!(w.lines(0.0), 1 + 70, "69.2 lines of 1.3 ms in 90 ms");
        assert_eq!(w.cover_s(PEAK_HALF_LIFE_S), 0.045);
        assert_eq!(w.lines(PEAK_HALF_LIFE_S), 1 + 35, "34.6 lines in 45 ms");
        w.delay(PEAK_HALF_LIFE_S, 0.050);
        assert_eq!(
            w.cover_s(PEAK_HALF_LIFE_S),
            0.050,
            "a longer one takes over"
        );
        assert_eq!(w.cover_s(10.0), MIN_COVER_S, "faded");
    }

    #[test]
    fn the_window_follows_the_line_time() {
        let mut w = Window::new(1);
        w.line_done(0.030);
        assert_eq!(w.lines(0.0), 1 + 1);
        for _ in 0..60 {
            w.line_done(0.0011);
        }
        assert_eq!(w.lines(0.0), 1 + 19, "cheaper lines: more queued");
        w.delay(0.0, f64::NAN);
        w.delay(0.0, -1.0);
        w.line_done(f64::INFINITY);
        w.line_done(-1.0);
        assert_eq!(w.lines(0.0), 1 + 19, "bad samples are ignored");
    }

    #[test]
    fn the_queue_is_capped() {
        let mut w = Window::new(4);
        w.line_done(0.0);
        assert_eq!(w.lines(0.0), 4 + MAX_QUEUED);
        let mut many = Window::new(1000);
        assert_eq!(many.lines(0.0), 1000 + MAX_QUEUED);
        many.line_done(100.0);
        assert_eq!(many.lines(0.0), 1001, "at least one queued line");
    }
}
