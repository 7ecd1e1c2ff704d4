//! `host-sim calibrate`: measures, on clean real drives, the numbers the detector's thresholds
//! are made of: the kinematic predictor's absolute error per receiver profile, and the GNSS
//! speeds seen while the wheels stand / turn.

use crate::detect;
use crate::input::{self, LoadOptions};
use crate::replay;
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
    /// Beyond the paper: p90 of |scale-corrected residual| (the CUSUM k), the largest CUSUM
    /// statistic on the clean drives with that k, the largest |GNSS - wheel speed| beyond 3 % of
    /// the speed, the largest |GNSS course change - yaw integral| over 10 s.
    pub cusum_k_m: f64,
    pub cusum_max_stat_m: f64,
    pub speed_excess_max_mps: f64,
    pub heading_diff_max_deg: f64,
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
    consistency(files, opts, sync, &mut out)?;
    Ok(out)
}

/// The beyond-the-paper detectors' numbers on the clean drives.
fn consistency(files: &[PathBuf], opts: &LoadOptions, sync: SyncConfig, out: &mut BTreeMap<&'static str, ProfileStats>) -> Result<(), input::InputError> {
    use detector_core::strategy::consistency::{HeadingCheck, ResidualCusum, SpeedCheck};
    let mut drives = Vec::new();
    for f in files {
        let r = input::load(f, opts)?;
        let (samples, _) = replay::synchronize(&r, sync);
        let p = detect::profile_of(&samples);
        let mut cfg = Config::for_profile(p);
        cfg.consistency.enabled = false;
        cfg.shift.settle_s = 0.0;
        let verdicts = detect::run(&samples, cfg);
        drives.push((p.name, cfg, samples, verdicts));
    }
    // Pass 1: the corrected residuals give k.
    let mut res: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for (name, cfg, samples, verdicts) in &drives {
        let mut c = cfg.consistency;
        c.cusum_k_m = 0.0;
        c.cusum_h_m = f32::INFINITY;
        let mut rc = ResidualCusum::default();
        for (s, v) in samples.iter().zip(verdicts) {
            match v.shift {
                Some(o) => {
                    res.entry(name).or_default().push(rc.corrected(o.gnss_shift_m, o.predicted_m).abs() as f64);
                    rc.step(&c, o.gnss_shift_m, o.predicted_m, s.dt_s);
                }
                None => rc.reset(),
            }
        }
    }
    for (name, v) in res.iter_mut() {
        v.sort_by(f64::total_cmp);
        if let Some(st) = out.get_mut(name) {
            st.cusum_k_m = pct(v, 0.9);
        }
    }
    // Pass 2: the largest statistic with that k; speed and heading differences. The detectors
    // restart at every 5 s of each drive (as a replay window or a power-up would), so the
    // maxima hold whatever the starting point.
    for (name, cfg, samples, verdicts) in &drives {
        let Some(st) = out.get_mut(name) else { continue };
        let mut c = cfg.consistency;
        c.cusum_k_m = st.cusum_k_m as f32;
        c.cusum_h_m = f32::INFINITY;
        c.speed_tol_mps = f32::INFINITY;
        c.heading_tol_deg = f32::INFINITY;
        let t_first = samples.first().map_or(0.0, |s| s.t);
        let starts: Vec<usize> = (0..).map(|k| t_first + 5.0 * k as f64)
            .map_while(|t| samples.iter().position(|s| s.t >= t))
            .take(2000)
            .collect();
        for start in starts {
        let (mut rc, mut sp, mut hd) = (ResidualCusum::default(), SpeedCheck::default(), HeadingCheck::default());
        for (s, v) in samples.iter().zip(verdicts).skip(start).take(200_000) {
            if v.reasons.contains(detector_core::fusion::Reason::TimeDiscontinuity) {
                rc.reset();
                sp.reset();
                hd.reset();
            }
            match v.shift {
                Some(o) => st.cusum_max_stat_m = st.cusum_max_stat_m.max(rc.step(&c, o.gnss_shift_m, o.predicted_m, s.dt_s).0 as f64),
                None => rc.reset(),
            }
            if let (Some((d, _)), Some(w), Some(g)) = (sp.step(&c, s), s.wheel_speed().get(), s.gnss_speed.get()) {
                st.speed_excess_max_mps = st.speed_excess_max_mps.max((d.abs() - c.speed_tol_rel * w.max(g)) as f64);
            }
            if let Some((d, _)) = hd.step(&c, s) {
                st.heading_diff_max_deg = st.heading_diff_max_deg.max(d.abs() as f64);
            }
        }
        }
    }
    Ok(())
}
