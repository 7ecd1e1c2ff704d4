//! Nuisances: a clean real drive transformed the way a new installation differs from the ones
//! the detector was built on. None of it is an attack; a detector must stay silent on all of it.
//!
//! | kind | what changes | drawn from |
//! |---|---|---|
//! | `delay` | GNSS position and/or speed and course reported late | 0.2 to 1.5 s |
//! | `speed-course-1hz` | speed and course from a second, 1 Hz receiver that lags (position keeps its rate); it steps on the same GNSS second as the first, so on a 10 Hz drive its velocity is held for up to 0.9 s more | lag 0.5 to 1.8 s |
//! | `wheel-speed` | wheel speed scaled (tyre radius, calibration) and quantised to 1 km/h at 2 Hz (OBD) | -5 to +5 % |
//! | `gyro` | gyro bias and scale error | bias up to 0.5 deg/s, scale -5 to +5 % |
//! | `rate-switch` | the fix rate switching between 10, 5 and 1 Hz (10 Hz drives) | every 20 to 90 s |
//! | `jitter` | epoch timestamps jittered | +-50 ms |
//! | `outage` | GNSS silent | 1 to 30 s, up to 4 times |
//! | `vehicle-late` | every vehicle signal (wheel speed, steering, pedal, yaw rate, acceleration) reported late, as a logger that stamps CAN frames late or a slow gateway does (the sddi_commuter car: 0.5 to 1.2 s) | 0.2 to 1.5 s |
//! | `coarse-steering` | the steering angle in coarse steps (the sddi_commuter car: 2.88 deg) | 2.5 to 3.5 deg |
//! | `gnss-noise` | GNSS position error correlated in time, as in town (multipath, trees): a smooth, second-order Gauss-Markov process per axis, as a receiver's filtered solution wanders (its velocity error `sd / tau`); speed and course (Doppler) unchanged | time constant 5 to 30 s, 2 to 8 m |
//!
//! `combined` draws each of them with probability one half. Everything is a pure function of
//! the drive, the parameters and the seed; [`Nuisance`] says exactly what was applied, so one case
//! can be reproduced from the command line (`host-sim nuisance ...`).

use crate::input::{Event, Replay};
use detector_core::geo::{angle_diff_deg, from_local, wrap_360, LatLon, EARTH_RADIUS_PAPER_M};
use detector_core::sample::{Fix, Signal};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// The kinds of nuisance, each a named slice of the suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum NuisanceKind {
    Delay,
    SpeedCourse1Hz,
    WheelSpeed,
    Gyro,
    RateSwitch,
    Jitter,
    Outage,
    VehicleLate,
    CoarseSteering,
    GnssNoise,
    /// Each of the above with probability one half.
    Combined,
}

impl NuisanceKind {
    pub const ALL: [NuisanceKind; 11] = [
        NuisanceKind::Delay,
        NuisanceKind::SpeedCourse1Hz,
        NuisanceKind::WheelSpeed,
        NuisanceKind::Gyro,
        NuisanceKind::RateSwitch,
        NuisanceKind::Jitter,
        NuisanceKind::Outage,
        NuisanceKind::VehicleLate,
        NuisanceKind::CoarseSteering,
        NuisanceKind::GnssNoise,
        NuisanceKind::Combined,
    ];
    pub fn name(self) -> &'static str {
        match self {
            NuisanceKind::Delay => "delay",
            NuisanceKind::SpeedCourse1Hz => "speed-course-1hz",
            NuisanceKind::WheelSpeed => "wheel-speed",
            NuisanceKind::Gyro => "gyro",
            NuisanceKind::RateSwitch => "rate-switch",
            NuisanceKind::Jitter => "jitter",
            NuisanceKind::Outage => "outage",
            NuisanceKind::VehicleLate => "vehicle-late",
            NuisanceKind::CoarseSteering => "coarse-steering",
            NuisanceKind::GnssNoise => "gnss-noise",
            NuisanceKind::Combined => "combined",
        }
    }
    pub fn from_name(s: &str) -> Option<NuisanceKind> {
        NuisanceKind::ALL.into_iter().find(|k| k.name() == s)
    }
}

