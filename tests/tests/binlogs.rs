//! The binary CAN logs people record with (ASAM MDF 4, Vector BLF) against independent
//! implementations, and the real CANedge logs behind css_canedge against the pack's sessions.
//!
//! - BLF that python-can writes (random frames on four channels, standard and extended ids, CAN
//!   and CAN FD) reads back frame for frame as python-can reads it; the comma2k19 segment's
//!   135,468 frames through BLF (python-can's converter from our candump export) read back frame
//!   for frame and give the candump route's digest.
//! - MDF 4 that asammdf writes (through python-can's MF4Writer: uncompressed, deflate,
//!   transposed deflate, and unfinalised) reads back frame for frame.
//! - The CANedge's own MF4 files: frame counts per bus and id equal asammdf's; through `detect`
//!   with the OBD-II and CSS DBCs and our map they give the pack's css_canedge sessions (the same
//!   fixes, times within 10 ms, positions within 1e-6 deg; the same alarm state at every epoch).
//!
//! python-can and asammdf are installed by the test command into the private venv.

use host_sim::input::candump::CanFrame;
use host_sim::input::{logs, LoadOptions};
use std::path::{Path, PathBuf};
use std::process::Command;
use system_tests::{data_dir, detect_json, python_with, ExportedLogs};

fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("py/binlogs.py")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gnss-guard-binlogs-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn py(args: &[&str]) -> String {
    let python = python_with(&["can=python-can", "asammdf"]);
    let out = Command::new(&python).arg(script()).args(args).output().expect("run python");
    assert!(out.status.success(), "binlogs.py {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

#[derive(Debug, PartialEq)]
struct Frame {
    t: f64,
    bus: u8,
    id: u32,
    ext: bool,
    data: Vec<u8>,
}

fn parse(lines: &str) -> Vec<Frame> {
    lines
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            let hex = v["data"].as_str().unwrap();
            Frame {
                t: v["t"].as_f64().unwrap(),
                bus: v["bus"].as_u64().unwrap() as u8,
                id: v["id"].as_u64().unwrap() as u32,
                ext: v["ext"].as_bool().unwrap(),
                data: (0..hex.len() / 2).map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap()).collect(),
            }
        })
        .collect()
}

fn ours(path: &Path) -> Vec<CanFrame> {
    logs::read_can_log(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}")).0
}

/// Frame for frame: the same order, bus, id, id space and payload; times within `tol_s`.
fn same_frames(what: &str, got: &[CanFrame], want: &[Frame], tol_s: f64) {
    assert_eq!(got.len(), want.len(), "{what}: frame count");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        let g2 = Frame { t: g.t, bus: g.bus().unwrap(), id: g.id, ext: g.extended, data: g.data.clone() };
        assert!((g2.t - w.t).abs() <= tol_s, "{what}: frame {k}: time {} against {}", g2.t, w.t);
        assert_eq!((g2.bus, g2.id, g2.ext, &g2.data), (w.bus, w.id, w.ext, &w.data), "{what}: frame {k}");
    }
}

