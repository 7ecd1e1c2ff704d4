//! Issue #17, one's own car: the comma2k19 segment re-expressed as a candump log and a Vector
//! ASC log of its real raw CAN frames, and an NMEA log and a UBX log of its u-blox fixes (written
//! by `host-sim export-logs` into a temporary folder, never committed), run through
//! `detect --can --gnss --dbc --map`, against the native comma2k19 loader.
//!
//! The logs share one clock, the segment's shifted onto UTC (a UBX fix carries only its UTC
//! time). The routes cannot give the same bits: the CAN logs carry microseconds, NMEA carries
//! minutes of arc to six decimals (about 2 cm), speed in knots to three decimals and course to
//! two; UBX 1e-7 deg, mm/s and 1e-5 deg. So each test asserts (1) the same epochs at the same
//! times (to the microsecond, after the shift) and the same alarm outcome as the native route,
//! and (2) that these resolutions are the *only* difference: the native drive with exactly that
//! rounding applied (times shifted and through `{:.6}`, fixes through the same sentences or
//! frames and the firmware's own parsers) gives the logs route's verdict digest, bit for bit.
//! ASC and candump logs of the same frames give the same digest.

use detector_core::sample::Fix;
use host_sim::input::{self, logs, Event, Format, LoadOptions, Replay};
use std::path::Path;
use system_tests::{detect_json, host_sim, ExportedLogs};

fn micros(t: f64) -> f64 {
    logs::micros_of(t) as f64 / 1e6
}

fn p(x: &Path) -> String {
    x.to_str().unwrap().to_string()
}

trait Checks {
    fn assert_same_epochs(&self, via_logs: &[serde_json::Value], logs_last: &serde_json::Value);
    fn rounded_native_digest(&self, fix_route: impl Fn(&[(f64, Fix)]) -> Vec<Fix>) -> (String, Replay);
}

impl Checks for ExportedLogs {
    /// (1) The same epochs as the native loader, at the same times (on the logs' UTC clock), with
    /// the same alarm outcome.
    fn assert_same_epochs(&self, via_logs: &[serde_json::Value], logs_last: &serde_json::Value) {
        let (native, native_last) = detect_json(&[&p(&self.seg)]);
        assert_eq!(native.len(), via_logs.len(), "epochs: native {} vs logs {}", native.len(), via_logs.len());
        assert!(native.len() > 500, "{} epochs", native.len());
        for (a, b) in native.iter().zip(via_logs) {
            let (ta, tb) = (a["t"].as_f64().unwrap() + self.offset_s, b["t"].as_f64().unwrap());
            assert!((ta - tb).abs() <= 1e-6, "epoch {}: t {ta} vs {tb}", a["epoch"]);
            assert_eq!(a["alarm"], b["alarm"], "epoch {}", a["epoch"]);
        }
        assert_eq!(native_last["summary"]["alarm"], logs_last["summary"]["alarm"]);
    }

    /// The digest of the native drive on the UTC clock, CAN times to the microsecond, each fix
    /// through `fix_route` (the GNSS format's own rounding).
    fn rounded_native_digest(&self, fix_route: impl Fn(&[(f64, Fix)]) -> Vec<Fix>) -> (String, Replay) {
        let r = input::load(&self.seg, &LoadOptions::default()).unwrap();
        let fixes: Vec<(f64, Fix)> = r.fixes().map(|f| (f.t + self.offset_s, *f)).collect();
        let routed = fix_route(&fixes);
        // Fixes first, as the logs loader orders them (same-time events keep this order).
        let mut events: Vec<Event> = routed.into_iter().map(Event::Fix).collect();
        events.extend(r.events.iter().filter_map(|e| match *e {
            Event::Obs { sig, t, v } => Some(Event::Obs { sig, t: micros(t + self.offset_s), v }),
            Event::Fix(_) => None,
        }));
        let rounded = Replay::new(&self.seg, Format::Comma2k19, events, 0);
        let (samples, _) = host_sim::replay::synchronize(&rounded, detector_core::sync::SyncConfig::default());
        let kind = host_sim::detect::PredictorKind::Lstm;
        let verdicts = host_sim::detect::run_with(&samples, host_sim::detect::config(host_sim::detect::profile_of(&samples), kind), kind);
        (host_sim::detect::digest_hex(&verdicts), rounded)
    }
}

