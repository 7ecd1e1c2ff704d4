//! The shared vocabulary: what the receiver reports, what the vehicle reports, and the
//! synchronised sample per GNSS epoch that every strategy consumes.

use crate::geo::LatLon;

/// The value of one signal at one epoch. Missing and stale are states, never NaN.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Reading {
    /// Interpolated (or exactly observed) value, always finite.
    Valid(f32),
    /// The signal exists but had no observation within the configured gap of this epoch.
    Stale,
    /// The signal has never been observed (the source does not have it).
    #[default]
    Missing,
}

impl Reading {
    /// A reading from an optional raw value: non-finite values become `Missing`.
    pub fn from_opt(v: Option<f32>) -> Self {
        match v {
            Some(x) if x.is_finite() => Reading::Valid(x),
            _ => Reading::Missing,
        }
    }
    /// The value, if valid.
    pub fn get(self) -> Option<f32> {
        match self {
            Reading::Valid(v) => Some(v),
            _ => None,
        }
    }
    /// Whether the reading holds a value.
    pub fn is_valid(self) -> bool {
        matches!(self, Reading::Valid(_))
    }
}

/// The in-vehicle signals, with their units and sign conventions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Signal {
    /// Wheel (vehicle) speed, m/s.
    WheelSpeed = 0,
    /// Steering wheel angle, degrees, + = left.
    Steering = 1,
    /// Accelerator pedal, percent 0..100.
    Pedal = 2,
    /// Yaw rate, deg/s, + = left (counter-clockwise seen from above).
    YawRate = 3,
    /// Longitudinal acceleration, m/s^2, + = forward.
    LongAccel = 4,
}

impl Signal {
    /// Whether the synchroniser integrates this signal between epochs (wheel speed into
    /// [`Sample::dist_m`], yaw rate into [`Sample::turn_deg`]).
    pub fn integrated(self) -> bool {
        matches!(self, Signal::WheelSpeed | Signal::YawRate)
    }

    /// How many signals there are.
    pub const COUNT: usize = 5;
    /// Every signal, in index order.
    pub const ALL: [Signal; Signal::COUNT] =
        [Signal::WheelSpeed, Signal::Steering, Signal::Pedal, Signal::YawRate, Signal::LongAccel];

    /// Index into [`Sample::signals`].
    pub const fn index(self) -> usize {
        self as usize
    }
    /// The signal's name in map files and reports (`wheel_speed`, ...).
    pub const fn name(self) -> &'static str {
        match self {
            Signal::WheelSpeed => "wheel_speed",
            Signal::Steering => "steering",
            Signal::Pedal => "pedal",
            Signal::YawRate => "yaw_rate",
            Signal::LongAccel => "long_accel",
        }
    }
}

/// One GNSS fix as the receiver reports it.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Fix {
    /// Time of the fix, seconds, on the same clock as the vehicle observations.
    pub t: f64,
    /// Position as reported.
    pub pos: LatLon,
    /// Speed over ground, m/s, when the receiver reports it.
    pub speed_mps: Option<f32>,
    /// Course over ground, degrees, 0 = north, clockwise, when the receiver reports it.
    pub course_deg: Option<f32>,
    /// The receiver's own estimate of its horizontal position error (1 sigma), metres, when it
    /// reports one (NMEA GST, UBX NAV-PVT hAcc).
    pub h_acc_m: Option<f32>,
    /// The receiver's own spoofing detection says it is being spoofed (UBX NAV-STATUS
    /// `spoofDetState` 2 or 3, the last one before this fix). Supporting evidence only: receivers
    /// raise it on benign events too.
    pub receiver_spoofing: bool,
}

/// Everything known at one GNSS epoch, synchronised.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Sample {
    /// Epoch time, seconds.
    pub t: f64,
    /// Seconds since the previous epoch (0 for the first epoch after a start or reset).
    pub dt_s: f32,
    /// The fix's position.
    pub pos: LatLon,
    /// Haversine distance from the previous fix, metres (`Missing` on the first epoch).
    pub shift_m: Reading,
    /// The receiver's speed over ground, m/s.
    pub gnss_speed: Reading,
    /// The receiver's course over ground, degrees, 0 = north, clockwise.
    pub gnss_course: Reading,
    /// The receiver's horizontal accuracy (1 sigma), metres.
    pub gnss_h_acc: Reading,
    /// The fix's [`Fix::receiver_spoofing`].
    pub receiver_spoofing: bool,
    /// Vehicle signals indexed by [`Signal::index`].
    pub signals: [Reading; Signal::COUNT],
    /// Distance driven since the previous epoch, metres: the wheel speed's integral over its
    /// observations (`Stale` across a gap in them, `Missing` on the first epoch of a source
    /// without wheel speed).
    pub dist_m: Reading,
    /// Heading change since the previous epoch, degrees, + = left: the yaw rate's integral.
    pub turn_deg: Reading,
    /// The turning since the previous epoch whatever its direction, degrees: the integral of
    /// the yaw rate's magnitude (at least `|turn_deg|`). Across a GNSS gap it tells one steady
    /// bend (`|turn_deg|`) from an S-bend or a turn and back (more).
    pub turn_abs_deg: Reading,
    /// The wheel speed's resolution as seen so far, m/s: the smallest change between two
    /// consecutive observations (0 before any). An OBD speed in whole km/h has 0.28 m/s, and
    /// the reading is then up to half that off for as long as the speed holds: an error no
    /// window averages away.
    pub wheel_step_mps: f32,
}

impl Sample {
    /// The reading of signal `s` at this epoch.
    pub fn signal(&self, s: Signal) -> Reading {
        self.signals[s.index()]
    }
    /// Wheel speed, m/s.
    pub fn wheel_speed(&self) -> Reading {
        self.signal(Signal::WheelSpeed)
    }
    /// Steering wheel angle, degrees, + = left.
    pub fn steering(&self) -> Reading {
        self.signal(Signal::Steering)
    }
    /// Accelerator pedal, percent.
    pub fn pedal(&self) -> Reading {
        self.signal(Signal::Pedal)
    }
    /// Yaw rate, deg/s, + = left.
    pub fn yaw_rate(&self) -> Reading {
        self.signal(Signal::YawRate)
    }
    /// Longitudinal acceleration, m/s^2, + = forward.
    pub fn long_accel(&self) -> Reading {
        self.signal(Signal::LongAccel)
    }
}
