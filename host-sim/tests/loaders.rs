//! Loader tests on the real drives, and error tests on deliberately broken copies.

use detector_core::sample::{Reading, Sample, Signal};
use detector_core::sync::SyncConfig;
use host_sim::input::{self, Format, LoadOptions, Location};
use host_sim::{inspect, replay, require_data};
use std::path::{Path, PathBuf};

const COMMA_CSV: &str = "drives/comma2k19/b0c9d2329ad1606b_2018-08-02--08-34-47_seg40.csv";
const OPENXC_CSV: &str = "drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv";

fn samples(p: &Path) -> Vec<Sample> {
    let r = input::load(p, &LoadOptions::default()).unwrap();
    replay::synchronize(&r, SyncConfig::default()).0
}

fn mean(xs: impl Iterator<Item = f32>) -> f64 {
    let v: Vec<f64> = xs.map(f64::from).collect();
    v.iter().sum::<f64>() / v.len() as f64
}

fn valid(s: &[Sample], sig: Signal) -> Vec<f32> {
    s.iter().filter_map(|x| x.signal(sig).get()).collect()
}

#[test]
fn drive_csv_real_epochs_and_signals() {
    let Some(d) = require_data("drive_csv_real_epochs_and_signals") else { return };
    let s = samples(&d.join(COMMA_CSV));
    assert_eq!(s.len(), 485, "rows with gnss_new_fix = 1");
    for sig in Signal::ALL {
        assert!(valid(&s, sig).len() >= 480, "{sig:?} valid almost everywhere");
    }
    // Wheel speed and GNSS speed agree on a real highway drive.
    let diff = mean(s.iter().filter_map(|x| Some((x.wheel_speed().get()? - x.gnss_speed.get()?).abs())));
    assert!(diff < 0.6, "mean |wheel - gnss| = {diff}");
    // udacity has no pedal: Missing, not NaN and not stale.
    let u = samples(&d.join("drives/udacity_ch2/mountainview_2016-11-17_ch2_test.csv"));
    assert!(u.iter().all(|x| x.pedal() == Reading::Missing));
}

#[test]
fn comma2k19_raw_matches_its_csv_conversion() {
    let Some(d) = require_data("comma2k19_raw_matches_its_csv_conversion") else { return };
    let raw = samples(&d.join("raw/comma2k19_rav4_seg40"));
    let csv = samples(&d.join(COMMA_CSV));
    assert_eq!(raw.len(), 579, "one epoch per live_gnss_ublox fix");
    for sig in Signal::ALL {
        let (a, b) = (mean(valid(&raw, sig).into_iter()), mean(valid(&csv, sig).into_iter()));
        assert!(valid(&raw, sig).len() > 570, "{sig:?} decoded from raw CAN");
        assert!((a - b).abs() <= 0.05 * b.abs().max(1.0), "{sig:?}: raw mean {a} vs csv mean {b}");
    }
    let dist: f32 = raw.iter().filter_map(|x| x.shift_m.get()).sum();
    assert!((dist - 1010.0).abs() < 20.0, "{dist}");
}

#[test]
fn openxc_raw_matches_its_csv_conversion() {
    let Some(d) = require_data("openxc_raw_matches_its_csv_conversion") else { return };
    let raw = samples(&d.join("raw/openxc_ford/drivingnew.jsonl"));
    let csv = samples(&d.join(OPENXC_CSV));
    assert_eq!(raw.len(), csv.len());
    for sig in [Signal::WheelSpeed, Signal::Steering, Signal::Pedal] {
        let (a, b) = (mean(valid(&raw, sig).into_iter()), mean(valid(&csv, sig).into_iter()));
        assert!((a - b).abs() <= 0.05 * b.abs().max(1.0), "{sig:?}: raw {a} vs csv {b}");
    }
}

fn hdd_fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/hdd/201702271017")
}

#[test]
fn hdd_fixture_swapped_latlon_and_units() {
    let p = hdd_fixture();
    assert_eq!(input::detect(&p), Some(Format::Hdd));
    let r = input::load(&p, &LoadOptions::default()).unwrap();
    assert!(r.notes.iter().any(|n| n.contains("swapped")), "{:?}", r.notes);
    let s = replay::synchronize(&r, SyncConfig::default()).0;
    assert!(s.len() > 150);
    // The fixture is the comma2k19 drive near San Francisco.
    assert!(s.iter().all(|x| (x.pos.lat_deg - 37.72).abs() < 0.05 && (x.pos.lon_deg + 122.47).abs() < 0.05));
    // km/h converted to m/s: wheel speed close to the GNSS course-track speed of the same drive.
    let ws = mean(valid(&s, Signal::WheelSpeed).into_iter());
    assert!((5.0..20.0).contains(&ws), "wheel speed mean {ws} m/s");
    assert!(s.iter().all(|x| x.gnss_course.is_valid()));
    assert!(valid(&s, Signal::Pedal).len() + 1 >= s.len());
    // m/s if told so: 3.6 times larger.
    let opts = LoadOptions { hdd: input::HddUnits { speed_scale: 1.0, steer_sign: 1.0 }, ..Default::default() };
    let s2 = replay::synchronize(&input::load(&p, &opts).unwrap(), SyncConfig::default()).0;
    let ws2 = mean(valid(&s2, Signal::WheelSpeed).into_iter());
    assert!((ws2 / ws - 3.6).abs() < 1e-3);
}