#[test]
fn comma2k19_as_candump_and_nmea_gives_the_native_epochs_and_only_nmeas_rounding_differs() {
    let Some(x) = ExportedLogs::new("comma2k19_as_candump_and_nmea_gives_the_native_epochs_and_only_nmeas_rounding_differs") else { return };
    let (via_logs, logs_last) = x.detect("can.log", "gnss.nmea");
    x.assert_same_epochs(&via_logs, &logs_last);
    // (2) The difference is exactly what the log formats cannot carry: NMEA's minutes to six
    // decimals (about 2 cm), knots to three decimals, course to two.
    let (digest, rounded) = x.rounded_native_digest(|fixes| {
        let mut fixer = gnss_guard_board::gnss::NmeaFixer::default();
        fixes.iter().filter_map(|(t, f)| logs::nmea_sentences_utc(f, *t).iter().filter_map(|s| fixer.line(micros(*t), s.as_bytes())).last()).collect()
    });
    assert_eq!(logs_last["digest"], digest.as_str(), "the logs route differs from the native drive rounded as the logs round it");
    // And the rounding does change bits (else the test above would prove nothing about it).
    let native = input::load(&x.seg, &LoadOptions::default()).unwrap();
    assert!(rounded.fixes().zip(native.fixes()).any(|(a, b)| a.pos != b.pos), "NMEA's rounding left every position unchanged");
}

#[test]
fn comma2k19_as_candump_or_asc_and_ubx_gives_the_native_epochs_and_only_ubxs_rounding_differs() {
    let Some(x) = ExportedLogs::new("comma2k19_as_candump_or_asc_and_ubx_gives_the_native_epochs_and_only_ubxs_rounding_differs") else { return };
    let (via_logs, logs_last) = x.detect("can.log", "gnss.ubx");
    x.assert_same_epochs(&via_logs, &logs_last);
    // (2) UBX carries 1e-7 deg, mm/s, 1e-5 deg and the UTC time to the nanosecond; the native
    // fixes carry no accuracy, which the exported NAV-PVT writes as 0 (not reported). The
    // digest still differs from the native one: the clock is shifted onto UTC.
    let (digest, rounded) = x.rounded_native_digest(|fixes| {
        let refs: Vec<(f64, &Fix)> = fixes.iter().map(|(t, f)| (*t, f)).collect();
        let bytes = host_sim::input::ubx_log::ubx_stream(&refs, gnss_guard_board::ubx::SpoofState::Unknown);
        host_sim::input::ubx_log::ubx_log_from_bytes(Path::new("fixes.ubx"), &bytes, &LoadOptions::default()).unwrap().0.fixes
    });
    assert_eq!(logs_last["digest"], digest.as_str(), "the UBX route differs from the native drive rounded as UBX rounds it");
    let native = input::load(&x.seg, &LoadOptions::default()).unwrap();
    // comma2k19's fixes came from the same receiver's NAV-PVT: UBX carries them without loss,
    // and only the clock differs.
    assert!(rounded.fixes().zip(native.fixes()).all(|(a, b)| (a.pos, a.speed_mps, a.course_deg) == (b.pos, b.speed_mps, b.course_deg)), "UBX lost a digit of a comma2k19 fix");
    assert!(rounded.fixes().all(|f| f.h_acc_m.is_none()));
    // The same frames through Vector ASC: the same verdicts, bit for bit.
    let (via_asc, asc_last) = x.detect("can.asc", "gnss.ubx");
    assert_eq!(via_asc.len(), via_logs.len());
    assert_eq!(asc_last["digest"], logs_last["digest"], "ASC and candump logs of the same frames differ");
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
    // A Vector ASC log (recognised by content, whatever its name) names its bad line too.
    std::fs::write(&can, "date Thu Aug 2 08:34:47.250 am 2018\nbase hex  timestamps absolute\n   0.010000 1  0B4  Rx   d 8 00 00 00\n").unwrap();
    let err = String::from_utf8_lossy(&run(&[]).stderr).to_string();
    assert!(err.contains("can.log:3:") && err.contains("expected 8 data bytes"), "{err}");
    std::fs::write(&can, "(1.000000) can0 0B4#0000000000123400\n").unwrap();
    // A GNSS log that is neither NMEA nor UBX is refused by content.
    std::fs::write(&gnss, "t_s,lat\n1,2\n").unwrap();
    let err = String::from_utf8_lossy(&run(&[]).stderr).to_string();
    assert!(err.contains("gnss.nmea") && err.contains("expected an NMEA log") && err.contains("UBX"), "{err}");
    // A UBX log cut inside a frame names the byte offset.
    let f = Fix { t: 0.0, pos: detector_core::geo::LatLon::new(48.0, 11.0), speed_mps: Some(1.0), course_deg: Some(0.0), h_acc_m: None, receiver_spoofing: false };
    let ubx = host_sim::input::ubx_log::ubx_stream(&[(1e9, &f), (1e9 + 0.1, &f)], gnss_guard_board::ubx::SpoofState::None);
    std::fs::write(&gnss, &ubx[..ubx.len() - 5]).unwrap();
    let err = String::from_utf8_lossy(&run(&[]).stderr).to_string();
    assert!(err.contains("gnss.nmea") && err.contains(&format!("byte offset {}", ubx.len() - 5)) && err.contains("ends inside a UBX frame"), "{err}");
    let _ = std::fs::remove_dir_all(&tmp);
}

