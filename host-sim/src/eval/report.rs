//! The evaluation report: `report.json`, `report.md` and the figures (SVG and PNG).

use gnss_data::attack::AttackKind;
use super::results::{Headroom, PredictorStats, Quantization, Report, Scenario};
use crate::output::write_atomic;
use detector_core::strategy::StrategyId;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Writes everything under `out`; returns the files written.
pub fn write_all(r: &Report, out: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    crate::output::remove_stale_temporaries(out);
    crate::output::remove_stale_temporaries(&out.join("figures"));
    let json = out.join("report.json");
    write_atomic(&json, |w| serde_json::to_writer_pretty(&mut *w, r).map_err(std::io::Error::other))?;
    files.push(json);
    let figs = super::figures::figures(r, &out.join("figures"))?;
    let md = out.join("report.md");
    let links: Vec<String> = figs.iter().filter(|f| f.extension().is_some_and(|e| e == "svg")).map(|f| f.strip_prefix(out).unwrap_or(f).display().to_string()).collect();
    let text = markdown(r, &links);
    write_atomic(&md, |w| w.write_all(text.as_bytes()))?;
    files.push(md);
    files.extend(figs);
    Ok(files)
}

fn opt(v: Option<f64>, unit: &str) -> String {
    v.map_or("-".into(), |x| format!("{x:.1}{unit}"))
}

/// The paper's Table 3, regenerated: scenarios in which each strategy fired, per attack kind.
pub fn table3(r: &Report) -> String {
    let mut s = String::from("| attack | scenarios | detected |");
    for st in StrategyId::ALL {
        let _ = write!(s, " {} |", st.name());
    }
    s.push_str("\n|---|---|---|");
    for _ in StrategyId::ALL {
        s.push_str("---|");
    }
    s.push('\n');
    for (k, a) in &r.attacks {
        let _ = write!(s, "| {k} | {} | {} |", a.scenarios, a.detected);
        for st in StrategyId::ALL {
            let _ = write!(s, " {} |", a.strategies[st.name()]);
        }
        s.push('\n');
    }
    s
}

/// Mohammadi et al. 2025 (adaptive DBSCAN, HDD), published detection rates.
pub const MOHAMMADI: [(&str, &str); 4] = [
    ("turn-by-turn", "98.62 %"),
    ("stop", "99.96 %"),
    ("overshoot", "99.88 %"),
    ("small-biased", "98.38 % (25 to 50 s windows)"),
];

/// Our detection next to the paper's strategies alone and Mohammadi et al.'s published figures.
pub fn comparison(r: &Report) -> String {
    let mut s = String::from("| attack | paper's strategies alone | ours (all detectors) | ours within 10 s | TTD median / p95 | Mohammadi et al. 2025 |\n|---|---|---|---|---|---|\n");
    for (k, a) in &r.attacks {
        let paper = r.paper_strategies_only.as_ref().and_then(|p| p.get(k)).map_or("-".to_string(), |p| format!("{:.0} % ({}/{})", 100.0 * p.detection_rate, p.detected, p.scenarios));
        let m = MOHAMMADI.iter().find(|m| m.0 == *k).map_or("not reported", |m| m.1);
        let _ = writeln!(s, "| {k} | {paper} | {:.0} % ({}/{}) | {:.0} % | {} / {} | {m} |", 100.0 * a.detection_rate, a.detected, a.scenarios, 100.0 * a.rate_within_10s, opt(a.ttd_median_s, " s"), opt(a.ttd_p95_s, " s"));
    }
    let _ = writeln!(s, "\nSmallest slow-drift rate detected within 10 s: {}.", r.smallest_drift_detected_10s_mps.map_or("none".to_string(), |v| format!("{v:.2} m/s")));
    s.push_str(&stealthy_breakdown(r));
    s
}

