//! `host-sim calibrate`: measures, on clean real drives, the numbers the detector's thresholds
//! are made of: the kinematic predictor's absolute error per receiver profile, and the GNSS
//! speeds seen while the wheels stand / turn.

use crate::detect;
use gnss_data::input::{self, LoadOptions};
use gnss_data::replay;
use detector_core::fusion::Config;
use detector_core::sync::SyncConfig;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

#[derive(Debug, Default, Serialize)]
pub struct ProfileStats {
    pub drives: Vec<String>,
    pub epochs: usize,
    pub max_abs_error_m: f64,
    pub p999_abs_error_m: f64,
    pub p99_abs_error_m: f64,
    pub median_abs_error_m: f64,
    pub rmse_m: f64,
    pub worst: String,
    /// Largest GNSS reported speed while the wheel speed is below 0.3 m/s.
    pub max_gnss_speed_standing_mps: f64,
    /// Largest speed from position change while the wheel speed is below 0.3 m/s.
    pub max_pos_speed_standing_mps: f64,
    /// Smallest GNSS reported speed while the wheel speed is above 1.0 m/s.
    pub min_gnss_speed_moving_mps: f64,
    /// Smallest speed from position change while the wheel speed is above 1.0 m/s.
    pub min_pos_speed_moving_mps: f64,
}

fn pct(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

pub fn run(files: &[PathBuf], opts: &LoadOptions, sync: SyncConfig) -> Result<BTreeMap<&'static str, ProfileStats>, input::InputError> {
    let mut errs: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut out: BTreeMap<&'static str, ProfileStats> = BTreeMap::new();
    for f in files {
        let r = input::load(f, opts)?;
        let (samples, _) = replay::synchronize(&r, sync);
        let p = detect::profile_of(&samples);
        let mut cfg = Config::for_profile(p);
        cfg.shift.predictor_error_m = 0.0;
        cfg.shift.gnss_error_m = 0.0;
        // Every epoch counts, the receiver's start-up included (conservative).
        cfg.shift.settle_s = 0.0;
        let verdicts = detect::run(&samples, cfg);
        let st = out.entry(p.name).or_insert_with(|| ProfileStats {
            min_gnss_speed_moving_mps: f64::INFINITY,
            min_pos_speed_moving_mps: f64::INFINITY,
            ..Default::default()
        });
        let e = errs.entry(p.name).or_default();
        let before = e.len();
        for (s, v) in samples.iter().zip(&verdicts) {
            if let Some(o) = v.shift {
                let a = o.residual_m.abs() as f64;
                if a > st.max_abs_error_m {
                    st.max_abs_error_m = a;
                    st.worst = format!("{} t={:.1}", f.display(), s.t);
                }
                e.push(a);
            }
            let Some(w) = s.wheel_speed().get() else { continue };
            let pos_v = s.shift_m.get().filter(|_| s.dt_s > 0.0 && v.shift.is_some()).map(|d| (d / s.dt_s) as f64);
            let gv = s.gnss_speed.get().map(f64::from);
            if w < 0.3 {
                if let Some(g) = gv { st.max_gnss_speed_standing_mps = st.max_gnss_speed_standing_mps.max(g) }
                if let Some(g) = pos_v { st.max_pos_speed_standing_mps = st.max_pos_speed_standing_mps.max(g) }
            } else if w > 1.0 {
                if let Some(g) = gv { st.min_gnss_speed_moving_mps = st.min_gnss_speed_moving_mps.min(g) }
                if let Some(g) = pos_v { st.min_pos_speed_moving_mps = st.min_pos_speed_moving_mps.min(g) }
            }
        }
        if e.len() > before {
            st.drives.push(f.display().to_string());
        }
    }
    for (name, e) in errs.iter_mut() {
        e.sort_by(f64::total_cmp);
        let st = out.get_mut(name).unwrap();
        st.epochs = e.len();
        st.p999_abs_error_m = pct(e, 0.999);
        st.p99_abs_error_m = pct(e, 0.99);
        st.median_abs_error_m = pct(e, 0.5);
        st.rmse_m = if e.is_empty() { 0.0 } else { (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt() };
    }
    out.retain(|_, s| s.epochs > 0);
    Ok(out)
}
