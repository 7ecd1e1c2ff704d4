//! A simulated drive, so the demo runs on a machine without `../shared/data`.
//!
//! A kinematic vehicle (wheelbase 2.7 m, steering ratio 15) follows a seeded urban route of
//! straights (8 to 17 m/s), 90 degree turns (radius 12 to 25 m at 5 to 7 m/s) and stops (6 to 15 s),
//! with acceleration limited to 2 m/s^2. Sensors like the real drives: wheel speed, steering wheel
//! angle and yaw rate at 50 Hz, pedal at 20 Hz, with white noise (0.05 m/s, 1 deg, 0.3 deg/s,
//! 0.5 %); GNSS at 10 Hz or 1 Hz with a slowly wandering position error (random walk, bounded
//! to 2 m) plus 0.15 m white noise, speed noise 0.05 m/s and course noise 0.5 deg.
//! Everything it makes is labelled `simulated`.

use crate::input::{Event, Format, Replay};
use detector_core::geo::{from_local, wrap_360, LatLon, EARTH_RADIUS_PAPER_M};
use detector_core::sample::{Fix, Signal};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr_free::normal;
use std::path::Path;

const WHEELBASE_M: f64 = 2.7;
const STEER_RATIO: f64 = 15.0;
const ACCEL: f64 = 2.0;

enum Leg {
    Straight { len: f64, v: f64 },
    Turn { deg: f64, r: f64, v: f64 },
    Stop { secs: f64 },
}

