//! Fuzz harnesses. The `cargo fuzz` targets in `tests/fuzz/` call these, and the normal test
//! command replays the committed corpora and regressions through them (`tests/tests/fuzz_corpora.rs`).
//! Each harness must never panic, hang or grow without bound on any input.

use detector_core::fusion::{Config, Detector};
use detector_core::geo::LatLon;
use detector_core::profile::{LOGGER_1HZ, UBLOX_10HZ};
use detector_core::sample::{Fix, Reading, Sample, Signal};
use detector_core::strategy::location_shift::{KinematicPredictor, Predictor};
use detector_core::strategy::turn::{self, TemplateSet, DEFAULT_TEMPLATES};
use detector_core::sync::{SyncConfig, Synchronizer};
use std::path::{Path, PathBuf};

/// NMEA bytes as a UART would deliver them, in arbitrary chunks, into the firmware's GNSS path.
pub fn nmea(data: &[u8]) {
    let mut split = gnss_guard_board::gnss::LineSplitter::default();
    let mut fixer = gnss_guard_board::gnss::NmeaFixer::default();
    let cut = data.first().map_or(1, |&b| b as usize % 17 + 1);
    for (k, chunk) in data.chunks(cut).enumerate() {
        if k % 7 == 6 {
            split.discard_partial(); // as after a UART overrun
        }
        split.push(chunk, |line| {
            if let Some(f) = fixer.line(k as f64, line) {
                assert!(f.pos.is_valid());
            }
        });
    }
}

/// CAN frames (id, length, payload) into the generated DBC decoder and through the pipeline.
pub fn can(data: &[u8]) {
    let predictor = detector_core::strategy::location_shift::Predictor::default_lstm();
    let cfg = Config::for_predictor(&UBLOX_10HZ, &predictor);
    let mut p = gnss_guard_board::pipeline::Pipeline::new(cfg, TemplateSet::parse(DEFAULT_TEMPLATES).ok(), predictor);
    let mut t = 0.0;
    for rec in data.chunks(11) {
        if rec.len() < 3 {
            break;
        }
        let id = u16::from_le_bytes([rec[0], rec[1]]) as u32 & 0x7FF;
        let len = (rec[2] as usize % 9).min(rec.len() - 3);
        let payload = &rec[3..3 + len];
        for (_, v) in gnss_guard_board::can::decode(id, payload) {
            assert!(v.is_finite());
        }
        // Map the id onto the profile's so most frames are real work for the pipeline.
        let ids = gnss_guard_board::can::FILTER_IDS;
        let pid = ids[id as usize % ids.len()] as u32;
        t += (rec[0] % 16) as f64 * 0.003;
        p.on_can(t, pid, payload, &mut |_| {});
    }
    p.finish(t, &mut |_| {});
}

fn scratch(name: &str) -> PathBuf {
    let base = if Path::new("/dev/shm").is_dir() { PathBuf::from("/dev/shm") } else { std::env::temp_dir() };
    let d = base.join(format!("gnss-guard-fuzz-{}-{name}", std::process::id()));
    let _ = std::fs::create_dir_all(&d);
    d
}

fn load_and_replay(p: &Path) {
    if let Ok(r) = host_sim::input::load(p, &host_sim::input::LoadOptions::default()) {
        let (s, _) = host_sim::replay::synchronize(&r, SyncConfig::default());
        let _ = host_sim::detect::run(&s, Config::for_profile(&LOGGER_1HZ));
    }
    let _ = host_sim::input::load(p, &host_sim::input::LoadOptions { skip_bad_rows: true, ..Default::default() });
}

/// A drive as a Parquet file (the arrow-rs reader: footer, Thrift metadata, pages, snappy),
/// strict and skipping bad rows, from bytes and from a file; what loads is synchronised and
/// judged, and written back as Parquet, which must read again, and again to the same events.
pub fn drive_parquet(data: &[u8]) {
    use host_sim::input::{drive_parquet, LoadOptions};
    let _ = drive_parquet::looks_like_parquet(data);
    let name = Path::new("fuzz.parquet");
    for skip in [false, true] {
        let opts = LoadOptions { skip_bad_rows: skip, ..LoadOptions::default() };
        let Ok(r) = drive_parquet::load_bytes(name, data.to_vec(), &opts) else { continue };
        let (s, _) = host_sim::replay::synchronize(&r, SyncConfig::default());
        let _ = host_sim::detect::run(&s, Config::for_profile(&UBLOX_10HZ));
        // Written back, it reads again (rows sharing a time become one: the writer's one
        // normalisation), and a second round trip changes nothing.
        let round_trip = |r: &host_sim::input::Replay| {
            let mut out = Vec::new();
            drive_parquet::write(r, None, &mut out).expect("a replay writes as Parquet");
            drive_parquet::load_bytes(name, out, &LoadOptions::default()).expect("our own Parquet reads back")
        };
        let once = round_trip(&r);
        assert!(once.events.len() <= r.events.len(), "the writer adds no event");
        assert_eq!(round_trip(&once).events, once.events, "a second round trip changes nothing");
    }
    let p = scratch("parquet").join("drive.parquet");
    let _ = std::fs::write(&p, data);
    load_and_replay(&p);
}

