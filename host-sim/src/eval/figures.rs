//! The evaluation's figures, drawn in memory (SVG, and PNG where a font is installed) and
//! written whole: the drift sweep, the pull-off, false alarms per kind, and per scenario the
//! residual (the paper's Fig. 5) and the true against the perceived track.

use gnss_data::attack::AttackKind;
use super::results::{Report, Scenario};
use super::stats::poisson_upper95;
use crate::output::write_atomic;
use detector_core::geo::{to_local, EARTH_RADIUS_PAPER_M};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

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

/// Draws every figure of `r` into `dir`; returns the files written.
pub fn figures(r: &Report, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let with_text = font_ok();
    for ext in ["svg", "png"] {
        if ext == "png" && !with_text {
            continue;
        }
        if r.drift_sweep.as_ref().is_some_and(|d| !d.is_empty()) {
            let p = dir.join(format!("drift-detection.{ext}"));
            let bytes = render((1100, 480), ext, |b| drift_draw(r, b.into_drawing_area()), |b| drift_draw(r, b.into_drawing_area())).map_err(anyhow::Error::msg)?;
            write_atomic(&p, |w| w.write_all(&bytes))?;
            out.push(p);
        }
        if r.drift_sweep.as_ref().is_some_and(|d| !d.is_empty()) {
            let p = dir.join(format!("drift-pull-off.{ext}"));
            let bytes = render((1100, 480), ext, |b| pull_off_draw(r, b.into_drawing_area()), |b| pull_off_draw(r, b.into_drawing_area())).map_err(anyhow::Error::msg)?;
            write_atomic(&p, |w| w.write_all(&bytes))?;
            out.push(p);
        }
        let rows = false_alarm_rows(r);
        if !rows.is_empty() {
            let p = dir.join(format!("false-alarms.{ext}"));
            let h = 90 + 26 * rows.len() as u32;
            let bytes = render((1000, h), ext, |b| false_alarm_draw(&rows, b.into_drawing_area()), |b| false_alarm_draw(&rows, b.into_drawing_area())).map_err(anyhow::Error::msg)?;
            write_atomic(&p, |w| w.write_all(&bytes))?;
            out.push(p);
        }
    }
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

/// The legend in its own panel right of the chart, so it never covers the data.
fn side_legend<DB: DrawingBackend>(area: &DrawingArea<DB, plotters::coord::Shift>, items: &[(&str, RGBColor, bool)]) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    for (k, (label, colour, dashed)) in items.iter().enumerate() {
        let y = 50 + 24 * k as i32;
        if *dashed {
            for x in (8..36).step_by(8) {
                area.draw(&PathElement::new(vec![(x, y), (x + 4, y)], colour.stroke_width(2))).map_err(e)?;
            }
        } else {
            area.draw(&PathElement::new(vec![(8, y), (36, y)], colour.stroke_width(2))).map_err(e)?;
        }
        area.draw(&Text::new(label.to_string(), (44, y - 7), ("sans-serif", 14))).map_err(e)?;
    }
    Ok(())
}

/// Strategy 1's residual against its threshold around the onset (the paper's Fig. 5), on a
/// logarithmic axis: the clean noise (decimetres), the threshold (metres) and the attack's
/// spike (hundreds of metres) all stay readable.
fn residual_draw<DB: DrawingBackend>(sc: &Scenario, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let (plot, legend) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(190));
    const FLOOR: f64 = 0.01;
    let pts: Vec<(f64, f64, f64)> = sc.trace.iter().filter_map(|p| Some((p.t, (p.residual_m? as f64).max(FLOOR), (p.threshold_m? as f64).max(FLOOR)))).collect();
    let (x0, x1) = (-30.0f64, 60.0f64);
    let ymax = pts.iter().filter(|p| p.0 >= x0 && p.0 <= x1).map(|p| p.1.max(p.2)).fold(1.0, f64::max) * 2.0;
    let mut chart = ChartBuilder::on(&plot)
        .caption(format!("{}: |GNSS shift - predicted| vs threshold", sc.id), ("sans-serif", 18))
        .margin(10).x_label_area_size(35).y_label_area_size(60)
        .build_cartesian_2d(x0..x1, (FLOOR..ymax).log_scale()).map_err(e)?;
    chart.configure_mesh().x_desc("time from onset (s)").y_desc("metres (log)").y_label_formatter(&|v| format!("{v}")).draw().map_err(e)?;
    let inwin = |p: &&(f64, f64, f64)| p.0 >= x0 && p.0 <= x1;
    chart.draw_series(LineSeries::new(vec![(0.0, FLOOR), (0.0, ymax)], BLACK.mix(0.5).stroke_width(1))).map_err(e)?;
    chart.draw_series(pts.iter().filter(inwin).map(|p| Circle::new((p.0, p.1), 2, BLUE.filled()))).map_err(e)?;
    chart.draw_series(LineSeries::new(pts.iter().filter(inwin).map(|p| (p.0, p.1)), BLUE.stroke_width(2))).map_err(e)?;
    chart.draw_series(LineSeries::new(pts.iter().filter(inwin).map(|p| (p.0, p.2)), RED.stroke_width(2))).map_err(e)?;
    let e2 = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    legend.draw(&Text::new(sc.params.chars().take(26).collect::<String>(), (8, 20), ("sans-serif", 12))).map_err(e2)?;
    side_legend(&legend, &[("|residual|", BLUE, false), ("threshold", RED, false), ("attack onset", RGBColor(128, 128, 128), false)])?;
    root.present().map_err(e)
}

