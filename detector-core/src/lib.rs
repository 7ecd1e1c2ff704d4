//! # detector-core
//!
//! The GNSS spoofing detector shared by the firmware and the host tools. `no_std`, no allocator:
//! every buffer has a fixed capacity, and no input (NaN, garbage, time going backwards, a sensor
//! going silent) makes it panic (the firmware's `nopanic` image proves it by the link).
//!
//! The modules follow the data path, each depending only on those above it in this list:
//!
//! 0. [`stage`]: cost accounting by stage (a stopwatch interface; nothing by default).
//!    [`trig`]: sine, cosine and tangent (libm's, without the reduction of huge arguments).
//! 1. [`wire`]: the binary formats read from flash (turn templates, LSTM model), one
//!    little-endian reader, CRC-32.
//! 2. [`geo`]: geodesy on WGS84 coordinates (haversine distance, initial bearing).
//! 3. [`sample`]: the vocabulary: a [`sample::Fix`] from the receiver, a vehicle
//!    [`sample::Signal`] observation, and the synchronised [`sample::Sample`] per GNSS epoch.
//! 4. [`sync`]: synchronisation. GNSS epochs are the reference clock; each vehicle signal is
//!    linearly interpolated to every epoch from its two nearest observations, or marked stale.
//! 5. [`vehicle`]: the car's own motion models (bicycle model, wheel-speed dead reckoning).
//! 6. [`profile`]: receiver profiles, the measured terms the thresholds are made of.
//! 7. [`strategy`]: the detection strategies, each on its own (location shift with its
//!    predictors, turns, motion state, the beyond-the-paper consistency checks).
//! 8. [`fusion`]: one [`fusion::Verdict`] per epoch from all strategies, degraded mode, and the
//!    latched alarm; [`fusion::Config`] gathers every strategy's configuration for a profile.
//!
//! # Feeding samples, reading verdicts
//!
//! The firmware and the host tools do the same three things: give the [`sync::Synchronizer`]
//! each GNSS fix and each vehicle-signal observation as it arrives (in any order across
//! inputs), step the [`fusion::Detector`] with every synchronised [`sample::Sample`] it emits,
//! and read the [`fusion::Verdict`]. Here a car drives north at 10 m/s with a 1 Hz receiver;
//! 40 s in, a spoofer moves the reported position 300 m east:
//!
//! ```
//! use detector_core::fusion::{Config, Detector, Reason};
//! use detector_core::geo::LatLon;
//! use detector_core::profile::LOGGER_1HZ;
//! use detector_core::sample::{Fix, Signal};
//! use detector_core::strategy::location_shift::kinematic::KinematicPredictor;
//! use detector_core::sync::{SyncConfig, Synchronizer};
//!
//! let mut sync = Synchronizer::new(SyncConfig::default());
//! let mut det = Detector::new(Config::for_profile(&LOGGER_1HZ), KinematicPredictor::default());
//! let mut first_alarm = None;
//! let mut judge = |s: &detector_core::sample::Sample| {
//!     let v = det.step(s);
//!     if v.alarm && first_alarm.is_none() {
//!         first_alarm = Some((v.t, v.reasons));
//!     }
//! };
//! for k in 0..600 {
//!     let t = k as f64 * 0.1;
//!     // The wheel speed from CAN, 10 times a second.
//!     sync.push_obs(Signal::WheelSpeed, t, 10.0, &mut judge);
//!     if k % 10 == 0 {
//!         // A fix once a second: 10 m further north each time, 300 m east from 40 s on.
//!         let east_m = if t >= 40.0 { 300.0 } else { 0.0 };
//!         let pos = LatLon::new(52.0 + 10.0 * t / 111_320.0, 5.0 + east_m / (111_320.0 * 0.6157));
//!         let fix = Fix { t, pos, speed_mps: Some(10.0), course_deg: Some(0.0), ..Fix::default() };
//!         sync.push_fix(fix, &mut judge);
//!     }
//! }
//! sync.flush(&mut judge);
//! let (t, reasons) = first_alarm.expect("the jump is found");
//! assert_eq!(t, 40.0);
//! assert!(reasons.contains(Reason::ShiftExceedsPrediction));
//! ```
//!
//! # The model and the templates, read in place
//!
//! Strategy 1's LSTM and strategy 2's turn templates are versioned, CRC-checked blobs
//! ([`wire::model`], [`wire::templates`]) read where they lie: on the board a `static` from
//! `include_bytes!` sits in flash and nothing is copied to RAM. A blob that fails its checks is
//! refused with the reason, and the detector runs without it (the kinematic predictor; no turn
//! check) and says so:
//!
//! ```
//! use detector_core::fusion::{Config, Detector};
//! use detector_core::profile::UBLOX_10HZ;
//! use detector_core::strategy::location_shift::lstm::predictor::{LstmPredictor, DEFAULT_MODEL};
//! use detector_core::strategy::location_shift::predictor::Predictor;
//! use detector_core::strategy::location_shift::fallback::WithFallback;
//! use detector_core::strategy::turn::strategy::DEFAULT_TEMPLATES;
//! use detector_core::wire::model::{LstmError, LstmModel};
//! use detector_core::wire::templates::TemplateSet;
//!
//! static MODEL: &[u8] = DEFAULT_MODEL; // on the board: include_bytes!("lstm.bin")
//! let model = LstmModel::parse(MODEL).expect("the committed model is valid");
//! assert_eq!((model.h1, model.h2), (128, 64)); // the paper's two layers
//! let lstm = Predictor::Lstm(WithFallback::new(LstmPredictor::int(model).expect("int8 blob")));
//! let templates = TemplateSet::parse(DEFAULT_TEMPLATES).expect("the committed templates are valid");
//! let config = Config::for_predictor(&UBLOX_10HZ, &lstm);
//! let detector = Detector::new(config, lstm).with_turns(templates);
//! assert!(detector.config().shift.predictor_error_m < 1.0); // the LSTM's measured error term
//!
//! // A blob cut short, or with a flipped bit, is refused:
//! assert_eq!(LstmModel::parse(&MODEL[..MODEL.len() - 1]).err(), Some(LstmError::BadLength));
//! let mut flipped = [0u8; 256];
//! flipped.copy_from_slice(&DEFAULT_TEMPLATES[..256]);
//! flipped[20] ^= 1;
//! assert!(TemplateSet::parse(&flipped).is_err());
//! ```
//!
//! A whole `no_std` integration, a Cortex-M image that decodes its own CAN frames and GNSS
//! sentences and feeds this crate, is `examples/cortex-m/` (it runs in QEMU).
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod stage;
pub mod time;
pub mod trig;
pub mod wire;
pub mod geo;
pub mod sample;
pub mod sync;
pub mod vehicle;
pub mod profile;
pub mod strategy;
pub mod fusion;
