//! The direction of travel: a car reverses (out of a parking space, into one, a three-point
//! turn), and its wheel speed does not say so. ABS wheel speeds and OBD speeds are magnitudes,
//! so the dead reckoning drives forward along the gyro's heading while the GNSS, rightly, goes
//! the other way: the velocity test's along-track residual is twice the speed, and a car with a
//! gyro that reversed for four seconds at 1.5 m/s raised the alarm (a car without one takes its
//! direction from the GNSS track and was never affected).
//!
//! A car can only change its direction of travel through a standstill, and reverses slowly and
//! not far. So after each standstill the direction is open while the car is within
//! [`REVERSE_MAX_MPS`] and [`REVERSE_MAX_M`] of it: a velocity pair whose GNSS velocity points
//! against the dead reckoning's (more than [`REVERSE_COS`] apart, at least half its speed)
//! turns the dead reckoning around from the standstill on (its history since then reflected
//! through the standstill's position, so the windows and the calibration's pairs see the
//! manoeuvre as driven), and that pair is not judged. Beyond those bounds the window closes; a
//! car still taken as reversing then is taken forward again (its history reflected back), so a
//! GNSS track that keeps going backwards at speed, or far, is judged as what it is, by the
//! windows over the whole manoeuvre. A reversal that ends in a standstill within them is kept.
//! [`REVERSE_MAX_M`] is also the most a car may reverse in all until it has driven
//! [`REVERSE_REFILL_M`] faster than [`REVERSE_MAX_MPS`]: a parking manoeuvre's several
//! reversals share it, and a queue's crawls between standstills cannot each be one.
//!
//! # What a spoofer gains
//! Within the window the GNSS chooses the direction: a spoofer may move the position backwards
//! by at most twice [`REVERSE_MAX_M`], at walking pace to 10 km/h, between stretches of
//! [`REVERSE_REFILL_M`] driven faster, without this check seeing it (strategies 1 and 3 compare
//! speeds and see nothing either). A gear signal would close that; the detector has none yet.

use super::history::History;
use super::plane::norm2;

/// A car reverses at walking pace to about 10 km/h: faster, the direction is forward, m/s. It
/// is also the speed from which the DR frame aligns to the GNSS heading and the position
/// windows judge (`TrackConfig::min_speed_mps`): a frame never aligns on a reversal.
pub const REVERSE_MAX_MPS: f32 = 3.0;
/// ... and not far: out of a parking space or a driveway, metres of wheel distance since the
/// standstill.
pub const REVERSE_MAX_M: f32 = 25.0;
/// A car has stood (and may go either way next) where the wheel speed at an epoch is under
/// this, m/s: it passes through zero between two epochs a second apart within half a second at
/// 1 m/s^2, and many ABS sensors read zero below about 2 km/h anyway.
pub const REVERSE_STANDSTILL_MPS: f32 = 0.5;
/// The reversing distance [`REVERSE_MAX_M`] is available again once the car has driven this
/// far faster than [`REVERSE_MAX_MPS`] since its last reversal, metres.
pub const REVERSE_REFILL_M: f32 = 100.0;
/// A pair reverses the direction when its GNSS velocity and the DR's are more than this apart
/// (the cosine: 134 degrees) ...
pub const REVERSE_COS: f32 = -0.7;
/// ... the DR's speed at least this, m/s (slower, a receiver's course says little) ...
pub const REVERSE_MIN_MPS: f32 = 1.0;
/// ... and the GNSS speed at least this share of the DR's.
const REVERSE_SPEED_SHARE: f32 = 0.5;

/// The move since the last standstill and its direction.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Travel {
    /// The standstill's time (stretch seconds) and DR position while the direction is open.
    open: Option<(f32, (f32, f32))>,
    /// Wheel distance since the standstill, metres.
    dist: f32,
    /// Metres taken in reverse since the car last drove [`REVERSE_REFILL_M`] faster than
    /// [`REVERSE_MAX_MPS`] ...
    reversed: f32,
    /// ... and the metres it drove that fast since its last reversal.
    fast: f32,
    /// The DR integrates backwards.
    reverse: bool,
}

impl Travel {
    /// The DR's direction of travel relative to its heading, radians (0 or pi).
    pub(super) fn offset(&self) -> f32 {
        if self.reverse { core::f32::consts::PI } else { 0.0 }
    }

    /// Reversing now.
    pub(super) fn reversing(&self) -> bool {
        self.reverse
    }

    /// After an epoch's integration, at time `t` with the wheel speed `wheel` and the wheel
    /// distance `dist` (finite, not negative) since the epoch before: the car has stood (a new
    /// move may go either way), or the move has outgrown a reversal (taken forward from here
    /// on: `true` when that turned the DR around).
    #[inline(never)]
    pub(super) fn epoch(&mut self, t: f32, wheel: f32, dist: f32, hist: &mut History, dr: &mut (f32, f32)) -> bool {
        if wheel < REVERSE_STANDSTILL_MPS {
            (self.open, self.dist, self.reverse) = ((self.reversed < REVERSE_MAX_M).then_some((t, *dr)), 0.0, false);
            return false;
        }
        self.dist += dist;
        if self.reverse {
            self.reversed += dist;
        }
        if wheel > REVERSE_MAX_MPS {
            self.fast += dist;
            if self.fast >= REVERSE_REFILL_M {
                self.reversed = 0.0;
            }
        }
        let close = self.open.is_some() && (wheel > REVERSE_MAX_MPS || self.dist > REVERSE_MAX_M || self.reversed > REVERSE_MAX_M);
        let back = close && self.reverse;
        if back {
            self.flip(hist, dr);
        }
        if close {
            self.open = None;
        }
        back
    }

    /// A velocity pair: its GNSS velocity `g` against the DR's prediction `pred`, m/s. While
    /// the direction is open and the pair points against the DR, the DR turns around (see the
    /// module documentation) and the pair is not judged (`false`).
    pub(super) fn pair(&mut self, g: (f32, f32), pred: (f32, f32), hist: &mut History, dr: &mut (f32, f32)) -> bool {
        if self.open.is_none() {
            return true;
        }
        let (g2, p2) = (norm2(g), norm2(pred));
        let dot = g.0 * pred.0 + g.1 * pred.1;
        // `dot < REVERSE_COS |g| |pred|`, without the root.
        let against = p2 >= REVERSE_MIN_MPS * REVERSE_MIN_MPS
            && g2 >= REVERSE_SPEED_SHARE * REVERSE_SPEED_SHARE * p2
            && dot < 0.0
            && dot * dot > REVERSE_COS * REVERSE_COS * g2 * p2;
        if against {
            if !self.reverse {
                // Reversing since the standstill: those metres count too.
                (self.fast, self.reversed) = (0.0, self.reversed + self.dist);
            }
            self.flip(hist, dr);
        }
        !against
    }

    /// The DR turned around since the standstill: every position since then reflected through
    /// the standstill's. Out of line: one copy for both callers.
    #[inline(never)]
    fn flip(&mut self, hist: &mut History, dr: &mut (f32, f32)) {
        let Some((t, at)) = self.open else { return };
        hist.reflect_d_after(t, at);
        *dr = (2.0 * at.0 - dr.0, 2.0 * at.1 - dr.1);
        self.reverse = !self.reverse;
    }
}
