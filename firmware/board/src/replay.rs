//! The compact replay input of the QEMU run and `host-sim digest`, and the scenario runner
//! both of them use.
//!
//! Little-endian layout:
//! ```text
//! "GGQI" | version u16 = 2 | scenarios u16 | can_count u32 | t0 f64
//! scenarios x ( name [u8; 16] (NUL-padded) | kind u32 (0 clean, 1 attack, 2 GNSS outage) |
//!               from_s f64 | until_s f64 (relative to t0: the attack's onset, or the outage;
//!               NaN where unused) | nmea_offset u32 | nmea_count u32 )
//! can_count x ( t_us u32 (since t0) | id u16 | len u8 | data [u8; 8] )
//! NMEA records at their offsets: ( t_us u32 | len u8 | bytes [len] )
//! ```
//! The CAN frames are shared by all scenarios (an attack rewrites only what the receiver says,
//! an outage removes its sentences).
//!
//! The runner replays a scenario through a fresh [`Pipeline`] in arrival order and, on the
//! replay's clock, does what the firmware's tasks do: polls the pipeline for the frames it owes
//! the bus, decodes them back through the DBC's fields (status and alarm, as a receiver on the
//! bus would), and asks the [`WatchdogGate`] every 0.5 s whether it may feed the watchdog.

use crate::health::{decode_status, State, StatusPage, WatchdogGate, BLIND_AFTER_S, STATUS_PERIOD_S};
use crate::outbox::AlarmFrame;
use crate::pipeline::{Digest, Pipeline};
use detector_core::wire::le::{f64 as f64_at, u16 as u16_at, u32 as u32_at};
use detector_core::fusion::{Config, Verdict};
use detector_core::strategy::location_shift::{Predictor, ShiftPredictor};
use detector_core::strategy::turn::TemplateSet;
use detector_core::stage::{NoStopwatch, Stage, Stopwatch};
use detector_core::wire::calibration::Record;

/// A stored calibration for the replayed car (the comma2k19 RAV4, 10 Hz): calibrated from the
/// first epoch, its delays' uncertainty from their fits (a first drive's first two minutes, all
/// that segment has, hold it at 0.5 s and skip that path). Plausible values for this car, not
/// learnt: the QEMU run measures a car's next drive's cost with it, and `host-sim live
/// --calibration` is checked against `detect --calibration` from it.
pub fn stored_record() -> Record {
    Record {
        scale: 1.0,
        delay_s: [0.0, 0.0],
        learnt_s: 3600.0,
        drives: 4,
        gyro_bias_degps: 0.0,
        gyro_bias_weight_s: 10.0,
        gyro_scale_error: 0.0,
        gyro_scale_sd: 0.01,
        noise_s0_m: [1.0; 2],
        noise_k: [0.01; 2],
        velocity_sigma_mps: [0.2; 2],
        nominal_dt_s: 0.1,
        anchor_scale: 1.0,
        anchor_delay_s: [0.0, 0.0],
        anchor_gyro_scale_error: 0.0,
        anchor_noise_s0_m: [1.0; 2],
        anchor_noise_k: [0.01; 2],
        anchor_velocity_sigma_mps: [0.2; 2],
    }
}

pub const MAGIC: &[u8; 4] = b"GGQI";
pub const VERSION: u16 = 2;
pub const HEADER: usize = 20;
pub const SCENARIO: usize = 16 + 4 + 8 + 8 + 4 + 4;
pub const CAN_RECORD: usize = 4 + 2 + 1 + 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputError {
    TooShort,
    BadMagic,
    BadVersion,
    OutOfBounds,
    BadKind,
}

/// What a scenario does to the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Clean = 0,
    /// A spoofing attack from `from_s`.
    Attack = 1,
    /// The receiver silent from `from_s` to `until_s`.
    GnssOutage = 2,
}

#[derive(Clone, Copy, Debug)]
pub struct Input<'a> {
    bytes: &'a [u8],
    scenarios: usize,
    can_count: usize,
    pub t0: f64,
}

