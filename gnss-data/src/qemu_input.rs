//! The input of the QEMU Cortex-M run and of `host-sim digest` (format in
//! `gnss_guard_board::replay`): the comma2k19 segment's real CAN frames (bus 0, the profile's
//! ids) and its u-blox fixes rendered as NMEA GGA + RMC sentences, once clean, once per
//! attack, and once with the receiver silent for 15 s. Without the real data, the simulated drive, its signals encoded into CAN frames
//! through the profile's DBC.

use crate::attack::{self, AttackKind};
use crate::input::{self, Event, Replay};
use detector_core::sample::Fix;
use gnss_guard_board::{can, replay as fmt};
use std::path::Path;

/// What a scenario does: nothing, an attack from an onset, or a GNSS outage.
#[derive(Clone, Copy, Debug)]
pub enum Setup {
    Clean,
    Attack(AttackKind, f64),
    /// The receiver silent from the first to the second time (seconds after the start).
    Outage(f64, f64),
}

/// The scenarios: name and what happens (seconds after the start).
pub const SCENARIOS: [(&str, Setup); 5] = [
    ("clean", Setup::Clean),
    ("turn-by-turn", Setup::Attack(AttackKind::TurnByTurn, 30.0)),
    ("overshoot", Setup::Attack(AttackKind::Overshoot, 25.0)),
    ("wrong-turn", Setup::Attack(AttackKind::WrongTurn, 20.0)),
    ("gnss-outage", Setup::Outage(30.0, 45.0)),
];

/// GGA and RMC sentences for a fix (the NMEA rendering lives with the log formats).
pub use crate::input::logs::nmea_sentences as nmea;

fn frames_real(seg: &Path) -> Result<Vec<(f64, u32, Vec<u8>)>, input::InputError> {
    use input::comma2k19::read_npy;
    let (_, t) = read_npy::<f64>(seg, "CAN/raw_can/t")?;
    let (_, a) = read_npy::<i64>(seg, "CAN/raw_can/address")?;
    let (_, s) = read_npy::<i64>(seg, "CAN/raw_can/src")?;
    let (_, d) = read_npy::<Vec<u8>>(seg, "CAN/raw_can/data")?;
    Ok((0..t.len().min(a.len()).min(s.len()).min(d.len()))
        .filter(|&i| s[i] == 0 && can::wanted(a[i] as u32) && t[i].is_finite())
        .map(|i| (t[i], a[i] as u32, d[i].clone()))
        .collect())
}

fn frames_sim(r: &Replay) -> Vec<(f64, u32, Vec<u8>)> {
    r.events.iter().filter_map(|e| match *e {
        Event::Obs { sig, t, v } => {
            let mut d = [0u8; 8];
            can::encode(sig, v, &mut d).map(|id| (t, id, d.to_vec()))
        }
        Event::Fix(_) => None,
    }).collect()
}