/// A drive CSV file.
pub fn drive_csv(data: &[u8]) {
    let p = scratch("csv").join("drive.csv");
    let _ = std::fs::write(&p, data);
    load_and_replay(&p);
}

/// An OpenXC trace.
pub fn openxc(data: &[u8]) {
    let p = scratch("openxc").join("trace.jsonl");
    let _ = std::fs::write(&p, data);
    load_and_replay(&p);
}

/// An HDD session: the input split at the first 0xFF into rtk_pos.csv and vel.csv.
pub fn hdd(data: &[u8]) {
    let s = scratch("hdd").join("session");
    let csv = s.join("general/csv");
    let _ = std::fs::create_dir_all(&csv);
    let (a, b) = match data.iter().position(|&x| x == 0xFF) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let _ = std::fs::write(csv.join("rtk_pos.csv"), a);
    let _ = std::fs::write(csv.join("vel.csv"), b);
    load_and_replay(&s);
}

/// A comma2k19 segment: the input split at the first 0xFF into the GNSS `t` and `value` arrays
/// (prefixed with valid .npy headers half of the time, so the parser is exercised past them).
pub fn comma2k19(data: &[u8]) {
    let s = scratch("comma").join("seg");
    let g = s.join("processed_log/GNSS/live_gnss_ublox");
    let _ = std::fs::create_dir_all(&g);
    let (a, b) = match data.iter().position(|&x| x == 0xFF) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let hdr = |shape: &str| {
        let h = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
        let mut v = b"\x93NUMPY\x01\x00".to_vec();
        let pad = 64 - (10 + h.len() + 1) % 64;
        v.extend_from_slice(&((h.len() + pad + 1) as u16).to_le_bytes());
        v.extend_from_slice(h.as_bytes());
        v.extend(std::iter::repeat_n(b' ', pad));
        v.push(b'\n');
        v
    };
    let with_hdr = data.first().is_some_and(|x| x & 1 == 1);
    let n = a.len() / 8;
    let mut ta = if with_hdr { hdr(&format!("({n},)")) } else { Vec::new() };
    ta.extend_from_slice(a);
    let rows = b.len() / 48;
    let mut vb = if with_hdr { hdr(&format!("({rows}, 6)")) } else { Vec::new() };
    vb.extend_from_slice(b);
    let _ = std::fs::write(g.join("t"), ta);
    let _ = std::fs::write(g.join("value"), vb);
    load_and_replay(&s);
}

/// The turn template blob parser and the classifier on whatever it accepts.
pub fn template_blob(data: &[u8]) {
    if let Ok(set) = TemplateSet::parse(data) {
        let q = [1.0f32; turn::QUERY_LEN];
        let a = turn::classify(&set, &q, 3);
        let b = turn::classify_reference(&set, &q, 3);
        assert_eq!(a.map(|n| (n.class, n.distance)), b.map(|n| (n.class, n.distance)));
    }
    // Fixing up the CRC gets the fuzzer past it into the record checks.
    if data.len() >= 18 {
        let mut v = data.to_vec();
        let n = v.len() - 4;
        let crc = detector_core::wire::crc32::crc32(&v[..n]);
        v[n..].copy_from_slice(&crc.to_le_bytes());
        let _ = TemplateSet::parse(&v);
    }
}