#[derive(Clone, Copy, Debug)]
pub struct Scenario<'a> {
    pub name: &'a str,
    pub kind: Kind,
    /// Seconds after t0: the attack's onset or the outage's start; NaN for the clean run.
    pub from_s: f64,
    /// Seconds after t0: the outage's end; NaN otherwise.
    pub until_s: f64,
    nmea: &'a [u8],
    nmea_count: usize,
}

impl<'a> Input<'a> {
    pub fn parse(bytes: &'a [u8]) -> Result<Self, InputError> {
        if bytes.len() < HEADER {
            return Err(InputError::TooShort);
        }
        if bytes.get(..4) != Some(&MAGIC[..]) {
            return Err(InputError::BadMagic);
        }
        if u16_at(bytes, 4) != Some(VERSION) {
            return Err(InputError::BadVersion);
        }
        let scenarios = u16_at(bytes, 6).ok_or(InputError::TooShort)? as usize;
        let can_count = u32_at(bytes, 8).ok_or(InputError::TooShort)? as usize;
        let t0 = f64_at(bytes, 12).ok_or(InputError::TooShort)?;
        let can_end = (scenarios * SCENARIO).checked_add(can_count.checked_mul(CAN_RECORD).ok_or(InputError::OutOfBounds)?).and_then(|n| n.checked_add(HEADER));
        if can_end.is_none_or(|e| bytes.len() < e) {
            return Err(InputError::OutOfBounds);
        }
        let input = Input { bytes, scenarios, can_count, t0 };
        for i in 0..scenarios {
            input.scenario(i)?;
        }
        Ok(input)
    }

    pub fn scenarios(&self) -> usize {
        self.scenarios
    }

    pub fn scenario(&self, i: usize) -> Result<Scenario<'a>, InputError> {
        let b = self.bytes;
        let o = HEADER + i * SCENARIO;
        let raw = b.get(o..o + 16).ok_or(InputError::OutOfBounds)?;
        let n = raw.iter().position(|&c| c == 0).unwrap_or(16);
        let name = core::str::from_utf8(raw.get(..n).unwrap_or(&[])).unwrap_or("?");
        let kind = match u32_at(b, o + 16).ok_or(InputError::OutOfBounds)? {
            0 => Kind::Clean,
            1 => Kind::Attack,
            2 => Kind::GnssOutage,
            _ => return Err(InputError::BadKind),
        };
        let from_s = f64_at(b, o + 20).ok_or(InputError::OutOfBounds)?;
        let until_s = f64_at(b, o + 28).ok_or(InputError::OutOfBounds)?;
        let off = u32_at(b, o + 36).ok_or(InputError::OutOfBounds)? as usize;
        let count = u32_at(b, o + 40).ok_or(InputError::OutOfBounds)? as usize;
        let nmea = b.get(off..).ok_or(InputError::OutOfBounds)?;
        Ok(Scenario { name, kind, from_s, until_s, nmea, nmea_count: count })
    }

    fn can(&self, k: usize) -> Option<(u32, u32, &'a [u8])> {
        let o = HEADER + self.scenarios * SCENARIO + k * CAN_RECORD;
        let b = self.bytes;
        let len = (*b.get(o + 6)? as usize).min(8);
        Some((u32_at(b, o)?, u16_at(b, o + 4)? as u32, b.get(o + 7..o + 7 + len)?))
    }
}

/// What the status frames of a scenario said, decoded through the DBC's fields.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StatusLog {
    /// Status frames decoded (three pages per period).
    pub frames: u32,
    /// Bit `1 << state` for every state reported.
    pub states: u8,
    /// Periods reported blind after the first fix, and the longest fix age reported, seconds.
    pub blind_periods: u32,
    pub max_fix_age_s: f64,
    /// A page-0 frame whose epoch count differed from the pipeline's.
    pub epochs_mismatch: u32,
    /// Periods reporting `alarm` before the first alarm verdict (must stay 0).
    pub early_alarm_periods: u32,
    /// The state of the last status frame.
    pub last_state: Option<State>,
    /// Alarm frames handed to the transmitter, before the onset and in all.
    pub alarm_frames: u32,
    pub alarm_frames_early: u32,
    /// Alarm frames sent per second of latched alarm (the repeat).
    pub alarm_latched_s: f64,
    /// Times the watchdog gate refused to feed, after the first status frame.
    pub watchdog_refused: u32,
}

