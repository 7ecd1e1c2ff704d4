//! The documentation's measured parts, kept true by construction: the figures `docs/` shows,
//! the evaluation report `docs/evaluation-report.md` and the results table in `README.md` are
//! what `eval` writes. `eval --docs ROOT` refreshes them from the run; `eval --check-docs ROOT`
//! fails, naming each file, where the committed ones differ from what the run wrote (the test
//! command runs it with the evaluation the docs quote: `--scenarios 100`, seed 1).

use super::results::Report;
use super::report::markdown;
use gnss_data::attack::AttackKind;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The figures the documentation shows (as `eval` names them under `figures/`).
pub const FIGURES: [&str; 5] = ["false-alarms.svg", "drift-detection.svg", "drift-pull-off.svg", "turn-by-turn-01-track.svg", "turn-by-turn-02-residual.svg"];
/// The evaluation report's place in the documentation.
pub const REPORT: &str = "docs/evaluation-report.md";
/// The README's results table sits between these lines.
pub const RESULTS_BEGIN: &str = "<!-- results: written by `host-sim eval --docs .`; do not edit by hand -->";
pub const RESULTS_END: &str = "<!-- /results -->";

/// Every documentation file this run determines: (path under the project root, contents).
pub fn expected(r: &Report, out: &Path, root: &Path) -> anyhow::Result<Vec<(PathBuf, Vec<u8>)>> {
    anyhow::ensure!(r.data == "real", "the documentation quotes the real drives; this run evaluated {} data", r.data);
    let mut files = Vec::new();
    for f in FIGURES {
        let p = out.join("figures").join(f);
        let bytes = std::fs::read(&p).map_err(|e| anyhow::anyhow!("{}: {e} (the docs show this figure: is the run `--scenarios 100` on the real drives?)", p.display()))?;
        files.push((Path::new("docs/figures").join(f), bytes));
    }
    let links: Vec<String> = FIGURES.iter().map(|f| format!("figures/{f}")).collect();
    files.push((PathBuf::from(REPORT), markdown(r, &links).into_bytes()));
    let readme_path = root.join("README.md");
    let readme = std::fs::read_to_string(&readme_path).map_err(|e| anyhow::anyhow!("{}: {e}", readme_path.display()))?;
    files.push((PathBuf::from("README.md"), with_results(&readme, &results_table(r)).map_err(|e| anyhow::anyhow!("{}: {e}", readme_path.display()))?.into_bytes()));
    Ok(files)
}

/// Writes `files` under `root`.
pub fn refresh(root: &Path, files: &[(PathBuf, Vec<u8>)]) -> anyhow::Result<()> {
    for (rel, bytes) in files {
        let p = root.join(rel);
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d)?;
        }
        crate::output::write_atomic(&p, |w| w.write_all(bytes))?;
    }
    Ok(())
}

/// The files under `root` that differ from `files` (empty: the documentation is this run's).
pub fn differing(root: &Path, files: &[(PathBuf, Vec<u8>)]) -> Vec<String> {
    let mut out = Vec::new();
    for (rel, bytes) in files {
        match std::fs::read(root.join(rel)) {
            Ok(b) if b == *bytes => {}
            Ok(b) => {
                let line = b.split(|c| *c == b'\n').zip(bytes.split(|c| *c == b'\n')).position(|(x, y)| x != y).map_or(b.len().min(bytes.len()), |l| l + 1);
                out.push(format!("{}: differs from this run's (first at line {line})", rel.display()));
            }
            Err(e) => out.push(format!("{}: {e}", rel.display())),
        }
    }
    out
}

/// `readme` with the text between the results markers replaced by `table`.
fn with_results(readme: &str, table: &str) -> Result<String, String> {
    let b = readme.find(RESULTS_BEGIN).ok_or_else(|| format!("expected the line {RESULTS_BEGIN}"))?;
    let e = readme.find(RESULTS_END).filter(|e| *e > b).ok_or_else(|| format!("expected the line {RESULTS_END} after the results' first line"))?;
    Ok(format!("{}{RESULTS_BEGIN}\n{table}{}", &readme[..b], &readme[e..]))
}

/// The README's headline table: the paper's attacks, the stealthy ones, false alarms; every
/// number linked to the report section that measures it.
pub fn results_table(r: &Report) -> String {
    let rep = "docs/evaluation-report.md";
    let mut s = String::from("| | detected | within 10 s | time to detect, median / p95 |\n|---|---|---|---|\n");
    let row = |s: &mut String, k: AttackKind| {
        if let Some(a) = r.attacks.get(k.name()) {
            let w = r.scenarios.iter().filter(|sc| sc.kind == k && sc.ttd_s.is_some_and(|t| t <= 10.0)).count();
            let f = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.1} s"));
            let _ = writeln!(s, "| {} | [{} of {}]({rep}#attacks) | [{w}]({rep}#beyond-the-paper-stealthy-spoofing) | [{} / {}]({rep}#attacks) |", k.name(), a.detected, a.scenarios, f(a.ttd_median_s), f(a.ttd_p95_s));
        }
    };
    s.push_str("| **the paper's attacks** | | | |\n");
    for k in [AttackKind::TurnByTurn, AttackKind::Overshoot, AttackKind::Stop] {
        row(&mut s, k);
    }
    s.push_str("| **beyond the paper** | | | |\n");
    for k in [AttackKind::WrongTurn, AttackKind::SmallBiased, AttackKind::Replay, AttackKind::Direction, AttackKind::SlowDrift, AttackKind::Jump] {
        row(&mut s, k);
    }
    let _ = writeln!(s, "\n| false alarms | |\n|---|---|");
    let _ = writeln!(s, "| clean real drives | [{} in {} drives, {:.2} h ({:.2} h with wheel speed, judged)]({rep}#clean-drives-false-alarms) |", r.clean.false_alarms, r.clean.drives, r.clean.hours, r.clean.hours_judged);
    if let Some(t) = &r.nuisance_total {
        let _ = writeln!(s, "| nuisance suite (new installations: timing, coarse sensors, town GNSS, ...) | [{} in {} runs, {:.0} judged h; upper 95 %: {:.4} per hour]({rep}#nuisance-suite) |", t.false_alarms, t.runs, t.hours, t.upper95_per_hour);
    }
    let pre: usize = r.scenarios.iter().map(|sc| sc.pre_onset_alarms.min(1)).sum();
    let _ = writeln!(s, "| attacked replays, before the onset | [{pre} of {}]({rep}#scenarios) |", r.scenarios.len());
    s
}
