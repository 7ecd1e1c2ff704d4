//! A random-walk drive for long-horizon tests and fuzzing.
//!
//! The property tests (`tests/tests/long_horizon.rs`) and the `long_horizon` fuzz target drive
//! every strategy and the whole detector for tens of thousands of epochs, so that states which
//! take minutes of driving to build are reached: a wheel held in a long bend before a turn (the
//! bug of issue #14 needed 16 s of it), a gyro bias learnt over minutes, a heading bridged with
//! the gyro across a long stop, learnt state kept across GNSS gaps, windows full for hours,
//! fix-rate changes between 10, 5, 2 and 1 Hz, time jumping either way, and sensor faults.
//!
//! A walk is a *program* of legs (what happens, and for how many epochs), cycled until the
//! horizon is reached. All parameters and noise come from a SplitMix64 generator seeded by the
//! program, so a walk is a pure function of its bytes (or of its seed).

use detector_core::geo::{destination, haversine_m, wrap_360, LatLon, EARTH_RADIUS_PAPER_M};
use detector_core::sample::{Fix, Reading, Sample, Signal};

const R: f64 = EARTH_RADIUS_PAPER_M;
const WHEELBASE_M: f64 = 2.7;
const STEER_RATIO: f64 = 15.0;

/// What happens during a leg of the walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leg {
    /// Straight-ish driving, the wheel wandering within +-10 deg.
    Cruise,
    /// The wheel held between 22 and 58 deg (a long bend, a loop ramp), then a sharp turn.
    Bend,
    /// A turn: the wheel to 90..450 deg and back.
    Turn,
    /// Braking to a standstill and standing (the wheel may turn while standing).
    Stop,
    /// Accelerating to 25..35 m/s.
    Accelerate,
    /// The receiver silent (tunnel, jamming); the vehicle signals go on.
    GnssGap,
    /// The receiver switches to another fix rate (10, 5, 2 or 1 Hz).
    RateChange,
    /// Sensor faults: NaN, infinities, stale and missing readings, a stuck steering sensor,
    /// duplicated timestamps, garbage positions.
    Faults,
    /// The reported position spoofed: a jump, or a drift growing every epoch.
    Spoof,
    /// Time jumps back (a clock reset) or far forward, once.
    TimeJump,
}

impl Leg {
    pub const ALL: [Leg; 10] = [
        Leg::Cruise,
        Leg::Bend,
        Leg::Turn,
        Leg::Stop,
        Leg::Accelerate,
        Leg::GnssGap,
        Leg::RateChange,
        Leg::Faults,
        Leg::Spoof,
        Leg::TimeJump,
    ];
}

/// SplitMix64: small, fast, and good enough for test data.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    /// Roughly normal (sum of four uniforms), standard deviation `sd`.
    pub fn noise(&mut self, sd: f64) -> f64 {
        (self.unit() + self.unit() + self.unit() + self.unit() - 2.0) * sd * 1.732
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    pub fn sign(&mut self) -> f64 {
        if self.chance(0.5) { 1.0 } else { -1.0 }
    }
}

/// One epoch of the walk: the synchronised sample a detector sees directly, and the raw events
/// (the fix and the vehicle observations since the previous epoch) for the synchroniser path.
#[derive(Clone, Debug, Default)]
pub struct Epoch {
    /// `None` while the receiver is silent.
    pub sample: Option<Sample>,
    pub fix: Option<Fix>,
    /// Vehicle observations since the previous epoch, in time order: (signal, t, value).
    pub obs: Vec<(Signal, f64, f32)>,
}

/// What the walk has generated so far (so tests can check the long states were reached).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Coverage {
    pub epochs: usize,
    pub samples: usize,
    pub seconds: f64,
    /// The longest stretch with the wheel held between 20 and 60 deg while moving, seconds.
    pub longest_bend_s: f64,
    /// Turns (the wheel beyond 90 deg while moving).
    pub turns: usize,
    /// The longest standstill, seconds.
    pub longest_stop_s: f64,
    /// GNSS gaps up to 60 s and longer ones.
    pub short_gaps: usize,
    pub long_gaps: usize,
    pub rate_changes: usize,
    pub time_jumps_back: usize,
    pub fault_epochs: usize,
    pub spoofed_epochs: usize,
}

