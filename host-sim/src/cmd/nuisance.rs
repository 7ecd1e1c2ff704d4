//! `nuisance`: a clean drive transformed the way a new installation differs (not an attack).

use super::LoadArgs;
use gnss_data::nuisance::{Nuisance, NuisanceKind};
use host_sim::input;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// delay, speed-course-1hz, wheel-speed, gyro, rate-switch, jitter, outage, vehicle-late,
    /// coarse-steering, gnss-noise, combined
    #[arg(long, value_parser = parse_nuisance_kind, default_value = "combined")]
    kind: NuisanceKind,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// GNSS position this late, seconds (with any of these options, only what they say is applied).
    #[arg(long)]
    pos_delay_s: Option<f64>,
    /// GNSS speed and course this late, seconds.
    #[arg(long)]
    vel_delay_s: Option<f64>,
    /// Speed and course from a separate 1 Hz receiver this late, seconds.
    #[arg(long)]
    vel_1hz_lag_s: Option<f64>,
    /// Wheel speed times this, resampled at 2 Hz and rounded to 1 km/h.
    #[arg(long)]
    wheel_scale: Option<f64>,
    /// Gyro bias, deg/s.
    #[arg(long)]
    gyro_bias_degps: Option<f64>,
    /// Gyro scale.
    #[arg(long)]
    gyro_scale: Option<f64>,
    /// Fix rate switching between 10, 5 and 1 Hz every this many seconds.
    #[arg(long)]
    rate_switch_s: Option<f64>,
    /// Timestamp jitter, +- seconds.
    #[arg(long)]
    jitter_s: Option<f64>,
    /// A GNSS outage START:LENGTH (seconds after the drive's start); repeatable.
    #[arg(long, value_parser = parse_outage)]
    outage: Vec<(f64, f64)>,
    /// Every vehicle signal this late, seconds.
    #[arg(long)]
    vehicle_delay_s: Option<f64>,
    /// The steering angle in steps of this many degrees.
    #[arg(long)]
    steering_step_deg: Option<f64>,
    /// GNSS position noise TAU:SD (a Gauss-Markov process per axis: time constant, seconds;
    /// standard deviation, metres).
    #[arg(long, value_parser = parse_gnss_noise)]
    gnss_noise: Option<(f64, f64)>,
    path: PathBuf,
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    load: LoadArgs,
}

fn parse_nuisance_kind(s: &str) -> Result<NuisanceKind, String> {
    NuisanceKind::from_name(s).ok_or_else(|| format!("expected one of {:?}", NuisanceKind::ALL.map(NuisanceKind::name)))
}

fn parse_outage(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(':').ok_or("expected START:LENGTH in seconds")?;
    let (a, b) = (a.parse::<f64>().map_err(|e| e.to_string())?, b.parse::<f64>().map_err(|e| e.to_string())?);
    if a.is_finite() && b.is_finite() && a >= 0.0 && b > 0.0 { Ok((a, b)) } else { Err("expected START >= 0 and LENGTH > 0".into()) }
}

fn parse_gnss_noise(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(':').ok_or("expected TAU:SD (time constant, seconds; standard deviation, metres)")?;
    let (a, b) = (a.parse::<f64>().map_err(|e| e.to_string())?, b.parse::<f64>().map_err(|e| e.to_string())?);
    if a.is_finite() && b.is_finite() && a > 0.0 && b >= 0.0 { Ok((a, b)) } else { Err("expected TAU > 0 and SD >= 0".into()) }
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let r = input::load(&a.path, &a.load.options())?;
    let given = Nuisance {
        pos_delay_s: a.pos_delay_s,
        vel_delay_s: a.vel_delay_s,
        vel_1hz_lag_s: a.vel_1hz_lag_s,
        wheel_scale: a.wheel_scale,
        wheel_quantised: a.wheel_scale.is_some(),
        gyro_bias_degps: a.gyro_bias_degps,
        gyro_scale: a.gyro_scale,
        rate_switch_s: a.rate_switch_s,
        jitter_s: a.jitter_s,
        outages: a.outage,
        vehicle_delay_s: a.vehicle_delay_s,
        steering_step_deg: a.steering_step_deg,
        gnss_noise: a.gnss_noise,
    };
    let (t, n) = host_sim::transform::nuisance(&r, a.kind, a.seed, given, a.load.sync());
    host_sim::output::write_atomic(&a.out, |w| super::write_drive(&a.out, &t, None, w))?;
    eprintln!("wrote {}: {}", a.out.display(), n.describe());
    Ok(())
}