#[test]
fn a_logs_folder_is_a_drive_for_inspect_attack_and_eval() {
    let Some(x) = ExportedLogs::new("a_logs_folder_is_a_drive_for_inspect_attack_and_eval") else { return };
    // data/drives/mycar/drive1/: a Vector ASC log, a UBX log, the DBC and the map (the source is
    // the car's folder, as for CSV drives).
    let car = x.dir.join("data/drives/mycar/drive1");
    std::fs::create_dir_all(&car).unwrap();
    for f in ["can.asc", "gnss.ubx"] {
        std::fs::copy(x.dir.join(f), car.join(f)).unwrap();
    }
    std::fs::copy(&x.dbc, car.join("car.dbc")).unwrap();
    std::fs::copy(&x.map, car.join("car.map")).unwrap();
    let out = host_sim(&["inspect", "--json", &p(&car)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((s["format"].as_str(), s["epochs"].as_u64()), (Some("can+gnss logs"), Some(579)), "{s}");
    // The folder gives detect the digest of the two files given apart.
    let (_, last) = detect_json(&[&p(&car)]);
    let (_, apart) = x.detect("can.asc", "gnss.ubx");
    assert_eq!(last["digest"], apart["digest"]);
    let csv = x.dir.join("jump.csv");
    let out = host_sim(&["attack", "--kind", "jump", &p(&car), "--out", &p(&csv)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read_to_string(&csv).unwrap().lines().count() > 500);
    let out = host_sim(&["eval", "--data", &p(&x.dir.join("data")), "--scenarios", "1", "--out", &p(&x.dir.join("eval"))]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(x.dir.join("eval/report.json")).unwrap()).unwrap();
    assert!(report["cross_source"].get("mycar").is_some(), "{}", report["cross_source"]);
    // Two CAN logs in one folder: which one is meant is not guessed.
    std::fs::copy(x.dir.join("can.log"), car.join("can.log")).unwrap();
    let out = host_sim(&["inspect", &p(&car)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("expected one CAN log and one GNSS log") && err.contains("can.asc, can.log"), "{err}");
}