/// Gaussian noise without another dependency: Box-Muller on the seeded generator.
mod rand_distr_free {
    use rand::Rng;
    pub fn normal(rng: &mut impl Rng, sigma: f64) -> f64 {
        let u1: f64 = rng.random_range(1e-12..1.0);
        let u2: f64 = rng.random_range(0.0..1.0);
        sigma * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

fn route(rng: &mut ChaCha8Rng, minutes: f64) -> Vec<Leg> {
    let mut legs = vec![Leg::Stop { secs: 8.0 }];
    let mut t = 0.0;
    while t < minutes * 60.0 {
        let v = rng.random_range(8.0..17.0);
        let len = rng.random_range(150.0..600.0);
        legs.push(Leg::Straight { len, v });
        t += len / v + 6.0;
        match rng.random_range(0..3) {
            0 => {
                let secs = rng.random_range(6.0..15.0);
                legs.push(Leg::Stop { secs });
                t += secs + 8.0;
            }
            _ => {
                let deg = if rng.random_bool(0.5) { 90.0 } else { -90.0 };
                let r = rng.random_range(12.0..25.0);
                legs.push(Leg::Turn { deg, r, v: rng.random_range(5.0..7.0) });
                t += r * 1.6 / 6.0 + 6.0;
            }
        }
    }
    legs.push(Leg::Straight { len: 200.0, v: 10.0 });
    legs.push(Leg::Stop { secs: 5.0 });
    legs
}

/// A simulated drive of about `minutes` with GNSS at `gnss_hz`.
pub fn drive(seed: u64, minutes: f64, gnss_hz: f64) -> Replay {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let legs = route(&mut rng, minutes);
    let origin = LatLon::new(48.137, 11.575);
    let dt = 0.01;
    let (mut e, mut n, mut heading, mut v, mut t) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut events = Vec::new();
    let (mut bias_e, mut bias_n) = (0.0, 0.0);
    let gnss_every = (1.0 / gnss_hz / dt).round() as u64;
    let mut step: u64 = 0;
    let mut emit = |rng: &mut ChaCha8Rng, t: f64, e: f64, n: f64, heading: f64, v: f64, a: f64, steer: f64, yaw: f64, be: &mut f64, bn: &mut f64, step: u64| {
        if step.is_multiple_of(2) {
            events.push(Event::Obs { sig: Signal::WheelSpeed, t, v: (v + normal(rng, 0.05)).max(0.0) as f32 });
            events.push(Event::Obs { sig: Signal::Steering, t, v: (steer + normal(rng, 1.0)) as f32 });
            events.push(Event::Obs { sig: Signal::YawRate, t, v: (yaw + normal(rng, 0.3)) as f32 });
        }
        if step.is_multiple_of(5) {
            let pedal = if a > -0.1 && v > 0.05 || a > 0.1 { (12.0 + 0.8 * v + 10.0 * a).clamp(0.0, 100.0) } else { 0.0 };
            events.push(Event::Obs { sig: Signal::Pedal, t, v: (pedal + normal(rng, 0.5)).max(0.0) as f32 });
        }
        if step.is_multiple_of(gnss_every) {
            *be = (*be + normal(rng, 0.02)).clamp(-2.0, 2.0);
            *bn = (*bn + normal(rng, 0.02)).clamp(-2.0, 2.0);
            let pe = e + *be + normal(rng, 0.15);
            let pn = n + *bn + normal(rng, 0.15);
            let course = if v > 0.5 { wrap_360(heading + normal(rng, 0.5)) } else { 0.0 };
            events.push(Event::Fix(Fix {
                t,
                pos: from_local(origin, pe, pn, EARTH_RADIUS_PAPER_M),
                speed_mps: Some((v + normal(rng, 0.05)).max(0.0) as f32),
                course_deg: Some(course as f32),
                h_acc_m: None,
                receiver_spoofing: false,
            }));
        }
    };
    for (i, leg) in legs.iter().enumerate() {
        let next_v = match legs.get(i + 1) {
            Some(Leg::Turn { v, .. }) => *v,
            Some(Leg::Stop { .. }) | None => 0.0,
            Some(Leg::Straight { v, .. }) => *v,
        };
        match *leg {
            Leg::Stop { secs } => {
                let end = t + secs;
                while t < end {
                    v = 0.0;
                    emit(&mut rng, t, e, n, heading, 0.0, 0.0, 0.0, 0.0, &mut bias_e, &mut bias_n, step);
                    t += dt;
                    step += 1;
                }
            }
            Leg::Straight { len, v: target } => {
                let mut done = 0.0;
                while done < len {
                    let brake = (v * v - next_v * next_v) / (2.0 * ACCEL) >= len - done;
                    let goal = if brake { next_v } else { target };
                    let a = ((goal - v) / dt).clamp(-ACCEL, ACCEL);
                    v = (v + a * dt).max(if next_v > 0.0 { 0.5 } else { 0.0 });
                    if v <= 0.0 && brake { break; }
                    e += v * dt * heading.to_radians().sin();
                    n += v * dt * heading.to_radians().cos();
                    done += v * dt;
                    emit(&mut rng, t, e, n, heading, v, a, 0.0, 0.0, &mut bias_e, &mut bias_n, step);
                    t += dt;
                    step += 1;
                }
            }
            Leg::Turn { deg, r, v: vt } => {
                // + deg = left = counter-clockwise: the bearing decreases.
                let mut turned = 0.0;
                let steer = deg.signum() * STEER_RATIO * (WHEELBASE_M / r).atan().to_degrees();
                while turned < deg.abs() {
                    v = vt;
                    let rate = (v / r).to_degrees();
                    heading = wrap_360(heading - deg.signum() * rate * dt);
                    turned += rate * dt;
                    e += v * dt * heading.to_radians().sin();
                    n += v * dt * heading.to_radians().cos();
                    emit(&mut rng, t, e, n, heading, v, 0.0, steer, deg.signum() * rate, &mut bias_e, &mut bias_n, step);
                    t += dt;
                    step += 1;
                }
            }
        }
    }
    Replay::new(Path::new(&format!("simulated/seed{seed}_{gnss_hz}hz")), Format::Simulated, events, 0)
}

/// The demo's simulated drives: one with a 10 Hz receiver, one with a 1 Hz logger.
pub fn demo_drives(seed: u64) -> Vec<Replay> {
    vec![drive(seed, 12.0, 10.0), drive(seed + 1, 12.0, 1.0)]
}
