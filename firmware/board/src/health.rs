//! The device's health, visible from outside: what the firmware says about itself on CAN once a
//! second (`GNSS_GUARD_STATUS` in `profiles/gnss_guard.dbc`) and when it may feed its watchdog.
//! Plain logic on the device's clock (seconds), so the host tests, the QEMU run and the firmware
//! share it. The alarm frames' way to the bus is [`crate::outbox`].
//!
//! - [`Health`] follows the pipeline: fixes received, verdicts, counters. [`Health::state`] is
//!   one of [`State`]: a dead device (no status frame at all) and a blind one (status frames
//!   saying `blind`) are told apart from a quiet healthy one (`running`, no alarm frame).
//! - [`WatchdogGate`] says when the watchdog may be fed: only while the detector makes progress
//!   (an epoch within [`LIVE_S`]) or GNSS is silent and the last status frame said `blind`. A
//!   detector loop that hangs, or a pipeline that receives fixes but stops producing epochs, is
//!   reset by the watchdog.

use crate::can::ours::*;
use crate::can::Field;
use detector_core::fusion::Verdict;
use detector_core::strategy::StrategySet;
use detector_core::time::before;

/// Seconds between status frames (pages 0, 1 and 2 together).
pub const STATUS_PERIOD_S: f64 = 1.0;
/// No GNSS fix received for longer than this: the device is blind (the detector restarts after
/// an epoch this long anyway), seconds.
pub const BLIND_AFTER_S: f64 = 3.0;
/// The detector counts as making progress while its last epoch is at most this old (a 1 Hz
/// receiver with a dropped fix, plus the synchroniser's latency of up to 1 s), seconds.
pub const LIVE_S: f64 = 5.0;

/// What the device is doing, in the priority the status frame reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// Start-up: a strategy is still learning (the receiver settling, the car's scale and gyro
    /// bias being learnt).
    Learning = 0,
    /// Every strategy with inputs runs.
    Running = 1,
    /// Some strategy lacks its inputs (a vehicle signal stale or missing).
    Degraded = 2,
    /// The alarm is latched.
    Alarm = 3,
    /// No GNSS fix for more than [`BLIND_AFTER_S`]: nothing can be judged.
    Blind = 4,
}

impl State {
    pub fn from_u8(x: u8) -> Option<State> {
        Some(match x {
            0 => State::Learning,
            1 => State::Running,
            2 => State::Degraded,
            3 => State::Alarm,
            4 => State::Blind,
            _ => return None,
        })
    }
    pub const fn name(self) -> &'static str {
        match self {
            State::Learning => "learning",
            State::Running => "running",
            State::Degraded => "degraded",
            State::Alarm => "alarm",
            State::Blind => "blind",
        }
    }
}

/// Start-up faults (status page 2, `FAULTS`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Faults(pub u8);

impl Faults {
    pub const CAN_START: u8 = 1;
    pub const UART_START: u8 = 2;
    pub const MODEL_INVALID: u8 = 4;
    pub const TEMPLATES_INVALID: u8 = 8;
    /// The stored calibration record was invalid: ignored, the car is learnt afresh.
    pub const CALIBRATION_INVALID: u8 = 16;
    /// The calibration store (flash) failed.
    pub const CALIBRATION_STORE: u8 = 32;
    pub fn set(&mut self, bit: u8) {
        self.0 |= bit;
    }
}

/// The track check's calibration (status page 2, `CALIBRATION`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Calibration {
    /// A first drive: the car is being learnt.
    #[default]
    Learning = 0,
    /// Learnt in this drive.
    Learnt = 1,
    /// From the record in flash.
    Stored = 2,
    /// This drive contradicts the stored record (kept until a relearn request).
    Contradicted = 3,
}

/// Why the device last reset (status page 2, `RESET_CAUSE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ResetCause {
    #[default]
    PowerOn = 0,
    IndependentWatchdog = 1,
    WindowWatchdog = 2,
    Software = 3,
    Pin = 4,
    LowPower = 5,
    Unknown = 15,
}

