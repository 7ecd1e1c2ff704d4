//! Runs `detector_core`'s detector over synchronised samples and turns verdicts into JSON.

use detector_core::fusion::{Config, Detector, Verdict};
use detector_core::profile::{self, ReceiverProfile};
use detector_core::sample::Sample;
use detector_core::strategy::track::calibration::Record;
use detector_core::strategy::location_shift::{KinematicPredictor, Predictor, ShiftPredictor, WithFallback};
use detector_core::strategy::location_shift::lstm::{LstmModel, LstmPredictor, DEFAULT_MODEL};
use detector_core::strategy::turn::{TemplateSet, DEFAULT_TEMPLATES};
use detector_core::strategy::StrategyId;
use gnss_guard_board::store::SavePolicy;
use serde::Serialize;
use serde_json::{json, Value};
use std::collections::BTreeMap;

/// The receiver profile of a drive, from its median epoch duration.
pub fn profile_of(samples: &[Sample]) -> &'static ReceiverProfile {
    let mut dts: Vec<f32> = samples.iter().map(|s| s.dt_s).filter(|d| *d > 0.0).collect();
    if dts.is_empty() {
        return &profile::LOGGER_1HZ;
    }
    dts.sort_by(f32::total_cmp);
    profile::for_rate(1.0 / dts[dts.len() / 2] as f64)
}

/// The default turn templates (strategy 2), validated.
pub fn default_templates() -> TemplateSet<'static> {
    TemplateSet::parse(DEFAULT_TEMPLATES).expect("the committed template blob is valid")
}

/// The f32 twin of the default LSTM model (the reference the int8 model is checked against).
pub const DEFAULT_MODEL_F32: &[u8] = include_bytes!("../../detector-core/models/lstm.f32.bin");

/// The receiver profiles by name: what `--profile` and the Python package's `profile=` take.
pub fn receiver_profile(name: &str) -> Option<&'static ReceiverProfile> {
    [&profile::UBLOX_10HZ, &profile::LOGGER_1HZ].into_iter().find(|p| p.name == name)
}

/// Strategy 1's predictor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PredictorKind {
    /// Wheel-speed dead reckoning.
    Kinematic,
    /// The LSTM, integer kernel on the int8 model (what the firmware runs).
    Lstm,
    /// The LSTM, f32 reference kernel on the f32 model (fidelity checks only).
    LstmF32,
}

impl PredictorKind {
    pub fn name(self) -> &'static str {
        match self {
            PredictorKind::Kinematic => "kinematic",
            PredictorKind::Lstm => "lstm",
            PredictorKind::LstmF32 => "lstm-f32",
        }
    }
}

/// The committed int8 model, validated once (its CRC covers 123 KB).
pub fn default_lstm() -> LstmModel<'static> {
    static M: std::sync::OnceLock<LstmModel<'static>> = std::sync::OnceLock::new();
    *M.get_or_init(|| LstmModel::parse(DEFAULT_MODEL).expect("the committed LSTM blob is valid"))
}

/// The committed f32 twin, validated once.
pub fn default_lstm_f32() -> LstmModel<'static> {
    static M: std::sync::OnceLock<LstmModel<'static>> = std::sync::OnceLock::new();
    *M.get_or_init(|| LstmModel::parse(DEFAULT_MODEL_F32).expect("the committed f32 LSTM blob is valid"))
}

/// The runtime predictor of a kind (the f32 reference is host-only and has no variant). The
/// LSTM falls back to the kinematic predictor (and its error term) where it lacks inputs.
pub fn predictor(kind: PredictorKind) -> Predictor<'static> {
    match kind {
        PredictorKind::Kinematic => Predictor::Kinematic(KinematicPredictor::default()),
        _ => Predictor::Lstm(WithFallback::new(LstmPredictor::int(default_lstm()).expect("int8 blob"))),
    }
}