/// Detection within 10 s and 30 s against the drift rate, along and across the road, per rate
/// class, with the bound the learnt sensor noise allows (`drift_limit.*.bound_10s_mps`).
fn drift_draw<DB: DrawingBackend>(r: &Report, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let Some(sweep) = r.drift_sweep.as_ref() else { return root.present().map_err(e) };
    let (plots, legend) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(230));
    let panels = plots.split_evenly((1, 2));
    let rmin = sweep.iter().map(|p| p.rate_mps).fold(f64::MAX, f64::min).max(0.01) / 1.3;
    let rmax = sweep.iter().map(|p| p.rate_mps).fold(0.0, f64::max) * 1.3;
    for (panel, class) in panels.iter().zip(["velocity", "position"]) {
        let n = sweep.first().and_then(|p| p.by_class.get(class)).map_or((0, 0), |c| (c.along.scenarios, c.across.scenarios));
        let what = if class == "velocity" { "receivers reporting velocity" } else { "position-only receivers" };
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{what} ({} along, {} across per rate)", n.0, n.1), ("sans-serif", 16))
            .margin(10).x_label_area_size(35).y_label_area_size(45)
            .build_cartesian_2d((rmin..rmax).log_scale(), 0.0..100.0).map_err(e)?;
        chart.configure_mesh().x_desc("drift rate (m/s, log)").y_desc("% detected").x_label_formatter(&|v| format!("{v}")).draw().map_err(e)?;
        let pct = |k: usize, n: usize| if n > 0 { 100.0 * k as f64 / n as f64 } else { f64::NAN };
        type Pick = fn(&super::results::SweepCounts) -> (usize, usize);
        let series: [(Pick, RGBColor, bool); 4] = [
            (|c| (c.along.within_10s, c.along.scenarios), BLUE, false),
            (|c| (c.along.within_60s, c.along.scenarios), BLUE, true),
            (|c| (c.across.within_10s, c.across.scenarios), RED, false),
            (|c| (c.across.within_60s, c.across.scenarios), RED, true),
        ];
        for (pick, colour, dashed) in series {
            let pts: Vec<(f64, f64)> = sweep
                .iter()
                .filter_map(|p| p.by_class.get(class).map(|c| (p.rate_mps, pick(c))))
                .filter(|(_, (_, n))| *n > 0)
                .map(|(r, (k, n))| (r, pct(k, n)))
                .collect();
            if dashed {
                chart.draw_series(DashedLineSeries::new(pts.clone(), 6, 4, colour.stroke_width(2))).map_err(e)?;
            } else {
                chart.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2))).map_err(e)?;
            }
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(e)?;
        }
        chart.draw_series(LineSeries::new(vec![(rmin, 95.0), (rmax, 95.0)], BLACK.mix(0.3))).map_err(e)?;
    }
    side_legend(&legend, &[
        ("along, within 10 s", BLUE, false),
        ("along, within 60 s", BLUE, true),
        ("across, within 10 s", RED, false),
        ("across, within 60 s", RED, true),
        ("95 %", RGBColor(180, 180, 180), false),
    ])?;
    root.present().map_err(e)
}

/// How far the spoofer moved the car before the alarm (`pull_off_m`: median and p95 over the
/// scenarios of a rate) against the drift rate, along and across the road, per receiver kind,
/// with the 15 m line; a rate whose p95 is not reached (some scenario not found) is left out of
/// the p95 line.
fn pull_off_draw<DB: DrawingBackend>(r: &Report, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let Some(sweep) = r.drift_sweep.as_ref() else { return root.present().map_err(e) };
    let (plots, legend) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(230));
    let panels = plots.split_evenly((1, 2));
    let rmin = sweep.iter().map(|p| p.rate_mps).fold(f64::MAX, f64::min).max(0.01) / 1.3;
    let rmax = sweep.iter().map(|p| p.rate_mps).fold(0.0, f64::max) * 1.3;
    for (panel, class) in panels.iter().zip(["velocity", "position"]) {
        let what = if class == "velocity" { "receivers reporting velocity" } else { "position-only receivers" };
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{what}: offset at the alarm"), ("sans-serif", 16))
            .margin(10).x_label_area_size(35).y_label_area_size(45)
            .build_cartesian_2d((rmin..rmax).log_scale(), (1.0..400.0f64).log_scale()).map_err(e)?;
        chart.configure_mesh().x_desc("drift rate (m/s, log)").y_desc("pull-off (m, log)").x_label_formatter(&|v| format!("{v}")).draw().map_err(e)?;
        type Pick = fn(&super::results::SweepCounts) -> Option<f64>;
        let series: [(Pick, RGBColor, bool); 4] = [
            (|c| c.along.pull_off_median_m, BLUE, false),
            (|c| c.along.pull_off_p95_m, BLUE, true),
            (|c| c.across.pull_off_median_m, RED, false),
            (|c| c.across.pull_off_p95_m, RED, true),
        ];
        for (pick, colour, dashed) in series {
            let pts: Vec<(f64, f64)> = sweep.iter().filter_map(|p| p.by_class.get(class).and_then(pick).map(|v| (p.rate_mps, v.max(1.0)))).collect();
            if dashed {
                chart.draw_series(DashedLineSeries::new(pts.clone(), 6, 4, colour.stroke_width(2))).map_err(e)?;
            } else {
                chart.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2))).map_err(e)?;
            }
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(e)?;
        }
        chart.draw_series(LineSeries::new(vec![(rmin, 15.0), (rmax, 15.0)], BLACK.mix(0.3))).map_err(e)?;
    }
    side_legend(&legend, &[
        ("along, median", BLUE, false),
        ("along, p95", BLUE, true),
        ("across, median", RED, false),
        ("across, p95", RED, true),
        ("15 m", RGBColor(180, 180, 180), false),
    ])?;
    root.present().map_err(e)
}

