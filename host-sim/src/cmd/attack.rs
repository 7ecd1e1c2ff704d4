//! `attack`: an attacked copy of a drive, with its ground truth.

use super::{write_drive, LoadArgs};
use host_sim::attack::{self, AttackKind};
use host_sim::input::{self, InputError};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// turn-by-turn, overshoot, stop, wrong-turn, slow-drift, small-biased, direction, replay, jump
    #[arg(long, value_parser = parse_attack_kind)]
    kind: AttackKind,
    #[command(flatten)]
    params: AttackArgs,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Onset time, seconds on the drive's clock (default: drawn from the seed among the times
    /// where the attack makes sense).
    #[arg(long)]
    onset: Option<f64>,
    path: PathBuf,
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    load: LoadArgs,
}

/// Attack parameters fixed instead of drawn from the seed.
#[derive(clap::Args, Clone, Debug, Default)]
struct AttackArgs {
    /// turn-by-turn, jump: the offset, metres.
    #[arg(long)]
    offset_m: Option<f64>,
    /// turn-by-turn, jump: the offset's bearing, degrees.
    #[arg(long)]
    bearing_deg: Option<f64>,
    /// stop: the spoofed speed, m/s.
    #[arg(long)]
    speed_mps: Option<f64>,
    /// slow-drift: the rate, m/s.
    #[arg(long)]
    rate_mps: Option<f64>,
    /// slow-drift: across the road (else along it).
    #[arg(long)]
    across: Option<bool>,
    /// small-biased: the step per epoch, metres.
    #[arg(long)]
    step_m: Option<f64>,
    /// direction: the rotation rate, deg/s (+ = clockwise).
    #[arg(long, allow_hyphen_values = true)]
    deg_per_s: Option<f64>,
    /// replay: the delay, seconds.
    #[arg(long)]
    delay_s: Option<f64>,
    /// wrong-turn on a straight road: turn right (else left).
    #[arg(long)]
    right: Option<bool>,
}

impl AttackArgs {
    fn params(&self) -> attack::AttackParams {
        attack::AttackParams {
            offset_m: self.offset_m,
            bearing_deg: self.bearing_deg,
            speed_mps: self.speed_mps,
            rate_mps: self.rate_mps,
            across: self.across,
            step_m: self.step_m,
            deg_per_s: self.deg_per_s,
            delay_s: self.delay_s,
            right: self.right,
        }
    }
}

fn parse_attack_kind(s: &str) -> Result<AttackKind, String> {
    AttackKind::from_name(s).ok_or_else(|| format!("expected one of {:?}", AttackKind::ALL.map(AttackKind::name)))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let r = input::load(&a.path, &a.load.options())?;
    let at = host_sim::transform::attack(&r, a.kind, a.seed, a.onset, &a.params.params(), a.load.sync()).map_err(|e| InputError::file(&a.path, e))?;
    let onset = at.spec.onset_t;
    host_sim::output::write_atomic(&a.out, |w| write_drive(&a.out, &at.replay, Some(onset), w))?;
    eprintln!("wrote {}: {} from t={onset:.2} s ({})", a.out.display(), a.kind.name(), at.spec.params);
    Ok(())
}
