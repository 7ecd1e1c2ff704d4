//! The detector pipeline of the firmware: CAN frames and NMEA sentences in, verdicts out, and
//! the frames it owes the bus (alarm, status). The same code runs on the STM32, in QEMU and in
//! `host-sim digest`. Times are the device's clock, seconds.

use crate::can;
use crate::gnss::NmeaFixer;
use crate::ubx::UbxFixer;
use crate::health::{Faults, Health, StatusFrames};
use crate::outbox::{AlarmFrame, AlarmOutbox};
use crate::store::{Loaded, SavePolicy};
use detector_core::wire::calibration::Record;
use detector_core::fusion::{Config, Detector, Verdict};
use detector_core::sample::Sample;
use detector_core::strategy::location_shift::Predictor;
use detector_core::strategy::turn::TemplateSet;
use detector_core::sync::{SyncConfig, Synchronizer};
use detector_core::stage::{NoStopwatch, Stage, Stopwatch};

/// FNV-1a 64 over a canonical encoding of every verdict: equal digests mean equal decisions
/// (each strategy's ran, fired and degraded, the alarm, the reasons) and equal bits of strategy
/// 1's residual and threshold, strategy 3's disagreement and states and strategy 2's course
/// change, distance and mismatch. The track check's internals (its windows, velocity test and
/// calibration) and strategy 2's heading share are not in it: they reach the digest through the
/// decisions they make.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Digest(pub u64);

impl Default for Digest {
    fn default() -> Self {
        Digest(0xcbf2_9ce4_8422_2325)
    }
}

impl Digest {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn f32(&mut self, v: Option<f32>) {
        self.bytes(&v.map_or(u32::MAX, f32::to_bits).to_le_bytes());
    }
    pub fn add(&mut self, v: &Verdict) {
        self.bytes(&v.epoch.to_le_bytes());
        self.bytes(&v.t.to_bits().to_le_bytes());
        self.bytes(&[v.ran.0, v.fired.0, v.degraded.0, v.alarm as u8]);
        // The first 16 reasons as two bytes (the digest of every drive without the later ones is
        // unchanged); later reasons only when present.
        self.bytes(&(v.reasons.0 as u16).to_le_bytes());
        if v.reasons.0 >> 16 != 0 {
            self.bytes(&((v.reasons.0 >> 16) as u16).to_le_bytes());
        }
        self.f32(v.shift.map(|s| s.residual_m));
        self.f32(v.shift.map(|s| s.threshold_m));
        self.f32(v.motion.map(|m| m.disagree_s));
        self.bytes(&[v.motion.map_or(9, |m| m.wheel as u8), v.motion.map_or(9, |m| m.gnss as u8)]);
        self.f32(v.turn.map(|t| t.gnss_change_deg));
        self.f32(v.turn.map(|t| t.distance));
        self.bytes(&[v.turn.and_then(|t| t.mismatch).map_or(9, |m| m as u8)]);
    }
}

/// Everything between the receive tasks and the CAN transmitter.
pub struct Pipeline<'t> {
    sync: Synchronizer,
    det: Detector<'t, Predictor<'t>>,
    pub nmea: NmeaFixer,
    /// UBX fixes and the receiver's spoofing state. Once a NAV-PVT fix has come, NMEA fixes
    /// are left out (the receiver sends both for the same epoch; NAV-PVT is the finer one).
    pub ubx: UbxFixer,
    pub digest: Digest,
    /// Epochs judged and CAN frames received since start (each wraps at `u32::MAX`).
    pub epochs: u32,
    pub frames: u32,
    pub health: Health,
    pub alarm: AlarmOutbox,
    /// Clear requests honoured.
    pub clears: u32,
    /// UART errors and lines the splitter dropped (the firmware's GNSS task reports them).
    pub uart_errors: u32,
    /// When to keep the calibration, and the record waiting to be kept (take it with
    /// [`Pipeline::take_calibration`]).
    save: SavePolicy,
    to_save: Option<Record>,
    /// A relearn request came: the store must forget the record (take with
    /// [`Pipeline::take_forget`]).
    forget: bool,
}

