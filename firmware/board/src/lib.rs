//! Board-independent firmware logic, `no_std`, no allocation, shared by the STM32 firmware, the
//! QEMU image and `host-sim digest`:
//!
//! - [`can`]: CAN frame decoding generated at build time from the vehicle profile's DBC;
//! - [`gnss`]: NMEA sentences (RMC, GGA, VTG via the `nmea` crate) to receiver fixes;
//! - [`pipeline`]: frames and sentences -> `detector_core` synchroniser -> detector -> verdicts,
//!   with a digest of the verdict stream;
//! - [`replay`]: the compact replay input format and the scenario runner.
#![no_std]
#![forbid(unsafe_code)]

pub mod can;
pub mod gnss;
pub mod pipeline;
pub mod replay;