/// Where the stealthy kinds are missed: detected within 10 s of onset per source (the sensor
/// set and receiver rate differ by source), and per drift or rotation rate.
pub fn stealthy_breakdown(r: &Report) -> String {
    let cell = |v: &[&Scenario]| {
        if v.is_empty() {
            return "-".to_string();
        }
        format!("{}/{}", v.iter().filter(|sc| sc.ttd_s.is_some_and(|t| t <= 10.0)).count(), v.len())
    };
    let mut sources: Vec<&str> = r.scenarios.iter().map(|s| s.source.as_str()).collect();
    sources.sort_unstable();
    sources.dedup();
    let mut s = format!("\nDetected within 10 s of onset, by source:\n\n| attack | {} |\n|---|{}\n", sources.join(" | "), "---|".repeat(sources.len()));
    for kind in AttackKind::STEALTHY {
        let cells: Vec<String> = sources.iter().map(|src| {
            cell(&r.scenarios.iter().filter(|sc| sc.kind == kind && sc.source == *src).collect::<Vec<_>>())
        }).collect();
        let _ = writeln!(s, "| {} | {} |", kind.name(), cells.join(" | "));
    }
    let bins = |kind: AttackKind, edges: &[f64], filter: &dyn Fn(&Scenario) -> bool| -> Vec<String> {
        edges.windows(2).map(|e| {
            cell(&r.scenarios.iter().filter(|sc| sc.kind == kind && filter(sc) && sc.value.abs() >= e[0] && sc.value.abs() < e[1]).collect::<Vec<_>>())
        }).collect()
    };
    let drift = [0.05, 0.25, 0.5, 0.75, 1.0];
    let _ = writeln!(s, "\nslow-drift detected within 10 s, by rate (m/s):\n\n| direction | 0.05-0.25 | 0.25-0.5 | 0.5-0.75 | 0.75-1 |\n|---|---|---|---|---|");
    for dir in ["along", "across"] {
        let _ = writeln!(s, "| {dir} the road | {} |", bins(AttackKind::SlowDrift, &drift, &|sc| sc.params.contains(dir)).join(" | "));
    }
    if let Some(sweep) = &r.drift_sweep {
        let _ = writeln!(s, "\nThe same slow-drift scenarios replayed at fixed rates (`drift_sweep`): detected within 10 / 30 / 60 s of the scenarios, and the pull-off (how far the spoofer moved the car before the alarm) median / p95, metres (`-`: beyond, some not found):\n\n| receiver | direction | rate | scenarios | within 10 s | within 30 s | within 60 s | pull-off median / p95 |\n|---|---|---|---|---|---|---|---|");
        let m = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.1}"));
        for class in ["velocity", "position"] {
            for along in [true, false] {
                for p in sweep {
                    let Some(c) = p.by_class.get(class) else { continue };
                    let d = if along { &c.along } else { &c.across };
                    if d.scenarios == 0 {
                        continue;
                    }
                    let _ = writeln!(s, "| {class} | {} | {} m/s | {} | {} | {} | {} | {} / {} |", if along { "along" } else { "across" }, p.rate_mps, d.scenarios, d.within_10s, d.within_30s, d.within_60s, m(d.pull_off_median_m), m(d.pull_off_p95_m));
                }
            }
        }
    }
    let _ = writeln!(s, "\ndirection detected within 10 s, by rotation rate (deg/s):\n\n| 1-2 | 2-3 | 3-4 | 4-5 |\n|---|---|---|---|\n| {} |",
        bins(AttackKind::Direction, &[1.0, 2.0, 3.0, 4.0, 5.01], &|_| true).join(" | "));
    s
}

