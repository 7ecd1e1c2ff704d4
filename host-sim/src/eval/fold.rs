//! Leave-one-source-out: for each source in the data (a folder under `drives/`), every
//! data-derived number of the detector fitted on the other sources only, so that the source's
//! clean drives and attack scenarios are judged with numbers fitted on data they are not in.
//!
//! What is fitted per fold ([`Fitted`]):
//! - strategy 1's kinematic error term per receiver class (the largest |GNSS shift - wheel-speed
//!   dead reckoning| over the judged epochs of the training sources, rounded up to 0.05 m), also
//!   the LSTM's fallback term;
//! - strategy 2's turn templates (the trainer of `host-sim train turns` on the training
//!   sources' drives and the simulated ones).
//!
//! What is not: the LSTM is trained once (its training and validation drives are
//! [`LSTM_SOURCES`]); its threshold term comes from its validation drives, so strategy 1's
//! figures on those sources are marked in-sample. The design constants (strategy 3's motion
//! thresholds, strategy 2's angles, the track check's false-alarm budget) are stated, not fitted.

use crate::dataset::Drive;
use crate::detect;
use detector_core::fusion::Config;
use serde::Serialize;
use std::collections::BTreeMap;

/// The sources whose drives trained or validated the committed LSTM (css_canedge session 0 and
/// openxc_ford trained it; comma2k19 and css_canedge session 1 validated it and set its
/// threshold terms): strategy 1 on the LSTM is in-sample there.
pub const LSTM_SOURCES: [&str; 3] = ["comma2k19", "css_canedge", "openxc_ford"];

/// How the evaluation fits its numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Protocol {
    /// Each source judged with numbers fitted on the other sources (the default).
    LeaveOneSourceOut,
    /// Everything fitted on everything: in-sample, for comparison only.
    InSample,
}

/// The numbers a fold fitted, and what on.
#[derive(Clone, Debug, Serialize)]
pub struct Fitted {
    /// The sources the numbers were fitted on.
    pub fitted_on: Vec<String>,
    /// Strategy 1's kinematic error term, metres: `[10 Hz class, 1 Hz class]`.
    pub kinematic_error_m: [f32; 2],
    /// Epochs the error terms were measured over, per class (0: no training drive of that
    /// class, the compiled-in profile's term is used instead).
    pub kinematic_epochs: [usize; 2],
    /// Strategy 2's template blob.
    #[serde(skip)]
    pub templates: Vec<u8>,
    pub templates_count: usize,
}

impl Fitted {
    /// The detector's configuration for a drive under this fold.
    pub fn apply(&self, cfg: &mut Config, nominal_dt_s: f32, kinematic_predictor: bool) {
        let k = self.kinematic_error_m[if nominal_dt_s < 0.5 { 0 } else { 1 }];
        cfg.shift.fallback_error_m = k;
        if kinematic_predictor {
            cfg.shift.predictor_error_m = k;
        }
    }
}

/// The largest |GNSS shift - kinematic prediction| per class over the judged epochs of
/// `drives`, rounded up to 0.05 m (how `profile.rs`'s constants were made).
pub fn kinematic_error_terms(drives: &[&Drive]) -> ([f32; 2], [usize; 2]) {
    let mut max = [0.0f64; 2];
    let mut n = [0usize; 2];
    for d in drives {
        let mut cfg = Config::for_profile(d.profile);
        cfg.shift.predictor_error_m = 0.0;
        cfg.shift.fallback_error_m = 0.0;
        cfg.shift.gnss_error_m = 0.0;
        cfg.shift.settle_s = 0.0;
        let class = if d.profile.nominal_dt_s < 0.5 { 0 } else { 1 };
        for v in detect::run(&d.samples, cfg) {
            if let Some(o) = v.shift {
                max[class] = max[class].max(o.residual_m.abs() as f64);
                n[class] += 1;
            }
        }
    }
    (max.map(|m| ((m / 0.05).ceil() * 0.05) as f32), n)
}

/// Fits the numbers on the drives of `sources` (and, for the templates, the simulated drives).
pub fn fit(drives: &[Drive], sources: &[String]) -> Fitted {
    let training: Vec<&Drive> = drives.iter().filter(|d| sources.contains(&d.source)).collect();
    let (mut kinematic_error_m, kinematic_epochs) = kinematic_error_terms(&training);
    for (c, p) in [&detector_core::profile::UBLOX_10HZ, &detector_core::profile::LOGGER_1HZ].into_iter().enumerate() {
        if kinematic_epochs[c] == 0 {
            kinematic_error_m[c] = p.kinematic_max_error_m;
        }
    }
    let mut turn_drives: Vec<Drive> = training.iter().map(|d| (*d).clone()).collect();
    turn_drives.extend(crate::turns::sim_drives());
    let (templates, rep, _) = crate::turns::train_and_evaluate(&turn_drives, 1);
    Fitted { fitted_on: sources.to_vec(), kinematic_error_m, kinematic_epochs, templates, templates_count: rep.templates }
}

/// The sources of the drives, sorted.
pub fn sources(drives: &[Drive]) -> Vec<String> {
    let mut s: Vec<String> = drives.iter().map(|d| d.source.clone()).collect();
    s.sort();
    s.dedup();
    s
}

/// The fold each source is judged with: fitted without it (or, in-sample, on everything).
pub fn folds(drives: &[Drive], protocol: Protocol) -> BTreeMap<String, Fitted> {
    let all = sources(drives);
    match protocol {
        Protocol::InSample => {
            let f = fit(drives, &all);
            all.into_iter().map(|s| (s, f.clone())).collect()
        }
        Protocol::LeaveOneSourceOut => all
            .iter()
            .map(|held| {
                let others: Vec<String> = all.iter().filter(|s| *s != held).cloned().collect();
                (held.clone(), fit(drives, &others))
            })
            .collect(),
    }
}
