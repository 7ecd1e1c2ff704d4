//! Cost accounting by stage of the data path, for the QEMU run's per-stage breakdown.
//!
//! A [`Stopwatch`] is told, at each boundary, which stage the time since the previous boundary
//! belongs to. The detector and the firmware's pipeline call it at their boundaries; with
//! [`NoStopwatch`] (what every caller but the measurement uses) the calls compile to nothing,
//! so the measured code is the shipped code.

/// A stage of one epoch's processing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// CAN frame decoding: signals from the DBC, in our units.
    CanDecode,
    /// NMEA parsing: sentences to fixes.
    NmeaParse,
    /// Synchronisation: observations and fixes into samples (interpolation, integrals, the
    /// location shift between epochs).
    Sync,
    /// Strategy 1's predictor (the LSTM step, or the kinematic model).
    Predictor,
    /// Strategy 1's comparison of shift and prediction, and the epoch's bookkeeping before it.
    ShiftJudge,
    /// Strategy 3: wheel against GNSS motion state.
    Motion,
    /// Strategy 2 on an epoch without a turn query: segmenting the steering signal.
    Turn,
    /// Strategy 2 on an epoch that judged a turn: resampling and the k-NN DTW query.
    TurnQuery,
    /// The track check (dead reckoning against GNSS).
    Track,
    /// Fusion of the strategies into the verdict and the latched alarm.
    Fusion,
    /// After the verdict and after every input: digest, device health, alarm outbox, the poll
    /// for frames owed to the bus.
    Output,
    /// Anything else between epochs: the caller's own loop (in the QEMU run, the replay and its
    /// checks, which the per-epoch cost leaves out).
    Other,
}

impl Stage {
    /// Every stage, in data-path order.
    pub const ALL: [Stage; 12] = [
        Stage::CanDecode,
        Stage::NmeaParse,
        Stage::Sync,
        Stage::Predictor,
        Stage::ShiftJudge,
        Stage::Motion,
        Stage::Turn,
        Stage::TurnQuery,
        Stage::Track,
        Stage::Fusion,
        Stage::Output,
        Stage::Other,
    ];

    /// Index into [`Stage::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The stage's name in the QEMU run's breakdown.
    pub fn name(self) -> &'static str {
        match self {
            Stage::CanDecode => "CAN decode",
            Stage::NmeaParse => "NMEA parse",
            Stage::Sync => "sync",
            Stage::Predictor => "S1 predictor",
            Stage::ShiftJudge => "S1 judge",
            Stage::Motion => "S3 motion",
            Stage::Turn => "S2 segmenting",
            Stage::TurnQuery => "S2 turn query",
            Stage::Track => "track check",
            Stage::Fusion => "fusion",
            Stage::Output => "digest/health/alarm/poll",
            Stage::Other => "other",
        }
    }
}

/// Told at each stage boundary which stage the time since the previous boundary belongs to.
pub trait Stopwatch {
    /// The time since the previous lap belongs to `stage`.
    fn lap(&mut self, stage: Stage);
}

/// The stopwatch that measures nothing (compiles to nothing).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStopwatch;

impl Stopwatch for NoStopwatch {
    #[inline(always)]
    fn lap(&mut self, _: Stage) {}
}
