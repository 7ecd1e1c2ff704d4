//! `eval`: the evaluation on clean, attacked and transformed drives; the report and figures.

use super::{data_or_default, load_drives, outln};
use host_sim::dataset::Drive;
use host_sim::{detect, eval};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Data folder (with drives/); default ../shared/data or $GNSS_DATA_DIR.
    #[arg(long)]
    data: Option<PathBuf>,
    /// How the data-derived numbers are fitted: each source judged with numbers fitted on the
    /// others (`loso`, the default), or everything on everything (`in-sample`, for comparison).
    #[arg(long, value_parser = ["loso", "in-sample"], default_value = "loso")]
    protocol: String,
    /// Draws of each nuisance kind per drive with wheel speed (0: no nuisance suite).
    #[arg(long, default_value_t = 8)]
    nuisance_variants: usize,
    /// Scenarios per attack kind.
    #[arg(long, default_value_t = 10)]
    scenarios: usize,
    #[arg(long, default_value = "out/eval")]
    out: PathBuf,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Strategy 1's predictor for the main run (the report shows both side by side).
    #[arg(long, value_enum, default_value = "lstm")]
    predictor: detect::PredictorKind,
    /// Also refresh the documentation's measured parts under this project root from the run:
    /// the figures docs/ shows, docs/evaluation-report.md and README's results table.
    #[arg(long, conflicts_with = "check_docs")]
    docs: Option<PathBuf>,
    /// Fail, naming each file, where the documentation under this project root is not what the
    /// run wrote (the test command's check that docs/ and README quote the code as it is).
    #[arg(long)]
    check_docs: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let dir = data_or_default(a.data);
    let drives = load_drives(&dir.join("drives"))?;
    let protocol = if a.protocol == "in-sample" { eval::Protocol::InSample } else { eval::Protocol::LeaveOneSourceOut };
    let r = run_eval(drives, "real", &dir, protocol, a.nuisance_variants, a.scenarios, a.seed, a.predictor, &a.out)?;
    if let Some(root) = a.docs.as_ref().or(a.check_docs.as_ref()) {
        let files = eval::docs::expected(&r, &a.out, root)?;
        if a.docs.is_some() {
            eval::docs::refresh(root, &files)?;
            outln!("documentation refreshed under {}: {} files", root.display(), files.len());
        } else {
            let bad = eval::docs::differing(root, &files);
            if !bad.is_empty() {
                anyhow::bail!("the documentation is not this run's (refresh it with `eval --scenarios 100 --docs .`):\n  {}", bad.join("\n  "));
            }
            outln!("documentation under {} is this run's: {} files identical", root.display(), files.len());
        }
    }
    Ok(())
}

/// Evaluates `drives` and writes the report; prints the headline, Table 3 and the predictors.
#[allow(clippy::too_many_arguments)]
pub fn run_eval(drives: Vec<Drive>, data: &str, dir: &Path, protocol: eval::Protocol, nuisance_variants: usize, scenarios: usize, seed: u64, predictor: detect::PredictorKind, out: &Path) -> anyhow::Result<eval::Report> {
    let o = eval::EvalOptions { scenarios, seed, predictor, protocol, ..Default::default() };
    let nuisance_runs = drives.iter().filter(|d| d.has_wheel_speed()).count() * gnss_data::nuisance::NuisanceKind::ALL.len() * nuisance_variants;
    let total = drives.len() + eval::plan(&drives, &o).len() + nuisance_runs;
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}").unwrap().progress_chars("=> "));
    bar.set_message("evaluating");
    let r = eval::full(drives, &o, data, &dir.display().to_string(), nuisance_variants, &|| bar.inc(1));
    bar.finish_and_clear();
    for (k, st) in &r.attacks {
        if st.scenarios < st.requested {
            outln!("note: {k}: {} scenarios of the {} asked for: the data can host {} ({} drives)", st.scenarios, st.requested, st.capacity, st.hosting_drives);
        }
    }
    let files = eval::report::write_all(&r, out)?;
    outln!("{}", eval::report::headline(&r));
    outln!("Table 3 (scenarios in which each strategy fired):\n{}", eval::report::table3(&r));
    if let Some(p) = &r.predictors {
        outln!("Strategy 1 predictors:\n{}", eval::report::predictors(p, r.quantization.as_ref()));
    }
    outln!("wrote {} files under {} (report.json, report.md, figures/)", files.len(), out.display());
    Ok(r)
}
