//! What the track check says at each epoch.

use super::calibration::Contradiction;
use super::velocity::VelocityOutcome;

/// Where the dead reckoning's heading comes from.
///
/// A heading from steering and wheel speed (the bicycle model, its scale and offset learnt by
/// the same filter) was tried on the two drives with steering and no gyro (openxc_ford,
/// udacity_ch2): its rotation never settled within 2 degrees, so the check would only ever
/// learn there. It is not offered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HeadingSource {
    /// Yaw rate (gyro), bias and scale learnt.
    Gyro,
    /// The GNSS track itself: no independent heading (a rotated track is invisible).
    #[default]
    Gnss,
}

impl HeadingSource {
    /// The source's name in JSON (`gyro`, `gnss`).
    pub const fn name(self) -> &'static str {
        match self {
            HeadingSource::Gyro => "gyro",
            HeadingSource::Gnss => "gnss",
        }
    }
}

/// One position window's judgement.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WindowOutcome {
    /// |e|, metres, and the threshold on it (c sigma(L)), metres.
    pub e_m: f32,
    /// The threshold on `e_m` (c sigma(L)), metres.
    pub threshold_m: f32,
    /// Distance driven over the window (DR), metres.
    pub dist_m: f32,
    /// `e_m` in units of the window's noise: `|e| / sigma(L)`.
    pub z: f32,
}

/// One epoch of the track check.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackOutcome {
    /// The 10 s and 30 s windows, when judged at this epoch.
    pub windows: [Option<WindowOutcome>; 2],
    /// Which window fired.
    pub fired: [bool; 2],
    /// The velocity test, when it judged a pair at this epoch (its `fired` says which channel
    /// fired).
    pub velocity: Option<VelocityOutcome>,
    /// The stored calibration this drive contradicts, from the epoch it was found on.
    pub contradiction: Option<Contradiction>,
    /// The contradiction was found at this epoch (it fires once).
    pub contradiction_found: bool,
    /// The learnt delays of the GNSS position and of its velocity (GNSS behind the vehicle
    /// signals; negative: the vehicle late), s, the velocity's NaN without one, wheel-speed
    /// scale, rotation of the DR frame (deg) and gyro bias (deg/s).
    pub delay_s: f32,
    /// The learnt delay of the GNSS velocity, seconds (NaN without one).
    pub delay_velocity_s: f32,
    /// The position's delay the fits alone say (before the calibration's rates and bounds), s.
    pub delay_free_s: f32,
    /// The learnt wheel-speed scale (GNSS distance over wheel distance).
    pub scale: f32,
    /// The rotation of the DR frame against GNSS's, degrees.
    pub rotation_deg: f32,
    /// The rotation's uncertainty (1 sigma), deg.
    pub rotation_sd_deg: f32,
    /// The learnt gyro bias, deg/s.
    pub gyro_bias_degps: f32,
    /// The heading source, and its learnt scale (true turn over measured turn).
    pub heading: HeadingSource,
    /// The heading source's learnt scale (true turn over measured turn).
    pub turn_scale: f32,
    /// Calibrated: from a stored record, or after the first drive's warm-up.
    pub calibrated: bool,
    /// The dead reckoning takes the car to be reversing (see the track check's `travel`).
    pub reversing: bool,
    /// Still learning: the car's calibration on a first drive, or nothing of the check judges
    /// yet (the position windows in their warm-up, without a gyro or with the frame not yet
    /// aligned, and the velocity test with no pair judged since the stretch began).
    pub learning: bool,
    /// The check cannot tell: the position windows' learnt noise leaves them blind to drifts
    /// under `max_bound_mps` within 10 s and the velocity test judged nothing, or the windows
    /// do not judge (warm-up, no gyro) and the velocity test's last pair was blind.
    pub uninformative: bool,
    /// The check judges at this epoch: a position window judged, or the velocity test judged
    /// a pair within the last 1.5 s and is not blind (the hours a false alarm could happen in).
    pub judging: bool,
    /// The slowest drift visible within 10 s at this epoch's position-window threshold, m/s.
    pub bound_10s_mps: Option<f32>,
    /// The learnt noise per window: `s0` (metres) and `k`.
    pub noise_s0_m: [f32; 2],
    /// The learnt relative noise `k` per window.
    pub noise_k: [f32; 2],
}

impl TrackOutcome {
    /// Anything fired at this epoch.
    pub fn any_fired(&self) -> bool {
        self.fired.iter().any(|f| *f) || self.velocity.is_some_and(|v| v.fired.iter().any(|f| *f)) || self.contradiction_found
    }
}