/// The detector configuration of a profile with the predictor's error term.
pub fn config(p: &ReceiverProfile, kind: PredictorKind) -> Config {
    let mut c = Config::for_profile(p);
    c.shift.predictor_error_m = match kind {
        PredictorKind::Kinematic => p.kinematic_max_error_m,
        PredictorKind::Lstm => default_lstm().max_error_m(p.nominal_dt_s),
        PredictorKind::LstmF32 => default_lstm_f32().max_error_m(p.nominal_dt_s),
    };
    c
}

/// The detector over `samples`, and the record to keep after them: the drive's own at its end
/// (the end of a log is the car parked, where the board saves too), unless an alarm is latched
/// there; then the last one the board's [`SavePolicy`] saved before it (the car standing, no
/// alarm latched, at most every five minutes), or none: what a drive under attack learnt is
/// not kept. None when the drive contradicts the stored record: it is kept as it was.
fn run_detector<P: ShiftPredictor>(samples: &[Sample], cfg: Config, p: P, set: TemplateSet, record: Option<&Record>) -> (Vec<Verdict>, Option<Record>) {
    let mut d = Detector::new(cfg, p).with_turns(set);
    if let Some(r) = record {
        d = d.with_calibration(r);
    }
    let mut policy = SavePolicy::default();
    let mut saved = None;
    let v: Vec<Verdict> = samples
        .iter()
        .map(|s| {
            let v = d.step(s);
            // As the board's pipeline (`gnss_guard_board::pipeline`).
            saved = policy.keep(v.t, &v, &d).or(saved);
            v
        })
        .collect();
    let kept = record_at_the_end(&d, v.last(), saved);
    (v, kept)
}

/// The record to keep when the input ends (a log's end, or `live` stopped: the car parked),
/// `saved` the last one [`SavePolicy::keep`] gave during the drive: none when the drive
/// contradicts the stored record (it stays as it was: the board writes it back at the
/// standstill); else the drive's own, unless an alarm is latched at `last`: then `saved`.
pub fn record_at_the_end<P: ShiftPredictor>(d: &Detector<'_, P>, last: Option<&Verdict>, saved: Option<Record>) -> Option<Record> {
    if d.track().calibration().contradiction().is_some() {
        None
    } else if last.is_none_or(|x| !x.alarm) {
        d.calibration_record().or(saved)
    } else {
        saved
    }
}

/// [`run_with_templates`] on a car whose calibration was stored (`record`), returning the
/// record to store after this drive too, as the board saves it (`None`: nothing saved, see
/// [`run_detector`] and [`Detector::calibration_record`]).
pub fn run_calibrated(samples: &[Sample], cfg: Config, kind: PredictorKind, set: TemplateSet, record: Option<&Record>) -> (Vec<Verdict>, Option<Record>) {
    match kind {
        PredictorKind::LstmF32 => run_detector(samples, cfg, WithFallback::new(LstmPredictor::reference(default_lstm_f32())), set, record),
        k => run_detector(samples, cfg, predictor(k), set, record),
    }
}

/// Verdicts of the full detector (all strategies) with this predictor, one per sample.
pub fn run_with(samples: &[Sample], cfg: Config, kind: PredictorKind) -> Vec<Verdict> {
    run_with_templates(samples, cfg, kind, default_templates())
}

/// [`run_with`] with these turn templates.
pub fn run_with_templates(samples: &[Sample], cfg: Config, kind: PredictorKind, set: TemplateSet) -> Vec<Verdict> {
    run_calibrated(samples, cfg, kind, set, None).0
}

/// Verdicts with the kinematic predictor (calibration, and where a test needs it).
pub fn run(samples: &[Sample], cfg: Config) -> Vec<Verdict> {
    run_with(samples, cfg, PredictorKind::Kinematic)
}

fn names(set: detector_core::strategy::StrategySet) -> Vec<&'static str> {
    set.iter().map(StrategyId::name).collect()
}

