//! # gnss-data
//!
//! Real drives for the detector, with light dependencies (no training, no plotting), shared by
//! host-sim and by the QEMU image's build script. The data path:
//!
//! - [`input`]: drives in their native formats decoded into a time-ordered stream of receiver
//!   fixes and vehicle-signal observations (a [`input::Replay`]); CAN through a vehicle profile.
//! - [`replay`]: a replay through the core's synchroniser, as the firmware feeds it.
//! - [`tracks`]: what a track shows (stops, real turns).
//! - [`attack`]: spoofing attacks written into a replay (ground truth by onset).
//! - [`nuisance`]: a clean drive transformed the way a new installation differs (not attacks).
//! - [`sim`]: the simulated drive (never presented as real).
//! - [`qemu_input`]: the QEMU run's input (real CAN frames and NMEA, clean, attacked, an outage).

pub mod input;
pub mod replay;
pub mod tracks;
pub mod attack;
pub mod nuisance;
pub mod sim;
pub mod qemu_input;
