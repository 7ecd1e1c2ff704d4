//! The in-sample terms in `detector_core::profile` (strategy 1's kinematic error maxima, used as
//! the compiled-in prior and for the QEMU run; `eval` fits them per fold) are measurements:
//! re-measure and compare.

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
    }
    assert_eq!(st["ublox-10hz"].drives.len(), 2);
    assert_eq!(st["logger-1hz"].drives.len(), 8);
}
