//! Board-independent firmware logic, `no_std`, no allocation, shared by the STM32 firmware, the
//! QEMU image and `host-sim digest`:
//!
//! - [`can`]: CAN frame decoding generated at build time from the vehicle profile's DBC;
//! - [`nmea`]: the NMEA 0183 wire format (RMC, GGA, VTG, GST), panic-free;
//! - [`gnss`]: NMEA sentences to receiver fixes, and the UART line splitter;
//! - [`ubx`]: the u-blox UBX wire format (NAV-PVT, NAV-STATUS), UBX and NMEA told apart on one
//!   UART, frames to fixes and the receiver's own spoofing state;
//! - [`pipeline`]: frames and sentences -> `detector_core` synchroniser -> detector -> verdicts,
//!   with a digest of the verdict stream;
//! - [`health`]: the status frames and the watchdog gate;
//! - [`outbox`]: the alarm frames' outbox and the transmitter's queue;
//! - [`replay`]: the compact replay input format and the scenario runner.
#![no_std]
#![forbid(unsafe_code)]

pub mod can;
pub mod gnss;
pub mod health;
pub mod nmea;
pub mod outbox;
pub mod pipeline;
pub mod replay;
pub mod store;
pub mod ubx;
