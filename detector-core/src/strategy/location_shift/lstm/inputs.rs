//! The LSTM's four inputs per epoch, from synchronised samples: the one definition the trainer
//! (host-sim) and the streaming predictor share.

use crate::sample::Sample;
use crate::vehicle::Bicycle;
use crate::wire::model::N_IN;

/// The predictor's inputs, from synchronised samples (see the module documentation). The host
/// trainer uses this same type, so training windows are exactly what the streaming step sees.
#[derive(Clone, Copy, Debug)]
pub struct LstmInputs {
    prev_shift_mps: Option<f32>,
    /// Epochs longer than this break the run (the detector restarts on them too), seconds.
    pub max_dt_s: f32,
    proxy: Bicycle,
}

impl Default for LstmInputs {
    fn default() -> Self {
        LstmInputs { prev_shift_mps: None, max_dt_s: 3.0, proxy: Bicycle::default() }
    }
}

impl LstmInputs {
    fn dt_ok(&self, s: &Sample) -> bool {
        s.dt_s.is_finite() && s.dt_s > 0.0 && s.dt_s <= self.max_dt_s
    }

    /// This epoch's GNSS shift per second, the training target (and next epoch's first input).
    pub fn shift_mps(&self, s: &Sample) -> Option<f32> {
        let d = s.shift_m.get().filter(|d| d.is_finite() && *d >= 0.0)?;
        self.dt_ok(s).then(|| d / s.dt_s).filter(|v| v.is_finite())
    }

    /// The four inputs of this epoch, or `None` when the run breaks here. Call once per epoch.
    pub fn next(&mut self, s: &Sample) -> Option<[f32; N_IN]> {
        let cur = self.shift_mps(s);
        let prev = core::mem::replace(&mut self.prev_shift_mps, cur);
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
        self.prev_shift_mps = None;
    }
}
