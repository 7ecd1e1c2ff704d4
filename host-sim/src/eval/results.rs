//! What an evaluation reports (report.json's structure).

use gnss_data::attack::AttackKind;
use detector_core::geo::LatLon;
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Clone, Debug, Serialize)]
pub struct CleanDrive {
    pub drive: String,
    pub source: String,
    pub hours: f64,
    pub profile: &'static str,
    pub judged: bool,
    pub false_alarms: usize,
    /// Epochs where strategy 1 ran, and where it ran on the LSTM itself (not its fallback).
    pub s1_epochs: usize,
    pub s1_lstm_epochs: usize,
    /// Epochs, and per strategy the epochs at which it said it was degraded (could not judge:
    /// missing or implausible inputs, a stuck sensor, its own warm-up).
    pub epochs: usize,
    pub degraded_epochs: BTreeMap<&'static str, usize>,
    /// FNV-1a of every verdict (as the firmware's digest).
    pub digest: String,
    /// FNV-1a of the decisions only (ran, fired, degraded, reasons, alarm per epoch).
    pub decisions: String,
    /// The same up to the first alarm.
    pub decisions_to_alarm: String,
    /// How near the drive came to an alarm.
    pub headroom: Headroom,
}

/// How near a run came to an alarm: each check's statistic as a share of its threshold, the
/// largest it held for as long as the check's persistence (at 1 or more it fires; approximate
/// near 1, see `stats::headroom`). `None`: the check never judged. Strategy 2's turns have no
/// such statistic (a turn is read as one class or another); its heading check has.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Headroom {
    /// Strategy 1: |GNSS shift - prediction| over its threshold.
    pub shift: Option<f64>,
    /// Strategy 3: a wheel/GNSS disagreement's length over its persistence.
    pub motion: Option<f64>,
    /// The track check's position windows: |e| over its threshold.
    pub windows: Option<f64>,
    /// The velocity test along the road: the bank's `T` over `h` (its gross path apart),
    /// held for its persistence on the epochs' times (its pairs' run up to 2 s behind).
    pub velocity_along: Option<f64>,
    /// The same across the road (a gyro's cars only).
    pub velocity_across: Option<f64>,
    /// Strategy 2's heading check: the GNSS course change beyond the steering's over its
    /// threshold (it fires at once, no persistence).
    pub turn_heading: Option<f64>,
}

impl Headroom {
    /// The largest share of any check's threshold.
    pub fn nearest(&self) -> Option<f64> {
        [self.shift, self.motion, self.windows, self.velocity_along, self.velocity_across, self.turn_heading].into_iter().flatten().reduce(f64::max)
    }