impl StatusLog {
    pub fn saw(&self, s: State) -> bool {
        self.states & (1 << s as u8) != 0
    }
}

/// What one scenario gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    pub epochs: u32,
    pub alarm_t: Option<f64>,
    /// Epochs from the onset to the first alarm (attacks only).
    pub alarm_after_epochs: Option<u32>,
    pub alarm_after_s: Option<f64>,
    /// Alarms before the onset (clean run and outage: all of them).
    pub early_alarms: u32,
    pub digest: Digest,
    pub frames: u32,
    pub rejected_sentences: u32,
    pub status: StatusLog,
    /// The longest single call into the pipeline (one frame or sentence in, and the poll after
    /// it), in `clock` units: how long the detector task holds the CPU in one go.
    pub longest_call: u32,
}

impl Outcome {
    /// Clean and outage: no alarm at all. Attack: no alarm before the onset and one within
    /// `max_s` after it, reported by alarm frames and in the status. Always: status frames
    /// every period that decode to the pipeline's own numbers, and the watchdog fed throughout.
    /// Outage: reported blind for the outage (less the time blindness takes to be declared),
    /// with the fix age growing, and back to judging after it.
    pub fn pass(&self, sc: &Scenario, max_s: f64) -> bool {
        let st = &self.status;
        let healthy = st.frames > 0 && st.epochs_mismatch == 0 && st.watchdog_refused == 0 && st.early_alarm_periods == 0;
        healthy
            && match sc.kind {
                Kind::Clean => self.alarm_t.is_none() && st.alarm_frames == 0 && st.blind_periods == 0 && !st.saw(State::Alarm),
                Kind::Attack => {
                    self.early_alarms == 0
                        && self.alarm_after_s.is_some_and(|s| s <= max_s)
                        && st.alarm_frames_early == 0
                        && st.saw(State::Alarm)
                        // Repeated once a second while latched.
                        && st.alarm_frames as f64 >= libm::floor(st.alarm_latched_s)
                }
                Kind::GnssOutage => {
                    let outage = sc.until_s - sc.from_s;
                    self.alarm_t.is_none()
                        && st.alarm_frames == 0
                        && st.blind_periods as f64 >= libm::floor(outage - BLIND_AFTER_S) - 1.0
                        && st.max_fix_age_s >= outage - 1.0
                        && st.last_state != Some(State::Blind)
                }
            }
    }
}

/// Replays scenario `i` through a fresh pipeline, in arrival order. `clock` returns a running
/// cost counter (SysTick on the target, anything on the host); `cost` receives, for every epoch,
/// what the pipeline's calls (CAN frames, NMEA sentences, the poll for outgoing frames) took
/// since the previous epoch: everything the firmware did for it, and nothing of the replay's
/// own loop and checks.
pub fn run<'t>(
    input: &Input,
    i: usize,
    cfg: Config,
    templates: TemplateSet<'t>,
    predictor: &Predictor<'t>,
    clock: &mut dyn FnMut() -> u32,
    cost: &mut dyn FnMut(u32),
) -> Result<Outcome, InputError> {
    run_timed(input, i, cfg, templates, predictor, clock, cost, &mut NoStopwatch)
}

/// [`run`], telling `w` where each stage of the pipeline ends (the QEMU run's breakdown).
#[allow(clippy::too_many_arguments)]
pub fn run_timed<'t, W: Stopwatch + ?Sized>(
    input: &Input,
    i: usize,
    cfg: Config,
    templates: TemplateSet<'t>,
    predictor: &Predictor<'t>,
    clock: &mut dyn FnMut() -> u32,
    cost: &mut dyn FnMut(u32),
    w: &mut W,
) -> Result<Outcome, InputError> {
    let mut fresh = predictor.clone();
    fresh.reset();
    let mut p = Pipeline::new(cfg, Some(templates), fresh);
    run_in(&mut p, input, i, clock, cost, w)
}

