//! # detector-core
//!
//! The GNSS spoofing detector shared by the firmware and the host tools. `no_std`, no allocator:
//! every buffer has a fixed capacity, and no input (NaN, garbage, time going backwards, a sensor
//! going silent) makes it panic.
//!
//! The modules follow the data path:
//!
//! 1. [`geo`]: geodesy on WGS84 coordinates (haversine distance, initial bearing).
//! 2. [`sample`]: the vocabulary: a [`sample::Fix`] from the receiver, a vehicle
//!    [`sample::Signal`] observation, and the synchronised [`sample::Sample`] per GNSS epoch.
//! 3. [`sync`]: synchronisation. GNSS epochs are the reference clock; each vehicle signal is
//!    linearly interpolated to every epoch from its two nearest observations, or marked stale.
//!
//! 4. [`strategy`]: the detection strategies (location shift, motion state; turns plug in).
//! 5. [`fusion`]: one [`fusion::Verdict`] per epoch from all strategies, degraded mode, and the
//!    latched alarm; [`fusion::Config`] holds all tuning, from a [`profile::ReceiverProfile`].
#![no_std]
#![forbid(unsafe_code)]

pub mod crc32;
pub mod geo;
pub mod sample;
pub mod sync;
pub mod strategy;
pub mod fusion;
pub mod profile;
