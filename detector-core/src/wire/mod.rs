//! Wire formats: the binary blobs the detector reads from flash, apart from the algorithms that
//! use them (the smoltcp way). Nothing here allocates, and nothing panics on any input: a blob
//! is validated once (`parse`) and read through [`le`], which returns `None` out of range.
//!
//! - [`le`]: the one little-endian byte reader.
//! - [`crc32`]: CRC-32 (IEEE), the blobs' checksum.
//! - [`templates`]: strategy 2's turn templates (`GGTT`).
//! - [`model`]: strategy 1's LSTM model (`GGLM`), f32 or int8.
//! - [`calibration`]: a car's calibration record (`GGCR`), kept across drives.
//!
//! (The third format, the QEMU run's replay input `GGQI`, belongs to the firmware's board crate
//! and reads through the same [`le`].)

pub mod calibration;
pub mod crc32;
pub mod le;
pub mod model;
pub mod templates;
