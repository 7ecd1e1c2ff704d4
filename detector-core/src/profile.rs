//! Receiver profiles: what a class of GNSS receiver contributes to the thresholds.
//!
//! `gnss_error_m` is the GNSS positioning-error term of strategy 1's threshold: the horizontal
//! accuracy (CEP 50) that the receiver class states, taken as the worst plausible epoch-to-epoch
//! disagreement beyond what the measured prediction error already contains.
//! `kinematic_max_error_m` is the maximum absolute error of the kinematic predictor measured on
//! the clean real drives at that rate (`host-sim calibrate`, see the README for the run).

/// A receiver class.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReceiverProfile {
    /// The profile's name (`ublox-10hz`, `logger-1hz`).
    pub name: &'static str,
    /// Nominal epoch duration, seconds.
    pub nominal_dt_s: f32,
    /// GNSS positioning-error term of the strategy-1 threshold, metres.
    pub gnss_error_m: f32,
    /// Measured maximum absolute error of the kinematic predictor at this rate, metres.
    pub kinematic_max_error_m: f32,
    /// Standing / moving thresholds on the reported speed over ground, m/s.
    pub gnss_speed_stop_mps: f32,
    /// Moving above this reported speed, m/s.
    pub gnss_speed_move_mps: f32,
    /// Standing / moving thresholds on the speed from position change, m/s (noisier).
    pub pos_speed_stop_mps: f32,
    /// Moving above this speed from position change, m/s.
    pub pos_speed_move_mps: f32,
}

/// NEO-M8 datasheet: CEP 2.5 m.
const UBLOX_GNSS_ERROR_M: f32 = 2.5;

/// u-blox M8-class receiver at 10 Hz (comma2k19).
pub const UBLOX_10HZ: ReceiverProfile = ReceiverProfile {
    name: "ublox-10hz",
    nominal_dt_s: 0.1,
    gnss_error_m: UBLOX_GNSS_ERROR_M,
    kinematic_max_error_m: KINEMATIC_MAX_ERROR_10HZ_M,
    gnss_speed_stop_mps: 0.5,
    gnss_speed_move_mps: 1.5,
    pos_speed_stop_mps: 1.0,
    pos_speed_move_mps: 3.0,
};

/// 1 Hz data loggers (CSS CANedge GNSS, OpenXC vehicle interface, DrivePlotR phone logs).
/// Consumer and logger GNSS modules state 2.5 to 5 m CEP; we take 5 m.
pub const LOGGER_1HZ: ReceiverProfile = ReceiverProfile {
    name: "logger-1hz",
    nominal_dt_s: 1.0,
    gnss_error_m: 5.0,
    kinematic_max_error_m: KINEMATIC_MAX_ERROR_1HZ_M,
    gnss_speed_stop_mps: 0.5,
    gnss_speed_move_mps: 1.5,
    pos_speed_stop_mps: 1.0,
    pos_speed_move_mps: 3.0,
};

/// Measured with `host-sim calibrate ../shared/data/drives`: max |GNSS shift - kinematic| over
/// all 2,682 judged epochs of the 10 Hz drives with wheel speed (comma2k19, udacity_ch2) was
/// 1.106 m (p99 0.50 m), rounded up to 0.05 m.
pub const KINEMATIC_MAX_ERROR_10HZ_M: f32 = 1.15;
/// The same over the 17,646 judged epochs of the 1 Hz drives with wheel speed (css_canedge x2,
/// openxc_ford, sddi_commuter x5): 15.74 m (p99 2.68 m; the maximum is a GNSS step of the
/// sddi_commuter receiver at 1418 s of nl_20210215_072115), rounded up to 0.05 m.
pub const KINEMATIC_MAX_ERROR_1HZ_M: f32 = 15.75;

/// The profile for a receiver of the given fix rate: 10 Hz class at 5 Hz and above.
pub fn for_rate(gnss_hz: f64) -> &'static ReceiverProfile {
    if gnss_hz >= 5.0 { &UBLOX_10HZ } else { &LOGGER_1HZ }
}