#[test]
fn inspect_distance_matches_index_for_every_drive() {
    let Some(d) = require_data("inspect_distance_matches_index_for_every_drive") else { return };
    let text = std::fs::read_to_string(d.join("index.csv")).unwrap();
    let mut rdr = csv::Reader::from_reader(text.as_bytes());
    let h = rdr.headers().unwrap().clone();
    let (fi, di) = (h.iter().position(|x| x == "file").unwrap(), h.iter().position(|x| x == "dist_km").unwrap());
    let mut n = 0;
    for rec in rdr.records() {
        let rec = rec.unwrap();
        let p = d.join(&rec[fi]);
        let r = input::load(&p, &LoadOptions::default()).unwrap();
        let s = replay::synchronize(&r, SyncConfig::default()).0;
        let st = inspect::stats(&r, &s, SyncConfig::default().earth_radius_m);
        let want = rec[di].parse::<f64>().unwrap() * 1000.0;
        assert!((st.distance_m / want - 1.0).abs() < 0.02, "{}: {} m vs index {} m", &rec[fi], st.distance_m, want);
        n += 1;
    }
    // Every drive CSV under drives/ is in the index, and the other way round.
    assert_eq!(n, input::discover(&d.join("drives")).unwrap().len());
}

// ---- broken copies: one per failure class ----

fn broken_copy(dir: &Path, edit: impl Fn(&str) -> String) -> PathBuf {
    // A small real-shaped drive: the HDD fixture's source is not needed, a few rows suffice.
    let base = "t_s,unix_time_s,lat_deg,lon_deg,gnss_new_fix,gnss_fix_age_s,gnss_speed_mps,gnss_course_deg,veh_speed_mps,steer_wheel_deg,accel_pedal_pct,long_accel_mps2,yaw_rate_degps\n\
0,1533226488,37.7209977,-122.4723053,1,0,7.8,2.1,8.0,-0.4,29,1.5,-0.56\n\
0.1,1533226488,37.721005,-122.472305,1,0.01,7.9,2.2,8.2,-0.4,28.7,1.6,-0.31\n\
0.2,1533226489,37.7210124,-122.4723046,1,0.01,8.2,2.3,8.4,-0.4,28.5,1.7,-0.56\n\
0.3,1533226489,37.7210124,-122.4723046,0,0.11,8.2,2.3,8.6,-0.7,28.5,1.9,-0.80\n";
    let p = dir.join("broken.csv");
    std::fs::write(&p, edit(base)).unwrap();
    p
}

fn expect_error(p: &Path, line: u64, needle: &str) {
    let e = input::load(p, &LoadOptions::default()).unwrap_err();
    assert_eq!(e.file, p);
    assert_eq!(e.at, Location::Line(line), "{e}");
    assert!(e.to_string().contains(needle), "`{e}` should mention `{needle}`");
    // With --skip-bad-rows the row is counted and the rest is kept.
    if line > 1 {
        let r = input::load(p, &LoadOptions { skip_bad_rows: true, ..Default::default() }).unwrap();
        assert_eq!(r.skipped_rows, 1, "{needle}");
    }
}

#[test]
fn errors_name_file_line_and_expectation() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // truncated file: the last row is cut mid-way
    let p = broken_copy(d, |s| s[..s.len() - 30].to_string());
    expect_error(&p, 5, "expected 13 fields");
    // missing column
    let p = broken_copy(d, |s| s.replacen("lat_deg", "latitude", 1));
    expect_error(&p, 1, "missing column `lat_deg`");
    // text in a number field
    let p = broken_copy(d, |s| s.replacen("8.2,-0.4", "fast,-0.4", 1));
    expect_error(&p, 3, "expected a number, found \"fast\"");
    // time going backwards
    let p = broken_copy(d, |s| s.replacen("\n0.2,", "\n0.05,", 1));
    expect_error(&p, 4, "time goes backwards");
    // NaN coordinates on a fix row
    let p = broken_copy(d, |s| s.replacen("37.721005", "NaN", 1));
    expect_error(&p, 3, "needs coordinates");
}

#[test]
fn openxc_and_npy_and_hdd_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = d.join("t.jsonl");
    std::fs::write(&p, "1.0: {\"name\":\"latitude\",\"value\":42.0}\n1.1: {\"name\":\"longitude\",\"value\":-83.0}\n1.2: {\"name\":\"vehicle_speed\",\"value\":\n").unwrap();
    let e = input::load(&p, &LoadOptions::default()).unwrap_err();
    assert_eq!(e.at, Location::Line(3), "{e}");
    // comma2k19 with a truncated array
    let seg = d.join("seg");
    let g = seg.join("processed_log/GNSS/live_gnss_ublox");
    std::fs::create_dir_all(&g).unwrap();
    std::fs::write(g.join("t"), b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, 'shape': (10,), }").unwrap();
    let e = input::load(&seg, &LoadOptions::default()).unwrap_err();
    assert_eq!(e.at, Location::Array("GNSS/live_gnss_ublox/t".into()), "{e}");
    // HDD with a missing column
    let h = d.join("sess/general/csv");
    std::fs::create_dir_all(&h).unwrap();
    std::fs::write(h.join("rtk_pos.csv"), "# unix_timestamp,latitude,lng\n1.0,37.0,-122.0\n").unwrap();
    let e = input::load(&d.join("sess"), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("rtk_pos.csv:1: missing column"), "{e}");
}
