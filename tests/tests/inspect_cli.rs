//! `host-sim inspect` end to end on the real drives.

use system_tests::{data_dir, host_sim};

#[test]
fn inspect_json_all_drives_and_raw_folders() {
    let Some(d) = data_dir("inspect_json_all_drives_and_raw_folders") else { return };
    let drives = d.join("drives");
    let raw = d.join("raw");
    let out = host_sim(&["inspect", "--json", drives.to_str().unwrap(), raw.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout).unwrap().lines()
        .map(|l| serde_json::from_str(l).unwrap()).collect();
    let index = std::fs::read_to_string(d.join("index.csv")).unwrap();
    let rows = index.lines().skip(1).filter(|l| !l.trim().is_empty()).count();
    assert_eq!(lines.len(), rows + 2, "the index's drive CSVs + the comma2k19 segment + the OpenXC trace");
    for v in &lines {
        for k in ["path", "format", "epochs", "duration_s", "gnss_hz", "distance_m", "signals", "stops", "turns_left", "turns_right"] {
            assert!(v.get(k).is_some(), "missing {k} in {v}");
        }
        assert!(v["epochs"].as_u64().unwrap() > 50);
        assert!(v["signals"]["wheel_speed"].as_f64().is_some());
    }
    let formats: Vec<&str> = lines.iter().map(|v| v["format"].as_str().unwrap()).collect();
    assert!(formats.contains(&"comma2k19") && formats.contains(&"openxc"));
}

#[test]
fn inspect_text_output() {
    let Some(d) = data_dir("inspect_text_output") else { return };
    let f = d.join("drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv");
    let out = host_sim(&["inspect", f.to_str().unwrap()]);
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("format drive-csv") && s.contains("stops"), "{s}");
}

#[test]
fn bad_input_exits_2_and_prints_nothing() {
    let dir = tempfile_dir();
    let good = dir.join("good.csv");
    std::fs::write(&good, "t_s,lat_deg,lon_deg,gnss_new_fix,veh_speed_mps\n0,48.0,11.0,1,1.0\n1,48.0001,11.0,1,1.0\n").unwrap();
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "t_s,lat_deg,lon_deg,gnss_new_fix,veh_speed_mps\n0,48.0,11.0,1,1.0\n1,48.0001,11.0,1,one\n2,48.0002,11.0,1,1.0\n").unwrap();
    let out = host_sim(&["inspect", "--json", good.to_str().unwrap(), bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty(), "nothing written on error");
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("bad.csv:3:") && err.contains("veh_speed_mps") && err.contains("expected a number"), "{err}");
    // --skip-bad-rows: counted and reported
    let out = host_sim(&["inspect", "--json", "--skip-bad-rows", bad.to_str().unwrap()]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["skipped_rows"], 1);
    assert_eq!(v["epochs"], 2);
    // not a drive at all
    let out = host_sim(&["inspect", dir.join("nope.bin").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

fn tempfile_dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("gnss-guard-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