/// Builds the input. Returns the bytes and a one-line description of what they hold.
pub fn generate(data: &Path) -> Result<(Vec<u8>, String), input::InputError> {
    let seg = data.join("raw/comma2k19_rav4_seg40");
    let (replay, mut frames, desc) = if seg.join("processed_log").is_dir() {
        let r = input::comma2k19::load(&seg)?;
        let f = frames_real(&seg)?;
        let d = format!("REAL drive: comma2k19 segment {} ({} CAN frames, {} u-blox fixes)", seg.display(), f.len(), r.fixes().count());
        (r, f, d)
    } else {
        let mut r = crate::sim::drive(7, 1.0, 10.0);
        // The first 60 s: the embedded input must fit the STM32F405's 1 MiB of flash.
        let end = r.events.first().map_or(0.0, |e| e.t()) + 60.0;
        r.events.retain(|e| e.t() <= end);
        let f = frames_sim(&r);
        let d = format!("SIMULATED drive (no {}): {} CAN frames, {} fixes", seg.display(), f.len(), r.fixes().count());
        (r, f, d)
    };
    frames.sort_by(|a, b| a.0.total_cmp(&b.0));
    let t0 = replay.events.first().map_or(0.0, |e| e.t()).min(frames.first().map_or(f64::INFINITY, |f| f.0));
    let us = |t: f64| ((t - t0) * 1e6).round().clamp(0.0, u32::MAX as f64) as u32;

    let mut nmea_blocks = Vec::new();
    for (_, setup) in SCENARIOS {
        let fixes: Vec<Fix> = match setup {
            Setup::Clean => replay.fixes().copied().collect(),
            Setup::Attack(k, onset) => attack::apply(&replay, k, 1, t0 + onset).replay.fixes().copied().collect(),
            Setup::Outage(a, b) => replay.fixes().filter(|f| !(t0 + a..t0 + b).contains(&f.t)).copied().collect(),
        };
        let mut block = Vec::new();
        let mut count = 0u32;
        for f in &fixes {
            for s in nmea(f, f.t - t0) {
                block.extend_from_slice(&us(f.t).to_le_bytes());
                block.push(s.len() as u8);
                block.extend_from_slice(s.as_bytes());
                count += 1;
            }
        }
        nmea_blocks.push((block, count));
    }
    let mut out = Vec::new();
    out.extend_from_slice(fmt::MAGIC);
    out.extend_from_slice(&fmt::VERSION.to_le_bytes());
    out.extend_from_slice(&(SCENARIOS.len() as u16).to_le_bytes());
    out.extend_from_slice(&(frames.len() as u32).to_le_bytes());
    out.extend_from_slice(&t0.to_le_bytes());
    let mut off = fmt::HEADER + SCENARIOS.len() * fmt::SCENARIO + frames.len() * fmt::CAN_RECORD;
    for ((name, setup), (block, count)) in SCENARIOS.iter().zip(&nmea_blocks) {
        let mut n = [0u8; 16];
        n[..name.len()].copy_from_slice(name.as_bytes());
        out.extend_from_slice(&n);
        let (kind, from, until) = match *setup {
            Setup::Clean => (fmt::Kind::Clean, f64::NAN, f64::NAN),
            Setup::Attack(_, onset) => (fmt::Kind::Attack, onset, f64::NAN),
            Setup::Outage(a, b) => (fmt::Kind::GnssOutage, a, b),
        };
        out.extend_from_slice(&(kind as u32).to_le_bytes());
        out.extend_from_slice(&from.to_le_bytes());
        out.extend_from_slice(&until.to_le_bytes());
        out.extend_from_slice(&(off as u32).to_le_bytes());
        out.extend_from_slice(&count.to_le_bytes());
        off += block.len();
    }
    for (t, id, d) in &frames {
        out.extend_from_slice(&us(*t).to_le_bytes());
        out.extend_from_slice(&(*id as u16).to_le_bytes());
        out.push(d.len().min(8) as u8);
        let mut p = [0u8; 8];
        p[..d.len().min(8)].copy_from_slice(&d[..d.len().min(8)]);
        out.extend_from_slice(&p);
    }
    for (block, _) in &nmea_blocks {
        out.extend_from_slice(block);
    }
    Ok((out, desc))
}

/// Runs every scenario through the board pipeline (as the QEMU image does) and returns the
/// report lines and whether every scenario passed.
pub fn run_all(bytes: &[u8]) -> (Vec<String>, bool) {
    let input = fmt::Input::parse(bytes).expect("our own input");
    let predictor = detector_core::strategy::location_shift::Predictor::default_lstm();
    let cfg = detector_core::fusion::Config::for_predictor(&detector_core::profile::UBLOX_10HZ, &predictor);
    let set = detector_core::strategy::turn::TemplateSet::parse(detector_core::strategy::turn::DEFAULT_TEMPLATES).expect("the committed template blob is valid");
    let mut lines = Vec::new();
    let mut all = true;
    let mut digests = Vec::new();
    for i in 0..input.scenarios() {
        let sc = input.scenario(i).expect("scenario");
        let o = fmt::run(&input, i, cfg, set, &predictor, &mut || 0, &mut |_| {}).expect("run");
        let pass = o.pass(&sc, fmt::MAX_ALARM_DELAY_S);
        all &= pass;
        digests.push(o.digest);
        lines.push(fmt::describe(sc.name, &o, pass).to_string());
    }
    lines.push(format!("verdict digest: {:016x}", fmt::combine(&digests)));
    (lines, all)
}