/// What the pipeline owes the bus at one moment.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outgoing {
    pub alarm: Option<AlarmFrame>,
    pub status: Option<StatusFrames>,
}

impl<'t> Pipeline<'t> {
    /// The full pipeline; without templates strategy 2 is left out. `cfg.shift` must carry the
    /// predictor's error term ([`Config::for_predictor`]).
    pub fn new(cfg: Config, templates: Option<TemplateSet<'t>>, predictor: Predictor<'t>) -> Self {
        let det = Detector::new(cfg, predictor);
        Self {
            sync: Synchronizer::new(SyncConfig::default()),
            det: match templates {
                Some(t) => det.with_turns(t),
                None => det,
            },
            nmea: NmeaFixer::default(),
            ubx: UbxFixer::default(),
            digest: Digest::default(),
            epochs: 0,
            frames: 0,
            health: Health::default(),
            alarm: AlarmOutbox::default(),
            clears: 0,
            uart_errors: 0,
            save: SavePolicy::default(),
            to_save: None,
            forget: false,
        }
    }

    /// Starts the detector from what the store held: a record (calibrated from the first epoch),
    /// nothing (the car is learnt), or bytes that are not a record (ignored and reported:
    /// status fault `CALIBRATION_INVALID`), or a flash that failed (`CALIBRATION_STORE`).
    pub fn calibrate(&mut self, loaded: &Loaded) {
        let record = match loaded {
            Loaded::Record(r) if r.plausible().is_ok() => Some(r),
            Loaded::Record(_) | Loaded::Invalid(_) => {
                self.health.faults.set(Faults::CALIBRATION_INVALID);
                None
            }
            Loaded::FlashError => {
                self.health.faults.set(Faults::CALIBRATION_STORE);
                None
            }
            Loaded::None => None,
        };
        self.health.set_calibration_stored(record.is_some());
        self.det.set_calibration(record);
    }

    /// The record to keep now, once (the car stood, no alarm, spaced: see [`SavePolicy`]).
    pub fn take_calibration(&mut self) -> Option<Record> {
        self.to_save.take()
    }

    /// Whether a relearn request asks the store to forget the record, once.
    pub fn take_forget(&mut self) -> bool {
        core::mem::take(&mut self.forget)
    }

    /// The store failed to keep or forget the record (status fault `CALIBRATION_STORE`).
    pub fn store_failed(&mut self) {
        self.health.faults.set(Faults::CALIBRATION_STORE);
    }

    /// This pipeline made afresh for another run, in place: part by part, so that no whole
    /// pipeline (31 KB) is built on the stack to be copied in (the QEMU image keeps one in static
    /// memory and runs every scenario in it).
    pub fn restart(&mut self, cfg: Config, templates: Option<TemplateSet<'t>>, predictor: Predictor<'t>) {
        self.sync = Synchronizer::new(SyncConfig::default());
        self.det.reinit(cfg, predictor, templates);
        self.nmea = NmeaFixer::default();
        self.ubx = UbxFixer::default();
        self.digest = Digest::default();
        self.epochs = 0;
        self.frames = 0;
        self.health = Health::default();
        self.alarm = AlarmOutbox::default();
        self.clears = 0;
        self.uart_errors = 0;
        self.save = SavePolicy::default();
        self.to_save = None;
        self.forget = false;
    }

    /// One received CAN frame (standard id) at time `t`, seconds. Our clear request clears
    /// the latched alarm.
    pub fn on_can(&mut self, t: f64, id: u32, data: &[u8], out: &mut impl FnMut(&Verdict)) {
        self.on_can_timed(t, id, data, out, &mut NoStopwatch)
    }