/// [`run_timed`] in a pipeline the caller keeps (the QEMU image keeps one in static memory:
/// a pipeline is 31 KB, and one built on the stack for each scenario left copies of itself
/// there until the stack ran into the static data). `p` must be fresh: built for this run.
pub fn run_in<W: Stopwatch + ?Sized>(
    p: &mut Pipeline<'_>,
    input: &Input,
    i: usize,
    clock: &mut dyn FnMut() -> u32,
    cost: &mut dyn FnMut(u32),
    w: &mut W,
) -> Result<Outcome, InputError> {
    let sc = input.scenario(i)?;
    let onset = if sc.kind == Kind::Attack { sc.from_s } else { f64::INFINITY };
    let mut o = Outcome {
        epochs: 0,
        alarm_t: None,
        alarm_after_epochs: None,
        alarm_after_s: None,
        early_alarms: 0,
        digest: Digest::default(),
        frames: 0,
        rejected_sentences: 0,
        status: StatusLog::default(),
        longest_call: 0,
    };
    let mut onset_epoch: Option<u32> = None;
    let mut busy: u32 = 0;
    let t0 = input.t0;
    let mut gate = WatchdogGate::default();
    let mut next_gate_t = f64::NEG_INFINITY;
    let mut first_fix_t: Option<f64> = None;
    let mut latched_since: Option<f64> = None;
    let mut last_t = t0;
    let mut on_verdict = |v: &Verdict, o: &mut Outcome, onset_epoch: &mut Option<u32>, busy: &mut u32| {
        cost(*busy);
        *busy = 0;
        let rel = v.t - t0;
        if rel >= onset && onset_epoch.is_none() {
            *onset_epoch = Some(v.epoch);
        }
        if !v.fired.is_empty() {
            if rel < onset {
                o.early_alarms += 1;
            }
            if o.alarm_t.is_none() {
                o.alarm_t = Some(rel);
            }
            if let (Some(e), None) = (*onset_epoch, o.alarm_after_epochs) {
                o.alarm_after_epochs = Some(v.epoch.wrapping_sub(e));
                o.alarm_after_s = Some(rel - onset);
            }
        }
    };
    let (mut k, mut off, mut n) = (0usize, 0usize, 0usize);
    loop {
        let next_can = if k < input.can_count { input.can(k) } else { None };
        let next_nmea = if n < sc.nmea_count {
            match (u32_at(sc.nmea, off), sc.nmea.get(off + 4)) {
                (Some(t), Some(&len)) => sc.nmea.get(off + 5..off + 5 + len as usize).map(|l| (t, l)),
                _ => None,
            }
        } else {
            None
        };
        let mut got = heapless::Vec::<Verdict, 8>::new();
        w.lap(Stage::Other);
        let call_start = clock();
        let now = match (next_can, next_nmea) {
            (Some((tc, id, data)), Some((tn, _))) if tc <= tn => {
                let t = t0 + tc as f64 * 1e-6;
                p.on_can_timed(
                    t,
                    id,
                    data,
                    &mut |v| {
                        let _ = got.push(*v);
                    },
                    w,
                );
                k += 1;
                t
            }
            (Some((tc, id, data)), None) => {
                let t = t0 + tc as f64 * 1e-6;
                p.on_can_timed(
                    t,
                    id,
                    data,
                    &mut |v| {
                        let _ = got.push(*v);
                    },
                    w,
                );
                k += 1;
                t
            }
            (_, Some((tn, line))) => {
                let t = t0 + tn as f64 * 1e-6;
                let fixes = p.nmea.counters.fixes;
                p.on_nmea_timed(
                    t,
                    line,
                    &mut |v| {
                        let _ = got.push(*v);
                    },
                    w,
                );
                if p.nmea.counters.fixes != fixes {
                    first_fix_t.get_or_insert(t);
                }
                off += 5 + line.len();
                n += 1;
                t
            }
            (None, None) => break,
        };
        last_t = now;
        let out = p.poll(now);
        w.lap(Stage::Output);
        let c = clock();
        o.longest_call = o.longest_call.max(c.wrapping_sub(call_start));
        busy = busy.wrapping_add(c.wrapping_sub(call_start));
        if !got.is_empty() {
            for v in &got {
                on_verdict(v, &mut o, &mut onset_epoch, &mut busy);
            }
        }
        // The firmware's transmit side: the frames owed to the bus, decoded as the bus sees them.
        if let Some(f) = out.alarm {
            let (id, d) = f.encode();
            if AlarmFrame::decode(id, &d) == Some(AlarmFrame { epoch: f.epoch & 0xFF_FFFF, ..f }) {
                o.status.alarm_frames += 1;
                if now - t0 < onset {
                    o.status.alarm_frames_early += 1;
                }
            }
            p.alarm.sent(now);
        }
        if p.alarm.latched() {
            let since = *latched_since.get_or_insert(now);
            o.status.alarm_latched_s = now - since;
        }
        if let Some(frames) = out.status {
            for (id, d) in frames {
                let Some(page) = decode_status(id, &d) else { continue };
                o.status.frames += 1;
                if let StatusPage::Page0 { state, fix_age_s, epochs, .. } = page {
                    let state = state.unwrap_or(State::Blind);
                    o.status.states |= 1 << state as u8;
                    o.status.last_state = Some(state);
                    if epochs != p.epochs & 0xFF_FFFF {
                        o.status.epochs_mismatch += 1;
                    }
                    if state == State::Alarm && o.alarm_t.is_none() {
                        o.status.early_alarm_periods += 1;
                    }
                    if state == State::Blind && first_fix_t.is_some() {
                        o.status.blind_periods += 1;
                    }
                    if let Some(a) = fix_age_s {
                        o.status.max_fix_age_s = o.status.max_fix_age_s.max(a);
                    }
                }
            }
        }
        // The detector loop wakes at least every 0.5 s and asks whether it may feed.
        if now >= next_gate_t {
            next_gate_t = now + 0.5 * STATUS_PERIOD_S;
            if !gate.may_feed(&p.health, now) && p.health.last_status().is_some() {
                o.status.watchdog_refused += 1;
            }
        }
    }
    let mut tail = heapless::Vec::<Verdict, 32>::new();
    let call_start = clock();
    p.finish(last_t, &mut |v| {
        let _ = tail.push(*v);
    });
    busy = busy.wrapping_add(clock().wrapping_sub(call_start));
    for v in &tail {
        on_verdict(v, &mut o, &mut onset_epoch, &mut busy);
    }
    o.epochs = p.epochs;
    o.digest = p.digest;
    o.frames = p.frames;
    o.rejected_sentences = p.nmea.counters.rejected;
    Ok(o)
}

