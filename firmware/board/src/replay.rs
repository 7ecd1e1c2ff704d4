//! The compact replay input of the QEMU run and `host-sim digest`, and the scenario runner
//! both of them use.
//!
//! Little-endian layout:
//! ```text
//! "GGQI" | version u16 = 1 | scenarios u16 | can_count u32 | t0 f64
//! scenarios x ( name [u8; 16] (NUL-padded) | onset_s f64 (relative to t0; NaN = clean) |
//!               nmea_offset u32 | nmea_count u32 )
//! can_count x ( t_us u32 (since t0) | id u16 | len u8 | data [u8; 8] )
//! NMEA records at their offsets: ( t_us u32 | len u8 | bytes [len] )
//! ```
//! The CAN frames are shared by all scenarios (an attack rewrites only what the receiver says).

use crate::pipeline::{Digest, Pipeline};
use detector_core::fusion::Config;
use detector_core::strategy::turn::TemplateSet;
use detector_core::strategy::location_shift::{Predictor, ShiftPredictor};

pub const MAGIC: &[u8; 4] = b"GGQI";
pub const VERSION: u16 = 1;
pub const HEADER: usize = 20;
pub const SCENARIO: usize = 16 + 8 + 4 + 4;
pub const CAN_RECORD: usize = 4 + 2 + 1 + 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputError {
    TooShort,
    BadMagic,
    BadVersion,
    OutOfBounds,
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
    /// Seconds after t0; NaN for the clean run.
    pub onset_s: f64,
    nmea: &'a [u8],
    nmea_count: usize,
}

fn u16_at(b: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}
fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}
fn f64_at(b: &[u8], i: usize) -> f64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[i..i + 8]);
    f64::from_le_bytes(a)
}