/// The LSTM model blob parser, and both kernels on whatever it accepts.
pub fn lstm_blob(data: &[u8]) {
    use detector_core::strategy::location_shift::lstm::{LstmModel, LstmPredictor};
    let run = |bytes: &[u8]| {
        if let Ok(m) = LstmModel::parse(bytes) {
            let x = [f32::NAN, 1e30, -3.0, 20.0];
            let _ = LstmPredictor::reference(m).step_raw(x);
            if let Ok(mut p) = LstmPredictor::int(m) {
                for _ in 0..3 {
                    let _ = p.step_raw(x);
                    let _ = p.step_raw([10.0, 20.0, 30.0, 10.0]);
                }
            }
        }
    };
    run(data);
    // Fixing up the CRC gets the fuzzer past it into the weights.
    if data.len() >= 84 {
        let mut v = data.to_vec();
        let n = v.len() - 4;
        let crc = detector_core::wire::crc32::crc32(&v[..n]);
        v[n..].copy_from_slice(&crc.to_le_bytes());
        run(&v);
    }
}

/// The LSTM's dot-product kernels (`gnss-guard-dsp`): on arbitrary weights, activations and
/// shapes, the optimised kernel of this machine (AVX2 here) and the Cortex-M4 algorithm on its
/// DSP layout (`emulated`, instruction by instruction; the QEMU run checks the assembly) equal
/// the portable reference; the integer LSTM on the optimised and portable dot products gives
/// the same outputs on a blob whose weights are the input.
pub fn dsp(data: &[u8]) {
    use gnss_guard_dsp::{emulated, portable, Activations};
    let Some((&shape, rest)) = data.split_first() else { return };
    let cols = 1 + (shape as usize % 48);
    let (v_bytes, w) = rest.split_at(rest.len().min(2 * cols));
    let v: Vec<i16> = v_bytes.chunks_exact(2).map(|b| i16::from_le_bytes([b[0], b[1]])).collect();
    let mut acts = Activations::<48>::default();
    let (x, h) = v.split_at(v.len() / 3);
    acts.load(&[x, h]);
    // Two rows.
    let (w0, w1) = w.split_at(w.len() / 2);
    assert_eq!(acts.dot2(w0, w1), portable::dot2(w0, w1, &v), "dot2");
    assert_eq!(acts.dot1(w0), portable::dot(w0, &v), "dot1");
    // A matrix of `cols` columns (13, 16 and 48 cover the tails of every kernel).
    fn matrix<const S: usize>(acts: &Activations<48>, w: &[u8], v: &[i16]) {
        let mut out = [0i32; 9];
        acts.matvec::<S>(w, &mut out);
        let n = S.min(v.len());
        for (r, o) in out.iter().enumerate() {
            let row = w.get(r * S..).unwrap_or(&[]);
            assert_eq!(*o, portable::dot(row.get(..n).unwrap_or(row), v), "matvec<{S}> row {r}");
        }
    }
    matrix::<13>(&acts, w, &v);
    matrix::<16>(&acts, w, &v);
    matrix::<48>(&acts, w, &v);
    // The Cortex-M4 algorithm on the DSP layout.
    assert_eq!(emulated::dot2(w0, w1, &v), portable::dot2(w0, w1, &v), "emulated Cortex-M4 kernel");
    // The whole integer LSTM, both dot products, on a blob made from the input.
    lstm_parity(data);
}

/// An int8 blob (h1 = 5, h2 = 3: every tail) with weights from `data`; both integer kernels.
fn lstm_parity(data: &[u8]) {
    use detector_core::strategy::location_shift::lstm::{BlobSpec, LstmModel, LstmPredictor, WeightKind, N_IN};
    let (h1, h2) = (5usize, 3usize);
    let mut k = 0usize;
    let mut next = |scale: f32| {
        let b = data.get(k % data.len().max(1)).copied().unwrap_or(0);
        k += 1;
        (b as i8 as f32 / 128.0) * scale
    };
    let mut mk = |r: usize, c: usize| -> (Vec<f32>, Vec<f32>) { ((0..r * c).map(|_| next(1.0)).collect(), (0..r).map(|_| next(0.5)).collect()) };
    let (l1, l2, d) = (mk(4 * h1, N_IN + h1), mk(4 * h2, h1 + h2), mk(1, h2));
    let spec = BlobSpec {
        kind: WeightKind::I8,
        h1,
        h2,
        in_min: [0.0; N_IN],
        in_max: [1.0; N_IN],
        out_min: 0.0,
        out_max: 1.0,
        max_err_m: [0.0; 2],
        rmse_m: [0.0; 2],
        layers: [(&l1.0, &l1.1), (&l2.0, &l2.1), (&d.0, &d.1)],
    };
    let mut blob = vec![0u8; spec.byte_len()];
    assert!(spec.write(&mut blob));
    let m = LstmModel::parse(&blob).expect("a written blob parses");
    let (mut a, mut b) = (LstmPredictor::int(m).unwrap(), LstmPredictor::int_portable(m).unwrap());
    for i in 0..8 {
        let x = [next(8.0), next(8.0), next(8.0), i as f32 * 0.1];
        assert_eq!(a.step_raw(x).to_bits(), b.step_raw(x).to_bits(), "integer LSTM, step {i}");
    }
}