/// The longest accepted delay from an attack's onset to the alarm, seconds. Strategies 2 and 3
/// need a few seconds of evidence; strategy 1 fires at the onset epoch.
pub const MAX_ALARM_DELAY_S: f64 = 10.0;

/// One digest for all scenarios (FNV-1a 64 over their digests).
pub fn combine(ds: &[Digest]) -> u64 {
    let mut d = Digest::default();
    for x in ds {
        for b in x.0.to_le_bytes() {
            d.0 ^= b as u64;
            d.0 = d.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    d.0
}

/// One report line per scenario, identical on the host and the target.
pub fn describe(name: &str, o: &Outcome, pass: bool) -> heapless::String<320> {
    use core::fmt::Write;
    let mut s = heapless::String::new();
    let _ = write!(s, "scenario {name}: {} epochs, {} frames", o.epochs, o.frames);
    match (o.alarm_after_epochs, o.alarm_after_s, o.alarm_t) {
        (Some(e), Some(t), _) => {
            let _ = write!(s, ", alarm {e} epochs ({:.1} s) after onset", t);
        }
        (_, _, Some(t)) => {
            let _ = write!(s, ", alarm at {:.1} s", t);
        }
        _ => {
            let _ = write!(s, ", no alarm");
        }
    }
    let st = &o.status;
    let _ = write!(s, "; status: {} frames, states", st.frames);
    for state in [State::Learning, State::Running, State::Degraded, State::Alarm, State::Blind] {
        if st.saw(state) {
            let _ = write!(s, " {}", state.name());
        }
    }
    let _ = write!(
        s,
        ", blind {} s, fix age up to {:.1} s, {} alarm frames, watchdog refused {}",
        st.blind_periods, st.max_fix_age_s, st.alarm_frames, st.watchdog_refused
    );
    let _ = write!(s, "; digest {:016x}: {}", o.digest.0, if pass { "PASS" } else { "FAIL" });
    s
}