/// The predictors side by side, and the int8 model's fidelity.
pub fn predictors(p: &std::collections::BTreeMap<&'static str, PredictorStats>, q: Option<&Quantization>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "Errors on the validation drives (the LSTM never trained on them), metres; threshold = error term + GNSS error at the nominal epoch. Paper (HDD, 120 Hz): RMSE 0.0278 m, max 0.0446 m.\n");
    let _ = writeln!(s, "| predictor | profile | validation epochs | RMSE | max abs | threshold |\n|---|---|---|---|---|---|");
    for (k, v) in p {
        for (prof, e) in &v.profiles {
            let m = |v: Option<f64>| v.map_or("- (no real validation drive)".to_string(), |v| format!("{v:.3} m"));
            let _ = writeln!(s, "| {k} | {prof} | {} | {} | {} | {:.2} m |", e.validation_epochs, m(e.rmse_m), m(e.max_abs_m), e.threshold_m);
        }
    }
    let kinds: Vec<&str> = p.values().next().map(|v| v.detection_rate.keys().copied().collect()).unwrap_or_default();
    let _ = write!(s, "\n| predictor | false alarms | S1 epochs (clean; by the LSTM itself) |");
    for k in &kinds {
        let _ = write!(s, " {k} |");
    }
    let _ = write!(s, "\n|---|---|---|{}", "---|".repeat(kinds.len()));
    for (name, v) in p {
        let _ = write!(s, "\n| {name} | {} | {} ({}) |", v.false_alarms, v.s1_epochs_clean, v.s1_lstm_epochs_clean);
        for k in &kinds {
            let _ = write!(s, " {:.0} % ({:.0} % in 10 s) |", 100.0 * v.detection_rate[k], 100.0 * v.rate_within_10s[k]);
        }
    }
    let _ = writeln!(s, "\n");
    if let Some(q) = q.filter(|q| q.validation_epochs == 0) {
        let _ = writeln!(s, "int8 integer kernel vs the f32 model: no real validation drive here; decisions identical up to the first alarm on all {} streams: **{}**.\n", q.streams_compared, q.verdicts_identical);
    } else if let Some(q) = q {
        let _ = writeln!(s, "int8 integer kernel vs the f32 model on {} validation epochs: max |int - f32| {} ({} of the threshold); decisions identical up to the first alarm on all {} streams: **{}** (differing after the latched alarm: {}).\n",
            q.validation_epochs, q.max_abs_diff_m.map_or("-".into(), |v| format!("{v:.3} m")), q.ratio_to_threshold.map_or("-".into(), |v| format!("{:.2} %", 100.0 * v)), q.streams_compared, q.verdicts_identical,
            if q.streams_differing_after_alarm.is_empty() { "none".to_string() } else { q.streams_differing_after_alarm.join(", ") });
    }
    s
}

pub fn headline(r: &Report) -> String {
    let mut s = format!(
        "data: {} | clean: {} drives, {:.2} h ({} drives / {:.2} h with wheel speed, judged), false alarms {} ({:.3}/h)\n",
        r.data, r.clean.drives, r.clean.hours, r.clean.drives_judged, r.clean.hours_judged, r.clean.false_alarms, r.clean.false_alarms_per_hour
    );
    for (k, a) in &r.attacks {
        let _ = writeln!(
            s,
            "{k:>13}: detected {}/{} ({:.0} %), time to detect median {} p95 {} max {} (sources: {})",
            a.detected, a.scenarios, 100.0 * a.detection_rate, opt(a.ttd_median_s, " s"), opt(a.ttd_p95_s, " s"), opt(a.ttd_max_s, " s"), a.sources.join(", ")
        );
    }
    s
}