    /// [`Pipeline::on_can`], telling `w` where each stage ends (the QEMU run's breakdown).
    pub fn on_can_timed<W: Stopwatch + ?Sized>(&mut self, t: f64, id: u32, data: &[u8], out: &mut impl FnMut(&Verdict), w: &mut W) {
        self.frames = self.frames.wrapping_add(1);
        if can::is_clear_request(id, data) {
            self.det.clear_alarm();
            self.alarm.clear();
            self.health.on_clear();
            self.clears = self.clears.wrapping_add(1);
            return;
        }
        if can::is_relearn_request(id, data) {
            // The stored calibration forgotten, here and in the store: the car is learnt
            // afresh (the only way a stored record is ever replaced by a contradicting drive).
            self.det.set_calibration(None);
            self.health.set_calibration_stored(false);
            self.forget = true;
            self.to_save = None;
            return;
        }
        let Self { sync, det, digest, epochs, health, alarm, save, to_save, .. } = self;
        let mut keep = Keep { policy: save, record: to_save };
        for (sig, v) in can::decode(id, data) {
            w.lap(Stage::CanDecode);
            sync.push_obs(sig, t, v, &mut |s: &Sample| judge(det, digest, epochs, health, alarm, &mut keep, t, out, s, w));
            w.lap(Stage::Sync);
        }
        w.lap(Stage::CanDecode);
    }

    /// One NMEA sentence received at time `t`, seconds.
    pub fn on_nmea(&mut self, t: f64, line: &[u8], out: &mut impl FnMut(&Verdict)) {
        self.on_nmea_timed(t, line, out, &mut NoStopwatch)
    }

    /// [`Pipeline::on_nmea`], telling `w` where each stage ends (the QEMU run's breakdown).
    pub fn on_nmea_timed<W: Stopwatch + ?Sized>(&mut self, t: f64, line: &[u8], out: &mut impl FnMut(&Verdict), w: &mut W) {
        let fix = self.nmea.line(t, line).filter(|_| self.ubx.fixes == 0);
        let c = self.nmea.counters;
        self.health.counters.nmea_errors = c.rejected.saturating_add(c.overlong).saturating_add(self.uart_errors);
        w.lap(Stage::NmeaParse);
        let Some(fix) = fix else { return };
        self.push_fix(t, fix, out, w);
    }

    /// One checked UBX frame (class, id, payload) received at time `t`, seconds: NAV-PVT gives a
    /// fix (stamped `t`, as NMEA fixes are), NAV-STATUS the receiver's spoofing flag.
    pub fn on_ubx(&mut self, t: f64, class: u8, id: u8, payload: &[u8], out: &mut impl FnMut(&Verdict)) {
        let fix = self.ubx.frame(Some(t), crate::ubx::Frame { class, id, payload });
        let Some(fix) = fix else { return };
        self.push_fix(t, fix, out, &mut NoStopwatch);
    }

    fn push_fix<W: Stopwatch + ?Sized>(&mut self, t: f64, fix: detector_core::sample::Fix, out: &mut impl FnMut(&Verdict), w: &mut W) {
        self.health.on_fix(t);
        let Self { sync, det, digest, epochs, health, alarm, save, to_save, .. } = self;
        let mut keep = Keep { policy: save, record: to_save };
        sync.push_fix(fix, &mut |s: &Sample| judge(det, digest, epochs, health, alarm, &mut keep, t, out, s, w));
        w.lap(Stage::Sync);
    }

    /// Emits what is pending (end of a replay), at time `t`.
    pub fn finish(&mut self, t: f64, out: &mut impl FnMut(&Verdict)) {
        let Self { sync, det, digest, epochs, health, alarm, save, to_save, .. } = self;
        let mut keep = Keep { policy: save, record: to_save };
        sync.flush(&mut |s: &Sample| judge(det, digest, epochs, health, alarm, &mut keep, t, out, s, &mut NoStopwatch));
    }

    /// What is owed to the bus at `now`: an alarm frame (pending, or the latched alarm's
    /// repeat) and, once a period, the status frames. Report the alarm frame's fate with
    /// [`AlarmOutbox::sent`] or [`AlarmOutbox::failed`] on `self.alarm`.
    pub fn poll(&mut self, now: f64) -> Outgoing {
        self.health.counters.alarm_retries = self.alarm.retries;
        Outgoing { alarm: self.alarm.next(now), status: self.health.status_due(now) }
    }
}