/// Counters of things that went wrong outside the detector. Each saturates at `u32::MAX` (and
/// at its field's width on the wire).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub can_dropped: u32,
    pub can_overruns: u32,
    pub nmea_errors: u32,
    pub alarm_retries: u32,
    pub detector_restarts: u32,
    pub restarts: u32,
}

/// The health of the pipeline, on the device's clock (seconds).
#[derive(Clone, Debug, Default)]
pub struct Health {
    last_fix_t: Option<f64>,
    last_epoch_t: Option<f64>,
    epochs: u32,
    ran: StrategySet,
    degraded: StrategySet,
    learning: bool,
    alarm: bool,
    receiver_spoofing: bool,
    calibration: Calibration,
    /// The detector started from a stored calibration record (see [`Health::set_calibration_stored`]).
    calibration_stored: bool,
    next_status_t: Option<f64>,
    /// A poll after this (and before `next_status_t`) is certainly within the period of it: one
    /// comparison instead of a soft-float subtraction per poll (see [`Health::status_due`]).
    quiet_after: f64,
    last_status: Option<(f64, State)>,
    pub faults: Faults,
    pub reset_cause: ResetCause,
    pub counters: Counters,
}

/// The three status frames of one period.
pub type StatusFrames = [(u16, [u8; 8]); 3];

pub(crate) fn put(f: &Field, d: &mut [u8; 8], v: u64, bits: u32) {
    let max = if bits >= 64 { u64::MAX } else { (1u64 << bits) - 1 };
    let _ = f.put_raw(d, v.min(max) as i64);
}

fn sat(v: u32, bits: u32) -> u64 {
    (v as u64).min((1u64 << bits) - 1)
}

impl Health {
    /// A GNSS fix was received at `now`.
    pub fn on_fix(&mut self, now: f64) {
        if now.is_finite() {
            self.last_fix_t = Some(now);
        }
    }

    /// The detector produced a verdict at `now`.
    /// The detector (re)started from a stored record, or without one: the state says so from
    /// the first status on, before the track check's first outcome.
    pub fn set_calibration_stored(&mut self, stored: bool) {
        self.calibration_stored = stored;
        self.calibration = if stored { Calibration::Stored } else { Calibration::Learning };
    }

    pub fn on_verdict(&mut self, v: &Verdict, now: f64) {
        self.epochs = self.epochs.wrapping_add(1);
        if now.is_finite() {
            self.last_epoch_t = Some(now);
        }
        self.ran = v.ran;
        self.degraded = v.degraded;
        self.learning = v.learning;
        self.alarm = v.alarm;
        use detector_core::fusion::Reason;
        self.receiver_spoofing = v.reasons.contains(Reason::ReceiverSpoofing);
        if let Some(t) = v.track {
            self.calibration = if t.contradiction.is_some() {
                Calibration::Contradicted
            } else if !t.calibrated {
                Calibration::Learning
            } else if self.calibration_stored {
                Calibration::Stored
            } else {
                Calibration::Learnt
            };
        }
        if v.reasons.contains(Reason::TimeDiscontinuity) || v.reasons.contains(Reason::InvalidSample) {
            self.counters.detector_restarts = self.counters.detector_restarts.saturating_add(1);
        }
    }

    /// The latched alarm was cleared.
    pub fn on_clear(&mut self) {
        self.alarm = false;
    }

    pub fn epochs(&self) -> u32 {
        self.epochs
    }

    /// The calibration as the last verdict said.
    pub fn calibration(&self) -> Calibration {
        self.calibration
    }

    /// Seconds since the last fix at `now`, or `None` before the first.
    pub fn fix_age_s(&self, now: f64) -> Option<f64> {
        self.last_fix_t.map(|t| (now - t).max(0.0))
    }

    /// The state at `now`.
    pub fn state(&self, now: f64) -> State {
        if self.alarm {
            State::Alarm
        } else if self.fix_age_s(now).is_none_or(|a| a.is_nan() || a > BLIND_AFTER_S) {
            State::Blind
        } else if self.learning {
            State::Learning
        } else if !self.degraded.is_empty() {
            State::Degraded
        } else {
            State::Running
        }
    }

    /// The detector made progress recently: an epoch within [`LIVE_S`] of `now`.
    pub fn live(&self, now: f64) -> bool {
        self.last_epoch_t.is_some_and(|t| now - t <= LIVE_S && now >= t)
    }