/// `report.md`, its figures section linking `figures` (paths relative to the report).
pub fn markdown(r: &Report, figures: &[String]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# GNSS spoofing detection: evaluation report\n");
    if r.data == "simulated" {
        let _ = writeln!(s, "**Data: SIMULATED drives** (no `../shared/data` found). These numbers describe the simulator, not real driving.\n");
    } else {
        let _ = writeln!(s, "Data: real drives from `../shared/data`.\n");
    }
    let _ = writeln!(s, "## Clean drives (false alarms)\n");
    let _ = writeln!(s, "{} drives, {:.2} h; the strategies run on the {} drives with wheel speed ({:.2} h). False alarms: **{}** ({:.3} per hour).\n",
        r.clean.drives, r.clean.hours, r.clean.drives_judged, r.clean.hours_judged, r.clean.false_alarms, r.clean.false_alarms_per_hour);
    let _ = writeln!(s, "| drive | source | hours | profile | judged | false alarms |\n|---|---|---|---|---|---|");
    for d in &r.clean.per_drive {
        let _ = writeln!(s, "| {} | {} | {:.3} | {} | {} | {} |", d.drive, d.source, d.hours, d.profile, if d.judged { "yes" } else { "no (no wheel speed: degraded)" }, d.false_alarms);
    }
    s.push_str(&degraded_by_source(r));
    let _ = writeln!(s, "\n## Attacks\n");
    let _ = writeln!(s, "| attack | scenarios | hosting drives | sources | detected | rate | TTD median | p95 | max | TTD epochs median / p95 / max |\n|---|---|---|---|---|---|---|---|---|---|");
    for (k, a) in &r.attacks {
        let _ = writeln!(s, "| {k} | {} | {} | {} | {} | {:.0} % | {} | {} | {} | {} / {} / {} |", a.scenarios, a.hosting_drives, a.sources.join(", "), a.detected, 100.0 * a.detection_rate,
            opt(a.ttd_median_s, " s"), opt(a.ttd_p95_s, " s"), opt(a.ttd_max_s, " s"), opt(a.ttd_median_epochs, ""), opt(a.ttd_p95_epochs, ""), opt(a.ttd_max_epochs, ""));
    }
    let _ = writeln!(s, "\n## Table 3: which strategy fired (scenarios)\n\n{}", table3(r));
    s.push_str(&held_out(r));
    s.push_str(&nuisance(r));
    s.push_str(&headroom(r));
    if let Some(p) = &r.predictors {
        let _ = writeln!(s, "## Strategy 1: kinematic and LSTM predictors\n\n{}", predictors(p, r.quantization.as_ref()));
    }
    let _ = writeln!(s, "## Beyond the paper: stealthy spoofing\n\n{}", comparison(r));
    s.push_str(&drift_limits(r));
    s.push_str(&calibrated_cars(r));
    if let Some(t) = &r.turns {
        let _ = writeln!(s, "## Strategy 2: turn classifier on held-out drives\n");
        let _ = writeln!(s, "{} held-out turns ({} templates, {} bytes; {} training turns). Accuracy **{:.1} %** (95 % Clopper-Pearson {:.1} to {:.1} %), macro F1 (left/right) {:.3}. Pruned k-NN identical to plain banded DTW on all {} queries: {} (its speed: `report.json`, `turns.us_per_query_*`).\n",
            t.held_out, t.templates, t.templates_bytes, t.train_turns, 100.0 * t.accuracy, 100.0 * t.ci95_low, 100.0 * t.ci95_high, t.f1, t.exact_checked, t.exact);
        let _ = writeln!(s, "| provenance | turns | accuracy | 95 % CI |\n|---|---|---|---|");
        for (k, p) in &t.by_provenance {
            let _ = writeln!(s, "| {k} | {} | {:.1} % | {:.1} to {:.1} % |", p.n, 100.0 * p.accuracy, 100.0 * p.ci95_low, 100.0 * p.ci95_high);
        }
        let _ = writeln!(s, "\n| class | precision | recall | F1 |\n|---|---|---|---|");
        for (k, c) in &t.per_class {
            let _ = writeln!(s, "| {k} | {:.3} | {:.3} | {:.3} |", c.precision, c.recall, c.f1);
        }
        let _ = writeln!(s, "\nConfusion (rows: GNSS-confirmed label, columns: predicted):\n\n| | none | left | right |\n|---|---|---|---|");
        for (k, row) in &t.confusion {
            let _ = writeln!(s, "| {k} | {} | {} | {} |", row["none"], row["left"], row["right"]);
        }
        if !t.misses.is_empty() {
            let _ = writeln!(s, "\nThe held-out segments read otherwise than their label (the label: the GNSS course change from the segment's start to its end and the late GNSS's margin after it, + = right; a turn beyond {:.0} deg, straight under {:.0} deg):\n\n| drive | start (s) | steering | label | read as | GNSS course change | steering peak (+ = left) |\n|---|---|---|---|---|---|---|", crate::turns::LABEL_TURN_DEG, crate::turns::LABEL_STRAIGHT_DEG);
            for m in &t.misses {
                let _ = writeln!(s, "| {} | {:.1} | {} | {} | {} | {:.1} deg | {:.0} deg |", m.drive, m.t, m.provenance, m.label, m.predicted, m.gnss_change_deg, m.steering_peak_deg);
            }
        }
        s.push('\n');
    }
    let _ = writeln!(s, "## Missed scenarios\n");
    let mut any = false;
    for (k, a) in &r.attacks {
        for m in &a.missed {
            let _ = writeln!(s, "- {k}: {m}");
            any = true;
        }
    }
    if !any {
        let _ = writeln!(s, "None.");
    }
    let _ = writeln!(s, "\n## Scenarios\n\n| id | drive | onset (s) | parameters | detected | TTD (s) | strategies | pre-onset alarms |\n|---|---|---|---|---|---|---|---|");
    for sc in &r.scenarios {
        let _ = writeln!(s, "| {} | {} | {:.1} | {} | {} | {} | {} | {} |", sc.id, sc.drive, sc.onset_t, sc.params, sc.detected, opt(sc.ttd_s, ""), sc.strategies.join(", "), sc.pre_onset_alarms);
    }
    let _ = writeln!(s, "\n## Configuration\n\n```json\n{}\n```\n", serde_json::to_string_pretty(&r.config).unwrap_or_default());
    let _ = writeln!(s, "## Figures\n");
    for f in figures {
        let _ = writeln!(s, "![{f}]({f})");
    }
    s
}