    /// The larger of each check's peaks.
    pub fn max(self, o: Headroom) -> Headroom {
        let m = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(x), Some(y)) => Some(x.max(y)),
            (x, y) => x.or(y),
        };
        Headroom {
            shift: m(self.shift, o.shift),
            motion: m(self.motion, o.motion),
            windows: m(self.windows, o.windows),
            velocity_along: m(self.velocity_along, o.velocity_along),
            velocity_across: m(self.velocity_across, o.velocity_across),
            turn_heading: m(self.turn_heading, o.turn_heading),
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct CleanStats {
    pub drives: usize,
    pub hours: f64,
    /// Drives with wheel speed, where the strategies run, and their hours.
    pub drives_judged: usize,
    pub hours_judged: f64,
    pub false_alarms: usize,
    pub false_alarms_per_hour: f64,
    pub per_drive: Vec<CleanDrive>,
}

/// One point of a scenario's trace (for the figures).
#[derive(Clone, Debug, Serialize)]
pub struct TracePoint {
    pub t: f64,
    pub residual_m: Option<f32>,
    pub threshold_m: Option<f32>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Scenario {
    pub id: String,
    pub kind: AttackKind,
    pub drive: String,
    pub source: String,
    pub seed: u64,
    pub onset_t: f64,
    pub params: String,
    /// The attack's main parameter (offset m, drift m/s, rotation deg/s, delay s, step m).
    pub value: f64,
    pub detected: bool,
    pub ttd_s: Option<f64>,
    pub ttd_epochs: Option<usize>,
    /// Strategies that fired at any epoch from the onset to the end of the window.
    pub strategies: Vec<&'static str>,
    /// Alarm episodes before the onset (on clean data: false alarms).
    pub pre_onset_alarms: usize,
    /// FNV-1a of every verdict (as the firmware's digest).
    pub digest: String,
    /// FNV-1a of the decisions only (ran, fired, degraded, reasons, alarm per epoch).
    pub decisions: String,
    /// The same up to the first alarm.
    pub decisions_to_alarm: String,
    #[serde(skip)]
    pub trace: Vec<TracePoint>,
    #[serde(skip)]
    pub true_track: Vec<(f64, LatLon)>,
    #[serde(skip)]
    pub perceived: Vec<(f64, LatLon)>,
}

#[derive(Clone, Debug, Serialize)]
pub struct KindStats {
    pub scenarios: usize,
    pub detected: usize,
    pub detection_rate: f64,
    /// Detected within 10 s of the onset.
    pub detected_within_10s: usize,
    pub rate_within_10s: f64,
    pub ttd_median_s: Option<f64>,
    pub ttd_p95_s: Option<f64>,
    pub ttd_max_s: Option<f64>,
    pub ttd_median_epochs: Option<f64>,
    pub ttd_p95_epochs: Option<f64>,
    pub ttd_max_epochs: Option<f64>,
    /// Scenarios in which each strategy fired (a row of the paper's Table 3).
    pub strategies: BTreeMap<&'static str, usize>,
    pub sources: Vec<String>,
    pub missed: Vec<String>,
    pub hosting_drives: usize,
    /// Scenarios asked for, and how many the data can host (all candidate onsets).
    pub requested: usize,
    pub capacity: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// "real" or "simulated".
    pub data: String,
    /// The data folder the run read.
    pub data_dir: String,
    /// How the numbers were fitted: `leave-one-source-out` (each source judged with numbers fitted
    /// on the others) or `in-sample`.
    pub protocol: super::fold::Protocol,
    /// Per source, judged with the numbers fitted without it (leave-one-source-out).
    pub cross_source: BTreeMap<String, CrossSource>,
    /// The nuisance suite (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nuisance: Option<BTreeMap<&'static str, NuisanceStats>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nuisance_total: Option<NuisanceTotal>,
    /// The slow drift's limits per receiver class and direction (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_limit: Option<BTreeMap<&'static str, BTreeMap<&'static str, DriftLimit>>>,
    pub clean: CleanStats,
    pub attacks: BTreeMap<&'static str, KindStats>,
    pub scenarios: Vec<Scenario>,
    pub config: serde_json::Value,
    /// Strategy 2's classifier on held-out turns (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub turns: Option<crate::turns::TurnReport>,
    /// The same scenarios judged by the paper's three strategies alone (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_strategies_only: Option<BTreeMap<&'static str, KindStats>>,
    /// The smallest slow-drift rate detected within 10 s, m/s.
    pub smallest_drift_detected_10s_mps: Option<f64>,
    /// The slow-drift scenarios replayed at fixed rates (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_sweep: Option<Vec<DriftSweepPoint>>,
    /// Strategy 1's predictors side by side (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predictors: Option<BTreeMap<&'static str, PredictorStats>>,
    /// Calibrated cars: each source's last drive judged with the calibration its earlier drives
    /// left (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibrated: Option<BTreeMap<String, CalibratedCar>>,
    /// The int8 LSTM against its f32 original (filled by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quantization: Option<Quantization>,
}

/// One predictor on the validation epochs of one receiver profile.
#[derive(Clone, Debug, Serialize)]
pub struct ProfileErr {
    pub validation_epochs: usize,
    /// Absent without validation epochs (simulated data).
    pub rmse_m: Option<f64>,
    pub max_abs_m: Option<f64>,
    /// Strategy 1's threshold at the nominal epoch: error term + GNSS error term.
    pub threshold_m: f64,
}

/// One predictor: accuracy on the validation drives (the LSTM never saw them) and what the
/// whole detector achieved with it.
#[derive(Clone, Debug, Serialize)]
pub struct PredictorStats {
    /// Pooled over the validation epochs of both profiles (absent without real data).
    pub rmse_m: Option<f64>,
    pub max_abs_m: Option<f64>,
    /// The largest nominal threshold of the profiles.
    pub threshold_m: f64,
    pub profiles: BTreeMap<&'static str, ProfileErr>,
    pub detection_rate: BTreeMap<&'static str, f64>,
    pub rate_within_10s: BTreeMap<&'static str, f64>,
    pub false_alarms: usize,
    /// Epochs of the clean drives where strategy 1 ran, and where the LSTM itself made the
    /// prediction (elsewhere it lacked an input and the kinematic fallback did).
    pub s1_epochs_clean: usize,
    pub s1_lstm_epochs_clean: usize,
}

/// The deployed int8 integer kernel against the f32 model it was quantised from.
#[derive(Clone, Debug, Serialize)]
pub struct Quantization {
    pub validation_epochs: usize,
    /// Largest |int - f32| predicted shift over the validation epochs, metres.
    pub max_abs_diff_m: Option<f64>,
    /// Largest |int - f32| / strategy-1 threshold of the epoch's profile.
    pub ratio_to_threshold: Option<f64>,
    /// Every clean drive and scenario gave the same decisions (ran, fired, degraded, reasons,
    /// alarm) at every epoch up to and including the first alarm: the same alarm, at the same
    /// epoch, for the same reasons.
    pub verdicts_identical: bool,
    pub streams_compared: usize,
    pub streams_differing: Vec<String>,
    /// Streams whose per-epoch decisions differ anywhere, also after the (latched) first alarm,
    /// where the spoofed inputs drive both kernels far outside the training range.
    pub streams_differing_after_alarm: Vec<String>,
}

/// One rate of the drift sweep: the planned slow-drift scenarios (same drives, onsets and
/// directions) replayed at this rate.
#[derive(Clone, Debug, Serialize)]
pub struct DriftSweepPoint {
    pub rate_mps: f64,
    /// Per receiver kind: `velocity` (the receiver reports speed and course) and `position`
    /// (position only).
    pub by_class: BTreeMap<&'static str, SweepCounts>,
    /// Per source.
    pub by_source: BTreeMap<String, SweepCounts>,
}

/// Slow drifts of one rate, along and across the road.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SweepCounts {
    pub along: SweepDirection,
    pub across: SweepDirection,
}

/// Slow drifts of one rate in one direction: scenarios, detected within 10, 30 and 60 s, and how
/// far the spoofer had moved the car at the alarm (`pull_off_m`, rate times time to detect;
/// the percentiles count an undetected scenario as beyond any finite offset).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SweepDirection {
    pub scenarios: usize,
    pub within_10s: usize,
    pub within_30s: usize,
    pub within_60s: usize,
    pub detected: usize,
    pub pull_off_median_m: Option<f64>,
    pub pull_off_p95_m: Option<f64>,
    pub pull_off_max_m: Option<f64>,
    #[serde(skip)]
    pub pull_offs: Vec<f64>,
}