/// One's own car's logs (issue #17): a candump log and an NMEA log (the input split at its first
/// 0xFF byte), strict and skipping bad lines, decoded through the RAV4 profile at run time and
/// synchronised.
pub fn logs(data: &[u8]) {
    use host_sim::input::{logs, LoadOptions, Replay, Format};
    let cut = data.iter().position(|&b| b == 0xFF).unwrap_or(data.len());
    let can = String::from_utf8_lossy(&data[..cut]);
    let gnss = String::from_utf8_lossy(data.get(cut + 1..).unwrap_or(&[]));
    let _ = logs::looks_like_candump(&can);
    let _ = logs::looks_like_nmea(&gnss);
    let profile = gnss_guard_profile::load::load(
        include_str!("../../firmware/board/profiles/toyota_rav4.dbc"),
        include_str!("../../firmware/board/profiles/toyota_rav4.map"),
    )
    .expect("the RAV4 profile loads");
    for skip in [false, true] {
        let opts = LoadOptions { skip_bad_rows: skip, ..LoadOptions::default() };
        let frames = logs::candump_from_text(Path::new("fuzz.log"), &can, &opts).map(|(f, _)| f).unwrap_or_default();
        let fixes = logs::nmea_log_from_text(Path::new("fuzz.nmea"), &gnss, &opts).map(|(f, _)| f).unwrap_or_default();
        for f in &frames {
            let _ = logs::parse_candump_line(&f.candump_line()).expect("a written frame line parses");
        }
        let r = Replay::new(Path::new("fuzz"), Format::Logs, logs::events_of(&frames, fixes, &profile), 0);
        let _ = host_sim::replay::synchronize(&r, SyncConfig::default());
    }
}

/// Vector ASC logs (issue #17): the reader, strict and skipping bad lines; what it accepts,
/// written again and read back, gives the same frames.
pub fn asc(data: &[u8]) {
    use host_sim::input::{asc, LoadOptions};
    let text = String::from_utf8_lossy(data);
    let _ = asc::looks_like_asc(&text);
    for skip in [false, true] {
        let opts = LoadOptions { skip_bad_rows: skip, ..LoadOptions::default() };
        let Ok((frames, _)) = asc::asc_from_text(Path::new("fuzz.asc"), &text, &opts) else { continue };
        // (frames the writer can date: up to 2200, as the reader allows)
        let classic: Vec<_> = frames.iter().filter(|f| f.data.len() <= 8 && f.t.is_finite() && f.t.abs() < 7.2e9).collect();
        let timed: Vec<(i64, &host_sim::input::logs::CanFrame)> = classic.iter().map(|f| (host_sim::input::logs::micros_of(f.t), *f)).collect();
        if timed.is_empty() || timed.iter().any(|(us, _)| *us < 0) {
            continue;
        }
        let back = asc::asc_from_text(Path::new("back.asc"), &asc::asc_text(&timed), &LoadOptions::default()).expect("a written ASC log reads back").0;
        assert_eq!(back.len(), timed.len());
        for (b, (us, f)) in back.iter().zip(&timed) {
            assert_eq!((b.id, b.extended, &b.data, b.bus()), (f.id, f.extended, &f.data, f.bus().or(Some(0))), "a frame changed through ASC");
            assert_eq!(host_sim::input::logs::micros_of(b.t), *us);
        }
    }
}