/// Per source with wheel speed: the share of the clean drives' epochs at which each strategy
/// said it was degraded (it could not judge: inputs missing or implausible, a stuck sensor,
/// its warm-up).
fn degraded_by_source(r: &Report) -> String {
    let mut by: BTreeMap<&str, (usize, BTreeMap<&str, usize>)> = BTreeMap::new();
    for d in r.clean.per_drive.iter().filter(|d| d.judged) {
        let e = by.entry(d.source.as_str()).or_default();
        e.0 += d.epochs;
        for (k, n) in &d.degraded_epochs {
            *e.1.entry(k).or_default() += n;
        }
    }
    let mut s = String::from("\nDegraded: the share of the clean epochs at which each strategy could not judge (inputs missing or implausible, a stuck sensor, its warm-up), sources with wheel speed.\n\n| source | epochs |");
    let names: Vec<&str> = StrategyId::ALL.iter().map(|x| x.name()).collect();
    for n in &names {
        let _ = write!(s, " {n} |");
    }
    s.push_str("\n|---|---|");
    s.push_str(&"---|".repeat(names.len()));
    for (src, (epochs, deg)) in &by {
        let _ = write!(s, "\n| {src} | {epochs} |");
        for n in &names {
            let _ = write!(s, " {:.1} % |", 100.0 * deg.get(n).copied().unwrap_or(0) as f64 / (*epochs).max(1) as f64);
        }
    }
    s.push('\n');
    s
}

/// Each source judged with the numbers fitted on the others.
fn held_out(r: &Report) -> String {
    let mut s = String::new();
    if r.cross_source.is_empty() {
        return s;
    }
    let kinds: Vec<&str> = AttackKind::ALL.iter().map(|k| k.name()).collect();
    let _ = write!(s, "## Held out per source\n\nEach source judged with the numbers fitted on the others (`cross_source`): detected of the scenarios, and within 10 s in brackets.\n\n| source (held out) | fitted on | judged h | false alarms |");
    for k in &kinds {
        let _ = write!(s, " {k} |");
    }
    s.push_str("\n|---|---|---|---|");
    for _ in &kinds {
        s.push_str("---|");
    }
    s.push('\n');
    for (src, c) in &r.cross_source {
        let _ = write!(s, "| {src}{} | {} | {:.2} | {} |", if c.lstm_in_sample { " (S1's LSTM in-sample)" } else { "" }, c.fitted_on.join(", "), c.hours_judged, c.false_alarms);
        for k in &kinds {
            match c.attacks.get(k) {
                Some(a) if a.scenarios > 0 => {
                    let _ = write!(s, " {}/{} ({}) |", a.detected, a.scenarios, a.within_10s);
                }
                _ => s.push_str(" - |"),
            }
        }
        s.push('\n');
    }
    s.push('\n');
    s
}