    /// The state the last status frame reported, and when.
    pub fn last_status(&self) -> Option<(f64, State)> {
        self.last_status
    }

    /// The status frames when one period has passed since the last ones (the first at once).
    pub fn status_due(&mut self, now: f64) -> Option<StatusFrames> {
        if !now.is_finite() {
            return None;
        }
        if let Some(t) = self.next_status_t {
            // Within the period: nothing owed. Asked after every CAN frame, so the common case
            // is integer compares (`before`); the soft-float subtraction only where that cannot
            // tell. Time going backwards (a clock reset) restarts the period.
            if before(now, t) && before(self.quiet_after, now) {
                return None;
            }
            if now < t && t - now <= STATUS_PERIOD_S {
                return None;
            }
        }
        // On the period's grid (a late poll does not shift it), unless a whole period was missed.
        let next = match self.next_status_t {
            Some(t) if now >= t && now - t < STATUS_PERIOD_S => t + STATUS_PERIOD_S,
            _ => now + STATUS_PERIOD_S,
        };
        self.next_status_t = Some(next);
        // `now > next - P + 1 ms` implies `next - now < P` exactly while the rounding stays
        // under 1 ms (|next| < 1e12 s); beyond that the exact test always runs.
        self.quiet_after = if libm::fabs(next) < 1e12 { next - STATUS_PERIOD_S + 1e-3 } else { f64::INFINITY };
        let state = self.state(now);
        self.last_status = Some((now, state));
        Some(self.frames(now, state))
    }

    fn frames(&self, now: f64, state: State) -> StatusFrames {
        let c = &self.counters;
        let mut p0 = [0u8; 8];
        put(&STATUS_PAGE, &mut p0, STATUS_STATE_MUX, 4);
        put(&STATUS_STATE, &mut p0, state as u64, 4);
        put(&STATUS_RAN, &mut p0, self.ran.0 as u64, 8);
        put(&STATUS_DEGRADED, &mut p0, self.degraded.0 as u64, 8);
        let age = self.fix_age_s(now).map_or(u64::MAX, |a| libm::round(a * 10.0) as u64);
        put(&STATUS_FIX_AGE, &mut p0, age, 16);
        put(&STATUS_EPOCHS, &mut p0, (self.epochs & 0xFF_FFFF) as u64, 24);
        let mut p1 = [0u8; 8];
        put(&STATUS_PAGE, &mut p1, STATUS_CAN_DROPPED_MUX, 4);
        put(&STATUS_CAN_DROPPED, &mut p1, sat(c.can_dropped, 16), 16);
        put(&STATUS_CAN_OVERRUNS, &mut p1, sat(c.can_overruns, 16), 16);
        put(&STATUS_NMEA_ERRORS, &mut p1, sat(c.nmea_errors, 16), 16);
        put(&STATUS_RESTARTS, &mut p1, sat(c.restarts, 8), 8);
        let mut p2 = [0u8; 8];
        put(&STATUS_PAGE, &mut p2, STATUS_FAULTS_MUX, 4);
        put(&STATUS_FAULTS, &mut p2, self.faults.0 as u64, 8);
        put(&STATUS_RESET_CAUSE, &mut p2, self.reset_cause as u64, 4);
        put(&STATUS_ALARM_RETRIES, &mut p2, sat(c.alarm_retries, 16), 16);
        put(&STATUS_DETECTOR_RESTARTS, &mut p2, sat(c.detector_restarts, 16), 16);
        put(&STATUS_RECEIVER_SPOOFING, &mut p2, self.receiver_spoofing as u64, 1);
        put(&STATUS_CALIBRATION, &mut p2, self.calibration as u64, 2);
        [(STATUS_ID, p0), (STATUS_ID, p1), (STATUS_ID, p2)]
    }
}

/// A status frame decoded through the DBC's fields (what a receiver on the bus sees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StatusPage {
    Page0 { state: Option<State>, ran: u8, degraded: u8, fix_age_s: Option<f64>, epochs: u32 },
    Page1 { can_dropped: u16, can_overruns: u16, nmea_errors: u16, restarts: u8 },
    Page2 { faults: u8, reset_cause: u8, alarm_retries: u16, detector_restarts: u16, receiver_spoofing: bool, calibration: u8 },
}

