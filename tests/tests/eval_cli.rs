//! `host-sim attack`, `eval` and `demo` end to end.

use system_tests::{data_dir, host_sim};

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("gnss-guard-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn eval_writes_report_markdown_and_figures() {
    let Some(d) = data_dir("eval_writes_report_markdown_and_figures") else { return };
    let out = tmp("eval");
    let o = host_sim(&["eval", "--data", d.to_str().unwrap(), "--scenarios", "10", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    for k in ["drives", "hours", "false_alarms", "false_alarms_per_hour"] {
        assert!(r["clean"][k].is_number(), "clean.{k}");
    }
    for kind in ["turn-by-turn", "overshoot", "stop", "wrong-turn"] {
        let a = &r["attacks"][kind];
        for k in ["scenarios", "detected", "detection_rate", "ttd_median_s", "ttd_p95_s", "ttd_max_s", "strategies"] {
            assert!(a.get(k).is_some(), "{kind}.{k}");
        }
        assert!(a["scenarios"].as_u64().unwrap() >= 10);
    }
    assert!(r["config"]["profiles"].is_object());
    // Strategy 1's predictors side by side; the LSTM is the default.
    assert_eq!(r["config"]["profiles"]["logger-1hz"]["s1_predictor"], "lstm");
    for p in ["kinematic", "lstm"] {
        for k in ["rmse_m", "max_abs_m", "threshold_m"] {
            assert!(r["predictors"][p][k].as_f64().unwrap() > 0.0, "predictors.{p}.{k}");
        }
        assert_eq!(r["predictors"][p]["false_alarms"], 0, "{p}");
        assert!(r["predictors"][p]["detection_rate"]["turn-by-turn"].as_f64().unwrap() >= 0.9);
    }
    // The int8 model against its f32 original: within 2 % of the threshold, same verdicts.
    let q = &r["quantization"];
    assert!(q["validation_epochs"].as_u64().unwrap() > 3000);
    assert!(q["ratio_to_threshold"].as_f64().unwrap() <= 0.02, "{q}");
    assert_eq!(q["verdicts_identical"], true, "{q}");
    // The slow drifts replayed at fixed rates, per receiver class and direction: every planned
    // drift at every rate; fast drifts are found within 10 s more often than slow ones; the
    // offset at detection (pull-off) is reported per class, direction and rate.
    let sweep = r["drift_sweep"].as_array().unwrap();
    assert_eq!(sweep.len(), host_sim::eval::DRIFT_SWEEP_MPS.len());
    let count = |p: &serde_json::Value, k: &str| -> u64 {
        p["by_class"].as_object().unwrap().values().map(|c| c["along"][k].as_u64().unwrap() + c["across"][k].as_u64().unwrap()).sum()
    };
    let n = count(&sweep[0], "scenarios");
    assert!(n > 0);
    for p in sweep {
        assert_eq!(count(p, "scenarios"), n, "{p}");
        for (class, c) in p["by_class"].as_object().unwrap() {
            assert!(class == "velocity" || class == "position", "{class}");
            for dir in ["along", "across"] {
                let d = &c[dir];
                let (w10, w30, w60) = (d["within_10s"].as_u64().unwrap(), d["within_30s"].as_u64().unwrap(), d["within_60s"].as_u64().unwrap());
                assert!(w10 <= w30 && w30 <= w60 && w60 <= d["detected"].as_u64().unwrap(), "{d}");
                assert!(d.get("pull_off_p95_m").is_some(), "{d}");
            }
        }
    }
    assert!(count(sweep.last().unwrap(), "within_10s") > count(&sweep[0], "within_10s"), "{sweep:?}");
    // Cars judged from the calibration learnt on their earlier drives.
    let cal = r["calibrated"].as_object().unwrap();
    assert!(cal.contains_key("css_canedge") && cal.contains_key("sddi_commuter"), "{cal:?}");
    for (src, c) in cal {
        assert_eq!(c["false_alarms"], 0, "{src}: {c}");
        assert!(c["record"].is_object() && c["tyre_change_found_s"].is_number(), "{src}: a 3 % tyre change is found: {c}");
        assert_eq!(c["contradicted"], false, "{src}: {c}");
        // Every drive of the car, judged with the record its other drives left.
        let every = c["every_drive"].as_array().unwrap();
        assert!(every.len() >= 2, "{src}: {c}");
        for h in every {
            assert!(h["recorded"] == true && h["false_alarms"] == 0 && h["contradicted"] == false, "{src}: {h}");
            assert!(h["tyre_change_found_s"].is_number(), "{src}: a 3 % tyre change is found: {h}");
        }
        // The judged drive under every kind of nuisance, from the record: passed or
        // contradicted, never a false alarm.
        let kinds = c["nuisance"].as_array().unwrap();
        assert_eq!(kinds.len(), host_sim::nuisance::NuisanceKind::ALL.len(), "{src}: {c}");
        for k in kinds {
            assert_eq!(k["runs"].as_u64(), Some(host_sim::eval::calibrated::CALIBRATED_NUISANCE_DRAWS as u64), "{src}: {k}");
            assert_eq!(k["uncontradicted_alarms"], 0, "{src}: a false alarm from the record: {k}");
        }
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("Table 3") && md.contains("| turn-by-turn |"));
    assert!(md.contains("replayed at fixed rates") && md.contains("by source"));
    let figs: Vec<_> = std::fs::read_dir(out.join("figures")).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    assert!(figs.iter().any(|f| f.ends_with("-residual.svg")) && figs.iter().any(|f| f.ends_with("-track.svg")));
    assert!(figs.iter().any(|f| f.ends_with("-residual.png")), "PNG figures (DejaVu font from fonts-dejavu-core)");
    assert!(!figs.iter().any(|f| f.contains(".tmp")), "no temporary files left");
    let stdout = String::from_utf8(o.stdout).unwrap();
    assert!(stdout.contains("data: real") && stdout.contains("Table 3"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn demo_runs_without_the_data_folder_on_a_simulated_drive() {
    let out = tmp("demo-sim");
    let o = std::process::Command::new(system_tests::host_sim_bin())
        .args(["demo", "--out", out.to_str().unwrap()])
        .env("GNSS_DATA_DIR", "/nonexistent-gnss-data")
        .output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = String::from_utf8(o.stdout).unwrap();
    assert!(s.contains("SIMULATED") && s.contains("data: simulated"), "{s}");
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["data"], "simulated");
    assert_eq!(r["clean"]["false_alarms"], 0);
    assert!(std::fs::read_to_string(out.join("report.md")).unwrap().contains("SIMULATED"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn demo_uses_the_real_drives_when_present() {
    let Some(d) = data_dir("demo_uses_the_real_drives_when_present") else { return };
    let out = tmp("demo-real");
    let o = host_sim(&["demo", "--data", d.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success());
    let s = String::from_utf8(o.stdout).unwrap();
    assert!(s.contains("REAL drives") && s.contains("data: real"), "{s}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn attack_cli_writes_the_common_layout_with_ground_truth() {
    let Some(d) = data_dir("attack_cli_writes_the_common_layout_with_ground_truth") else { return };
    let out = tmp("attack");
    std::fs::create_dir_all(&out).unwrap();
    let src = d.join("drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv");
    for kind in ["turn-by-turn", "overshoot", "stop", "wrong-turn"] {
        let f = out.join(format!("{kind}.csv"));
        let o = host_sim(&["attack", "--kind", kind, "--seed", "3", src.to_str().unwrap(), "-o", f.to_str().unwrap()]);
        assert!(o.status.success(), "{kind}: {}", String::from_utf8_lossy(&o.stderr));
        let text = std::fs::read_to_string(&f).unwrap();
        let header = text.lines().next().unwrap();
        assert!(header.starts_with("t_s,unix_time_s,lat_deg,lon_deg,gnss_new_fix") && header.ends_with(",attack_active"), "{header}");
        assert!(text.lines().any(|l| l.ends_with(",1")) && text.lines().skip(1).any(|l| l.ends_with(",0")));
        // The attacked file is itself a drive: detect raises the alarm after the onset.
        let o = host_sim(&["detect", "--json", f.to_str().unwrap()]);
        assert!(o.status.success());
        let last: serde_json::Value = serde_json::from_str(String::from_utf8(o.stdout).unwrap().lines().last().unwrap()).unwrap();
        if kind != "wrong-turn" {
            assert_eq!(last["summary"]["alarm"], true, "{kind}");
        }
    }
    // A kind the drive cannot host: a clear error, exit 2.
    let hw = d.join("drives/comma2k19/b0c9d2329ad1606b_2018-08-02--08-34-47_seg40.csv");
    let o = host_sim(&["attack", "--kind", "stop", hw.to_str().unwrap(), "-o", out.join("x.csv").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot host a stop attack"));
    assert!(!out.join("x.csv").exists());
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn digest_runs_the_firmware_pipeline_on_the_host() {
    // Same input and code as the QEMU image; tests/run-all.sh compares the two digests.
    let out = system_tests::host_sim(&["digest"]);
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(out.status.success(), "{s}");
    assert!(s.lines().filter(|l| l.starts_with("scenario ") && l.ends_with("PASS")).count() == 5, "{s}");
    // The outage is reported: blind for most of its 15 s, the fix age growing to its length.
    let outage = s.lines().find(|l| l.starts_with("scenario gnss-outage")).unwrap();
    assert!(outage.contains("no alarm") && outage.contains(" blind 1") && outage.contains("watchdog refused 0"), "{outage}");
    assert!(s.lines().last().unwrap().starts_with("verdict digest: "));
    let sim = std::process::Command::new(system_tests::host_sim_bin()).arg("digest").env("GNSS_DATA_DIR", "/nonexistent-gnss-data").output().unwrap();
    let s2 = String::from_utf8(sim.stdout).unwrap();
    assert!(sim.status.success() && s2.contains("SIMULATED"), "{s2}");
}

#[test]
fn train_turns_and_calibrate_commands() {
    let Some(d) = data_dir("train_turns_and_calibrate_commands") else { return };
    let out = tmp("train");
    std::fs::create_dir_all(&out).unwrap();
    let blob = out.join("turns.bin");
    let o = host_sim(&["train", "turns", "--data", d.to_str().unwrap(), "--out", blob.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let committed = std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../detector-core/models/turn_templates.bin")).unwrap();
    assert_eq!(std::fs::read(&blob).unwrap(), committed, "the tool reproduces the committed templates");
    let rep: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(rep["held_out"].as_u64().unwrap() >= 100);
    let o = host_sim(&["calibrate", d.join("drives").to_str().unwrap()]);
    assert!(o.status.success());
    let cal: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(cal["logger-1hz"]["max_abs_error_m"].as_f64().unwrap() > 0.0);
    let _ = std::fs::remove_dir_all(&out);
}
