//! `host-sim detect` end to end: zero alarms on every clean real drive, degraded mode said.

use system_tests::{data_dir, host_sim};

fn detect(path: &std::path::Path) -> (Vec<serde_json::Value>, serde_json::Value) {
    let out = host_sim(&["detect", "--json", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}: {}", path.display(), String::from_utf8_lossy(&out.stderr));
    let mut lines: Vec<serde_json::Value> =
        String::from_utf8(out.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let summary = lines.pop().unwrap()["summary"].clone();
    (lines, summary)
}

#[test]
fn clean_drives_raise_no_alarm_and_say_when_degraded() {
    let Some(d) = data_dir("clean_drives_raise_no_alarm_and_say_when_degraded") else { return };
    let mut drives: Vec<_> = walk(&d.join("drives"));
    drives.push(d.join("raw/comma2k19_rav4_seg40"));
    drives.push(d.join("raw/openxc_ford/drivingnew.jsonl"));
    assert_eq!(drives.len(), 32);
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
        for strat in ["location_shift", "motion", "turn", "residual_cusum", "speed", "heading"] {
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
    assert_eq!((judged, degraded), (7, 25), "drives with and without wheel speed");
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
}
