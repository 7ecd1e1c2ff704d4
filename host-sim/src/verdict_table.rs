//! The per-epoch verdicts as an Arrow table (`detect --out verdicts.parquet`; the Python package's
//! DataFrame): one row per epoch, the columns of `detect --json`'s lines flattened, every number of
//! each strategy in its own nullable column, and the strategy and reason sets both as lists of
//! names and as the bit masks of the alarm frame.

use arrow_array::builder::{BooleanBuilder, Float32Builder, Float64Builder, ListBuilder, StringBuilder, UInt32Builder, UInt8Builder};
use arrow_array::{ArrayRef, RecordBatch};
use detector_core::fusion::Verdict;
use detector_core::strategy::StrategySet;
use std::sync::Arc;

/// Builds a nullable f32 column from one value per verdict.
fn f32s(vs: &[Verdict], f: impl Fn(&Verdict) -> Option<f32>) -> ArrayRef {
    let mut b = Float32Builder::with_capacity(vs.len());
    for v in vs {
        b.append_option(f(v).filter(|x| x.is_finite()));
    }
    Arc::new(b.finish())
}

fn f64s(vs: &[Verdict], f: impl Fn(&Verdict) -> Option<f64>) -> ArrayRef {
    let mut b = Float64Builder::with_capacity(vs.len());
    for v in vs {
        b.append_option(f(v).filter(|x| x.is_finite()));
    }
    Arc::new(b.finish())
}

fn bools(vs: &[Verdict], f: impl Fn(&Verdict) -> Option<bool>) -> ArrayRef {
    let mut b = BooleanBuilder::with_capacity(vs.len());
    for v in vs {
        b.append_option(f(v));
    }
    Arc::new(b.finish())
}

fn strs(vs: &[Verdict], f: impl Fn(&Verdict) -> Option<String>) -> ArrayRef {
    let mut b = StringBuilder::new();
    for v in vs {
        b.append_option(f(v));
    }
    Arc::new(b.finish())
}

fn lists(vs: &[Verdict], f: impl Fn(&Verdict) -> Vec<&'static str>) -> ArrayRef {
    let mut b = ListBuilder::new(StringBuilder::new());
    for v in vs {
        for n in f(v) {
            b.values().append_value(n);
        }
        b.append(true);
    }
    Arc::new(b.finish())
}

fn names(set: StrategySet) -> Vec<&'static str> {
    set.iter().map(|s| s.name()).collect()
}