/// One JSON line per epoch.
pub fn verdict_json(v: &Verdict) -> Value {
    let mut o = json!({
        "epoch": v.epoch,
        "t": v.t,
        "alarm": v.alarm,
        "fired": names(v.fired),
        "ran": names(v.ran),
        "degraded": names(v.degraded),
        "reasons": v.reasons.iter().map(|r| r.name()).collect::<Vec<_>>(),
    });
    if let Some(s) = v.shift {
        o["shift"] = json!({"gnss_m": s.gnss_shift_m, "predicted_m": s.predicted_m, "residual_m": s.residual_m, "threshold_m": s.threshold_m, "fallback": s.fallback});
    }
    if let Some(m) = v.motion {
        o["motion"] = json!({"wheel": format!("{:?}", m.wheel).to_lowercase(), "gnss": format!("{:?}", m.gnss).to_lowercase(), "disagree_s": m.disagree_s});
    }
    if let Some(t) = v.turn {
        o["turn"] = json!({"steering": t.steering.name(), "distance": t.distance, "gnss_change_deg": t.gnss_change_deg, "steering_change_deg": t.steering_change_deg,
            "mismatch": t.mismatch.map(|m| format!("{m:?}")), "derived_steering": t.derived, "start_t": t.start_t, "end_t": t.end_t});
    }
    if let Some(h) = v.turn_heading {
        o["turn_heading_share"] = json!(h);
    }
    // Beyond the paper: the track check's windows and what it learnt.
    if let Some(t) = v.track {
        let win = |w: Option<detector_core::strategy::track::WindowOutcome>| w.map(|w| json!({"e_m": w.e_m, "threshold_m": w.threshold_m, "dist_m": w.dist_m, "z": w.z}));
        o["track"] = json!({"w10s": win(t.windows[0]), "w30s": win(t.windows[1]), "delay_s": t.delay_s, "scale": t.scale, "rotation_deg": t.rotation_deg, "rotation_sd_deg": t.rotation_sd_deg, "gyro_bias_degps": t.gyro_bias_degps, "heading": t.heading.name(), "turn_scale": t.turn_scale,
            "learning": t.learning, "uninformative": t.uninformative, "bound_10s_mps": t.bound_10s_mps, "noise_s0_m": t.noise_s0_m, "noise_k": t.noise_k,
            "calibrated": t.calibrated, "reversing": t.reversing, "delay_free_s": t.delay_free_s, "delay_velocity_s": if t.delay_velocity_s.is_finite() { json!(t.delay_velocity_s) } else { Value::Null }, "contradiction": t.contradiction.map(|c| format!("{c:?}").to_lowercase()),
            "velocity": t.velocity.map(|v| json!({"residual_mps": v.residual_mps, "sigma_mps": v.sigma_mps, "t": v.t, "t_windows": v.t_windows, "h": v.h, "fired": v.fired, "suspicious": v.suspicious, "blind": v.blind, "settled": v.settled, "bound_10s_mps": v.bound_10s_mps, "pairs": v.pairs}))});
    }
    if let Some(f) = v.first_alarm {
        o["first_alarm"] = json!({"epoch": f.epoch, "t": f.t});
    }
    o
}

/// One human-readable line per epoch.
pub fn verdict_line(v: &Verdict) -> String {
    let mut l = format!("{:>6} t={:>9.2} alarm={}", v.epoch, v.t, if v.alarm { "YES" } else { "no " });
    if let Some(s) = v.shift {
        l += &format!(" shift {:6.2} m pred {:6.2} m |res| {:6.2} / thr {:5.2}", s.gnss_shift_m, s.predicted_m, s.residual_m.abs(), s.threshold_m);
        if s.fallback {
            l += " (kinematic fallback)";
        }
    }
    if !v.fired.is_empty() {
        l += &format!(" FIRED {:?}", names(v.fired));
    }
    if !v.degraded.is_empty() {
        l += &format!(" degraded {:?}", names(v.degraded));
    }
    let r: Vec<_> = v.reasons.iter().map(|r| r.name()).collect();
    if !r.is_empty() {
        l += &format!(" [{}]", r.join(","));
    }
    l
}

