//! `host-sim eval`: the detector against clean drives (false alarms) and attacked drives
//! (detection rate, time to detect, which strategies fired: the paper's Table 3).
//!
//! Every number comes from the detector's verdicts; the attack generator only supplies the
//! onset time (ground truth). Scenarios are drawn deterministically from the seed and spread
//! round-robin over the drives that can host each kind, and run in parallel (rayon), so a run is
//! reproducible whatever the thread count.
//!
//! Files, in the order of the data: [`plan`] (options, which scenario runs where), [`run`] (clean
//! drives and scenarios through the detector, the drift sweep, the whole evaluation),
//! [`results`] (what a run reports), [`stats`] (how verdicts become those numbers), [`report`]
//! (report.json, report.md, figures).

pub mod calibrated;
pub mod docs;
pub mod figures;
pub mod fold;
pub mod full;
pub mod plan;
pub mod report;
pub mod results;
pub mod run;
pub mod stats;

pub use plan::{plan, EvalOptions, DRIFT_SWEEP_MPS, PRE_ONSET_S, WINDOW_S};
pub use results::*;
pub use fold::{Fitted, Protocol};
pub use full::full;
pub use run::{drift_sweep, evaluate, nuisance_suite, run_scenario, run_scenario_with, verdicts, Folds};
pub use stats::{decisions, decisions_to_alarm, digest, predictor_stats, quantization, validation_runs};
