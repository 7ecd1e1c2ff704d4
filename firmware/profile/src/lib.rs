//! # gnss-guard-profile
//!
//! A vehicle profile says where the detector's signals (wheel speed, steering, pedal, yaw rate,
//! acceleration), and where a receiver reports on CAN its fix, are on a car's buses: DBC files,
//! which describe the frames, and a small map file, which picks the DBC signals and converts
//! them to our units. The same two files serve
//! the firmware (compiled in by the board crate's build script) and host-sim (read at run time),
//! through this one implementation.
//!
//! - [`field`]: a signal's bits in a payload (no_std): decode and encode.
//! - [`mapping`]: a mapped signal and the frame decoder over a list of them (no_std).
//! - `load` (feature `std`): the DBC (`can-dbc`) and map parser, with errors that name the
//!   file's line, and the Rust source the firmware's build script writes.
#![no_std]
#![forbid(unsafe_code)]

#[cfg(feature = "std")]
extern crate std;

pub mod field;
pub mod mapping;
#[cfg(feature = "std")]
pub mod load;

pub use field::Field;
pub use mapping::{decode, decode_gnss, GnssField, GnssMapped, Mapped};