/// The verdict digest of a run (the board's FNV-1a over every verdict's bits, as `host-sim
/// digest` and the QEMU run compute it), 16 hex digits: two routes to the same drive can be
/// compared by it.
pub fn digest_hex(verdicts: &[Verdict]) -> String {
    let mut d = gnss_guard_board::pipeline::Digest::default();
    for v in verdicts {
        d.add(v);
    }
    format!("{:016x}", d.0)
}

/// How a drive is judged (`detect`'s options; the Python package's too).
#[derive(Clone, Copy, Debug)]
pub struct DetectOptions<'a> {
    /// The receiver profile, or `None` to take it from the drive's fix rate.
    pub profile: Option<&'static ReceiverProfile>,
    pub predictor: PredictorKind,
    pub sync: detector_core::sync::SyncConfig,
    /// The car's stored calibration, if any.
    pub stored: Option<&'a Record>,
}

impl Default for DetectOptions<'_> {
    fn default() -> Self {
        DetectOptions { profile: None, predictor: PredictorKind::Lstm, sync: detector_core::sync::SyncConfig::default(), stored: None }
    }
}

/// A drive judged: every verdict, what the drive left the car's calibration at, the summary and
/// the digest.
pub struct Detection {
    pub verdicts: Vec<Verdict>,
    pub profile: &'static ReceiverProfile,
    pub learnt: Option<Record>,
    pub summary: Summary,
    pub digest: String,
    /// Wall-clock seconds synchronising the drive into samples (host code, not the core's).
    pub sync_s: f64,
    /// Wall-clock seconds in the detector core (every epoch, the calibration record included).
    pub core_s: f64,
}

/// Synchronises a drive and runs the full detector over it: what `detect` prints, and what the
/// Python package returns (one path, so both give the same verdicts bit for bit).
pub fn detect_replay(r: &gnss_data::input::Replay, o: &DetectOptions) -> Detection {
    let t0 = std::time::Instant::now();
    let (samples, _) = gnss_data::replay::synchronize(r, o.sync);
    let sync_s = t0.elapsed().as_secs_f64();
    let p = o.profile.unwrap_or_else(|| profile_of(&samples));
    let t1 = std::time::Instant::now();
    let (verdicts, learnt) = run_calibrated(&samples, config(p, o.predictor), o.predictor, default_templates(), o.stored);
    let core_s = t1.elapsed().as_secs_f64();
    let summary = summarize(&verdicts, p);
    let digest = digest_hex(&verdicts);
    Detection { verdicts, profile: p, learnt, summary, digest, sync_s, core_s }
}

/// Seconds judged: the time covered by the epochs at which any strategy ran (each epoch counts
/// its own duration, `dt`, up to 3 s: a gap is not judged time).
pub fn judged_s(verdicts: &[Verdict]) -> f64 {
    verdicts.windows(2).filter(|w| !w[1].ran.is_empty()).map(|w| (w[1].t - w[0].t).clamp(0.0, 3.0)).sum()
}

/// Per-drive summary of a detection run.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    pub epochs: usize,
    pub profile: &'static str,
    /// Epochs at which each strategy fired.
    pub fired: BTreeMap<&'static str, usize>,
    /// Epochs at which each strategy ran.
    pub ran: BTreeMap<&'static str, usize>,
    /// Epochs at which each strategy was degraded.
    pub degraded: BTreeMap<&'static str, usize>,
    pub alarm: bool,
    pub first_alarm_t: Option<f64>,
    pub first_alarm_epoch: Option<u32>,
}

pub fn summarize(verdicts: &[Verdict], profile: &ReceiverProfile) -> Summary {
    let mut fired = BTreeMap::new();
    let mut ran = BTreeMap::new();
    let mut degraded = BTreeMap::new();
    for s in StrategyId::ALL {
        let count = |f: &dyn Fn(&Verdict) -> bool| verdicts.iter().filter(|v| f(v)).count();
        fired.insert(s.name(), count(&|v| v.fired.contains(s)));
        ran.insert(s.name(), count(&|v| v.ran.contains(s)));
        degraded.insert(s.name(), count(&|v| v.degraded.contains(s)));
    }
    let first = verdicts.iter().rev().find_map(|v| v.first_alarm);
    Summary {
        epochs: verdicts.len(),
        profile: profile.name,
        fired,
        ran,
        degraded,
        alarm: first.is_some(),
        first_alarm_t: first.map(|f| f.t),
        first_alarm_epoch: first.map(|f| f.epoch),
    }
}