/// Decodes a status frame, or `None` for another id, a short frame or an unknown page.
pub fn decode_status(id: u16, data: &[u8]) -> Option<StatusPage> {
    if id != STATUS_ID {
        return None;
    }
    let raw = |f: &Field| f.raw(data).map(|v| v as u64);
    let page = raw(&STATUS_PAGE)?;
    Some(if page == STATUS_STATE_MUX {
        let age = raw(&STATUS_FIX_AGE)?;
        StatusPage::Page0 {
            state: State::from_u8(raw(&STATUS_STATE)? as u8),
            ran: raw(&STATUS_RAN)? as u8,
            degraded: raw(&STATUS_DEGRADED)? as u8,
            fix_age_s: (age != 0xFFFF).then_some(age as f64 * STATUS_FIX_AGE.factor),
            epochs: raw(&STATUS_EPOCHS)? as u32,
        }
    } else if page == STATUS_CAN_DROPPED_MUX {
        StatusPage::Page1 {
            can_dropped: raw(&STATUS_CAN_DROPPED)? as u16,
            can_overruns: raw(&STATUS_CAN_OVERRUNS)? as u16,
            nmea_errors: raw(&STATUS_NMEA_ERRORS)? as u16,
            restarts: raw(&STATUS_RESTARTS)? as u8,
        }
    } else if page == STATUS_FAULTS_MUX {
        StatusPage::Page2 {
            faults: raw(&STATUS_FAULTS)? as u8,
            reset_cause: raw(&STATUS_RESET_CAUSE)? as u8,
            alarm_retries: raw(&STATUS_ALARM_RETRIES)? as u16,
            detector_restarts: raw(&STATUS_DETECTOR_RESTARTS)? as u16,
            receiver_spoofing: raw(&STATUS_RECEIVER_SPOOFING)? != 0,
            calibration: raw(&STATUS_CALIBRATION)? as u8,
        }
    } else {
        return None;
    })
}

/// When the watchdog may be fed. See the module documentation.
#[derive(Clone, Copy, Debug, Default)]
pub struct WatchdogGate {
    refused: u32,
}

