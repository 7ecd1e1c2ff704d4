//! Issue #17, one's own car: the comma2k19 segment re-expressed as a candump log of its real raw
//! CAN frames and an NMEA log of its u-blox fixes (written by `host-sim export-logs` into a
//! temporary folder, never committed), run through `detect --can --gnss --dbc --map`, against the
//! native comma2k19 loader.
//!
//! The two routes cannot give the same bits: candump timestamps carry microseconds, NMEA carries
//! minutes of arc to six decimals (about 2 cm), speed in knots to three decimals and course to
//! two. So the test asserts (1) the same epochs at the same times (to the microsecond) and the
//! same alarm outcome as the native route, and (2) that these resolutions are the *only*
//! difference: the native drive with exactly that rounding applied (timestamps through
//! `{:.6}`, fixes through the same NMEA sentences and the firmware's NMEA parser) gives the logs
//! route's verdict digest, bit for bit.

use detector_core::sample::Fix;
use host_sim::input::{self, logs, Event, Format, LoadOptions, Replay};
use std::path::Path;
use system_tests::{data_dir, host_sim};

fn detect_json(args: &[&str]) -> (Vec<serde_json::Value>, serde_json::Value) {
    let mut a = vec!["detect", "--json"];
    a.extend_from_slice(args);
    let out = host_sim(&a);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut lines: Vec<serde_json::Value> = String::from_utf8(out.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let last = lines.pop().unwrap();
    lines.retain(|l| l.get("status").is_none());
    (lines, last)
}

fn micros(t: f64) -> f64 {
    format!("{t:.6}").parse().unwrap()
}

#[test]
fn comma2k19_as_candump_and_nmea_gives_the_native_epochs_and_only_nmeas_rounding_differs() {
    let Some(d) = data_dir("comma2k19_as_candump_and_nmea_gives_the_native_epochs_and_only_nmeas_rounding_differs") else { return };
    let seg = d.join("raw/comma2k19_rav4_seg40");
    let tmp = std::env::temp_dir().join(format!("gnss-guard-logs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let out = host_sim(&["export-logs", seg.to_str().unwrap(), "--out", tmp.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let dbc = std::fs::read_dir(&seg).unwrap().flatten().map(|e| e.path()).find(|p| p.extension().is_some_and(|x| x == "dbc")).expect("the segment's DBC");
    // The firmware's RAV4 map, with bus 0 (comma logs forwarded copies of the frames on buses 1
    // and 2; the native loader reads bus 0 only).
    let rav4 = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/board/profiles/toyota_rav4.map")).unwrap();
    let map: String = rav4.lines().map(|l| if l.trim().is_empty() || l.starts_with('#') { format!("{l}\n") } else { format!("{l} bus=0\n") }).collect();
    let map_path = tmp.join("rav4_bus0.map");
    std::fs::write(&map_path, &map).unwrap();
    let (can, gnss) = (tmp.join("can.log"), tmp.join("gnss.nmea"));
    let p = |x: &Path| x.to_str().unwrap().to_string();

    // (1) The same epochs, at the same times, with the same outcome.
    let (native, native_last) = detect_json(&[&p(&seg)]);
    let (via_logs, logs_last) = detect_json(&["--can", &p(&can), "--gnss", &p(&gnss), "--dbc", &p(&dbc), "--map", &p(&map_path)]);
    assert_eq!(native.len(), via_logs.len(), "epochs: native {} vs logs {}", native.len(), via_logs.len());
    assert!(native.len() > 500, "{} epochs", native.len());
    for (a, b) in native.iter().zip(&via_logs) {
        let (ta, tb) = (a["t"].as_f64().unwrap(), b["t"].as_f64().unwrap());
        assert!((ta - tb).abs() <= 1e-6, "epoch {}: t {ta} vs {tb}", a["epoch"]);
        assert_eq!(a["alarm"], b["alarm"], "epoch {}", a["epoch"]);
    }
    assert_eq!(native_last["summary"]["alarm"], logs_last["summary"]["alarm"]);

    // (2) The difference is exactly what the log formats cannot carry.
    let r = input::load(&seg, &LoadOptions::default()).unwrap();
    let mut fixer = gnss_guard_board::gnss::NmeaFixer::default();
    let events: Vec<Event> = r
        .events
        .iter()
        .filter_map(|e| match *e {
            Event::Obs { sig, t, v } => Some(Event::Obs { sig, t: micros(t), v }),
            Event::Fix(f) => {
                let t = micros(f.t);
                logs::nmea_sentences(&f, f.t).iter().filter_map(|s| fixer.line(t, s.as_bytes())).last().map(Event::Fix)
            }
        })
        .collect();
    let rounded = Replay::new(&seg, Format::Comma2k19, events, 0);
    let (samples, _) = host_sim::replay::synchronize(&rounded, detector_core::sync::SyncConfig::default());
    let kind = host_sim::detect::PredictorKind::Lstm;
    let verdicts = host_sim::detect::run_with(&samples, host_sim::detect::config(host_sim::detect::profile_of(&samples), kind), kind);
    assert_eq!(logs_last["digest"], host_sim::detect::digest_hex(&verdicts).as_str(), "the logs route differs from the native drive rounded as the logs round it");
    // And the rounding does change bits (else the test above would prove nothing about it).
    let native_fix: Vec<Fix> = r.fixes().copied().collect();
    assert!(rounded.fixes().zip(&native_fix).any(|(a, b)| a.pos != b.pos), "NMEA's rounding left every position unchanged");
    let _ = std::fs::remove_dir_all(&tmp);
}

#[test]
fn log_errors_name_the_file_line_and_what_was_expected() {
    let tmp = std::env::temp_dir().join(format!("gnss-guard-logerr-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let dbc = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/board/profiles/toyota_rav4.dbc");
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/board/profiles/toyota_rav4.map");
    let can = tmp.join("can.log");
    let gnss = tmp.join("gnss.nmea");
    std::fs::write(&can, "(1.000000) can0 0B4#0000000000123400\n(1.010000) can0 0B4#00000000001234\n(1.020000) can0 0B4#GG\n").unwrap();
    std::fs::write(&gnss, "(1.0) $GPRMC,000000.00,A,4808.22000,N,01134.50000,E,10.0,90.0,020818,,,A*6C\n").unwrap();
    let run = |extra: &[&str]| {
        let mut a = vec!["detect", "--can", can.to_str().unwrap(), "--gnss", gnss.to_str().unwrap(), "--dbc", dbc.to_str().unwrap(), "--map", map.to_str().unwrap()];
        a.extend_from_slice(extra);
        host_sim(&a)
    };
    let out = run(&[]);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success());
    assert!(err.contains("can.log:3:") && err.contains("hex data"), "{err}");
    // A GNSS log that is not NMEA is refused by content.
    std::fs::write(&gnss, "t_s,lat\n1,2\n").unwrap();
    let err = String::from_utf8_lossy(&run(&[]).stderr).to_string();
    assert!(err.contains("gnss.nmea") && err.contains("expected an NMEA log"), "{err}");
    let _ = std::fs::remove_dir_all(&tmp);
}