/// The device's status, as the firmware sends it once a second (`GNSS_GUARD_STATUS`), for a
/// replayed drive: the board's own [`Health`](gnss_guard_board::health::Health) fed with the
/// epochs (each epoch is a fix), then its frames decoded through the DBC's fields. On a replay
/// nothing is dropped on a bus, so the CAN counters stay 0. One line per second of drive time,
/// through GNSS gaps too (where the device says `blind`), as `(t, json)`.
pub fn status_lines(verdicts: &[Verdict], calibration_stored: bool) -> Vec<(f64, Value)> {
    let mut st = StatusStream::default();
    st.h.set_calibration_stored(calibration_stored);
    let mut out = Vec::new();
    for v in verdicts {
        st.on_verdict(v, &mut out);
    }
    out
}

/// [`status_lines`] as the verdicts come (`host-sim live`): the board's health, fed epoch by
/// epoch, and its status frames decoded.
#[derive(Default)]
pub struct StatusStream {
    h: gnss_guard_board::health::Health,
    prev_t: Option<f64>,
}

impl StatusStream {
    /// The status lines due up to and at this verdict, appended to `out` as `(t, json)`.
    pub fn on_verdict(&mut self, v: &Verdict, out: &mut Vec<(f64, Value)>) {
        use gnss_guard_board::health::STATUS_PERIOD_S;
        if !v.t.is_finite() {
            return;
        }
        // Through a gap the device keeps reporting, once a period.
        if let Some(p) = self.prev_t.filter(|p| v.t > *p) {
            let mut t = p + STATUS_PERIOD_S;
            while t < v.t && t < p + 86_400.0 {
                self.emit(t, out);
                t += STATUS_PERIOD_S;
            }
        }
        self.h.on_fix(v.t);
        self.h.on_verdict(v, v.t);
        self.emit(v.t, out);
        self.prev_t = Some(self.prev_t.map_or(v.t, |p| p.max(v.t)));
    }

    fn emit(&mut self, t: f64, out: &mut Vec<(f64, Value)>) {
        use gnss_guard_board::health::{decode_status, StatusPage};
        let Some(frames) = self.h.status_due(t) else { return };
        let mut o = json!({ "t": t });
        for (id, d) in frames {
            match decode_status(id, &d) {
                Some(StatusPage::Page0 { state, ran, degraded, fix_age_s, epochs }) => {
                    o["state"] = json!(state.map_or("unknown", |s| s.name()));
                    o["ran"] = json!(names(detector_core::strategy::StrategySet(ran)));
                    o["degraded"] = json!(names(detector_core::strategy::StrategySet(degraded)));
                    o["fix_age_s"] = json!(fix_age_s);
                    o["epochs"] = json!(epochs);
                }
                Some(StatusPage::Page1 { can_dropped, can_overruns, nmea_errors, restarts }) => {
                    o["can_dropped"] = json!(can_dropped);
                    o["can_overruns"] = json!(can_overruns);
                    o["nmea_errors"] = json!(nmea_errors);
                    o["restarts"] = json!(restarts);
                }
                Some(StatusPage::Page2 { faults, reset_cause, alarm_retries, detector_restarts, receiver_spoofing, calibration }) => {
                    o["receiver_spoofing"] = json!(receiver_spoofing);
                    o["calibration"] = json!(["learning", "learnt", "stored", "contradicted"].get(calibration as usize).copied().unwrap_or("unknown"));
                    o["faults"] = json!(faults);
                    o["reset_cause"] = json!(reset_cause);
                    o["alarm_retries"] = json!(alarm_retries);
                    o["detector_restarts"] = json!(detector_restarts);
                }
                None => {}
            }
        }
        out.push((t, o));
    }
}