/// One bar per nuisance and per held-out source: (label, hours judged, false alarms).
fn false_alarm_rows(r: &Report) -> Vec<(String, f64, usize)> {
    let mut rows = Vec::new();
    if let Some(n) = &r.nuisance {
        for (k, v) in n {
            rows.push((format!("nuisance: {k}"), v.hours, v.false_alarms));
        }
    }
    if let Some(t) = &r.nuisance_total {
        rows.push(("nuisance: all".to_string(), t.hours, t.false_alarms));
    }
    // Sources without wheel speed are never judged (no hours): left out.
    for (k, c) in r.cross_source.iter().filter(|(_, c)| c.hours_judged > 1e-6) {
        rows.push((format!("held out: {k}"), c.hours_judged, c.false_alarms));
    }
    rows
}

/// False alarms per hour (the bar) and the 95 % upper bound the hours allow (the whisker).
fn false_alarm_draw<DB: DrawingBackend>(rows: &[(String, f64, usize)], root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string();
    root.fill(&WHITE).map_err(e)?;
    let (plot, legend) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(250));
    let up: Vec<f64> = rows.iter().map(|(_, h, k)| poisson_upper95(*k, *h)).collect();
    let xmax = up.iter().copied().filter(|x| x.is_finite()).fold(0.1, f64::max) * 2.0;
    // A logarithmic axis: bounds from hundreds of hours (hundredths per hour) to minutes
    // (hundreds per hour) side by side; a rate of zero sits on the left edge.
    const XMIN: f64 = 0.005;
    let n = rows.len();
    let mut chart = ChartBuilder::on(&plot)
        .caption("False alarms per hour judged, with the 95 % upper bound", ("sans-serif", 16))
        .margin(10).x_label_area_size(35).y_label_area_size(300)
        .build_cartesian_2d((XMIN..xmax).log_scale(), (0..n).into_segmented()).map_err(e)?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(n)
        .y_label_formatter(&|v| match v {
            SegmentValue::CenterOf(i) => rows.get(*i).map_or(String::new(), |(l, h, k)| format!("{l} ({:.1} h, {k})", h.max(0.0))),
            _ => String::new(),
        })
        .x_desc("false alarms per hour (log)")
        .x_label_formatter(&|v| format!("{v}"))
        .draw()
        .map_err(e)?;
    for (i, ((_, h, k), u)) in rows.iter().zip(&up).enumerate() {
        let rate = if *h > 0.0 { *k as f64 / h } else { 0.0 };
        if rate > XMIN {
            let (a, b) = (SegmentValue::Exact(i), SegmentValue::Exact(i + 1));
            chart.draw_series(std::iter::once(Rectangle::new([(XMIN, a), (rate, b)], BLUE.filled()))).map_err(e)?;
        }
        if u.is_finite() {
            chart.draw_series(std::iter::once(PathElement::new(vec![(XMIN, SegmentValue::CenterOf(i)), (*u, SegmentValue::CenterOf(i))], BLACK.stroke_width(1)))).map_err(e)?;
            chart.draw_series(std::iter::once(Circle::new((*u, SegmentValue::CenterOf(i)), 3, BLACK.filled()))).map_err(e)?;
        }
    }
    side_legend(&legend, &[("measured rate", BLUE, false), ("95 % upper bound", BLACK, false)])?;
    legend.draw(&Text::new("labels: (hours judged, alarms)", (8, 110), ("sans-serif", 12))).map_err(|x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string())?;
    legend.draw(&Text::new("no bar: no false alarm", (8, 128), ("sans-serif", 12))).map_err(|x: DrawingAreaErrorKind<DB::ErrorType>| x.to_string())?;
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