/// A GNSS receiver's bytes (issue #17): UBX and NMEA interleaved, in arbitrary chunks, through
/// the firmware's framer and fixers; the UBX log reader, strict and skipping; NAV-PVT payloads
/// decoded, encoded and decoded again.
pub fn ubx(data: &[u8]) {
    use gnss_guard_board::ubx::{self, Chunk, Framer, NavPvt, UbxFixer};
    let mut fr = Framer::default();
    let mut fixer = UbxFixer::default();
    let mut nmea = gnss_guard_board::gnss::NmeaFixer::default();
    let cut = data.first().map_or(1, |&b| b as usize % 23 + 1);
    let mut chunks = 0u32;
    for chunk in data.chunks(cut) {
        fr.push(chunk, |c| {
            chunks += 1;
            match c {
                Chunk::Nmea(l) => {
                    let _ = nmea.line(1.0, l);
                }
                Chunk::Ubx(f) => {
                    assert!(f.payload.len() <= ubx::MAX_PAYLOAD);
                    let _ = fixer.frame(None, f);
                    let _ = fixer.frame(Some(2.0), f);
                }
            }
        });
    }
    assert!(fr.counters.frames <= chunks);
    for skip in [false, true] {
        let opts = host_sim::input::LoadOptions { skip_bad_rows: skip, ..Default::default() };
        let _ = host_sim::input::ubx_log::ubx_log_from_bytes(Path::new("fuzz.ubx"), data, &opts);
    }
    if let Some(p) = data.get(..ubx::NAV_PVT_LEN).and_then(NavPvt::parse) {
        assert_eq!(NavPvt::parse(&p.to_payload()), Some(p));
        let _ = UbxFixer::fix_of(None, &p);
        if let Some(t) = p.utc_s() {
            let mut q = p;
            q.set_utc(t);
            assert!(q.utc_s().is_some_and(|u| (u - t).abs() <= 1e-6 * t.abs().max(1.0)), "{t}");
        }
    }
}

/// The vehicle-profile loader (issue #17): a DBC and a map (the input split at its first 0xFF),
/// and, when they load, frames (the rest of the input) decoded through every mapping.
pub fn profile(data: &[u8]) {
    let mut parts = data.splitn(3, |&b| b == 0xFF);
    let dbc = String::from_utf8_lossy(parts.next().unwrap_or(&[]));
    let map = String::from_utf8_lossy(parts.next().unwrap_or(&[]));
    let frames = parts.next().unwrap_or(&[]);
    let _ = gnss_guard_profile::load::messages(&dbc);
    let Ok(p) = gnss_guard_profile::load::load(&dbc, &map) else { return };
    let _ = p.filter_ids();
    let _ = gnss_guard_profile::load::rust_mappings(&p.mappings);
    for chunk in frames.chunks(9) {
        let (len, payload) = chunk.split_first().unwrap_or((&0, &[]));
        let payload = payload.get(..(*len as usize % 9).min(payload.len())).unwrap_or(&[]);
        for m in &p.mappings {
            let _ = m.value(payload);
            assert_eq!(m.field.raw(payload), m.field.raw_bitwise(payload));
            let _ = gnss_guard_profile::decode(&p.mappings, m.id, m.extended, m.bus, payload).count();
        }
    }
}

/// The QEMU/digest replay input parser and runner.
pub fn replay_input(data: &[u8]) {
    use gnss_guard_board::replay;
    if let Ok(input) = replay::Input::parse(data) {
        let set = TemplateSet::parse(DEFAULT_TEMPLATES).unwrap();
        for i in 0..input.scenarios().min(4) {
            let _ = replay::run(&input, i, Config::for_profile(&UBLOX_10HZ), set, &detector_core::strategy::location_shift::Predictor::default_lstm(), &mut || 0, &mut |_| {});
        }
    }
}

fn f64_at(d: &[u8], i: usize) -> f64 {
    let mut a = [0u8; 8];
    for (k, x) in a.iter_mut().enumerate() {
        *x = d.get(i + k).copied().unwrap_or(0);
    }
    f64::from_le_bytes(a)
}