/// What a nuisance does; `None` (or empty) leaves that part of the drive as it is.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Nuisance {
    /// GNSS position reported this late, seconds.
    pub pos_delay_s: Option<f64>,
    /// GNSS speed and course reported this late, seconds.
    pub vel_delay_s: Option<f64>,
    /// Speed and course from a second receiver at 1 Hz, lagging by this much, seconds.
    pub vel_1hz_lag_s: Option<f64>,
    /// Wheel speed times this.
    pub wheel_scale: Option<f64>,
    /// Wheel speed resampled at 2 Hz and rounded to 1 km/h.
    pub wheel_quantised: bool,
    /// Gyro bias, deg/s, and scale.
    pub gyro_bias_degps: Option<f64>,
    pub gyro_scale: Option<f64>,
    /// The fix rate switches between 10, 5 and 1 Hz every this many seconds.
    pub rate_switch_s: Option<f64>,
    /// Fix timestamps moved by up to +- this, seconds.
    pub jitter_s: Option<f64>,
    /// GNSS outages: (start, length), seconds after the drive's first event.
    pub outages: Vec<(f64, f64)>,
    /// Every vehicle signal reported this late, seconds.
    pub vehicle_delay_s: Option<f64>,
    /// The steering angle rounded to steps of this many degrees.
    pub steering_step_deg: Option<f64>,
    /// GNSS position error: a Gauss-Markov process per axis of this time constant, seconds, and
    /// standard deviation, metres.
    pub gnss_noise: Option<(f64, f64)>,
}

impl Nuisance {
    /// A nuisance of `kind` with parameters drawn from `seed` for a drive of `duration_s`
    /// whose receiver runs at `gnss_hz`.
    pub fn draw(kind: NuisanceKind, seed: u64, duration_s: f64, gnss_hz: f64) -> Nuisance {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6e75_6973_616e_6365);
        let mut n = Nuisance::default();
        let pick = |k: NuisanceKind, rng: &mut ChaCha8Rng| kind == k || (kind == NuisanceKind::Combined && rng.random_bool(0.5));
        if pick(NuisanceKind::Delay, &mut rng) {
            // Position, speed and course, or only one of them, late.
            match rng.random_range(0..3) {
                0 => n.pos_delay_s = Some(rng.random_range(0.2..1.5)),
                1 => n.vel_delay_s = Some(rng.random_range(0.2..1.5)),
                _ => {
                    let d = rng.random_range(0.2..1.5);
                    (n.pos_delay_s, n.vel_delay_s) = (Some(d), Some(d));
                }
            }
        }
        if pick(NuisanceKind::SpeedCourse1Hz, &mut rng) {
            n.vel_1hz_lag_s = Some(rng.random_range(0.5..1.8));
        }
        if pick(NuisanceKind::WheelSpeed, &mut rng) {
            n.wheel_scale = Some(rng.random_range(0.95..1.05));
            n.wheel_quantised = true;
        }
        if pick(NuisanceKind::Gyro, &mut rng) {
            n.gyro_bias_degps = Some(rng.random_range(-0.5..0.5));
            n.gyro_scale = Some(rng.random_range(0.95..1.05));
        }
        if pick(NuisanceKind::RateSwitch, &mut rng) && gnss_hz >= 5.0 {
            n.rate_switch_s = Some(rng.random_range(20.0..90.0));
        }
        if pick(NuisanceKind::Jitter, &mut rng) {
            n.jitter_s = Some(0.05);
        }
        // Drawn after the older kinds, so their draws (and every older case) are unchanged.
        let outage = pick(NuisanceKind::Outage, &mut rng);
        if pick(NuisanceKind::VehicleLate, &mut rng) {
            n.vehicle_delay_s = Some(rng.random_range(0.2..1.5));
        }
        if pick(NuisanceKind::CoarseSteering, &mut rng) {
            n.steering_step_deg = Some(rng.random_range(2.5..3.5));
        }
        if pick(NuisanceKind::GnssNoise, &mut rng) {
            n.gnss_noise = Some((rng.random_range(5.0..30.0), rng.random_range(2.0..8.0)));
        }
        if outage && duration_s > 40.0 {
            for _ in 0..rng.random_range(1..=4) {
                let len = rng.random_range(1.0..30.0f64).min(duration_s / 4.0);
                n.outages.push((rng.random_range(5.0..(duration_s - len).max(6.0)), len));
            }
            n.outages.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        n
    }

