//! `host-sim detect` end to end: zero alarms on every clean real drive, degraded mode said.

use system_tests::{data_dir, host_sim};

/// Verdict lines and the summary (the once-a-second status lines are checked and dropped).
fn detect(path: &std::path::Path) -> (Vec<serde_json::Value>, serde_json::Value) {
    let (lines, summary, status) = detect_with_status(path);
    // The device's status once a second of drive time, with the firmware's fields.
    let secs = lines.last().zip(lines.first()).map_or(0.0, |(a, b)| a["t"].as_f64().unwrap() - b["t"].as_f64().unwrap());
    assert!(status.len() as f64 >= secs.floor(), "{}: {} status lines for {secs} s", path.display(), status.len());
    for st in &status {
        for k in ["state", "ran", "degraded", "fix_age_s", "epochs", "can_dropped", "can_overruns", "nmea_errors", "restarts", "detector_restarts"] {
            assert!(st.get(k).is_some(), "{k} missing in {st}");
        }
    }
    (lines, summary)
}

/// An empty directory of this test run's own under the system's temporary one.
fn fresh_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("gnss-guard-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn detect_with_status(path: &std::path::Path) -> (Vec<serde_json::Value>, serde_json::Value, Vec<serde_json::Value>) {
    let out = host_sim(&["detect", "--json", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}: {}", path.display(), String::from_utf8_lossy(&out.stderr));
    let mut lines: Vec<serde_json::Value> =
        String::from_utf8(out.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let last = lines.pop().unwrap();
    let summary = last["summary"].clone();
    // The verdict digest, comparable with `host-sim digest` and the QEMU run's.
    let digest = last["digest"].as_str().unwrap_or_default();
    assert!(digest.len() == 16 && digest.chars().all(|c| c.is_ascii_hexdigit()), "digest {digest:?}");
    let status = lines.iter().filter_map(|l| l.get("status").cloned()).collect();
    lines.retain(|l| l.get("status").is_none());
    (lines, summary, status)
}

/// Issue #14: a 10 Hz drive at 8 m/s with the wheel held between 20 and 60 deg for 25 s and
/// then turned past 60 deg panicked `host-sim detect` (turn.rs: index out of bounds). It must
/// run to the end, exit 0 and raise nothing (GNSS follows the wheel).
#[test]
fn a_long_bend_before_a_turn_is_judged_without_panic() {
    let dir = std::env::temp_dir().join(format!("gnss-guard-bend-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bend.csv");
    let mut csv = String::from("t_s,unix_time_s,lat_deg,lon_deg,gnss_new_fix,gnss_fix_age_s,gnss_speed_mps,gnss_course_deg,veh_speed_mps,steer_wheel_deg,accel_pedal_pct,long_accel_mps2,yaw_rate_degps\n");
    let (r, v) = (6_378_000.0f64, 8.0f64);
    let (mut lat, mut lon, mut hdg) = (48.0f64, 11.0f64, 0.0f64);
    let mut seed = 1u32;
    let mut noise = |a: f64| {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        a * ((seed >> 8) as f64 / (1u32 << 24) as f64 * 2.0 - 1.0)
    };
    for k in 0..900 {
        let t = k as f64 * 0.1;
        let st = if t < 30.0 { noise(3.0) } else if t < 55.0 { 40.0 + noise(4.0) } else if t < 62.0 { 120.0 + noise(4.0) } else { noise(3.0) };
        let yaw = (v * (st / 15.0).to_radians().tan() / 2.7).to_degrees();
        hdg = (hdg - yaw * 0.1).rem_euclid(360.0);
        lat += v * 0.1 * hdg.to_radians().cos() / r * 180.0 / std::f64::consts::PI;
        lon += v * 0.1 * hdg.to_radians().sin() / (r * lat.to_radians().cos()) * 180.0 / std::f64::consts::PI;
        csv += &format!("{t:.1},{:.1},{lat:.8},{lon:.8},1,0.0,{v:.2},{hdg:.2},{v:.2},{st:.2},20,0,{yaw:.3}\n", 1.6e9 + t);
    }
    std::fs::write(&path, csv).unwrap();
    let out = host_sim(&["detect", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let (lines, summary, status) = detect_with_status(&path);
    assert_eq!(lines.len(), 900);
    assert_eq!(summary["alarm"], false, "{summary}");
    assert!(lines.iter().any(|l| l["turn"]["steering"] == "left"), "the turn was judged");
    // 90 s from power-up without a standstill: the track check may still be learning the
    // gyro's bias (no standstill to read it) and its frame; nothing is degraded or alarmed.
    let last = status.last().unwrap()["state"].as_str().unwrap();
    assert!(last == "running" || last == "learning", "{last}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn clean_drives_raise_no_alarm_and_say_when_degraded() {
    let Some(d) = data_dir("clean_drives_raise_no_alarm_and_say_when_degraded") else { return };
    let mut drives: Vec<_> = walk(&d.join("drives"));
    drives.push(d.join("raw/comma2k19_rav4_seg40"));
    drives.push(d.join("raw/openxc_ford/drivingnew.jsonl"));
    // Every drive of the index, and the two raw originals (both with wheel speed).
    let index = std::fs::read_to_string(d.join("index.csv")).unwrap();
    let rows: Vec<&str> = index.lines().skip(1).filter(|l| !l.trim().is_empty()).collect();
    let with_wheels = rows.iter().filter(|l| l.contains("veh_speed_mps")).count() + 2;
    assert_eq!(drives.len(), rows.len() + 2);
    let (mut judged, mut degraded) = (0, 0);
    for p in &drives {
        let (lines, s) = detect(p);
        assert_eq!(lines.len() as u64, s["epochs"].as_u64().unwrap());
        for l in &lines {
            for k in ["t", "alarm", "fired", "degraded"] {
                assert!(l.get(k).is_some(), "{k} missing in {l}");
            }
            assert_eq!(l["alarm"], false, "{}: false alarm at {l}", p.display());
        }
        assert_eq!(s["alarm"], false, "{}", p.display());
        for strat in ["location_shift", "motion", "turn", "track"] {
            assert_eq!(s["fired"][strat], 0, "{} {strat}", p.display());
        }
        let n = s["epochs"].as_u64().unwrap();
        if s["ran"]["location_shift"].as_u64().unwrap() == 0 {
            // No wheel speed (driveplotr_nds): S1 and S3 degraded at every epoch, and said so.
            assert_eq!(s["degraded"]["location_shift"].as_u64().unwrap(), n, "{}", p.display());
            assert_eq!(s["degraded"]["motion"].as_u64().unwrap(), n);
            assert!(lines.iter().all(|l| l["degraded"].as_array().unwrap().iter().any(|x| x == "location_shift")));
            degraded += 1;
        } else {
            // Everywhere but the receiver's first 5 s (50 epochs at 10 Hz) and a few gaps.
            assert!(s["ran"]["location_shift"].as_u64().unwrap() + 60 >= n, "{}: S1 ran almost everywhere", p.display());
            judged += 1;
        }
    }
    assert_eq!((judged, degraded), (with_wheels, drives.len() - with_wheels), "drives with and without wheel speed");
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else if p.extension().is_some_and(|x| x == "csv") {
            out.push(p);
        }
    }
    out.sort();
    out
}

#[test]
fn detect_text_output_has_a_summary() {
    let Some(d) = data_dir("detect_text_output_has_a_summary") else { return };
    let out = host_sim(&["detect", d.join("drives/comma2k19/b0c9d2329ad1606b_2018-08-02--08-34-47_seg40.csv").to_str().unwrap()]);
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("summary:") && s.contains("shift") && s.contains("thr"), "{}", &s[..200.min(s.len())]);
    // The same run in JSON gives the same verdict digest.
    let text_digest = s.lines().find_map(|l| l.strip_prefix("verdict digest: ")).expect("a digest line").to_string();
    let out = host_sim(&["detect", "--json", d.join("drives/comma2k19/b0c9d2329ad1606b_2018-08-02--08-34-47_seg40.csv").to_str().unwrap()]);
    let last: serde_json::Value = serde_json::from_str(String::from_utf8(out.stdout).unwrap().lines().last().unwrap()).unwrap();
    assert_eq!(last["digest"], text_digest.as_str());
}

/// `detect --calibration FILE`: a car's first drive says it is learning and writes the record;
/// its second drive starts from it (calibrated from the first status line), and `inspect` shows
/// it; a damaged record is reported with its byte, moved aside, and the drive starts afresh.
#[test]
fn the_calibration_file_carries_the_car_across_drives() {
    let Some(d) = data_dir("the_calibration_file_carries_the_car_across_drives") else { return };
    let dir = fresh_dir("cal");
    let file = dir.join("car.ggcr");
    let run = |drive: &str| -> (serde_json::Value, Vec<serde_json::Value>, String) {
        let p = d.join("drives/css_canedge").join(drive);
        let out = host_sim(&["detect", "--json", "--calibration", file.to_str().unwrap(), p.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let status = lines.iter().filter_map(|l| l.get("status").cloned()).collect();
        (lines.last().unwrap().clone(), status, String::from_utf8(out.stderr).unwrap())
    };
    // First drive: no record yet; learning at first, a record written at the end.
    let (last, status, err) = run("denmark_2021-07-26_session0.csv");
    assert!(err.contains("none yet"), "{err}");
    assert_eq!(status[0]["calibration"], "learning", "{}", status[0]);
    assert_eq!(last["calibration"]["written"], true, "{last}");
    assert_eq!(last["summary"]["alarm"], false);
    let first = std::fs::read(&file).unwrap();
    assert_eq!(&first[..4], b"GGCR");
    // Second drive: starts from it, no contradiction, and the record grows by one drive.
    let (last, status, _) = run("denmark_2021-07-26_session1.csv");
    assert_eq!(last["calibration"]["loaded"], true);
    assert_eq!(last["calibration"]["contradicted"], false, "{last}");
    assert_ne!(status[0]["calibration"], "learning", "a second drive starts calibrated: {}", status[0]);
    assert_eq!(last["summary"]["alarm"], false);
    let second = detector_core::wire::calibration::Record::decode(&std::fs::read(&file).unwrap()).unwrap();
    assert_eq!(second.drives, 2);
    // `inspect` reads it: its fields and the car's anchors, as text and as JSON.
    let out = host_sim(&["inspect", file.to_str().unwrap()]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(out.status.success() && text.contains("calibration record, version 3") && text.contains("learnt over 2 drives"), "{text}");
    let out = host_sim(&["inspect", "--json", file.to_str().unwrap()]);
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((j["drives"].as_u64(), j["anchor_scale"].as_f64()), (Some(2), Some(second.anchor_scale as f64)), "{j}");
    // A damaged record: reported with its byte, moved aside, and the drive learns afresh.
    let mut bad = std::fs::read(&file).unwrap();
    bad[9] ^= 0x10;
    std::fs::write(&file, &bad).unwrap();
    // `inspect` refuses it with the byte where it failed (the CRC's) and exit code 2.
    let out = host_sim(&["inspect", file.to_str().unwrap()]);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(out.status.code() == Some(2) && err.contains("byte 112: expected the CRC-32"), "{err}");
    let (last, status, err) = run("denmark_2021-07-26_session1.csv");
    assert!(err.contains("byte ") && err.contains("expected"), "{err}");
    assert_eq!(std::fs::read(dir.join("car.bad")).unwrap(), bad, "the bad record is kept aside");
    assert_eq!(last["calibration"]["loaded"], false);
    assert_eq!(status[0]["calibration"], "learning");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Drives of `source` in turn (`drives` indexes its sorted CSV files) through `detect
/// --calibration`, each with `column` multiplied by its factor: per drive, the last JSON line
/// and the record in the file after it.
fn drives_in_turn(name: &str, d: &std::path::Path, source: &str, drives: &[usize], column: &str, factors: &[f64]) -> Vec<(serde_json::Value, detector_core::wire::calibration::Record)> {
    let dir = fresh_dir(name);
    let file = dir.join("car.ggcr");
    let mut all: Vec<_> = std::fs::read_dir(d.join("drives").join(source)).unwrap().flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "csv")).collect();
    all.sort();
    let mut out = Vec::new();
    for (k, (&i, f)) in drives.iter().zip(factors).enumerate() {
        let text = std::fs::read_to_string(&all[i]).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        let col = header.split(',').position(|c| c == column).unwrap();
        let mut csv = format!("{header}\n");
        for l in lines {
            let cells: Vec<String> = l.split(',').enumerate().map(|(i, c)| if i == col && !c.is_empty() { format!("{:.6}", c.parse::<f64>().unwrap() * f) } else { c.to_string() }).collect();
            csv.push_str(&cells.join(","));
            csv.push('\n');
        }
        let p = dir.join(format!("drive{k}.csv"));
        std::fs::write(&p, csv).unwrap();
        let run = host_sim(&["detect", "--json", "--calibration", file.to_str().unwrap(), p.to_str().unwrap()]);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        let stdout = String::from_utf8(run.stdout).unwrap();
        let last: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
        out.push((last, detector_core::wire::calibration::Record::decode(&std::fs::read(&file).unwrap()).unwrap()));
    }
    let _ = std::fs::remove_dir_all(&dir);
    out
}

/// The first drives of a walk are the car's (no contradiction, no alarm), the last is reported
/// and leaves the record as the drive before it wrote it.
fn walk_is_stopped_at_the_last(runs: &[(serde_json::Value, detector_core::wire::calibration::Record)]) {
    let n = runs.len();
    for (k, (last, rec)) in runs.iter().enumerate() {
        if k + 1 < n {
            assert_eq!((last["calibration"]["contradicted"].as_bool(), last["summary"]["alarm"].as_bool()), (Some(false), Some(false)), "drive {k}: {last}");
        } else {
            assert_eq!(last["calibration"]["contradicted"], true, "drive {k}: {last}");
            assert_eq!(rec.encode(), runs[k - 1].1.encode(), "drive {k}: the record kept");
        }
    }
}

/// A spoofer present on every drive, asking a little more of the wheel-speed scale each time
/// (GNSS 0.8 % faster than the wheels per drive, within one drive's bound of the record it
/// starts from), cannot walk the car's calibration: the record keeps the car's anchor, and the
/// third drive, 1.6 % from it, is reported (sddi_commuter's first three drives, their wheel
/// speed scaled). Without the anchor the record walked to 1.016 there, with no alarm.
#[test]
fn a_spoofer_on_every_drive_cannot_walk_the_calibration() {
    let Some(d) = data_dir("a_spoofer_on_every_drive_cannot_walk_the_calibration") else { return };
    // The wheels 0.8 % slower per drive than the last: the scale GNSS over wheels 0.8 % more.
    let runs = drives_in_turn("walk", &d, "sddi_commuter", &[0, 1, 2], "veh_speed_mps", &[1.0, 1.0 / 1.008, 1.0 / 1.016]);
    walk_is_stopped_at_the_last(&runs);
    let first = runs[0].1.scale;
    for (last, rec) in &runs {
        assert_eq!(rec.anchor_scale, first, "the anchor is the first record's: {last}");
        assert!(rec.scale <= first * 1.0102, "{rec:?}");
    }
}

/// The same for the gyro's scale: every turn's GNSS course 2 % larger than the gyro's per
/// drive (css_canedge's sessions, their yaw rate scaled). The second drive is within its bound
/// and learnt; the third, 4 % from the car's anchor, is reported. Without the anchor the
/// record's gyro scale error walked 2 % per drive, to 0.153 in eight drives, with no alarm.
#[test]
fn a_spoofer_on_every_drive_cannot_walk_the_gyro_scale() {
    let Some(d) = data_dir("a_spoofer_on_every_drive_cannot_walk_the_gyro_scale") else { return };
    let runs = drives_in_turn("gyro-walk", &d, "css_canedge", &[0, 1, 0], "yaw_rate_degps", &[1.0, 0.98, 0.96]);
    walk_is_stopped_at_the_last(&runs);
    let anchor = runs[0].1.gyro_scale_error;
    assert!(runs[1].1.gyro_scale_error > anchor + 0.01, "the second drive's 2 % is learnt: {:?}", runs[1].1);
    for (_, rec) in &runs {
        assert_eq!(rec.anchor_gyro_scale_error, anchor);
        assert!((rec.gyro_scale_error - anchor).abs() <= 0.03 + 1e-6, "{rec:?}");
    }
}

/// A fresh directory `name` holding `car.ggcr`, the record css_canedge session 0 leaves: the
/// directory, the record's path and css_canedge's drives.
fn session0_record(d: &std::path::Path, name: &str) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    let dir = fresh_dir(name);
    let (file, css) = (dir.join("car.ggcr"), d.join("drives/css_canedge"));
    let out = host_sim(&["detect", "--calibration", file.to_str().unwrap(), css.join("denmark_2021-07-26_session0.csv").to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    (dir, file, css)
}

/// A logger whose latency differs from boot to boot: css_canedge session 1 with its vehicle
/// signals late (the nuisance suite's `vehicle-late`), judged from session 0's record. 0.79 s
/// late (seed 1), within the delay's bound of the record, is found by the drive's own fits in
/// its first minutes and raises no alarm (before, the delay moved one candidate per 30 s from
/// the record's and the 10 s window fired 191 s in); 1.19 s (seed 2), beyond the bound, is
/// reported as the contradiction it is, and nothing else fires.
#[test]
fn a_stored_record_finds_this_drives_own_delay_within_its_bound() {
    let Some(d) = data_dir("a_stored_record_finds_this_drives_own_delay_within_its_bound") else { return };
    let (dir, file, css) = session0_record(&d, "late");
    let late = dir.join("late.csv");
    let record = std::fs::read(&file).unwrap();
    for (seed, contradicted) in [("1", false), ("2", true)] {
        let out = host_sim(&["nuisance", "--kind", "vehicle-late", "--seed", seed, "-o", late.to_str().unwrap(), css.join("denmark_2021-07-26_session1.csv").to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        std::fs::write(&file, &record).unwrap();
        let out = host_sim(&["detect", "--json", "--calibration", file.to_str().unwrap(), late.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let last = lines.last().unwrap();
        assert_eq!(last["calibration"]["contradicted"].as_bool(), Some(contradicted), "seed {seed}: {last}");
        let reasons: std::collections::BTreeSet<String> = lines.iter().filter(|l| l["alarm"] == true).flat_map(|l| l["reasons"].as_array().cloned().unwrap_or_default()).filter_map(|r| r.as_str().map(str::to_string)).collect();
        let expected: std::collections::BTreeSet<String> = if contradicted { ["calibration_contradicted".to_string()].into() } else { Default::default() };
        assert_eq!(reasons, expected, "seed {seed}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// What a drive under attack learnt is not kept: css_canedge session 1 with a jump of 300 m at
/// 1500 s, judged from session 0's record, writes the record as the board saved it at a
/// standstill before the alarm (5 s more learnt than session 0's), not the drive's own at its
/// end (2,200 s more, the code before), and says so.
#[test]
fn a_drive_that_ends_in_an_alarm_keeps_what_was_saved_before_it() {
    let Some(d) = data_dir("a_drive_that_ends_in_an_alarm_keeps_what_was_saved_before_it") else { return };
    let (dir, file, css) = session0_record(&d, "attacked");
    let stored = detector_core::wire::calibration::Record::decode(&std::fs::read(&file).unwrap()).unwrap();
    let jumped = dir.join("jumped.csv");
    let out = host_sim(&["attack", "--kind", "jump", "--offset-m", "300", "--bearing-deg", "90", "--onset", "1500", "-o", jumped.to_str().unwrap(), css.join("denmark_2021-07-26_session1.csv").to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = host_sim(&["detect", "--json", "--calibration", file.to_str().unwrap(), jumped.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8(out.stdout).unwrap();
    let last: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
    let said = last["calibration"]["said"].as_str().unwrap_or_default();
    assert!(said.contains("before the alarm at 1500.0 s"), "{said}");
    let kept = detector_core::wire::calibration::Record::decode(&std::fs::read(&file).unwrap()).unwrap();
    assert_eq!(kept.drives, stored.drives + 1);
    assert!(kept.learnt_s - stored.learnt_s < 1500.0, "learnt {} s after {} s", kept.learnt_s, stored.learnt_s);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A spoofer who only adds noise (css_canedge session 1 under GNSS noise of 5.7 m correlated
/// over 16 s, the nuisance suite's `gnss-noise` at seed 1), drive after drive, raises no alarm,
/// and the noise the record keeps for the next drive rises by a quarter per drive at most and
/// to twice the car's anchor (its first record's) at most, the prior a drift at the start of the
/// next drive is judged with. Without the first bound the 30 s window's s0 went from 1.0 to 3.0 m
/// and the velocity noise from 0.14 to 0.21 m/s in one drive; without the second it rose a
/// quarter on every drive, to 2.4 m on the fifth.
#[test]
fn added_noise_raises_the_stored_noise_a_quarter_per_drive_and_to_twice_the_anchor_at_most() {
    let Some(d) = data_dir("added_noise_raises_the_stored_noise_a_quarter_per_drive_and_to_twice_the_anchor_at_most") else { return };
    let (dir, file, css) = session0_record(&d, "noise");
    let noisy = dir.join("noisy.csv");
    let first = detector_core::wire::calibration::Record::decode(&std::fs::read(&file).unwrap()).unwrap();
    let noise = |r: &detector_core::wire::calibration::Record| [r.noise_s0_m[0], r.noise_s0_m[1], r.noise_k[0], r.noise_k[1], r.velocity_sigma_mps[0], r.velocity_sigma_mps[1]];
    let anchors = |r: &detector_core::wire::calibration::Record| [r.anchor_noise_s0_m[0], r.anchor_noise_s0_m[1], r.anchor_noise_k[0], r.anchor_noise_k[1], r.anchor_velocity_sigma_mps[0], r.anchor_velocity_sigma_mps[1]];
    assert_eq!(anchors(&first), noise(&first), "a first record is its own anchor");
    let out = host_sim(&["nuisance", "--kind", "gnss-noise", "--seed", "1", "-o", noisy.to_str().unwrap(), css.join("denmark_2021-07-26_session1.csv").to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut before = first;
    for drive in 2..=5 {
        let out = host_sim(&["detect", "--json", "--calibration", file.to_str().unwrap(), noisy.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let last: serde_json::Value = serde_json::from_str(String::from_utf8(out.stdout).unwrap().lines().last().unwrap()).unwrap();
        assert_eq!((last["summary"]["alarm"].as_bool(), last["calibration"]["written"].as_bool()), (Some(false), Some(true)), "drive {drive}: {last}");
        let after = detector_core::wire::calibration::Record::decode(&std::fs::read(&file).unwrap()).unwrap();
        assert_eq!(anchors(&after), noise(&first), "drive {drive}: the anchor is the first record's");
        for ((b, a), x) in noise(&before).into_iter().zip(noise(&after)).zip(noise(&first)) {
            assert!(a <= (b * 1.25).min(x * 2.0) * (1.0 + 1e-6), "drive {drive}: {before:?} -> {after:?}");
        }
        if drive == 2 {
            // The rise's bound binds: the drive's own noise was higher.
            assert!(after.noise_s0_m[1] >= before.noise_s0_m[1] * 1.249, "{after:?}");
        }
        before = after;
    }
    // The anchor's bound binds by the fifth drive (1.25^4 is 2.4).
    assert!(before.noise_s0_m[1] >= first.noise_s0_m[1] * 1.999, "{before:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