/// Arbitrary sample sequences into the detector, and arbitrary events into the synchroniser.
pub fn detector(data: &[u8]) {
    let set = TemplateSet::parse(DEFAULT_TEMPLATES).unwrap();
    // Kinematic or LSTM by the first byte, so both predictors see the garbage.
    let predictor = match data.first() {
        Some(b) if b % 2 == 1 => Predictor::default_lstm(),
        _ => Predictor::Kinematic(KinematicPredictor::default()),
    };
    let mut d = Detector::new(Config::for_predictor(&LOGGER_1HZ, &predictor), predictor).with_turns(set);
    let mut sync = Synchronizer::new(SyncConfig::default());
    let reading = |b: u8, v: f64| match b % 3 {
        0 => Reading::Valid(v as f32),
        1 => Reading::Stale,
        _ => Reading::Missing,
    };
    for rec in data.chunks(24) {
        let (t, a, b) = (f64_at(rec, 0), f64_at(rec, 8), f64_at(rec, 16));
        let k = rec.first().copied().unwrap_or(0);
        let k2 = rec.get(6).copied().unwrap_or(0);
        let mut signals = [Reading::Missing; Signal::COUNT];
        for (i, s) in signals.iter_mut().enumerate() {
            *s = reading(rec.get(i + 1).copied().unwrap_or(0), a * (i as f64 + 1.0));
        }
        let s = Sample { t, dt_s: b as f32, pos: LatLon::new(a, b), shift_m: reading(k, b), gnss_speed: reading(k >> 2, a), gnss_course: reading(k >> 4, b), gnss_h_acc: reading(k >> 6, a), signals, dist_m: reading(k2, b), turn_deg: reading(k2 >> 2, a * b), turn_abs_deg: reading(k2 >> 4, a - b), receiver_spoofing: k2 & 0x80 != 0, wheel_step_mps: (a * b) as f32 };
        let v = d.step(&s);
        assert_eq!(v.ran.0 & v.degraded.0, 0);
        if k % 2 == 0 {
            sync.push_obs(Signal::ALL[k as usize % Signal::COUNT], t, a as f32, &mut |x| { d.step(x); });
        } else {
            sync.push_fix(Fix { t, pos: LatLon::new(a, b), speed_mps: Some(b as f32), course_deg: None, h_acc_m: None, receiver_spoofing: false }, &mut |x| { d.step(x); });
        }
    }
    sync.flush(&mut |x| { d.step(x); });
}

/// Epochs of a `long_horizon` run: states that take minutes of driving to build are reached.
pub const LONG_HORIZON_EPOCHS: usize = 20_000;

/// A random-walk drive programmed by the input (`crate::walk`: legs of cruising, long bends,
/// turns, stops, GNSS gaps, rate changes, time jumps, faults, spoofing, cycled) for 20,000
/// epochs, into the whole detector (kinematic predictor, all strategies) directly and behind
/// the synchroniser. The LSTM's kernels are the `lstm_blob` target's; 20,000 LSTM steps per
/// input would leave the fuzzer a few executions a second.
pub fn long_horizon(data: &[u8]) {
    let set = TemplateSet::parse(DEFAULT_TEMPLATES).unwrap();
    let profile = if data.first().is_some_and(|b| b & 0x80 != 0) { &UBLOX_10HZ } else { &LOGGER_1HZ };
    let cfg = Config::for_profile(profile);
    let mut direct = Detector::new(cfg, KinematicPredictor::default()).with_turns(set);
    let mut synced = Detector::new(cfg, KinematicPredictor::default()).with_turns(set);
    let mut sync = Synchronizer::new(SyncConfig::default());
    let mut walk = crate::walk::Walk::from_bytes(data);
    let check = |v: &detector_core::fusion::Verdict| {
        assert_eq!(v.ran.0 & v.degraded.0, 0);
        assert_eq!(v.fired.0 & !v.ran.0, 0);
        if let Some(o) = v.turn.filter(|o| o.steering != turn::TurnClass::None) {
            assert!(o.end_t - o.start_t <= turn::MAX_SEGMENT as f64 * 0.2 + 1e-6, "{o:?}");
        }
    };
    for _ in 0..LONG_HORIZON_EPOCHS {
        let e = walk.next_epoch();
        for &(sig, t, v) in &e.obs {
            sync.push_obs(sig, t, v, &mut |s| check(&synced.step(s)));
        }
        if let Some(f) = e.fix {
            sync.push_fix(f, &mut |s| check(&synced.step(s)));
        }
        if let Some(s) = e.sample {
            check(&direct.step(&s));
        }
    }
    sync.flush(&mut |s| check(&synced.step(s)));
}

/// A fuzz harness.
pub type Harness = fn(&[u8]);

/// All harnesses by name (the fuzz targets and the corpus replay use the same names).
pub const TARGETS: [(&str, Harness); 20] = [
    ("nmea", nmea),
    ("can", can),
    ("drive_csv", drive_csv),
    ("openxc", openxc),
    ("hdd", hdd),
    ("comma2k19", comma2k19),
    ("template_blob", template_blob),
    ("lstm_blob", lstm_blob),
    ("dsp", dsp),
    ("logs", logs),
    ("asc", asc),
    ("ubx", ubx),
    ("profile", profile),
    ("replay_input", replay_input),
    ("detector", detector),
    ("long_horizon", long_horizon),
    ("calibration", calibration),
    ("blf", blf),
    ("mdf4", mdf4),
    ("drive_parquet", drive_parquet),
];