#[test]
fn blf_written_by_python_can_reads_back_frame_for_frame() {
    let d = tmp("blf");
    let frames = d.join("frames.jsonl");
    std::fs::write(&frames, py(&["random-frames", "7", "3000"])).unwrap();
    let blf = d.join("random.blf");
    py(&["write-blf", frames.to_str().unwrap(), blf.to_str().unwrap()]);
    let theirs = parse(&py(&["read-blf", blf.to_str().unwrap()]));
    let written = parse(&std::fs::read_to_string(&frames).unwrap());
    assert_eq!(theirs.len(), written.len(), "python-can reads back what it wrote");
    let mine = ours(&blf);
    same_frames("BLF (python-can)", &mine, &theirs, 1.5e-6);
    let fd = mine.iter().filter(|f| f.data.len() > 8).count();
    let ext = mine.iter().filter(|f| f.extended).count();
    eprintln!("BLF: {} frames ({fd} CAN FD, {ext} extended, 4 channels) as python-can reads them", mine.len());
    assert!(fd > 100 && ext > 100);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn mdf4_written_by_asammdf_reads_back_frame_for_frame() {
    let d = tmp("mf4");
    let frames = d.join("frames.jsonl");
    std::fs::write(&frames, py(&["random-frames", "11", "3000"])).unwrap();
    let want = parse(&std::fs::read_to_string(&frames).unwrap());
    for (name, level) in [("plain", "0"), ("deflate", "1"), ("transposed", "2")] {
        let f = d.join(format!("{name}.mf4"));
        py(&["write-mf4", frames.to_str().unwrap(), f.to_str().unwrap(), level]);
        // MF4 stores each time as an offset from the header's start: a few microseconds of
        // float rounding at UNIX magnitudes.
        same_frames(&format!("MF4 {name}"), &ours(&f), &want, 2e-6);
        if name == "plain" {
            let u = d.join("unfinalised.mf4");
            py(&["unfinalise", f.to_str().unwrap(), u.to_str().unwrap()]);
            assert_eq!(&std::fs::read(&u).unwrap()[..8], b"UnFinMF ");
            same_frames("MF4 unfinalised", &ours(&u), &want, 2e-6);
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_binary_logs_name_the_file_and_the_offset() {
    let d = tmp("bad");
    let f = d.join("cut.blf");
    let mut b = b"LOGG".to_vec();
    b.extend(144u32.to_le_bytes());
    b.resize(144, 0);
    b.extend(b"LOBJ\x10\x00\x01\x00\xff\xff\x00\x00\x0a\x00\x00\x00");
    std::fs::write(&f, &b).unwrap();
    let e = logs::read_can_log(&f, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("cut.blf") && e.contains("byte 144") && e.contains("expected an object size"), "{e}");
    let f = d.join("cut.mf4");
    std::fs::write(&f, b"MDF     4.10    junk").unwrap();
    let e = logs::read_can_log(&f, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("cut.mf4") && e.contains("MDF 4"), "{e}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_comma2k19_segment_through_blf_gives_the_candump_routes_digest() {
    let Some(x) = ExportedLogs::new("the_comma2k19_segment_through_blf_gives_the_candump_routes_digest") else { return };
    let blf = x.dir.join("can.blf");
    py(&["candump-to-blf", &x.path("can.log"), blf.to_str().unwrap()]);
    let candump = ours(Path::new(&x.path("can.log")));
    let theirs: Vec<Frame> = candump.iter().map(|f| Frame { t: f.t, bus: f.bus().unwrap(), id: f.id, ext: f.extended, data: f.data.clone() }).collect();
    let mine = ours(&blf);
    // To the microsecond: the BLF reader rounds as the candump reader does.
    same_frames("comma2k19 through BLF", &mine, &theirs, 0.0);
    assert_eq!(mine.len(), 135_468);
    let (_, dump) = x.detect("can.log", "gnss.nmea");
    let (_, via_blf) = x.detect("can.blf", "gnss.nmea");
    assert_eq!(dump["digest"], via_blf["digest"], "the BLF route's digest is the candump route's");
    eprintln!("comma2k19 via BLF: 135468 frames identical, digest {}", via_blf["digest"]);
}

/// The CANedge's folder of a session, and the pack's CSV of it.
const CSS: [(&str, &str); 2] = [("00000164", "denmark_2021-07-26_session0"), ("00000165", "denmark_2021-07-26_session1")];

#[test]
fn the_canedge_mf4_frame_counts_are_asammdfs() {
    let Some(d) = data_dir("the_canedge_mf4_frame_counts_are_asammdfs") else { return };
    let root = d.join("raw/css_canedge_mf4/3BA199E2");
    let mut files: Vec<String> = Vec::new();
    let mut mine = std::collections::BTreeMap::<String, u64>::new();
    for (sess, _) in CSS {
        for f in host_sim::input::mdf4::mdf4_files(&root.join(sess)) {
            for fr in host_sim::input::mdf4::read_mdf4(&f).unwrap().frames {
                // asammdf gives the logger's BusChannel (ours is BusChannel - 1).
                *mine.entry(format!("{}:{}", fr.bus().unwrap() + 1, fr.id)).or_default() += 1;
            }
            files.push(f.to_str().unwrap().to_string());
        }
    }
    let mut args = vec!["asammdf-counts"];
    args.extend(files.iter().map(String::as_str));
    let theirs: std::collections::BTreeMap<String, u64> = serde_json::from_str(&py(&args)).unwrap();
    assert_eq!(mine, theirs, "frames per BusChannel:ID");
    let total: u64 = mine.values().sum();
    eprintln!("CANedge MF4: {} files, {total} frames, {} (bus, id) pairs, counts equal to asammdf's", files.len(), mine.len());
    assert_eq!(total, 640_067);
}

#[test]
fn the_canedge_mf4_logs_through_detect_give_the_packs_sessions() {
    let Some(d) = data_dir("the_canedge_mf4_logs_through_detect_give_the_packs_sessions") else { return };
    let profiles = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../firmware/board/profiles");
    let (obd, gnss_dbc, map) = (profiles.join("obd2.dbc"), d.join("raw/css_canedge_mf4/gnss.dbc"), profiles.join("css_canedge.map"));
    let profile = logs::load_profile(&[obd.clone(), gnss_dbc.clone()], &map).unwrap();
    for (sess, csv) in CSS {
        let dir = d.join("raw/css_canedge_mf4/3BA199E2").join(sess);
        let pack = d.join("drives/css_canedge").join(format!("{csv}.csv"));
        // The fixes.
        let mf4 = logs::load(&dir, None, &profile, &LoadOptions::default()).unwrap();
        let csv_r = host_sim::input::load(&pack, &LoadOptions::default()).unwrap();
        let (a, b): (Vec<_>, Vec<_>) = (mf4.fixes().collect(), csv_r.fixes().collect());
        // The pack's 10 Hz grid ends before the session's last fix (its time is past the last
        // grid row), so the pack holds every fix but that one.
        assert_eq!(a.len(), b.len() + 1, "{csv}: fixes");
        let (ta, tb) = (a[0].t, b[0].t);
        let last_row = csv_r.events.iter().map(|e| e.t()).fold(f64::MIN, f64::max);
        assert!(a[a.len() - 1].t - ta > last_row - tb, "{csv}: the extra fix is past the pack's end");
        for (k, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!(((x.t - ta) - (y.t - tb)).abs() < 0.010, "{csv}: fix {k} at {} against {}", x.t - ta, y.t - tb);
            assert!((x.pos.lat_deg - y.pos.lat_deg).abs() < 1e-6 && (x.pos.lon_deg - y.pos.lon_deg).abs() < 1e-6, "{csv}: fix {k}: {:?} against {:?}", x.pos, y.pos);
        }
        // The same alarm state at every epoch, through `detect`.
        let (ma, msum) = detect_json(&["--can", dir.to_str().unwrap(), "--dbc", obd.to_str().unwrap(), "--dbc", gnss_dbc.to_str().unwrap(), "--map", map.to_str().unwrap()]);
        let (pa, _) = detect_json(&[pack.to_str().unwrap()]);
        assert_eq!(ma.len(), pa.len() + 1, "{csv}: epochs");
        for (k, (x, y)) in ma.iter().zip(&pa).enumerate() {
            assert_eq!(x["alarm"], y["alarm"], "{csv}: epoch {k}");
        }
        // And under the same attack (a turn-by-turn offset of 120 m, half a second after the fix
        // 600 s in): the alarm at the same epochs.
        let onset = b.iter().find(|f| f.t - tb >= 600.0).unwrap().t - tb + 0.5;
        let params = host_sim::attack::AttackParams { offset_m: Some(120.0), bearing_deg: Some(90.0), ..Default::default() };
        let alarms = |r: &host_sim::input::Replay, t0: f64| -> Vec<bool> {
            let at = host_sim::attack::apply_with(r, host_sim::attack::AttackKind::TurnByTurn, 1, t0 + onset, &params);
            let (samples, _) = host_sim::replay::synchronize(&at.replay, detector_core::sync::SyncConfig::default());
            let p = host_sim::detect::profile_of(&samples);
            let cfg = host_sim::detect::config(p, host_sim::detect::PredictorKind::Lstm);
            host_sim::detect::run_with_templates(&samples, cfg, host_sim::detect::PredictorKind::Lstm, host_sim::detect::default_templates()).iter().map(|v| v.alarm).collect()
        };
        let (xa, ya) = (alarms(&mf4, ta), alarms(&csv_r, tb));
        assert_eq!(&xa[..ya.len()], &ya[..], "{csv}: alarm state under attack");
        let first = ya.iter().position(|x| *x).expect("the attack is found");
        eprintln!("{csv}: {} MF4 fixes = the pack's {} + the one past its grid; alarm state identical at every epoch, clean ({}) and under a 120 m turn-by-turn attack (first alarm at epoch {first}, both); MF4 digest {}", a.len(), b.len(), ma.last().unwrap()["alarm"], msum["digest"]);
    }
}

#[test]
fn live_with_gnss_from_can_gives_detects_digest() {
    let Some(d) = data_dir("live_with_gnss_from_can_gives_detects_digest") else { return };
    let profiles = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../firmware/board/profiles");
    let (obd, gnss_dbc, map) = (profiles.join("obd2.dbc"), d.join("raw/css_canedge_mf4/gnss.dbc"), profiles.join("css_canedge.map"));
    let dir = d.join("raw/css_canedge_mf4/3BA199E2/00000165");
    let (_, batch) = detect_json(&["--can", dir.to_str().unwrap(), "--dbc", obd.to_str().unwrap(), "--dbc", gnss_dbc.to_str().unwrap(), "--map", map.to_str().unwrap()]);
    // The session's frames as `candump -L` text on stdin, as a logger would stream them; no
    // --gnss: the fixes come from CAN.
    let text: String = ours(&dir).iter().map(|f| f.candump_line() + "\n").collect();
    let mut child = Command::new(system_tests::host_sim_bin())
        .args(["live", "--can", "-", "--strict-merge", "--dbc", obd.to_str().unwrap(), "--dbc", gnss_dbc.to_str().unwrap(), "--map", map.to_str().unwrap()])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || std::io::Write::write_all(&mut stdin, text.as_bytes()));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(out.status.success(), "live: {}", String::from_utf8_lossy(&out.stderr));
    let last: serde_json::Value = serde_json::from_str(String::from_utf8(out.stdout).unwrap().lines().last().unwrap()).unwrap();
    assert_eq!(last["inputs"]["fixes"], batch["summary"]["epochs"], "live: {last}");
    assert_eq!(last["digest"], batch["digest"], "live with GNSS from CAN against detect on the MF4 files");
    eprintln!("live, GNSS from CAN: {} fixes, digest {} = detect's", last["inputs"]["fixes"], last["digest"]);
}

#[test]
fn the_fuzz_seeds_are_logs_with_gnss_on_can() {
    // The blf and mdf4 fuzz targets start from these: each must read, and carry fixes.
    let seeds = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds");
    for (dir, n) in [("blf", 2), ("mdf4", 3)] {
        let files: Vec<PathBuf> = std::fs::read_dir(seeds.join(dir)).unwrap().flatten().map(|e| e.path()).collect();
        assert_eq!(files.len(), n, "{dir} seeds");
        for f in files {
            let frames = ours(&f);
            assert_eq!(frames.len(), 48, "{}", f.display());
            let fixes = host_sim::input::can_gnss::fixes_from_can(&frames, &system_tests::fuzz::gnss_on_can());
            assert_eq!(fixes.len(), 12, "{}", f.display());
        }
    }
}