    /// One line saying what is applied.
    pub fn describe(&self) -> String {
        let mut p = Vec::new();
        if let Some(d) = self.pos_delay_s {
            p.push(format!("position {d:.2} s late"));
        }
        if let Some(d) = self.vel_delay_s {
            p.push(format!("speed and course {d:.2} s late"));
        }
        if let Some(d) = self.vel_1hz_lag_s {
            p.push(format!("speed and course from a 1 Hz receiver {d:.2} s late"));
        }
        if let Some(s) = self.wheel_scale {
            p.push(format!("wheel speed x{s:.3}{}", if self.wheel_quantised { ", 1 km/h at 2 Hz" } else { "" }));
        }
        if self.gyro_bias_degps.is_some() || self.gyro_scale.is_some() {
            p.push(format!("gyro bias {:+.2} deg/s scale x{:.3}", self.gyro_bias_degps.unwrap_or(0.0), self.gyro_scale.unwrap_or(1.0)));
        }
        if let Some(s) = self.rate_switch_s {
            p.push(format!("fix rate switching among 10/5/1 Hz every {s:.0} s"));
        }
        if let Some(j) = self.jitter_s {
            p.push(format!("timestamps +-{:.0} ms", j * 1000.0));
        }
        for (a, l) in &self.outages {
            p.push(format!("outage {l:.1} s at {a:.0} s"));
        }
        if let Some(d) = self.vehicle_delay_s {
            p.push(format!("vehicle signals {d:.2} s late"));
        }
        if let Some(q) = self.steering_step_deg {
            p.push(format!("steering in {q:.2} deg steps"));
        }
        if let Some((tau, sd)) = self.gnss_noise {
            p.push(format!("GNSS position noise {sd:.1} m correlated over {tau:.0} s"));
        }
        if p.is_empty() { "nothing".into() } else { p.join("; ") }
    }
}

/// The receiver's track, interpolated at any time (positions linearly, courses by the shorter way).
struct Track<'a> {
    fixes: &'a [Fix],
}

impl Track<'_> {
    fn around(&self, t: f64) -> (usize, usize, f64) {
        let j = self.fixes.partition_point(|f| f.t <= t);
        let (a, b) = (j.saturating_sub(1), j.min(self.fixes.len() - 1));
        let (fa, fb) = (self.fixes[a], self.fixes[b]);
        let w = if fb.t > fa.t { ((t - fa.t) / (fb.t - fa.t)).clamp(0.0, 1.0) } else { 0.0 };
        (a, b, w)
    }
    fn pos(&self, t: f64) -> LatLon {
        let (a, b, w) = self.around(t);
        let (pa, pb) = (self.fixes[a].pos, self.fixes[b].pos);
        LatLon::new(pa.lat_deg + (pb.lat_deg - pa.lat_deg) * w, pa.lon_deg + (pb.lon_deg - pa.lon_deg) * w)
    }
    fn vel(&self, t: f64) -> (Option<f32>, Option<f32>) {
        let (a, b, w) = self.around(t);
        let (fa, fb) = (self.fixes[a], self.fixes[b]);
        let speed = match (fa.speed_mps, fb.speed_mps) {
            (Some(x), Some(y)) => Some(x + (y - x) * w as f32),
            (x, y) => x.or(y),
        };
        let course = match (fa.course_deg, fb.course_deg) {
            (Some(x), Some(y)) => Some(wrap_360(x as f64 + angle_diff_deg(x as f64, y as f64) * w) as f32),
            (x, y) => x.or(y),
        };
        (speed, course)
    }
}

/// One step of `h` seconds of a second-order (critically damped) Gauss-Markov process per axis,
/// `(position, velocity)`: correlation time `tau`, position standard deviation `sd`, velocity
/// standard deviation `sd / tau`. Smooth, as a receiver's filtered position error is (a
/// first-order process would jump by metres from one fix to the next). Euler-Maruyama.
fn gm2_step((x, v): (f64, f64), tau: f64, sd: f64, h: f64, rng: &mut ChaCha8Rng) -> (f64, f64) {
    let w = 1.0 / tau;
    // Stationary var(x) = q^2 / (4 w^3).
    let q = sd * (4.0 * w * w * w).sqrt();
    let a = -w * w * x - 2.0 * w * v;
    (x + v * h, v + a * h + q * h.sqrt() * gauss(rng))
}

