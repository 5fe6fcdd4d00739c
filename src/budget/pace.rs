//! The pace of a deadline: how much refinement the time left affords at
//! the rate measured so far.

use crate::math;

/// Sizes a deadline's refinement from the clock: the rate measured so far
/// and the time left. The executors refine in rounds and ask before each one,
/// so a rate that was wrong at first (the preview's: on a host several times
/// lower than the refinement's, from thread start-up and the first touch of
/// memory) is replaced by the refinement's own after the first round.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pace {
    pub(super) deadline: u64,
    pub(super) paths: u64,
    pub(super) micros: u64,
    /// Whether the rate is a round's (not the first guess's).
    pub(super) measured: bool,
}

impl Pace {
    /// A pace for a deadline at clock reading `deadline` (microseconds), with
    /// a first rate of `paths` traced in `micros`.
    pub const fn new(deadline: u64, paths: u64, micros: u64) -> Self {
        Self {
            deadline,
            paths,
            micros,
            measured: false,
        }
    }

    /// Replaces the rate: `paths` traced in `micros` (everything the rounds
    /// so far cost: recomputed previews, drawing, waiting for threads).
    pub fn measured(&mut self, paths: u64, micros: u64) {
        self.paths = paths;
        self.micros = micros;
        self.measured = true;
    }

    /// The paths the time from `now` to the deadline affords at the measured
    /// rate, for `part` of the `whole` (pixels) still to refine.
    pub fn afford(&self, now: u64, part: u64, whole: u64) -> u64 {
        let left = self.deadline.saturating_sub(now) as f32;
        let rate = self.paths as f32 / math::max(self.micros as f32, 1.0);
        let share = part as f32 / math::max(whole as f32, 1.0);
        let a = math::floor(rate * left * math::min(share, 1.0));
        math::clamp(a, 0.0, 1.0e18) as u64
    }

    /// The next round for `pixels` pixels: half of what the time left
    /// affords while that is at least two samples per pixel (a rate that is
    /// too high by up to 2x still ends the round before the deadline), else
    /// all of it, which the deadline's stop may cut. The first round, sized
    /// by the first guess (which may be wrong either way), is at most one
    /// sample per pixel: it measures the rate. 0: nothing is affordable.
    pub fn round(&self, now: u64, pixels: u64) -> u64 {
        let a = self.afford(now, 1, 1);
        let r = if a >= pixels.saturating_mul(2) {
            a / 2
        } else {
            a
        };
        if self.measured { r } else { r.min(pixels) }
    }
}