/// The walk. See the module documentation.
#[derive(Clone, Debug)]
pub struct Walk {
    program: Vec<(Leg, u32)>,
    pc: usize,
    left: u32,
    leg: Leg,
    leg_epochs: u32,
    rng: Rng,
    t: f64,
    dt: f64,
    pos: LatLon,
    heading: f64,
    v: f64,
    v_target: f64,
    steer: f64,
    steer_target: f64,
    gyro_bias: f64,
    wheel_scale: f64,
    gnss_err: (f64, f64),
    spoof: (f64, f64),
    spoof_rate: (f64, f64),
    stuck: Option<f32>,
    prev_fix: Option<(f64, LatLon)>,
    /// The previous sample's signals (the integrals since it).
    prev_signals: Option<[Reading; Signal::COUNT]>,
    last_obs_t: f64,
    bend_s: f64,
    stop_s: f64,
    gap_s: f64,
    pub coverage: Coverage,
}

impl Walk {
    /// A walk from a program: each pair of bytes is a leg (`b0 % 10`) and its length
    /// (`(b1 + 1) * 4` epochs); the program is cycled. The bytes also seed the noise.
    pub fn from_bytes(data: &[u8]) -> Self {
        let mut program: Vec<(Leg, u32)> = data
            .chunks(2)
            .map(|c| (Leg::ALL[c[0] as usize % Leg::ALL.len()], (c.get(1).copied().unwrap_or(0) as u32 + 1) * 4))
            .collect();
        if program.is_empty() {
            program.push((Leg::Cruise, 100));
        }
        let seed = data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3));
        Self::new(program, seed)
    }

    /// A walk of 64 legs drawn from a seed, every leg kind among them.
    pub fn from_seed(seed: u64) -> Self {
        let mut rng = Rng::new(seed ^ 0x5eed);
        let mut program: Vec<(Leg, u32)> = Leg::ALL.iter().map(|&l| (l, 0)).collect();
        while program.len() < 64 {
            program.push((Leg::ALL[(rng.next_u64() % Leg::ALL.len() as u64) as usize], 0));
        }
        for p in program.iter_mut() {
            const LENGTHS: [u32; 6] = [20, 60, 150, 300, 600, 1200];
            p.1 = LENGTHS[(rng.next_u64() % LENGTHS.len() as u64) as usize];
        }
        // Shuffle (Fisher-Yates), keeping a cruise first so the detectors warm up.
        for i in (2..program.len()).rev() {
            let j = 1 + (rng.next_u64() % i as u64) as usize;
            program.swap(i, j);
        }
        program[0] = (Leg::Cruise, 400);
        Self::new(program, seed)
    }

    fn new(program: Vec<(Leg, u32)>, seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let (leg, left) = program[0];
        let lat = rng.range(-60.0, 60.0);
        let lon = rng.range(-179.0, 179.0);
        Walk {
            program,
            pc: 0,
            left,
            leg,
            leg_epochs: 0,
            t: rng.range(0.0, 1.7e9),
            dt: 0.1,
            pos: LatLon::new(lat, lon),
            heading: rng.range(0.0, 360.0),
            v: 10.0,
            v_target: 15.0,
            steer: 0.0,
            steer_target: 0.0,
            gyro_bias: rng.noise(0.4),
            wheel_scale: 1.0 + rng.noise(0.02),
            gnss_err: (0.0, 0.0),
            spoof: (0.0, 0.0),
            spoof_rate: (0.0, 0.0),
            stuck: None,
            prev_fix: None,
            prev_signals: None,
            last_obs_t: f64::NAN,
            bend_s: 0.0,
            stop_s: 0.0,
            gap_s: 0.0,
            rng,
            coverage: Coverage::default(),
        }
    }

    fn start_leg(&mut self) {
        self.leg_epochs = 0;
        let r = &mut self.rng;
        match self.leg {
            Leg::Cruise => self.v_target = r.range(8.0, 30.0),
            Leg::Bend => self.steer_target = r.sign() * r.range(22.0, 58.0),
            Leg::Turn => {
                self.steer_target = r.sign() * r.range(90.0, 450.0);
                self.v_target = r.range(4.0, 10.0);
            }
            Leg::Stop => self.v_target = 0.0,
            Leg::Accelerate => self.v_target = r.range(25.0, 35.0),
            Leg::RateChange => {
                self.dt = [0.1, 0.2, 0.5, 1.0][(r.next_u64() % 4) as usize];
                self.coverage.rate_changes += 1;
            }
            Leg::Spoof => {
                if r.chance(0.5) {
                    let (b, d) = (r.range(0.0, 360.0_f64).to_radians(), r.range(20.0, 800.0));
                    self.spoof = (self.spoof.0 + d * b.sin(), self.spoof.1 + d * b.cos());
                    self.spoof_rate = (0.0, 0.0);
                } else {
                    let (b, w) = (r.range(0.0, 360.0_f64).to_radians(), r.range(0.05, 5.0));
                    self.spoof_rate = (w * b.sin(), w * b.cos());
                }
            }
            Leg::TimeJump => {
                if r.chance(0.5) {
                    self.t -= r.range(1.0, 2000.0);
                    self.coverage.time_jumps_back += 1;
                } else {
                    self.t += r.range(4.0, 5000.0);
                }
            }
            Leg::GnssGap | Leg::Faults => {}
        }
    }

    /// The next epoch.
    pub fn next_epoch(&mut self) -> Epoch {
        if self.left == 0 {
            if self.leg == Leg::GnssGap {
                if self.gap_s <= 60.0 { self.coverage.short_gaps += 1 } else { self.coverage.long_gaps += 1 }
                self.gap_s = 0.0;
            }
            if self.leg == Leg::Spoof && self.rng.chance(0.5) {
                self.spoof = (0.0, 0.0);
                self.spoof_rate = (0.0, 0.0);
            }
            self.pc = (self.pc + 1) % self.program.len();
            (self.leg, self.left) = self.program[self.pc];
            self.left = self.left.max(1);
            // A stuck steering sensor recovers when the faults end.
            self.stuck = None;
            self.start_leg();
        }
        self.left -= 1;
        self.leg_epochs += 1;
        let dt = self.dt * (1.0 + self.rng.noise(0.01));
        let t0 = self.t;
        self.t += dt;
        self.coverage.epochs += 1;
        self.coverage.seconds += dt;

        // Driver: the wheel and the speed move toward their targets.
        let r = &mut self.rng;
        match self.leg {
            Leg::Cruise if r.chance(0.05) => self.steer_target = r.noise(6.0).clamp(-10.0, 10.0),
            // The last 40 epochs of a long bend: a sharp turn the same way.
            Leg::Bend if self.left == 40 && self.leg_epochs > 40 => self.steer_target = self.steer_target.signum() * r.range(90.0, 300.0),
            Leg::Turn if self.left < self.leg_epochs => self.steer_target = 0.0,
            Leg::Stop if self.v < 0.1 && r.chance(0.02) => self.steer_target = r.noise(200.0),
            _ => {}
        }
        let max_steer_rate = 300.0 * dt;
        self.steer += (self.steer_target - self.steer).clamp(-max_steer_rate, max_steer_rate) + r.noise(1.5);
        let accel = (self.v_target - self.v).clamp(-3.0 * dt, 2.0 * dt);
        self.v = (self.v + accel).max(0.0);
        if self.v < 0.05 && self.v_target == 0.0 {
            self.v = 0.0;
        }
        // Vehicle: kinematic bicycle model (+ steering = left = bearing decreasing).
        let curvature = (self.steer / STEER_RATIO).to_radians().tan() / WHEELBASE_M;
        let yaw_degps = (self.v * curvature).to_degrees();
        self.heading = wrap_360(self.heading - yaw_degps * dt);
        self.pos = destination(self.pos, self.heading, self.v * dt, R);
        if !self.pos.is_valid() {
            self.pos = LatLon::new(0.0, 0.0);
        }

        // Coverage of the long states.
        let moving = self.v > 2.0;
        if moving && (20.0..60.0).contains(&self.steer.abs()) {
            self.bend_s += dt;
            self.coverage.longest_bend_s = self.coverage.longest_bend_s.max(self.bend_s);
        } else {
            self.bend_s = 0.0;
        }
        if moving && self.steer.abs() > 90.0 && self.leg_epochs == 1 {
            self.coverage.turns += 1;
        }
        if self.v == 0.0 {
            self.stop_s += dt;
            self.coverage.longest_stop_s = self.coverage.longest_stop_s.max(self.stop_s);
        } else {
            self.stop_s = 0.0;
        }

        // Vehicle observations: about three per signal between epochs (the synchroniser path).
        let faults = self.leg == Leg::Faults;
        if faults {
            self.coverage.fault_epochs += 1;
        }
        let mut obs = Vec::new();
        let t_from = if self.last_obs_t.is_finite() && self.last_obs_t < self.t && self.t - self.last_obs_t < 5.0 { self.last_obs_t } else { t0 };
        for k in 1..=3 {
            let ot = t_from + (self.t - t_from) * k as f64 / 3.0;
            for sig in Signal::ALL {
                let v = self.signal(sig, yaw_degps);
                let v = if faults { self.fault_f32(v) } else { v };
                obs.push((sig, ot, v));
            }
        }
        self.last_obs_t = self.t;

        // The receiver.
        if self.leg == Leg::GnssGap {
            self.gap_s += dt;
            return Epoch { sample: None, fix: None, obs };
        }
        let r = &mut self.rng;
        self.gnss_err = (0.95 * self.gnss_err.0 + r.noise(0.3), 0.95 * self.gnss_err.1 + r.noise(0.3));
        self.spoof.0 += self.spoof_rate.0 * dt;
        self.spoof.1 += self.spoof_rate.1 * dt;
        if self.spoof != (0.0, 0.0) {
            self.coverage.spoofed_epochs += 1;
        }
        let (e, n) = (self.gnss_err.0 + self.spoof.0, self.gnss_err.1 + self.spoof.1);
        let mut reported = destination(destination(self.pos, 90.0, e, R), 0.0, n, R);
        if !reported.is_valid() {
            reported = self.pos;
        }
        let speed = (self.v + r.noise(0.1)).max(0.0) as f32;
        let course = if self.v > 1.0 { wrap_360(self.heading + r.noise(1.0)) } else { r.range(0.0, 360.0) } as f32;
        let mut fix = Fix { t: self.t, pos: reported, speed_mps: Some(speed), course_deg: Some(course), h_acc_m: None, receiver_spoofing: false };
        if faults {
            match r.next_u64() % 8 {
                0 => fix.pos = LatLon::new(f64::NAN, fix.pos.lon_deg),
                1 => fix.speed_mps = Some(f32::NAN),
                2 => fix.course_deg = None,
                3 => fix.t = t0, // a repeated timestamp
                4 => fix.pos = LatLon::new(91.0, 200.0),
                _ => {}
            }
        }
        // The sample the synchroniser would make of this fix.
        let signals = Signal::ALL.map(|sig| {
            let v = self.signal(sig, yaw_degps);
            if faults {
                match self.rng.next_u64() % 4 {
                    0 => Reading::Stale,
                    1 => Reading::Missing,
                    2 => Reading::Valid(self.fault_f32(v)),
                    _ => Reading::Valid(v),
                }
            } else {
                Reading::Valid(v)
            }
        });
        let (dt_s, shift_m) = match self.prev_fix {
            Some((pt, pp)) if fix.t > pt && fix.pos.is_valid() => ((fix.t - pt) as f32, Reading::Valid(haversine_m(pp, fix.pos, R) as f32)),
            _ => (0.0, Reading::Missing),
        };
        // The synchroniser's integrals since the previous epoch (trapezoids of the values).
        let integral = |r: Reading, prev: Option<Reading>, rng: &mut Rng| -> Reading {
            let v = match (r.get(), prev.and_then(Reading::get)) {
                (Some(a), Some(b)) if dt_s > 0.0 => Reading::Valid(0.5 * (a + b) * dt_s),
                (Some(_), _) => Reading::Stale,
                _ => r,
            };
            if faults && rng.next_u64().is_multiple_of(8) {
                Reading::Valid(f32::from_bits(rng.next_u64() as u32))
            } else {
                v
            }
        };
        let dist_m = integral(signals[Signal::WheelSpeed.index()], self.prev_signals.map(|p| p[Signal::WheelSpeed.index()]), &mut self.rng);
        let turn_deg = integral(signals[Signal::YawRate.index()], self.prev_signals.map(|p| p[Signal::YawRate.index()]), &mut self.rng);
        // The turning whatever its direction: the net turn's magnitude (a steady turn), or
        // (with faults) any number.
        let turn_abs_deg = match turn_deg.get() {
            Some(_) if faults && self.rng.next_u64().is_multiple_of(8) => Reading::Valid(f32::from_bits(self.rng.next_u64() as u32)),
            Some(x) => Reading::Valid(x.abs()),
            None => turn_deg,
        };
        self.prev_signals = Some(signals);
        // A wheel speed in whole km/h, or (with faults) any number.
        let wheel_step_mps = if faults { self.fault_f32(1.0 / 3.6) } else { 1.0 / 3.6 };
        let sample = Sample {
            t: fix.t,
            dt_s,
            pos: fix.pos,
            shift_m,
            gnss_speed: Reading::from_opt(fix.speed_mps),
            gnss_course: Reading::from_opt(fix.course_deg),
            gnss_h_acc: Reading::Missing,
            receiver_spoofing: false,
            signals,
            dist_m,
            turn_deg,
            turn_abs_deg,
            wheel_step_mps,
        };
        if fix.pos.is_valid() && self.prev_fix.is_none_or(|(pt, _)| fix.t > pt || fix.t < pt - 5.0) {
            self.prev_fix = Some((fix.t, fix.pos));
        }
        self.coverage.samples += 1;
        Epoch { sample: Some(sample), fix: Some(fix), obs }
    }

    /// A vehicle signal now, in the detector's units, with sensor noise.
    fn signal(&mut self, sig: Signal, yaw_degps: f64) -> f32 {
        let r = &mut self.rng;
        let v = match sig {
            Signal::WheelSpeed => self.v * self.wheel_scale + r.noise(0.05),
            Signal::Steering => {
                if let Some(s) = self.stuck {
                    return s;
                }
                self.steer + r.noise(0.5)
            }
            Signal::Pedal => (self.v_target - self.v).clamp(0.0, 10.0) * 8.0 + r.noise(1.0),
            Signal::YawRate => yaw_degps + self.gyro_bias + r.noise(0.2),
            Signal::LongAccel => r.noise(0.3),
        };
        v.max(if sig == Signal::WheelSpeed { 0.0 } else { f64::MIN }) as f32
    }

    /// A faulty sensor value: NaN, an infinity, a huge value, or the steering stuck.
    fn fault_f32(&mut self, v: f32) -> f32 {
        match self.rng.next_u64() % 10 {
            0 => f32::NAN,
            1 => f32::INFINITY,
            2 => -f32::MAX,
            3 => 1e30,
            4 => {
                self.stuck = if self.stuck.is_some() { None } else { Some(v) };
                v
            }
            _ => v,
        }
    }
}