/// The calibration record (`wire::calibration`) and the board's store of it. The input is:
/// a record's bytes as they come (and again with the header and CRC fixed up, to reach every
/// field's check); a detector started from what decodes, driven for 10 minutes, whose own record
/// must decode again; and the same bytes as the raw contents of the store's flash (a corrupted
/// store), which must load as something (never a panic), take a new record, and give it back.
pub fn calibration(data: &[u8]) {
    use detector_core::wire::calibration::{Record, RECORD_LEN};
    let mut tried: Vec<Record> = Vec::new();
    if let Ok(r) = Record::decode(data) {
        assert!(r.check().is_ok(), "decode accepted what check refuses: {r:?}");
        assert_eq!(Record::decode(&r.encode()).map(|x| x.encode()), Ok(r.encode()), "encode/decode round trip");
        tried.push(r);
    }
    if data.len() >= RECORD_LEN {
        let mut v = data[..RECORD_LEN].to_vec();
        v[..4].copy_from_slice(b"GGCR");
        v[4..6].copy_from_slice(&detector_core::wire::calibration::VERSION.to_le_bytes());
        v[6..8].copy_from_slice(&(detector_core::wire::calibration::PAYLOAD_LEN as u16).to_le_bytes());
        let n = RECORD_LEN - 4;
        let crc = detector_core::wire::crc32::crc32(&v[..n]);
        v[n..].copy_from_slice(&crc.to_le_bytes());
        if let Ok(r) = Record::decode(&v) {
            assert!(r.check().is_ok());
            tried.push(r);
        }
    }
    for r in &tried {
        let mut d = Detector::new(Config::for_profile(&LOGGER_1HZ), KinematicPredictor::default()).with_calibration(r);
        let mut pos = LatLon::new(52.0, 5.0);
        for k in 0..600u32 {
            let v = 10.0 + 5.0 * ((k / 60) % 2) as f32;
            let next = detector_core::geo::destination(pos, 90.0, v as f64, detector_core::geo::EARTH_RADIUS_PAPER_M);
            let mut signals = [Reading::Missing; Signal::COUNT];
            signals[Signal::WheelSpeed.index()] = Reading::Valid(v);
            let s = Sample { t: k as f64, dt_s: 1.0, pos: next, shift_m: Reading::Valid(v), gnss_speed: Reading::Missing, gnss_course: Reading::Missing, gnss_h_acc: Reading::Missing, signals, ..Default::default() };
            pos = next;
            let out = d.step(&s);
            assert_eq!(out.ran.0 & out.degraded.0, 0);
        }
        if let Some(own) = d.calibration_record() {
            assert!(Record::decode(&own.encode()).is_ok(), "the detector's own record does not decode: {own:?}");
        }
    }
    store(data, tried.first());
}

/// The calibration store over a mock flash whose two sectors hold `data` (cycled).
fn store(data: &[u8], record: Option<&detector_core::wire::calibration::Record>) {
    use gnss_guard_board::store::{mock::MockFlash, Loaded, Store};
    let mut flash: MockFlash<2, 1024> = MockFlash::default();
    if !data.is_empty() {
        for (b, x) in flash.bytes.iter_mut().zip(data.iter().cycle()) {
            *b = *x;
        }
    }
    let Some(mut s) = Store::new(flash, 0..2048) else { panic!("the range holds a store") };
    let _ = block_on(s.load());
    let r = record.copied().unwrap_or(detector_core::wire::calibration::Record {
        scale: 1.0,
        delay_s: [0.5, f32::NAN],
        learnt_s: 600.0,
        drives: 1,
        gyro_bias_degps: f32::NAN,
        gyro_bias_weight_s: 0.0,
        gyro_scale_error: 0.0,
        gyro_scale_sd: 0.05,
        noise_s0_m: [1.5, 1.5],
        noise_k: [0.01, 0.01],
        velocity_sigma_mps: [0.2, 0.3],
        nominal_dt_s: 1.0,
        anchor_scale: 1.0,
        anchor_delay_s: [0.5, f32::NAN],
        anchor_gyro_scale_error: 0.0,
        anchor_noise_s0_m: [1.5, 1.5],
        anchor_noise_k: [0.01, 0.01],
        anchor_velocity_sigma_mps: [0.2, 0.3],
    });
    if block_on(s.save(&r)).is_ok() {
        match block_on(s.load()) {
            Loaded::Record(got) => assert_eq!(got.encode(), r.encode(), "a saved record reads back"),
            other => panic!("saved, then loaded {other:?}"),
        }
    }
}