/// The nuisance suite: a new installation is not an attack.
fn nuisance(r: &Report) -> String {
    let mut s = String::new();
    let (Some(n), Some(t)) = (&r.nuisance, &r.nuisance_total) else { return s };
    let _ = writeln!(s, "## Nuisance suite\n\nClean drives transformed as installations differ (not attacks), each judged with its source held out. Judged hours: the track check judged; any: any strategy ran.\n\n| nuisance | runs | judged h | any h | false alarms |\n|---|---|---|---|---|");
    for (k, v) in n {
        let _ = writeln!(s, "| {k} | {} | {:.1} | {:.1} | {} |", v.runs, v.hours, v.hours_any, v.false_alarms);
    }
    let _ = writeln!(s, "| **all** | {} | {:.1} | {:.1} | **{}** |\n", t.runs, t.hours, t.hours_any, t.false_alarms);
    let _ = writeln!(s, "Upper 95 % bound of the false-alarm rate (Poisson, judged hours): **{:.4} per hour**.\n", t.upper95_per_hour);
    s
}

/// How near the clean drives and the nuisance suite came to an alarm, per check.
fn headroom(r: &Report) -> String {
    let mut s = String::from("## Headroom\n\nHow near the clean drives (per source, the nearest of its drives) and the nuisance suite (per kind, the nearest of its runs) came to an alarm: each check's statistic as a share of its threshold, the largest it held for as long as the check's persistence (at 1.00 or more it fires). Strategy 1: |GNSS shift - prediction| over its threshold; strategy 3: a wheel/GNSS disagreement's length over its persistence; the track check's position windows: |e| over their threshold; the velocity test: the bank's `T` over `h` along and across the road (its gross path, a run of pairs each beyond 6 sigma, apart); strategy 2's heading check: the GNSS course change beyond the steering's over its threshold (it fires at once). Measured on the epochs' times, while the velocity test's persistence runs on its pairs' (up to 2 s behind), so a value near 1.00 is approximate. `-`: the check never judged. Strategy 2's turns are read as a class and have no such statistic. A drive not in this data meets these margins, not the false-alarm count.\n\n| run | strategy 1 | strategy 3 | position windows | velocity along | velocity across | strategy 2 heading |\n|---|---|---|---|---|---|---|\n");
    let f = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.2}"));
    let row = |s: &mut String, name: &str, h: &Headroom| {
        let _ = writeln!(s, "| {name} | {} | {} | {} | {} | {} | {} |", f(h.shift), f(h.motion), f(h.windows), f(h.velocity_along), f(h.velocity_across), f(h.turn_heading));
    };
    let mut by: BTreeMap<&str, Headroom> = BTreeMap::new();
    // Every clean drive, those without wheel speed too (judged for false alarms only: strategy
    // 2 runs there on the yaw-rate proxy).
    for d in &r.clean.per_drive {
        let e = by.entry(d.source.as_str()).or_default();
        *e = e.max(d.headroom);
    }
    for (src, h) in &by {
        row(&mut s, &format!("clean {src}"), h);
    }
    for (k, v) in r.nuisance.iter().flatten() {
        row(&mut s, &format!("nuisance `{k}`"), &v.headroom);
    }
    s.push_str("\nThe nuisance runs that came nearest, per kind:\n\n| nuisance | run | share |\n|---|---|---|\n");
    for (k, v) in r.nuisance.iter().flatten() {
        if let Some((run, x)) = &v.nearest_run {
            let _ = writeln!(s, "| {k} | {run} | {x:.2} |");
        }
    }
    s.push('\n');
    s
}