/// A standard normal draw (Box-Muller).
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(1e-12..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// The drive with the nuisance applied (`seed` draws the rate segments, the jitter and the
/// position noise).
pub fn apply(r: &Replay, n: &Nuisance, seed: u64) -> Replay {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0061_7070_6c79);
    let fixes: Vec<Fix> = r.fixes().copied().collect();
    let t0 = r.events.first().map_or(0.0, |e| e.t());
    let mut events: Vec<Event> = Vec::with_capacity(r.events.len());
    if !fixes.is_empty() {
        let track = Track { fixes: &fixes };
        let mut rate_until = f64::NEG_INFINITY;
        let mut period = 0.0f64;
        let mut last_kept = f64::NEG_INFINITY;
        let mut last_t = f64::NEG_INFINITY;
        let (mut gm, mut gm_t) = ([(0.0f64, 0.0f64); 2], f64::NEG_INFINITY);
        // A second receiver's epochs: once a second on the same GNSS time as the first
        // receiver's fixes (both receivers step on the GNSS second), so every 1 Hz fix or every
        // tenth 10 Hz one, not whole seconds of the logger's clock: that clock drifts against
        // GNSS time (css_canedge: 0.1 s in 45 minutes), and a fix stamped 180.9999999 s is the
        // same epoch as one stamped 181.0 s.
        let second: Vec<f64> = fixes.iter().map(|f| f.t).fold(Vec::new(), |mut v, t| {
            if v.last().is_none_or(|&l| t - l >= 0.95) {
                v.push(t);
            }
            v
        });
        for f in &fixes {
            if n.outages.iter().any(|&(a, l)| (t0 + a..t0 + a + l).contains(&f.t)) {
                continue;
            }
            if let Some(s) = n.rate_switch_s {
                if f.t >= rate_until {
                    period = [0.1, 0.2, 1.0][rng.random_range(0..3)];
                    rate_until = f.t + s;
                }
                if f.t < last_kept + period - 0.02 {
                    continue;
                }
            }
            // A receiver that reports late has nothing to report before its first late epoch
            // (the track is not extrapolated back past the drive's first fix).
            let first = fixes[0].t;
            let late = n.pos_delay_s.into_iter().chain(n.vel_delay_s).chain(n.vel_1hz_lag_s.map(|l| l + 1.0)).fold(0.0f64, f64::max);
            if f.t - late < first {
                continue;
            }
            last_kept = f.t;
            let mut g = *f;
            if let Some(d) = n.pos_delay_s {
                g.pos = track.pos(f.t - d);
            }
            if let Some(d) = n.vel_delay_s {
                (g.speed_mps, g.course_deg) = track.vel(f.t - d);
            }
            if let Some(lag) = n.vel_1hz_lag_s {
                // The second receiver's latest epoch reports the velocity of `lag` before it.
                let k = second.partition_point(|&e| e <= f.t + 1e-6).checked_sub(1).and_then(|i| second.get(i)).copied().unwrap_or(f.t);
                (g.speed_mps, g.course_deg) = track.vel(k - lag);
            }
            if let Some((tau, sd)) = n.gnss_noise {
                if !gm_t.is_finite() {
                    // Start in the stationary state.
                    gm = [(sd * gauss(&mut rng), sd / tau * gauss(&mut rng)), (sd * gauss(&mut rng), sd / tau * gauss(&mut rng))];
                    gm_t = f.t;
                }
                while gm_t < f.t {
                    let h = (f.t - gm_t).min(0.05);
                    for axis in gm.iter_mut() {
                        *axis = gm2_step(*axis, tau, sd, h, &mut rng);
                    }
                    gm_t += h;
                }
                g.pos = from_local(g.pos, gm[0].0, gm[1].0, EARTH_RADIUS_PAPER_M);
            }
            if let Some(j) = n.jitter_s {
                g.t = (f.t + rng.random_range(-j..j)).max(last_t + 1e-3);
            }
            last_t = g.t;
            events.push(Event::Fix(g));
        }
    }
    // Vehicle signals: scaled, biased, quantised, then reported late.
    let late = n.vehicle_delay_s.unwrap_or(0.0);
    let wheel: Vec<(f64, f32)> = r.events.iter().filter_map(|e| match *e {
        Event::Obs { sig: Signal::WheelSpeed, t, v } => Some((t, v)),
        _ => None,
    }).collect();
    for e in &r.events {
        let Event::Obs { sig, t, v } = *e else { continue };
        let v = match sig {
            Signal::WheelSpeed if n.wheel_quantised => continue,
            Signal::WheelSpeed => v * n.wheel_scale.unwrap_or(1.0) as f32,
            Signal::YawRate => v * n.gyro_scale.unwrap_or(1.0) as f32 + n.gyro_bias_degps.unwrap_or(0.0) as f32,
            Signal::Steering => match n.steering_step_deg {
                Some(q) => ((v as f64 / q).round() * q) as f32,
                None => v,
            },
            _ => v,
        };
        events.push(Event::Obs { sig, t: t + late, v });
    }
    if n.wheel_quantised && wheel.len() >= 2 {
        // An OBD speed: sampled at 2 Hz where the wheel speed was seen within 1 s, scaled,
        // rounded to whole km/h.
        let step = 1.0 / 3.6;
        let (a, b) = (wheel[0].0, wheel[wheel.len() - 1].0);
        let mut t = a;
        while t <= b {
            let j = wheel.partition_point(|w| w.0 <= t);
            let (pa, pb) = (wheel[j.saturating_sub(1)], wheel[j.min(wheel.len() - 1)]);
            if t - pa.0 <= 1.0 && pb.0 - t <= 1.0 {
                let w = if pb.0 > pa.0 { ((t - pa.0) / (pb.0 - pa.0)) as f32 } else { 0.0 };
                let v = (pa.1 + (pb.1 - pa.1) * w) * n.wheel_scale.unwrap_or(1.0) as f32;
                events.push(Event::Obs { sig: Signal::WheelSpeed, t: t + late, v: (v / step).round() * step });
            }
            t += 0.5;
        }
    }
    Replay::new(&r.path, r.format, events, r.skipped_rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Format;

    fn drive() -> Replay {
        let mut ev = Vec::new();
        for k in 0..600 {
            let t = k as f64 * 0.1;
            ev.push(Event::Fix(Fix { t, pos: LatLon::new(48.0 + t * 1e-4, 11.0), speed_mps: Some(11.1), course_deg: Some(0.0), h_acc_m: None, receiver_spoofing: false }));
            ev.push(Event::Obs { sig: Signal::WheelSpeed, t: t + 0.05, v: 11.0 });
            ev.push(Event::Obs { sig: Signal::YawRate, t: t + 0.05, v: 0.0 });
        }
        Replay::new(std::path::Path::new("x.csv"), Format::DriveCsv, ev, 0)
    }

    #[test]
    fn each_kind_changes_what_it_says_and_nothing_else() {
        let r = drive();
        let fixes = |r: &Replay| r.fixes().copied().collect::<Vec<_>>();
        // Position 1 s late: 11 m behind (1e-4 deg lat per s), times unchanged; the first
        // second has no late fix to report.
        let d = apply(&r, &Nuisance { pos_delay_s: Some(1.0), ..Default::default() }, 1);
        let (a, b) = (fixes(&r), fixes(&d));
        assert_eq!(a.len(), b.len() + 10);
        assert!((b[290].pos.lat_deg - a[290].pos.lat_deg).abs() < 1e-9 && b[290].t == a[300].t);
        assert_eq!(b[0].t, a[10].t);
        // Outage 10 s: 100 fixes fewer.
        let o = apply(&r, &Nuisance { outages: vec![(20.0, 10.0)], ..Default::default() }, 1);
        assert_eq!(fixes(&o).len(), 500);
        // Rate switching never keeps fixes closer than the period.
        let s = apply(&r, &Nuisance { rate_switch_s: Some(20.0), ..Default::default() }, 3);
        assert!(fixes(&s).len() < 600 && fixes(&s).windows(2).all(|w| w[1].t - w[0].t > 0.07));
        // Wheel speed at 2 Hz in whole km/h, scaled.
        let w = apply(&r, &Nuisance { wheel_scale: Some(1.05), wheel_quantised: true, ..Default::default() }, 1);
        let ws: Vec<f32> = w.events.iter().filter_map(|e| match e { Event::Obs { sig: Signal::WheelSpeed, v, .. } => Some(*v), _ => None }).collect();
        assert!(ws.len() > 100 && ws.len() < 130);
        assert!(ws.iter().all(|v| ((v * 3.6) - (v * 3.6).round()).abs() < 1e-3 && (v * 3.6 - 42.0).abs() < 1e-3));
        // Gyro bias.
        let g = apply(&r, &Nuisance { gyro_bias_degps: Some(0.5), gyro_scale: Some(1.05), ..Default::default() }, 1);
        assert!(g.events.iter().all(|e| !matches!(e, Event::Obs { sig: Signal::YawRate, v, .. } if (*v - 0.5).abs() > 1e-6)));
        // Nothing is nothing.
        assert_eq!(apply(&r, &Nuisance::default(), 1).events, r.events);
    }

    /// A drive whose reported speed ramps at 0.1 m/s^2 from 5 m/s (so a velocity's age is
    /// `(speed - 5) / 0.1` after its fix), fixes every `dt` seconds of GNSS time stamped by a
    /// logger whose clock starts 1e-7 s short of it and runs 1e-4 slow.
    fn ramp(dt: f64, n: usize) -> Replay {
        let mut ev = Vec::new();
        for k in 0..n {
            let t = (k as f64 * dt * (1.0 + 1e-4) - 1e-7).max(0.0);
            ev.push(Event::Fix(Fix { t, pos: LatLon::new(48.0 + t * 1e-4, 11.0), speed_mps: Some(5.0 + 0.1 * t as f32), course_deg: Some(0.0), h_acc_m: None, receiver_spoofing: false }));
            ev.push(Event::Obs { sig: Signal::WheelSpeed, t: t + 0.05, v: 5.0 });
        }
        Replay::new(std::path::Path::new("x.csv"), Format::DriveCsv, ev, 0)
    }

    /// A second 1 Hz receiver steps on the same GNSS second as the first: beside a 1 Hz
    /// receiver on a logger whose clock drifts against GNSS time (css_canedge's: 0.1 s in 45
    /// minutes, fixes stamped 180.9999999 s, then 181.0 s, then 181.1 s) its velocity is `lag`
    /// late at every fix, never a second more where a stamp falls just short of a whole second
    /// of the logger's clock; beside a 10 Hz receiver it is held, `lag` to `lag` + 0.9 s late.
    #[test]
    fn a_second_receivers_lag_does_not_step_with_the_loggers_clock() {
        let lag = 1.3;
        let ages = |r: &Replay| -> Vec<f64> {
            let d = apply(r, &Nuisance { vel_1hz_lag_s: Some(lag), ..Default::default() }, 1);
            d.fixes().map(|f| f.t - (f.speed_mps.unwrap_or(0.0) as f64 - 5.0) / 0.1).collect()
        };
        let one = ages(&ramp(1.0, 300));
        assert!(one.len() > 290);
        for (i, a) in one.iter().enumerate() {
            assert!((a - lag).abs() < 1e-3, "fix {i}: the velocity is {a:.3} s late, not {lag} s");
        }
        let ten = ages(&ramp(0.1, 3000));
        assert!(ten.len() > 2900 && ten.iter().all(|a| *a > lag - 1e-3 && *a < lag + 0.9 + 2e-3));
        assert!(ten.iter().any(|a| *a < lag + 0.01) && ten.iter().any(|a| *a > lag + 0.89));
    }

    #[test]
    fn draws_are_reproducible_and_named() {
        for k in NuisanceKind::ALL {
            assert_eq!(NuisanceKind::from_name(k.name()), Some(k));
            assert_eq!(Nuisance::draw(k, 7, 600.0, 10.0), Nuisance::draw(k, 7, 600.0, 10.0));
        }
        assert!(!Nuisance::draw(NuisanceKind::Outage, 1, 600.0, 1.0).outages.is_empty());
        assert!(Nuisance::draw(NuisanceKind::RateSwitch, 1, 600.0, 1.0).rate_switch_s.is_none(), "1 Hz drives cannot switch up");
    }
}
