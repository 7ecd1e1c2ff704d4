//! The evaluation report: `report.json`, `report.md` and the figures (SVG and PNG).

use gnss_data::attack::AttackKind;
use super::results::{PredictorStats, Quantization, Report, Scenario};
use crate::output::write_atomic;
use detector_core::geo::{to_local, EARTH_RADIUS_PAPER_M};
use detector_core::strategy::StrategyId;
use plotters::prelude::*;
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
    let figs = figures(r, &out.join("figures"))?;
    let md = out.join("report.md");
    let text = markdown(r, &figs, out);
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
        let _ = writeln!(s, "\nThe same slow-drift scenarios replayed at fixed rates, detected within 10 s:\n\n| rate | along the road | across the road |\n|---|---|---|");
        for p in sweep {
            let _ = writeln!(s, "| {} m/s | {}/{} | {}/{} |", p.rate_mps, p.along_within_10s, p.along_scenarios, p.across_within_10s, p.across_scenarios);
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

fn markdown(r: &Report, figs: &[PathBuf], out: &Path) -> String {
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
    let _ = writeln!(s, "\n## Attacks\n");
    let _ = writeln!(s, "| attack | scenarios | hosting drives | sources | detected | rate | TTD median | p95 | max | TTD epochs median / p95 / max |\n|---|---|---|---|---|---|---|---|---|---|");
    for (k, a) in &r.attacks {
        let _ = writeln!(s, "| {k} | {} | {} | {} | {} | {:.0} % | {} | {} | {} | {} / {} / {} |", a.scenarios, a.hosting_drives, a.sources.join(", "), a.detected, 100.0 * a.detection_rate,
            opt(a.ttd_median_s, " s"), opt(a.ttd_p95_s, " s"), opt(a.ttd_max_s, " s"), opt(a.ttd_median_epochs, ""), opt(a.ttd_p95_epochs, ""), opt(a.ttd_max_epochs, ""));
    }
    let _ = writeln!(s, "\n## Table 3: which strategy fired (scenarios)\n\n{}", table3(r));
    if let Some(p) = &r.predictors {
        let _ = writeln!(s, "## Strategy 1: kinematic and LSTM predictors\n\n{}", predictors(p, r.quantization.as_ref()));
    }
    let _ = writeln!(s, "## Beyond the paper: stealthy spoofing\n\n{}", comparison(r));
    if let Some(t) = &r.turns {
        let _ = writeln!(s, "## Strategy 2: turn classifier on held-out drives\n");
        let _ = writeln!(s, "{} held-out turns ({} templates, {} bytes; {} training turns). Accuracy **{:.1} %** (95 % Clopper-Pearson {:.1} to {:.1} %), macro F1 (left/right) {:.3}. Pruned k-NN identical to plain banded DTW on all {} queries: {}. {:.1} us per query pruned, {:.1} us unpruned (host, one core).\n",
            t.held_out, t.templates, t.templates_bytes, t.train_turns, 100.0 * t.accuracy, 100.0 * t.ci95_low, 100.0 * t.ci95_high, t.f1, t.exact_checked, t.exact, t.us_per_query_pruned, t.us_per_query_reference);
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
    for f in figs.iter().filter(|f| f.extension().is_some_and(|e| e == "svg")) {
        let rel = f.strip_prefix(out).unwrap_or(f);
        let _ = writeln!(s, "![{}]({})", rel.display(), rel.display());
    }
    s
}

fn font_ok() -> bool {
    use std::sync::OnceLock;
    static OK: OnceLock<bool> = OnceLock::new();
    *OK.get_or_init(|| {
        for p in ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"] {
            if let Ok(bytes) = std::fs::read(p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

fn figures(r: &Report, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let with_text = font_ok();
    let mut shown = std::collections::BTreeSet::new();
    for sc in &r.scenarios {
        let tbt = sc.kind == AttackKind::TurnByTurn;
        // Every turn-by-turn scenario (Fig. 5 of the paper), and a track map of the first of each other kind.
        if !tbt && !shown.insert(sc.kind) {
            continue;
        }
        for ext in ["svg", "png"] {
            if ext == "png" && !with_text {
                continue; // no font on this machine: SVG only
            }
            if tbt {
                let p = dir.join(format!("{}-residual.{ext}", sc.id));
                let bytes = residual_plot(sc, ext).map_err(anyhow::Error::msg)?;
                write_atomic(&p, |w| w.write_all(&bytes))?;
                out.push(p);
            }
            let p = dir.join(format!("{}-track.{ext}", sc.id));
            let bytes = track_plot(sc, ext).map_err(anyhow::Error::msg)?;
            write_atomic(&p, |w| w.write_all(&bytes))?;
            out.push(p);
        }
    }
    Ok(out)
}

/// A figure drawn in memory: SVG text, or an RGB bitmap encoded as PNG. Nothing touches the
/// disk until the whole file exists ([`write_atomic`]).
fn render(size: (u32, u32), ext: &str, svg: impl FnOnce(SVGBackend) -> Result<(), String>, bmp: impl FnOnce(BitMapBackend) -> Result<(), String>) -> Result<Vec<u8>, String> {
    if ext == "svg" {
        let mut s = String::new();
        svg(SVGBackend::with_string(&mut s, size))?;
        return Ok(s.into_bytes());
    }
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    bmp(BitMapBackend::with_buffer(&mut rgb, size))?;
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, size.0, size.1);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|e| e.to_string())?;
    w.write_image_data(&rgb).map_err(|e| e.to_string())?;
    w.finish().map_err(|e| e.to_string())?;
    Ok(out)
}

fn residual_plot(sc: &Scenario, ext: &str) -> Result<Vec<u8>, String> {
    render((900, 500), ext, |b| residual_draw(sc, b.into_drawing_area()), |b| residual_draw(sc, b.into_drawing_area()))
}

fn residual_draw<DB: DrawingBackend>(sc: &Scenario, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let pts: Vec<(f64, f64, f64)> = sc.trace.iter().filter_map(|p| Some((p.t, p.residual_m? as f64, p.threshold_m? as f64))).collect();
    let (x0, x1) = (-30.0f64, 60.0f64);
    let ymax = pts.iter().filter(|p| p.0 >= x0 && p.0 <= x1).map(|p| p.1.max(p.2)).fold(1.0, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{}: |GNSS shift - predicted| vs threshold ({})", sc.id, sc.params), ("sans-serif", 18))
        .margin(10).x_label_area_size(35).y_label_area_size(55)
        .build_cartesian_2d(x0..x1, 0.0..ymax).map_err(e)?;
    chart.configure_mesh().x_desc("time from onset (s)").y_desc("metres").draw().map_err(e)?;
    let inwin = |p: &&(f64, f64, f64)| p.0 >= x0 && p.0 <= x1;
    // The onset first, so the residual spike at t = 0 is drawn over it.
    chart.draw_series(LineSeries::new(vec![(0.0, 0.0), (0.0, ymax)], BLACK.mix(0.5).stroke_width(1))).map_err(e)?
        .label("attack onset").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    chart.draw_series(pts.iter().filter(inwin).map(|p| Circle::new((p.0, p.1), 2, BLUE.filled()))).map_err(e)?;
    chart.draw_series(LineSeries::new(pts.iter().filter(inwin).map(|p| (p.0, p.1)), BLUE.stroke_width(2))).map_err(e)?
        .label("|residual|").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    chart.draw_series(LineSeries::new(pts.iter().filter(inwin).map(|p| (p.0, p.2)), &RED)).map_err(e)?
        .label("threshold").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(e)?;
    root.present().map_err(e)
}

fn track_plot(sc: &Scenario, ext: &str) -> Result<Vec<u8>, String> {
    render((700, 700), ext, |b| track_draw(sc, b.into_drawing_area()), |b| track_draw(sc, b.into_drawing_area()))
}

fn track_draw<DB: DrawingBackend>(sc: &Scenario, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let Some(&(_, origin)) = sc.true_track.first() else { return root.present().map_err(e) };
    let keep = |t: f64| t >= sc.onset_t - 30.0 && t <= sc.onset_t + 60.0;
    let loc = |v: &[(f64, detector_core::geo::LatLon)]| -> Vec<(f64, f64)> {
        v.iter().filter(|p| keep(p.0)).map(|p| to_local(origin, p.1, EARTH_RADIUS_PAPER_M)).collect()
    };
    let (tt, pp) = (loc(&sc.true_track), loc(&sc.perceived));
    let all = tt.iter().chain(pp.iter());
    let (mut xa, mut xb, mut ya, mut yb) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all {
        xa = xa.min(x); xb = xb.max(x); ya = ya.min(y); yb = yb.max(y);
    }
    if xa > xb { return root.present().map_err(e); }
    let span = (xb - xa).max(yb - ya).max(50.0) * 1.1;
    let (cx, cy) = ((xa + xb) / 2.0, (ya + yb) / 2.0);
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{}: true vs perceived track ({} s before to 60 s after onset)", sc.id, 30), ("sans-serif", 16))
        .margin(10).x_label_area_size(35).y_label_area_size(55)
        .build_cartesian_2d(cx - span / 2.0..cx + span / 2.0, cy - span / 2.0..cy + span / 2.0).map_err(e)?;
    chart.configure_mesh().x_desc("east (m)").y_desc("north (m)").draw().map_err(e)?;
    chart.draw_series(LineSeries::new(tt.clone(), GREEN.stroke_width(3))).map_err(e)?
        .label("true (vehicle)").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
    chart.draw_series(LineSeries::new(pp.clone(), RED.stroke_width(2))).map_err(e)?
        .label("perceived (GNSS, spoofed)").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    if let Some(k) = sc.true_track.iter().position(|p| p.0 >= sc.onset_t) {
        let on = to_local(origin, sc.true_track[k].1, EARTH_RADIUS_PAPER_M);
        chart.draw_series(std::iter::once(Circle::new(on, 6, BLACK.filled()))).map_err(e)?
            .label("onset").legend(|(x, y)| Circle::new((x + 10, y), 4, BLACK.filled()));
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(e)?;
    root.present().map_err(e)
}