impl SweepDirection {
    pub fn add(&mut self, rate: f64, ttd_s: Option<f64>) {
        self.scenarios += 1;
        let hit = |w: f64| ttd_s.is_some_and(|t| t <= w) as usize;
        self.within_10s += hit(10.0);
        self.within_30s += hit(30.0);
        self.within_60s += hit(60.0);
        self.detected += ttd_s.is_some() as usize;
        self.pull_offs.push(ttd_s.map_or(f64::INFINITY, |t| rate * t.max(0.0)));
    }
    /// Fills the percentiles from the pull-offs.
    pub fn finish(&mut self) {
        let mut v = self.pull_offs.clone();
        v.sort_by(f64::total_cmp);
        let q = |p: f64| -> Option<f64> {
            if v.is_empty() {
                return None;
            }
            let i = ((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
            v.get(i).copied().filter(|x| x.is_finite())
        };
        self.pull_off_median_m = q(0.5);
        self.pull_off_p95_m = q(0.95);
        self.pull_off_max_m = q(1.0);
    }
}

/// One attack kind on one held-out source.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SourceAttack {
    pub scenarios: usize,
    pub detected: usize,
    pub within_10s: usize,
}

/// One source judged with the numbers fitted without it.
#[derive(Clone, Debug, Serialize)]
pub struct CrossSource {
    /// The sources the numbers were fitted on.
    pub fitted_on: Vec<String>,
    pub hours: f64,
    /// Hours of drives with wheel speed (where the strategies run).
    pub hours_judged: f64,
    pub false_alarms: usize,
    /// Strategy 1 on the LSTM is in-sample here (the LSTM was trained or validated on this
    /// source); the other strategies are held out.
    pub lstm_in_sample: bool,
    /// The fold's fitted numbers.
    pub kinematic_error_m: [f32; 2],
    pub templates: usize,
    pub attacks: BTreeMap<&'static str, SourceAttack>,
}

/// One slice of the nuisance suite.
#[derive(Clone, Debug, Default, Serialize)]
pub struct NuisanceStats {
    pub runs: usize,
    /// Hours at which the track check judged (warm, aligned, informative, driving): the hours
    /// a false alarm of the beyond-the-paper check could have happened in.
    pub hours: f64,
    /// Hours at which any strategy ran.
    pub hours_any: f64,
    pub false_alarms: usize,
    /// Epochs at which each strategy fired.
    pub fired_epochs: BTreeMap<&'static str, usize>,
    /// Epochs each reason code was given at an epoch where a strategy fired.
    pub fired_reasons: BTreeMap<&'static str, usize>,
    /// The runs that raised one: drive, seed, what was applied.
    pub false_alarm_runs: Vec<String>,
    /// The nearest any run came to an alarm, per check.
    pub headroom: Headroom,
    /// The run that came nearest (its largest share of any check's threshold), and that share.
    pub nearest_run: Option<(String, f64)>,
}

/// The whole nuisance suite: false alarms, and the 95 % upper bound of their rate (Poisson).
#[derive(Clone, Debug, Default, Serialize)]
pub struct NuisanceTotal {
    pub runs: usize,
    /// As in [`NuisanceStats`]: hours the track check judged, and hours any strategy ran.
    pub hours: f64,
    pub hours_any: f64,
    pub false_alarms: usize,
    pub upper95_per_hour: f64,
}

/// The slow drift's limits in one receiver class and direction.
#[derive(Clone, Debug, Serialize)]
pub struct DriftLimit {
    /// The smallest swept rate found in at least 95 % of the scenarios within 10 s, 30 s and
    /// 60 s (every faster rate too).
    pub rate_95_within_10s_mps: Option<f64>,
    pub rate_95_within_30s_mps: Option<f64>,
    pub rate_95_within_60s_mps: Option<f64>,
    /// The largest pull-off p95 over the rates from 0.2 m/s, metres (None: some rate is not
    /// found in 95 % at all).
    pub pull_off_p95_max_m: Option<f64>,
    /// The rate whose 10 s offset equals the position windows' threshold on the clean drives of
    /// this class (median over their judged epochs).
    pub bound_10s_mps: Option<f64>,
    pub scenarios_per_rate: usize,
}

/// A car judged with the calibration its earlier drives left (see `eval::calibrated`).
#[derive(Clone, Debug, Serialize)]
pub struct CalibratedCar {
    /// The drives the record was learnt from, in order, and the drive judged.
    pub learnt_on: Vec<String>,
    pub judged: String,
    /// What the judged drive's receiver reports (`velocity` or `position`).
    pub receiver: &'static str,
    /// The record the judged drive started from.
    #[serde(serialize_with = "record_json")]
    pub record: Option<detector_core::strategy::track::calibration::Record>,
    /// Alarm episodes on the judged drive, clean; and whether it contradicted the record.
    pub false_alarms: usize,
    pub contradicted: bool,
    /// The judged drive on tyres 3 % larger: seconds into it when the contradiction was found.
    pub tyre_change_found_s: Option<f64>,
    /// The earliest onset, seconds into the drive, and the onsets per rate and direction.
    pub first_onset_s: f64,
    pub onsets: usize,
    pub sweep: Vec<CalibratedRate>,
    /// Every drive of the car judged clean, and on tyres 3 % larger, with the record learnt over
    /// all its other drives (the drives a car will make after these are judged the same way).
    pub every_drive: Vec<HeldOutDrive>,
    /// The judged drive under each kind of the nuisance suite, judged from the record: another
    /// installation meeting a car's record, which it must either pass or contradict.
    pub nuisance: Vec<CalibratedNuisance>,
}

/// One kind of nuisance on a calibrated car's judged drive, from its record.
#[derive(Clone, Debug, Serialize)]
pub struct CalibratedNuisance {
    pub kind: &'static str,
    /// Draws of the kind (seeded), and how many raised the alarm.
    pub runs: usize,
    pub alarmed: usize,
    /// Draws that contradicted the record (the designed answer to another installation).
    pub contradicted: usize,
    /// Draws that raised the alarm without contradicting the record: false alarms.
    pub uncontradicted_alarms: usize,
    /// Draws where a check other than the contradiction fired, contradicted or not.
    pub other_checks_fired: usize,
}

/// One drive of a calibrated car judged with the record its other drives left.
#[derive(Clone, Debug, Serialize)]
pub struct HeldOutDrive {
    pub judged: String,
    /// The drives the record was learnt from, in order.
    pub learnt_on: Vec<String>,
    /// Whether the learning left a record at all.
    pub recorded: bool,
    pub false_alarms: usize,
    pub contradicted: bool,
    /// On tyres 3 % larger: seconds into the drive when the contradiction was found.
    pub tyre_change_found_s: Option<f64>,
}

/// One drift rate on a calibrated car.
#[derive(Clone, Debug, Serialize)]
pub struct CalibratedRate {
    pub rate_mps: f64,
    #[serde(flatten)]
    pub counts: SweepCounts,
    /// Scenarios that fired before their onset.
    pub pre_onset_alarms: usize,
}

fn record_json<S: serde::Serializer>(r: &Option<detector_core::strategy::track::calibration::Record>, s: S) -> Result<S::Ok, S::Error> {
    use serde::Serialize as _;
    r.as_ref().map(crate::detect::record_json).serialize(s)
}
