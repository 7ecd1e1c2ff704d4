//! The thresholds in `detector_core::profile` are measurements: re-measure and compare.

use detector_core::profile::{LOGGER_1HZ, UBLOX_10HZ};
use detector_core::sync::SyncConfig;
use host_sim::{calibrate, input, require_data};

#[test]
fn profile_error_terms_are_the_measured_maxima() {
    let Some(d) = require_data("profile_error_terms_are_the_measured_maxima") else { return };
    let files = input::discover(&d.join("drives")).unwrap();
    let st = calibrate::run(&files, &input::LoadOptions::default(), SyncConfig::default()).unwrap();
    for p in [&UBLOX_10HZ, &LOGGER_1HZ] {
        let m = st[p.name].max_abs_error_m as f32;
        assert!(p.kinematic_max_error_m >= m && p.kinematic_max_error_m - m < 0.05,
            "{}: constant {} vs measured {m}: update detector-core/src/profile.rs", p.name, p.kinematic_max_error_m);
        // Standstill GNSS speed noise stays under the profile's moving threshold.
        assert!((st[p.name].max_gnss_speed_standing_mps as f32) < p.gnss_speed_move_mps);
        assert!((st[p.name].max_pos_speed_standing_mps as f32) < p.pos_speed_move_mps);
        // Beyond the paper: thresholds are 1.25 x the clean maxima (k is the p90 residual), with
        // strategy 1 on either predictor.
        let s = &st[p.name];
        let near = |a: f32, b: f64| (a as f64 - b).abs() <= 0.01 * b.abs().max(1.0);
        assert!(near(p.cusum_k_m, s.cusum_k_m), "{}: cusum k {} vs {}", p.name, p.cusum_k_m, s.cusum_k_m);
        // Sums over a stretch: at least twice the receiver's error term.
        let floor = 2.0 * p.gnss_error_m as f64;
        assert!(near(p.cusum_h_m, (1.25 * s.cusum_max_stat_m).max(floor)), "{}: cusum h {} vs {}", p.name, p.cusum_h_m, s.cusum_max_stat_m);
        assert!(near(p.window_h_m, (1.25 * s.window_max_m).max(floor)), "{}: window h {} vs {}", p.name, p.window_h_m, s.window_max_m);
        assert!(near(p.speed_tol_mps, 1.25 * s.speed_excess_max_mps), "{}: speed {}", p.name, s.speed_excess_max_mps);
        assert!(near(p.heading_tol_deg, 1.25 * s.heading_diff_max_deg), "{}: heading {}", p.name, s.heading_diff_max_deg);
    }
    assert_eq!(st["ublox-10hz"].drives.len(), 2);
    assert_eq!(st["logger-1hz"].drives.len(), 3);
}