/// The save policy and the record it holds for the store.
struct Keep<'a> {
    policy: &'a mut SavePolicy,
    record: &'a mut Option<Record>,
}

/// One synchronised sample through the detector into the digest, the health, the alarm outbox
/// and the save policy, and out. The time before it belongs to the synchroniser that emitted the
/// sample.
#[allow(clippy::too_many_arguments)]
fn judge<W: Stopwatch + ?Sized>(
    det: &mut Detector<'_, Predictor<'_>>,
    digest: &mut Digest,
    epochs: &mut u32,
    health: &mut Health,
    alarm: &mut AlarmOutbox,
    keep: &mut Keep<'_>,
    now: f64,
    out: &mut impl FnMut(&Verdict),
    s: &Sample,
    w: &mut W,
) {
    w.lap(Stage::Sync);
    let v = det.step_timed(s, w);
    digest.add(&v);
    *epochs = epochs.wrapping_add(1);
    health.on_verdict(&v, now);
    alarm.on_verdict(&v);
    // Asked of the detector only when the policy says so (the car has stood for seconds); the
    // stored record written back if this drive contradicts it after a save of its own.
    if let Some(r) = keep.policy.keep(now, &v, det) {
        *keep.record = Some(r);
    }
    out(&v);
    w.lap(Stage::Output);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::{decode_status, StatusPage};
    use crate::store::Loaded;
    use detector_core::fusion::{Reason, Reasons, Verdict};
    use detector_core::profile::LOGGER_1HZ;
    use detector_core::strategy::location_shift::KinematicPredictor;
    use detector_core::strategy::StrategySet;
    use detector_core::wire::calibration::RecordError;

    fn pipeline() -> Pipeline<'static> {
        Pipeline::new(Config::for_profile(&LOGGER_1HZ), None, Predictor::Kinematic(KinematicPredictor::default()))
    }

    fn page2(p: &mut Pipeline<'_>) -> StatusPage {
        let f = p.poll(0.0).status.unwrap();
        decode_status(f[2].0, &f[2].1).unwrap()
    }

    #[test]
    fn a_bad_record_is_reported_and_a_relearn_request_forgets() {
        let mut p = pipeline();
        p.calibrate(&Loaded::Invalid(RecordError::BadMagic));
        assert!(matches!(page2(&mut p), StatusPage::Page2 { faults, calibration: 0, .. } if faults & Faults::CALIBRATION_INVALID != 0));
        let mut p = pipeline();
        p.calibrate(&Loaded::FlashError);
        assert!(matches!(page2(&mut p), StatusPage::Page2 { faults, .. } if faults & Faults::CALIBRATION_STORE != 0));
        // A relearn request: forgotten, and the store told once.
        let (id, d) = can::relearn_request();
        p.on_can(1.0, id as u32, &d, &mut |_| {});
        assert!(p.take_forget() && !p.take_forget());
        // A clear request is not a relearn request.
        let (id, d) = can::clear_request();
        p.on_can(2.0, id as u32, &d, &mut |_| {});
        assert!(!p.take_forget());
    }

    #[test]
    fn the_new_reasons_reach_the_alarm_frame() {
        let mut reasons = Reasons::default();
        reasons.insert(Reason::Track10s);
        reasons.insert(Reason::VelocityAlong);
        reasons.insert(Reason::CalibrationContradicted);
        let v = Verdict {
            epoch: 3,
            t: 0.0,
            ran: StrategySet::EMPTY,
            fired: StrategySet(8),
            degraded: StrategySet::EMPTY,
            reasons,
            shift: None,
            motion: None,
            turn: None,
            turn_heading: None,
            track: None,
            learning: false,
            alarm: true,
            first_alarm: None,
        };
        let (id, d) = AlarmFrame::of(&v).encode();
        let f = AlarmFrame::decode(id, &d).unwrap();
        assert_eq!(f.reasons, 1 << Reason::Track10s as u32);
        // Reason 17 is bit 0, reason 19 bit 2.
        assert_eq!(f.extra_reasons, 0b101);
    }
}