/// Polls a future that never waits (the mock flash answers at once) to its end.
fn block_on<F: core::future::Future>(f: F) -> F::Output {
    let mut cx = core::task::Context::from_waker(core::task::Waker::noop());
    let mut f = core::pin::pin!(f);
    loop {
        if let core::task::Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
    }
}

/// GNSS fields on CAN for the binary-log harnesses: a position message (0x3: valid bit, 28-bit
/// latitude and 29-bit longitude at 1e-6 deg, as the CANedge's) and a speed message (0x7).
pub fn gnss_on_can() -> Vec<gnss_guard_profile::GnssMapped> {
    use gnss_guard_profile::{Field, GnssField, GnssMapped};
    let m = |id: u32, f: Field, target: GnssField| GnssMapped { id, extended: false, bus: None, field: f, mux: None, target, factor: 1.0 };
    vec![
        m(3, Field::new(0, 1, false, false, 1.0, 0.0), GnssField::Valid),
        m(3, Field::new(1, 28, false, false, 1e-6, -90.0), GnssField::Lat),
        m(3, Field::new(29, 29, false, false, 1e-6, -180.0), GnssField::Lon),
        m(7, Field::new(1, 20, false, false, 0.001, 0.0), GnssField::Speed),
    ]
}

/// What every binary log reader's frames must satisfy, and GNSS from CAN assembled from them:
/// fixes in time order with valid positions, batch and frame by frame alike.
fn frames_and_can_gnss(frames: &[host_sim::input::logs::CanFrame]) {
    use host_sim::input::can_gnss::{fixes_from_can, Assembler};
    for f in frames {
        assert!(f.t.is_finite() && f.data.len() <= 64 && (f.extended || f.id <= 0x7FF) && f.id <= 0x1FFF_FFFF, "{f:?}");
    }
    let mut sorted = frames.to_vec();
    sorted.sort_by(|a, b| a.t.total_cmp(&b.t));
    let gnss = gnss_on_can();
    let batch = fixes_from_can(&sorted, &gnss);
    assert!(batch.windows(2).all(|w| w[0].t <= w[1].t) && batch.iter().all(|f| f.pos.is_valid()));
    let mut a = Assembler::new(gnss);
    let mut live = Vec::new();
    for f in &sorted {
        live.extend(a.push(f));
    }
    live.extend(a.finish());
    assert_eq!(live, batch, "GNSS from CAN: frame by frame is not the log's");
}

/// Vector BLF logs: the reader, strict and skipping bad objects (the input as a file's bytes, and
/// behind a valid file header so the fuzzer reaches the objects at once); the frames through
/// GNSS from CAN.
pub fn blf(data: &[u8]) {
    use host_sim::input::{blf, LoadOptions};
    let mut with_header = b"LOGG".to_vec();
    with_header.extend(144u32.to_le_bytes());
    with_header.resize(144, 0);
    with_header.extend_from_slice(data);
    for bytes in [data, &with_header[..]] {
        let _ = blf::looks_like_blf(bytes);
        for skip in [false, true] {
            let opts = LoadOptions { skip_bad_rows: skip, ..LoadOptions::default() };
            if let Ok((frames, _)) = blf::blf_from_bytes(Path::new("fuzz.blf"), bytes, &opts) {
                frames_and_can_gnss(&frames);
            }
        }
    }
}

/// ASAM MDF 4 bus logs (through falcon_mdf): a file's bytes, as they come and with the `MDF`
/// signature put first; the frames through GNSS from CAN.
pub fn mdf4(data: &[u8]) {
    use host_sim::input::mdf4;
    let mut signed = b"MDF     4.10    ".to_vec();
    signed.extend_from_slice(data.get(16..).unwrap_or(&[]));
    for bytes in [data.to_vec(), signed] {
        let _ = mdf4::looks_like_mdf4(&bytes);
        if let Ok(m) = mdf4::mdf4_from_bytes(Path::new("fuzz.mf4"), bytes) {
            frames_and_can_gnss(&m.frames);
        }
    }
}