impl WatchdogGate {
    /// Whether the detector loop, running at `now`, may feed the watchdog: the detector made
    /// progress (an epoch within [`LIVE_S`]), or GNSS is silent (no fix for over
    /// [`BLIND_AFTER_S`]) and the status frame of the last period reported it as blind.
    pub fn may_feed(&mut self, h: &Health, now: f64) -> bool {
        let reported_blind = h.state(now) == State::Blind
            && h.last_status().is_some_and(|(t, s)| s == State::Blind && now >= t && now - t <= 2.0 * STATUS_PERIOD_S);
        let ok = h.live(now) || reported_blind;
        if !ok {
            self.refused = self.refused.saturating_add(1);
        }
        ok
    }
    /// Calls that refused to feed.
    pub fn refused(&self) -> u32 {
        self.refused
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use detector_core::fusion::{Reasons, Verdict};
    use detector_core::strategy::StrategyId;

    pub(crate) fn verdict(epoch: u32, fired: Option<StrategyId>, alarm: bool) -> Verdict {
        let mut v = Verdict {
            epoch,
            t: epoch as f64 * 0.1,
            ran: StrategySet::EMPTY,
            fired: StrategySet::EMPTY,
            degraded: StrategySet::EMPTY,
            reasons: Reasons::default(),
            shift: None,
            motion: None,
            turn: None,
            turn_heading: None,
            track: None,
            learning: false,
            alarm,
            first_alarm: None,
        };
        v.ran.insert(StrategyId::LocationShift);
        v.ran.insert(StrategyId::Motion);
        if let Some(s) = fired {
            v.fired.insert(s);
        }
        v
    }

    #[test]
    fn status_frames_round_trip_through_the_dbc_fields() {
        let mut h = Health::default();
        h.on_fix(10.0);
        h.on_verdict(&verdict(7, None, false), 10.05);
        h.counters.can_dropped = 70_000;
        h.counters.nmea_errors = 12;
        h.faults.set(Faults::UART_START);
        h.reset_cause = ResetCause::IndependentWatchdog;
        let f = h.status_due(10.5).unwrap();
        assert!(h.status_due(11.0).is_none(), "one period between status frames");
        assert!(h.status_due(11.5).is_some());
        match decode_status(f[0].0, &f[0].1).unwrap() {
            StatusPage::Page0 { state, ran, fix_age_s, epochs, .. } => {
                assert_eq!(state, Some(State::Running));
                assert_eq!(ran, 0b101);
                assert!((fix_age_s.unwrap() - 0.5).abs() < 1e-9);
                assert_eq!(epochs, 1);
            }
            p => panic!("{p:?}"),
        }
        assert_eq!(decode_status(f[1].0, &f[1].1), Some(StatusPage::Page1 { can_dropped: 0xFFFF, can_overruns: 0, nmea_errors: 12, restarts: 0 }));
        assert_eq!(decode_status(f[2].0, &f[2].1), Some(StatusPage::Page2 { faults: Faults::UART_START, reset_cause: 1, alarm_retries: 0, detector_restarts: 0, receiver_spoofing: false, calibration: 0 }));
        assert_eq!(decode_status(f[0].0, &f[0].1[..3]), None, "a short frame decodes to nothing, no panic");
    }

    #[test]
    fn states_in_priority_order() {
        let mut h = Health::default();
        assert_eq!(h.state(0.0), State::Blind, "no fix yet");
        h.on_fix(1.0);
        let mut v = verdict(1, None, false);
        v.learning = true;
        h.on_verdict(&v, 1.0);
        assert_eq!(h.state(1.5), State::Learning);
        v.learning = false;
        v.degraded.insert(StrategyId::Turn);
        h.on_verdict(&v, 2.0);
        assert_eq!(h.state(2.5), State::Degraded);
        assert_eq!(h.state(10.0), State::Blind, "fixes stopped 9 s ago");
        h.on_verdict(&verdict(3, Some(StrategyId::Motion), true), 10.0);
        assert_eq!(h.state(10.0), State::Alarm, "the alarm outranks blindness");
        h.on_clear();
        assert_eq!(h.state(10.0), State::Blind);
    }

    #[test]
    fn the_watchdog_is_fed_only_on_progress_or_reported_blindness() {
        let mut h = Health::default();
        let mut g = WatchdogGate::default();
        // Power-up, nothing yet: blind, but not fed until a status frame said so.
        assert!(!g.may_feed(&h, 0.5));
        assert!(h.status_due(0.5).is_some());
        assert!(g.may_feed(&h, 0.6), "blind and reported");
        // Fixes and epochs: fed.
        for k in 0..50 {
            let t = 1.0 + k as f64 * 0.1;
            h.on_fix(t);
            h.on_verdict(&verdict(k, None, false), t + 0.01);
            let _ = h.status_due(t);
            assert!(g.may_feed(&h, t + 0.02));
        }
        // Fixes keep arriving but the pipeline stops producing epochs: a stall. Fed until the
        // last epoch is LIVE_S old, then refused (the watchdog resets the device).
        let mut refused_at = None;
        for k in 0..100 {
            let t = 6.0 + k as f64 * 0.1;
            h.on_fix(t);
            let _ = h.status_due(t);
            if !g.may_feed(&h, t) && refused_at.is_none() {
                refused_at = Some(t);
            }
        }
        let r = refused_at.expect("a stalled pipeline must not feed the watchdog");
        assert!((r - (5.91 + LIVE_S)).abs() < 0.15, "{r}");
        // GNSS silent instead: blind, reported every period, fed throughout.
        let mut h = Health::default();
        h.on_fix(1.0);
        h.on_verdict(&verdict(1, None, false), 1.0);
        let mut g = WatchdogGate::default();
        for k in 0..600 {
            let t = 1.0 + k as f64 * 0.1;
            let _ = h.status_due(t);
            assert!(g.may_feed(&h, t), "t {t}: silent GNSS reported as blind must keep the watchdog fed");
        }
        // Blind but the status frames stopped (their sender hangs): refused.
        assert!(!g.may_feed(&h, 70.0));
    }
}
