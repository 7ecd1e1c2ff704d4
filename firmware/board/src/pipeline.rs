//! The detector pipeline of the firmware: CAN frames and NMEA sentences in, verdicts out, and
//! the frames it owes the bus (alarm, status). The same code runs on the STM32, in QEMU and in
//! `host-sim digest`. Times are the device's clock, seconds.

use crate::can;
use crate::gnss::NmeaFixer;
use crate::ubx::UbxFixer;
use crate::health::{AlarmFrame, AlarmOutbox, Health, StatusFrames};
use detector_core::fusion::{Config, Detector, Verdict};
use detector_core::sample::Sample;
use detector_core::strategy::location_shift::Predictor;
use detector_core::strategy::turn::TemplateSet;
use detector_core::sync::{SyncConfig, Synchronizer};
use detector_core::stage::{NoStopwatch, Stage, Stopwatch};

/// FNV-1a 64 over a canonical encoding of every verdict: equal digests mean equal verdict
/// streams, down to the bits of every residual and threshold.
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
        }
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
        let Self { sync, det, digest, epochs, health, alarm, .. } = self;
        for (sig, v) in can::decode(id, data) {
            w.lap(Stage::CanDecode);
            sync.push_obs(sig, t, v, &mut |s: &Sample| judge(det, digest, epochs, health, alarm, t, out, s, w));
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
        let Self { sync, det, digest, epochs, health, alarm, .. } = self;
        sync.push_fix(fix, &mut |s: &Sample| judge(det, digest, epochs, health, alarm, t, out, s, w));
        w.lap(Stage::Sync);
    }

    /// Emits what is pending (end of a replay), at time `t`.
    pub fn finish(&mut self, t: f64, out: &mut impl FnMut(&Verdict)) {
        let Self { sync, det, digest, epochs, health, alarm, .. } = self;
        sync.flush(&mut |s: &Sample| judge(det, digest, epochs, health, alarm, t, out, s, &mut NoStopwatch));
    }

    /// What is owed to the bus at `now`: an alarm frame (pending, or the latched alarm's
    /// repeat) and, once a period, the status frames. Report the alarm frame's fate with
    /// [`AlarmOutbox::sent`] or [`AlarmOutbox::failed`] on `self.alarm`.
    pub fn poll(&mut self, now: f64) -> Outgoing {
        self.health.counters.alarm_retries = self.alarm.retries;
        Outgoing { alarm: self.alarm.next(now), status: self.health.status_due(now) }
    }
}

/// One synchronised sample through the detector into the digest, the health and the alarm
/// outbox, and out. The time before it belongs to the synchroniser that emitted the sample.
#[allow(clippy::too_many_arguments)]
fn judge<W: Stopwatch + ?Sized>(
    det: &mut Detector<'_, Predictor<'_>>,
    digest: &mut Digest,
    epochs: &mut u32,
    health: &mut Health,
    alarm: &mut AlarmOutbox,
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
    out(&v);
    w.lap(Stage::Output);
}
