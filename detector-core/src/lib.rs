//! # detector-core
//!
//! The GNSS spoofing detector shared by the firmware and the host tools. `no_std`, no allocator:
//! every buffer has a fixed capacity, and no input (NaN, garbage, time going backwards, a sensor
//! going silent) makes it panic (the firmware's `nopanic` image proves it by the link).
//!
//! The modules follow the data path, each depending only on those above it in this list:
//!
//! 0. [`stage`]: cost accounting by stage (a stopwatch interface; nothing by default).
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
#![no_std]
#![forbid(unsafe_code)]

pub mod stage;
pub mod wire;
pub mod geo;
pub mod sample;
pub mod sync;
pub mod vehicle;
pub mod profile;
pub mod strategy;
pub mod fusion;