/// Seconds the status reported each state.
pub fn state_seconds(status: &[(f64, Value)]) -> BTreeMap<String, usize> {
    let mut m = BTreeMap::new();
    for (_, s) in status {
        if let Some(st) = s["state"].as_str() {
            *m.entry(st.to_string()).or_insert(0) += 1;
        }
    }
    m
}

/// The track check's threshold on the 10 s discrepancy at this epoch, metres, when it judged.
pub fn track_threshold_m(v: &Verdict) -> Option<f32> {
    v.track.and_then(|t| t.windows[0]).map(|w| w.threshold_m)
}

/// The car's stored calibration record from `path`: `None` when there is none, and when the file
/// is not a valid record (said on stderr with the byte offset and what was expected there, and
/// the file moved to `<name>.bad`: the drive then starts uncalibrated, as the board does with a
/// bad record).
pub fn read_calibration(path: &std::path::Path) -> Option<Record> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            eprintln!("calibration: {}: none yet, this drive learns the car", path.display());
            return None;
        }
        Err(e) => {
            eprintln!("calibration: {}: cannot read ({e}): ignored, this drive starts uncalibrated", path.display());
            return None;
        }
    };
    match Record::decode(&bytes) {
        Ok(r) => {
            eprintln!("calibration: {}: scale {:.4}, {}, learnt over {} ({:.0} s)", path.display(), r.scale, delays(&r), drives(r.drives), r.learnt_s);
            Some(r)
        }
        Err(e) => {
            // Kept aside, not lost: the drive's own record will take its place.
            let aside = path.with_extension("bad");
            let moved = std::fs::rename(path, &aside).map_or_else(|m| format!("could not be moved aside ({m})"), |_| format!("moved to {}", aside.display()));
            eprintln!("calibration: {}: byte {}: expected {} ({e:?}): ignored ({moved}), this drive starts uncalibrated", path.display(), e.offset(), e.expected());
            None
        }
    }
}

/// "1 drive", "2 drives".
fn drives(n: u16) -> String {
    format!("{n} drive{}", if n == 1 { "" } else { "s" })
}

/// A calibration record as JSON: every field, the anchors beside the values (NaN as null).
pub fn record_json(r: &Record) -> Value {
    let f = |v: f32| if v.is_finite() { Some(v) } else { None };
    json!({
        "scale": r.scale, "delay_position_s": r.delay_s[0], "delay_velocity_s": f(r.delay_s[1]),
        "learnt_s": r.learnt_s, "drives": r.drives, "gyro_bias_degps": f(r.gyro_bias_degps),
        "gyro_bias_weight_s": r.gyro_bias_weight_s, "gyro_scale_error": r.gyro_scale_error,
        "gyro_scale_sd": r.gyro_scale_sd, "noise_s0_m": r.noise_s0_m, "noise_k": r.noise_k,
        "velocity_sigma_mps": r.velocity_sigma_mps, "nominal_dt_s": r.nominal_dt_s, "anchor_scale": r.anchor_scale,
        "anchor_delay_position_s": r.anchor_delay_s[0], "anchor_delay_velocity_s": f(r.anchor_delay_s[1]),
        "anchor_gyro_scale_error": r.anchor_gyro_scale_error, "anchor_noise_s0_m": r.anchor_noise_s0_m,
        "anchor_noise_k": r.anchor_noise_k, "anchor_velocity_sigma_mps": r.anchor_velocity_sigma_mps,
    })
}