impl<'a> Input<'a> {
    pub fn parse(bytes: &'a [u8]) -> Result<Self, InputError> {
        if bytes.len() < HEADER {
            return Err(InputError::TooShort);
        }
        if &bytes[..4] != MAGIC {
            return Err(InputError::BadMagic);
        }
        if u16_at(bytes, 4) != VERSION {
            return Err(InputError::BadVersion);
        }
        let scenarios = u16_at(bytes, 6) as usize;
        let can_count = u32_at(bytes, 8) as usize;
        let t0 = f64_at(bytes, 12);
        let can_end = HEADER + scenarios * SCENARIO + can_count * CAN_RECORD;
        if bytes.len() < can_end {
            return Err(InputError::OutOfBounds);
        }
        let input = Input { bytes, scenarios, can_count, t0 };
        for i in 0..scenarios {
            let o = HEADER + i * SCENARIO;
            let off = u32_at(bytes, o + 24) as usize;
            if off > bytes.len() {
                return Err(InputError::OutOfBounds);
            }
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
        let raw = &b[o..o + 16];
        let n = raw.iter().position(|&c| c == 0).unwrap_or(16);
        let name = core::str::from_utf8(&raw[..n]).unwrap_or("?");
        let off = u32_at(b, o + 24) as usize;
        let count = u32_at(b, o + 28) as usize;
        let nmea = b.get(off..).ok_or(InputError::OutOfBounds)?;
        Ok(Scenario { name, onset_s: f64_at(b, o + 16), nmea, nmea_count: count })
    }

    fn can(&self, k: usize) -> (u32, u32, &'a [u8]) {
        let o = HEADER + self.scenarios * SCENARIO + k * CAN_RECORD;
        let b = self.bytes;
        let len = (b[o + 6] as usize).min(8);
        (u32_at(b, o), u16_at(b, o + 4) as u32, &b[o + 7..o + 7 + len])
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
    /// Alarms before the onset (clean run: all of them).
    pub early_alarms: u32,
    pub digest: Digest,
    pub frames: u32,
    pub rejected_sentences: u32,
}

impl Outcome {
    /// Clean: no alarm at all. Attack: no alarm before the onset and one within `max_s` after it.
    pub fn pass(&self, clean: bool, max_s: f64) -> bool {
        if clean {
            self.alarm_t.is_none()
        } else {
            self.early_alarms == 0 && self.alarm_after_s.is_some_and(|s| s <= max_s)
        }
    }
}

/// Replays scenario `i` through a fresh pipeline, in arrival order. `clock` returns a running
/// cost counter (SysTick on the target, anything on the host); `cost` receives, for every epoch,
/// the counter difference since the previous epoch: everything the firmware did for it.
pub fn run<'t>(
    input: &Input,
    i: usize,
    cfg: Config,
    templates: TemplateSet<'t>,
    predictor: &Predictor<'t>,
    clock: &mut dyn FnMut() -> u32,
    cost: &mut dyn FnMut(u32),
) -> Result<Outcome, InputError> {
    let sc = input.scenario(i)?;
    let mut fresh = predictor.clone();
    fresh.reset();
    let mut p = Pipeline::new(cfg, Some(templates), fresh);
    let clean = sc.onset_s.is_nan();
    let mut o = Outcome { epochs: 0, alarm_t: None, alarm_after_epochs: None, alarm_after_s: None, early_alarms: 0, digest: Digest::default(), frames: 0, rejected_sentences: 0 };
    let mut onset_epoch: Option<u32> = None;
    let mut last_mark = clock();
    let t0 = input.t0;
    let mut on_verdict = |v: &detector_core::fusion::Verdict, o: &mut Outcome, onset_epoch: &mut Option<u32>, now: u32, last_mark: &mut u32| {
        cost(now.wrapping_sub(*last_mark));
        *last_mark = now;
        let rel = v.t - t0;
        if !clean && rel >= sc.onset_s && onset_epoch.is_none() {
            *onset_epoch = Some(v.epoch);
        }
        if !v.fired.is_empty() {
            if clean || rel < sc.onset_s {
                o.early_alarms += 1;
            }
            if o.alarm_t.is_none() {
                o.alarm_t = Some(rel);
            }
            if let (Some(e), None) = (*onset_epoch, o.alarm_after_epochs) {
                o.alarm_after_epochs = Some(v.epoch - e);
                o.alarm_after_s = Some(rel - sc.onset_s);
            }
        }
    };
    let (mut k, mut off, mut n) = (0usize, 0usize, 0usize);
    loop {
        let next_can = (k < input.can_count).then(|| input.can(k));
        let next_nmea = if n < sc.nmea_count && off + 5 <= sc.nmea.len() {
            let t = u32_at(sc.nmea, off);
            let len = sc.nmea[off + 4] as usize;
            sc.nmea.get(off + 5..off + 5 + len).map(|l| (t, l))
        } else {
            None
        };
        let mut got = heapless::Vec::<detector_core::fusion::Verdict, 8>::new();
        match (next_can, next_nmea) {
            (Some((tc, id, data)), Some((tn, _))) if tc <= tn => {
                p.on_can(t0 + tc as f64 * 1e-6, id, data, &mut |v| { let _ = got.push(*v); });
                k += 1;
            }
            (Some((tc, id, data)), None) => {
                p.on_can(t0 + tc as f64 * 1e-6, id, data, &mut |v| { let _ = got.push(*v); });
                k += 1;
            }
            (_, Some((tn, line))) => {
                p.on_nmea(t0 + tn as f64 * 1e-6, line, &mut |v| { let _ = got.push(*v); });
                off += 5 + line.len();
                n += 1;
            }
            (None, None) => break,
        }
        if !got.is_empty() {
            let now = clock();
            for v in &got {
                on_verdict(v, &mut o, &mut onset_epoch, now, &mut last_mark);
            }
        }
    }
    let mut tail = heapless::Vec::<detector_core::fusion::Verdict, 32>::new();
    p.finish(&mut |v| { let _ = tail.push(*v); });
    let now = clock();
    for v in &tail {
        on_verdict(v, &mut o, &mut onset_epoch, now, &mut last_mark);
    }
    o.epochs = p.epochs;
    o.digest = p.digest;
    o.frames = p.frames;
    o.rejected_sentences = p.nmea.counters.rejected;
    Ok(o)
}

/// The longest accepted delay from an attack's onset to the alarm, seconds. Strategy 3 and the
/// heading check need a few seconds of evidence; strategy 1 fires at the onset epoch.
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
pub fn describe(name: &str, o: &Outcome, pass: bool) -> heapless::String<160> {
    use core::fmt::Write;
    let mut s = heapless::String::new();
    let _ = write!(s, "scenario {name}: {} epochs, {} frames", o.epochs, o.frames);
    match (o.alarm_after_epochs, o.alarm_after_s) {
        (Some(e), Some(t)) => { let _ = write!(s, ", alarm {e} epochs ({:.1} s) after onset", t); }
        _ if o.alarm_t.is_some() => { let _ = write!(s, ", alarm at {:.1} s", o.alarm_t.unwrap_or(0.0)); }
        _ => { let _ = write!(s, ", no alarm"); }
    }
    let _ = write!(s, ", digest {:016x}: {}", o.digest.0, if pass { "PASS" } else { "FAIL" });
    s
}