/// The slowest drifts found in 95 % of the sweep's scenarios, per receiver class and direction.
fn drift_limits(r: &Report) -> String {
    let mut s = String::new();
    let Some(d) = &r.drift_limit else { return s };
    let _ = writeln!(s, "### Drift limits\n\nThe smallest swept rate found in at least 95 % of the scenarios (and every faster rate too) within 10, 30 and 60 s; the largest pull-off p95 over the rates from 0.2 m/s (`-`: none, or some rate not found in 95 %).\n\n| receiver | direction | scenarios per rate | 95 % within 10 s | within 30 s | within 60 s | pull-off p95, worst rate |\n|---|---|---|---|---|---|---|");
    let mps = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x} m/s"));
    for (class, dirs) in d {
        for (dir, l) in dirs {
            let _ = writeln!(s, "| {class} | {dir} | {} | {} | {} | {} | {} |", l.scenarios_per_rate, mps(l.rate_95_within_10s_mps), mps(l.rate_95_within_30s_mps), mps(l.rate_95_within_60s_mps), opt(l.pull_off_p95_max_m, " m"));
        }
    }
    s.push('\n');
    s
}

/// Cars judged with the calibration their earlier drives left.
fn calibrated_cars(r: &Report) -> String {
    let mut s = String::new();
    let Some(c) = &r.calibrated else { return s };
    let _ = writeln!(s, "### Calibrated cars\n\nThe record learnt over a car's earlier drives, then its last drive judged from its first minute (onsets from 20 s): clean, on tyres 3 % larger (which must contradict the record), and under slow drifts.\n\n| car | learnt on | judged | clean false alarms | contradicted | tyres 3 % larger: found at |\n|---|---|---|---|---|---|");
    for (car, v) in c {
        let _ = writeln!(s, "| {car} | {} drive(s) | {} | {} | {} | {} |", v.learnt_on.len(), v.judged, v.false_alarms, v.contradicted, opt(v.tyre_change_found_s, " s"));
    }
    let _ = writeln!(s, "\nEvery drive of the car judged the same way, with the record learnt over all its other drives in order (as a car's later drives will meet a record learnt before them):\n\n| car | judged | learnt on | clean false alarms | contradicted | tyres 3 % larger: found at |\n|---|---|---|---|---|---|");
    for (car, v) in c {
        for h in &v.every_drive {
            let learnt = if h.recorded { format!("{} drive(s)", h.learnt_on.len()) } else { "no record".to_string() };
            let _ = writeln!(s, "| {car} | {} | {learnt} | {} | {} | {} |", h.judged, h.false_alarms, h.contradicted, opt(h.tyre_change_found_s, " s"));
        }
    }
    let _ = writeln!(s, "\n| car | rate | along: within 10 / 30 / 60 s | across: within 10 / 30 / 60 s | pre-onset alarms |\n|---|---|---|---|---|");
    for (car, v) in c {
        for p in &v.sweep {
            let (a, x) = (&p.counts.along, &p.counts.across);
            let _ = writeln!(s, "| {car} | {} m/s | {}/{}/{} of {} | {}/{}/{} of {} | {} |", p.rate_mps, a.within_10s, a.within_30s, a.within_60s, a.scenarios, x.within_10s, x.within_30s, x.within_60s, x.scenarios, p.pre_onset_alarms);
        }
    }
    let _ = writeln!(s, "\nThe judged drive under each kind of the nuisance suite (draws of their own), from the record: another installation meeting the car's record, which must pass or contradict it. An alarm without the contradiction is a false alarm.\n\n| car | nuisance | draws | alarmed | contradicted | alarms without the contradiction | another check fired |\n|---|---|---|---|---|---|---|");
    for (car, v) in c {
        for n in &v.nuisance {
            let _ = writeln!(s, "| {car} | {} | {} | {} | {} | {} | {} |", n.kind, n.runs, n.alarmed, n.contradicted, n.uncontradicted_alarms, n.other_checks_fired);
        }
    }
    s.push('\n');
    s
}