/// A calibration record for a reader: what each field means, its value and the car's anchor.
pub fn record_text(r: &Record) -> Vec<String> {
    let opt = |v: f32, unit: &str| if v.is_finite() { format!("{v:.3} {unit}") } else { "none".to_string() };
    let pair = |a: [f32; 2], d: usize| format!("{:.d$} / {:.d$}", a[0], a[1]);
    vec![
        format!("learnt over {}, {:.0} s of driving, with a receiver of {} s epochs", drives(r.drives), r.learnt_s, r.nominal_dt_s),
        format!("wheel-speed scale (GNSS over wheels) {:.4}, the car's anchor {:.4}", r.scale, r.anchor_scale),
        format!(
            "GNSS late behind the vehicle signals (negative: the vehicle signals late): position {}, velocity {}; anchors {}, {}",
            opt(r.delay_s[0], "s"),
            opt(r.delay_s[1], "s"),
            opt(r.anchor_delay_s[0], "s"),
            opt(r.anchor_delay_s[1], "s")
        ),
        if r.gyro_bias_degps.is_finite() {
            format!(
                "gyro: bias {:.3} deg/s (weighed as {:.0} s of standstill: the last drive's own, and at most 10 s of the drives before), scale error {:.4} (sd {:.4}), anchor {:.4}",
                r.gyro_bias_degps, r.gyro_bias_weight_s, r.gyro_scale_error, r.gyro_scale_sd, r.anchor_gyro_scale_error
            )
        } else {
            "gyro: none measured".to_string()
        },
        format!(
            "noise: the windows' s0 {} m and k {} (10 s / 30 s), velocity {} m/s (along / across); anchors {} m, {}, {} m/s (the kept noise stays within twice them)",
            pair(r.noise_s0_m, 2),
            pair(r.noise_k, 4),
            pair(r.velocity_sigma_mps, 3),
            pair(r.anchor_noise_s0_m, 2),
            pair(r.anchor_noise_k, 4),
            pair(r.anchor_velocity_sigma_mps, 3)
        ),
    ]
}

/// A record's delays as a user reads them: the GNSS position's and the GNSS velocity's behind
/// the vehicle signals (negative: the vehicle signals are late), `none` for a receiver that
/// reports no velocity of its own.
fn delays(r: &Record) -> String {
    let f = |d: f32| if d.is_finite() { format!("{d:.3} s") } else { "none".into() };
    format!("GNSS delays {} (position) / {} (velocity)", f(r.delay_s[0]), f(r.delay_s[1]))
}

/// Writes what the drive learnt to `path` (whole or not at all), unless there is nothing to
/// store; says what happened (JSON: `loaded`, `written`, `contradicted`, `said`).
pub fn write_calibration(path: &std::path::Path, stored: Option<&Record>, learnt: Option<&Record>, verdicts: &[Verdict]) -> anyhow::Result<Value> {
    use detector_core::fusion::Reason;
    let contradicted = verdicts.iter().any(|v| v.reasons.contains(Reason::CalibrationContradicted));
    // An alarm latched at the end: the record is the last the board saved before it (see
    // `run_detector`), or none.
    let alarm_t = verdicts.last().filter(|v| v.alarm).and_then(|_| verdicts.iter().find(|v| v.alarm)).map(|v| v.t);
    let said = match learnt {
        Some(r) => {
            crate::output::write_atomic(path, |w| w.write_all(&r.encode())).map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
            let when = alarm_t.map_or(String::new(), |t| format!(" (as saved at a standstill before the alarm at {t:.1} s: what the drive learnt after it is not kept)"));
            format!("{} written: scale {:.4}, {}, {}{when}", path.display(), r.scale, delays(r), drives(r.drives))
        }
        None if contradicted => format!("{} kept: this drive contradicts it (reason calibration_contradicted: another car, other tyres, or GNSS spoofed since before the drive); delete it to let the car be learnt afresh", path.display()),
        None if alarm_t.is_some() => format!("{} {}: an alarm latched at {:.1} s before the car stood still calibrated (what a drive under attack learnt is not kept)", path.display(), if stored.is_some() { "kept" } else { "not written" }, alarm_t.unwrap_or(f64::NAN)),
        None => format!("{} not written: the car is not calibrated yet (a first drive learns it over {} s of driving)", path.display(), detector_core::strategy::track::calibration::CalLimits::default().warmup_s),
    };
    eprintln!("calibration: {said}");
    Ok(json!({"loaded": stored.is_some(), "written": learnt.is_some(), "contradicted": contradicted, "said": said}))
}
