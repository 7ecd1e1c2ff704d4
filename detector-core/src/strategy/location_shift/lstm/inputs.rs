//! The LSTM's four inputs per epoch, from synchronised samples: the one definition the trainer
//! (host-sim) and the streaming predictor share.

use crate::sample::Sample;
use crate::vehicle::Bicycle;
use crate::wire::model::N_IN;

/// An epoch shorter than this gives no rate of its own, seconds: a logger that stamps fixes on
/// arrival jitters them by tens of milliseconds, and 1.8 m over 3 ms is any speed (a 10 Hz drive
/// with its stamps jittered by +-50 ms fed the LSTM 587 m/s). Its shift is added to the epoch
/// before's, whose stamps then span it. No drive of our data has a fix less than 0.1 s after
/// the one before, so the training windows do not change.
pub const MIN_RATE_DT_S: f32 = 0.05;

/// The predictor's inputs, from synchronised samples (see the module documentation). The host
/// trainer uses this same type, so training windows are exactly what the streaming step sees.
#[derive(Clone, Copy, Debug)]
pub struct LstmInputs {
    /// The previous epoch's GNSS shift and duration (metres, seconds), with the epochs before
    /// it added while it was shorter than [`MIN_RATE_DT_S`].
    prev_shift: Option<(f32, f32)>,
    /// Epochs longer than this break the run (the detector restarts on them too), seconds.
    pub max_dt_s: f32,
    proxy: Bicycle,
}

impl Default for LstmInputs {
    fn default() -> Self {
        LstmInputs { prev_shift: None, max_dt_s: 3.0, proxy: Bicycle::default() }
    }
}

impl LstmInputs {
    fn dt_ok(&self, s: &Sample) -> bool {
        s.dt_s.is_finite() && s.dt_s > 0.0 && s.dt_s <= self.max_dt_s
    }

    /// This epoch's GNSS shift and duration (metres, seconds), where both are usable.
    fn shift(&self, s: &Sample) -> Option<(f32, f32)> {
        let d = s.shift_m.get().filter(|d| d.is_finite() && *d >= 0.0)?;
        self.dt_ok(s).then_some((d, s.dt_s))
    }

    /// This epoch's GNSS shift per second, the training target (and next epoch's first input).
    pub fn shift_mps(&self, s: &Sample) -> Option<f32> {
        self.shift(s).map(|(d, dt)| d / dt).filter(|v| v.is_finite())
    }

    /// The four inputs of this epoch, or `None` when the run breaks here. Call once per epoch.
    pub fn next(&mut self, s: &Sample) -> Option<[f32; N_IN]> {
        let cur = match (self.shift(s), self.prev_shift) {
            (Some((d, dt)), Some((pd, pdt))) if dt < MIN_RATE_DT_S => Some((d + pd, dt + pdt)),
            (Some((_, dt)), None) if dt < MIN_RATE_DT_S => None,
            (c, _) => c,
        };
        let prev = core::mem::replace(&mut self.prev_shift, cur).map(|(d, dt)| d / dt).filter(|v| v.is_finite());
        if !self.dt_ok(s) {
            return None;
        }
        let finite = |v: Option<f32>| v.filter(|x| x.is_finite());
        let speed = finite(s.wheel_speed().get())?;
        let pedal = finite(s.pedal().get())?;
        let steer = match s.steering() {
            crate::sample::Reading::Valid(v) => finite(Some(v))?,
            crate::sample::Reading::Stale => return None,
            // No steering sensor: the bicycle-model proxy from yaw rate (0 below its minimum speed).
            crate::sample::Reading::Missing => {
                let yaw = finite(s.yaw_rate().get())?;
                self.proxy.steering_deg(yaw, speed).unwrap_or(0.0)
            }
        };
        Some([prev?, pedal, steer, speed])
    }

    /// Forgets the previous shift: a new run starts.
    pub fn reset(&mut self) {
        self.prev_shift = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::{Reading, Signal};

    fn epoch(dt_s: f32, shift_m: f32) -> Sample {
        let mut s = Sample { dt_s, shift_m: Reading::Valid(shift_m), ..Default::default() };
        s.signals[Signal::WheelSpeed.index()] = Reading::Valid(17.6);
        s.signals[Signal::Pedal.index()] = Reading::Valid(10.0);
        s.signals[Signal::Steering.index()] = Reading::Valid(0.0);
        s
    }

    /// Fixes 0.1 s apart at 17.6 m/s whose stamps jitter: one epoch of 0.27 s, then one of
    /// 3 ms (the logger stamped two fixes almost together). The rate after the short epoch is
    /// the two epochs' shift over their span, not 1.76 m over 3 ms.
    #[test]
    fn an_epoch_of_a_few_milliseconds_gives_no_rate_of_its_own() {
        let mut x = LstmInputs::default();
        assert!(x.next(&epoch(0.1, 1.76)).is_none(), "no previous shift yet");
        assert_eq!(x.next(&epoch(0.27, 3.52)).map(|i| i[0]), Some(17.6));
        let after_long = x.next(&epoch(0.003, 1.76)).map(|i| i[0]);
        assert!(after_long.is_some_and(|v| (v - 3.52 / 0.27).abs() < 1e-3), "{after_long:?}");
        let after_short = x.next(&epoch(0.1, 1.76)).map(|i| i[0]);
        assert!(after_short.is_some_and(|v| (v - 5.28 / 0.273).abs() < 1e-3), "{after_short:?}: 1.76 m over 3 ms is 587 m/s");
        // An epoch of normal length gives its own rate again.
        assert!(x.next(&epoch(0.1, 1.76)).is_some_and(|i| (i[0] - 17.6).abs() < 1e-3));
        // Right after a restart a short epoch has nothing to be added to: no rate.
        x.reset();
        assert!(x.next(&epoch(0.003, 1.76)).is_none());
        assert!(x.next(&epoch(0.1, 1.76)).is_none(), "the short epoch gave no rate");
    }
}