/// The verdicts as one record batch (see the module documentation for the columns).
pub fn table(vs: &[Verdict]) -> Result<RecordBatch, arrow_schema::ArrowError> {
    let mut epoch = UInt32Builder::with_capacity(vs.len());
    let (mut fired_mask, mut ran_mask, mut degraded_mask) = (UInt8Builder::new(), UInt8Builder::new(), UInt8Builder::new());
    let mut reasons_mask = UInt32Builder::new();
    for v in vs {
        epoch.append_value(v.epoch);
        fired_mask.append_value(v.fired.0);
        ran_mask.append_value(v.ran.0);
        degraded_mask.append_value(v.degraded.0);
        reasons_mask.append_value(v.reasons.0);
    }
    let lower = |s: String| s.to_lowercase();
    let cols: Vec<(&str, ArrayRef)> = vec![
        ("epoch", Arc::new(epoch.finish())),
        ("t", f64s(vs, |v| Some(v.t))),
        ("alarm", bools(vs, |v| Some(v.alarm))),
        ("first_alarm_t", f64s(vs, |v| v.first_alarm.map(|f| f.t))),
        ("learning", bools(vs, |v| Some(v.learning))),
        ("fired", lists(vs, |v| names(v.fired))),
        ("ran", lists(vs, |v| names(v.ran))),
        ("degraded", lists(vs, |v| names(v.degraded))),
        ("reasons", lists(vs, |v| v.reasons.iter().map(|r| r.name()).collect())),
        ("fired_mask", Arc::new(fired_mask.finish())),
        ("ran_mask", Arc::new(ran_mask.finish())),
        ("degraded_mask", Arc::new(degraded_mask.finish())),
        ("reasons_mask", Arc::new(reasons_mask.finish())),
        // Strategy 1.
        ("shift_gnss_m", f32s(vs, |v| v.shift.map(|s| s.gnss_shift_m))),
        ("shift_predicted_m", f32s(vs, |v| v.shift.map(|s| s.predicted_m))),
        ("shift_residual_m", f32s(vs, |v| v.shift.map(|s| s.residual_m))),
        ("shift_threshold_m", f32s(vs, |v| v.shift.map(|s| s.threshold_m))),
        ("shift_fallback", bools(vs, |v| v.shift.map(|s| s.fallback))),
        // Strategy 3.
        ("motion_wheel", strs(vs, |v| v.motion.map(|m| lower(format!("{:?}", m.wheel))))),
        ("motion_gnss", strs(vs, |v| v.motion.map(|m| lower(format!("{:?}", m.gnss))))),
        ("motion_disagree_s", f32s(vs, |v| v.motion.map(|m| m.disagree_s))),
        // Strategy 2, at the epochs where it judged.
        ("turn_steering", strs(vs, |v| v.turn.map(|t| t.steering.name().to_string()))),
        ("turn_distance", f32s(vs, |v| v.turn.map(|t| t.distance))),
        ("turn_gnss_change_deg", f32s(vs, |v| v.turn.map(|t| t.gnss_change_deg))),
        ("turn_steering_change_deg", f32s(vs, |v| v.turn.map(|t| t.steering_change_deg))),
        ("turn_mismatch", strs(vs, |v| v.turn.and_then(|t| t.mismatch).map(|m| format!("{m:?}")))),
        ("turn_heading_share", f32s(vs, |v| v.turn_heading)),
        // The track check.
        ("track_learning", bools(vs, |v| v.track.map(|t| t.learning))),
        ("track_uninformative", bools(vs, |v| v.track.map(|t| t.uninformative))),
        ("track_calibrated", bools(vs, |v| v.track.map(|t| t.calibrated))),
        ("track_w10s_z", f32s(vs, |v| v.track.and_then(|t| t.windows[0]).map(|w| w.z))),
        ("track_w30s_z", f32s(vs, |v| v.track.and_then(|t| t.windows[1]).map(|w| w.z))),
        ("track_delay_s", f32s(vs, |v| v.track.map(|t| t.delay_s))),
        ("track_delay_velocity_s", f32s(vs, |v| v.track.map(|t| t.delay_velocity_s))),
        ("track_scale", f32s(vs, |v| v.track.map(|t| t.scale))),
        ("track_rotation_deg", f32s(vs, |v| v.track.map(|t| t.rotation_deg))),
        ("track_gyro_bias_degps", f32s(vs, |v| v.track.map(|t| t.gyro_bias_degps))),
        ("track_velocity_residual_along_mps", f32s(vs, |v| v.track.and_then(|t| t.velocity).and_then(|x| x.residual_mps[0]))),
        ("track_velocity_residual_across_mps", f32s(vs, |v| v.track.and_then(|t| t.velocity).and_then(|x| x.residual_mps[1]))),
        ("track_velocity_t_along", f32s(vs, |v| v.track.and_then(|t| t.velocity).map(|x| x.t[0]))),
        ("track_velocity_t_across", f32s(vs, |v| v.track.and_then(|t| t.velocity).map(|x| x.t[1]))),
        ("track_velocity_h", f32s(vs, |v| v.track.and_then(|t| t.velocity).map(|x| x.h))),
    ];
    RecordBatch::try_from_iter(cols)
}

/// Writes the verdicts as a Parquet file (snappy).
pub fn write_parquet(vs: &[Verdict], out: impl std::io::Write + Send) -> std::io::Result<()> {
    let b = table(vs).map_err(std::io::Error::other)?;
    gnss_data::input::drive_parquet::write_batch(&b, out)
}
