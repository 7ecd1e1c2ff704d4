//! ASAM MDF 4 bus-logging files (`.MF4`: CSS Electronics' CANedge, Vector, ETAS, Kvaser and
//! others): the CAN data frames of their `CAN_DataFrame` channel groups (CAN and CAN FD,
//! standard and extended ids, several buses), finalised or not, plain or with DZ-compressed
//! blocks, read through `falcon_mdf`.
//!
//! Why `falcon_mdf` and not `mdf4-rs` (measured on the CANedge files behind css_canedge, 11
//! files, 640,067 frames): `mdf4-rs` 0.4 and later need rustc 1.97 (ours is 1.95), and 0.3.3
//! returns the bus-logging group as one composite channel without its members (ID, DataBytes,
//! BusChannel, ...), so the record layout would be ours to parse; `falcon_mdf` 0.7 returns the
//! frames themselves (all 640,067 in 0.1 s, the count `asammdf` reads), reads unfinalised files
//! and DZ blocks, and is built to return errors, not panics, on damaged files (its authors swept
//! mutated files; our fuzz target `mdf4` runs it too).
//!
//! Times: each file's start time (its header) plus the frame's offset, to the microsecond
//! (every CAN log reader here keeps that resolution, so logs of the same frames in different
//! formats give the same drive). Buses: a frame's `BusChannel` N is bus N - 1, as an ASC
//! channel (CAN1 of a CANedge is bus 0, CAN2 bus 1); a file without bus channels is bus 0.
//!
//! A folder of MF4 files is one drive: its files in time order. A logger writes a session
//! (power-up to power-down) as several files that share the session's start time; files of
//! several sessions in one folder are refused, with each session's files named, as a drive must
//! be one session.

use super::candump::CanFrame;
use super::drive::InputError;
use std::path::{Path, PathBuf};

/// Does this byte string start like an MDF 4 file (finalised or not)?
pub fn looks_like_mdf4(head: &[u8]) -> bool {
    head.starts_with(b"MDF     ") || head.starts_with(b"UnFinMF ")
}

/// One MF4 file's frames: its session start (UNIX seconds) and its frames in file order.
pub struct Mf4Frames {
    /// The start time the file's header gives (a session's files share it).
    pub start_s: f64,
    /// The CAN data frames, every bus.
    pub frames: Vec<CanFrame>,
}

/// Reads the CAN data frames of one MF4 file's bytes.
pub fn mdf4_from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Mf4Frames, InputError> {
    let err = |e: falcon_mdf::error::Mf4Error| InputError::file(path, format!("not a readable MDF 4 bus log: {e}"));
    let file = falcon_mdf::Mf4File::from_bytes(bytes).map_err(err)?;
    let start_ns = file.start_time().timestamp_ns;
    let mut frames = Vec::new();
    for group in file.can_frame_groups() {
        let fr = file.can_frames(group).map_err(err)?;
        frames.reserve(fr.len());
        for f in fr.iter() {
            // Offsets from the file's start of up to 3,000 years: beyond that a time is garbage.
            if f.timestamp.is_nan() || f.timestamp.abs() >= 1e11 {
                return Err(InputError::file(path, format!("group {:?}, frame {}: expected a time offset from the file's start within 1e11 s, found {}", group.acquisition_name, frames.len(), f.timestamp)));
            }
            // Nanoseconds in integers (no rounding before the microsecond), rounded to the nearest
            // microsecond.
            let ns = i128::from(start_ns).saturating_add((f.timestamp * 1e9).round() as i128);
            let micros = (ns + 500).div_euclid(1000);
            let bus = f.bus_channel.saturating_sub(1);
            let extended = f.extended.unwrap_or(f.id > 0x7FF);
            if !extended && f.id > 0x7FF {
                return Err(InputError::file(path, format!("group {:?}, frame {}: expected an 11-bit id for a standard frame (IDE 0), found {:#x}", group.acquisition_name, frames.len(), f.id)));
            }
            frames.push(CanFrame { t: micros as f64 / 1e6, iface: format!("can{bus}"), id: f.id, extended, data: f.data.to_vec() });
        }
    }
    Ok(Mf4Frames { start_s: start_ns as f64 / 1e9, frames })
}

/// Reads one MF4 file.
pub fn read_mdf4(path: &Path) -> Result<Mf4Frames, InputError> {
    let bytes = std::fs::read(path).map_err(|e| InputError::file(path, format!("cannot read: {e}")))?;
    mdf4_from_bytes(path, bytes)
}

/// The MF4 files of a folder (not its subfolders), by name.
pub fn mdf4_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| rd.flatten().map(|e| e.path()).filter(|p| p.is_file() && is_mdf4_name(p)).collect())
        .unwrap_or_default();
    files.sort();
    files
}

fn is_mdf4_name(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("mf4") || e.eq_ignore_ascii_case("mdf"))
}

/// Every frame of a folder's MF4 files (one session), in time order; or of one file.
pub fn read_mdf4_drive(path: &Path) -> Result<Vec<CanFrame>, InputError> {
    if !path.is_dir() {
        let mut f = read_mdf4(path)?.frames;
        f.sort_by(|a, b| a.t.total_cmp(&b.t));
        return Ok(f);
    }
    let files = mdf4_files(path);
    if files.is_empty() {
        return Err(InputError::file(path, "expected MF4 files (*.MF4) in this folder"));
    }
    let mut sessions: Vec<(f64, Vec<PathBuf>)> = Vec::new();
    let mut frames = Vec::new();
    for f in &files {
        let m = read_mdf4(f)?;
        match sessions.iter_mut().find(|(s, _)| *s == m.start_s) {
            Some((_, v)) => v.push(f.clone()),
            None => sessions.push((m.start_s, vec![f.clone()])),
        }
        frames.extend(m.frames);
    }
    if sessions.len() > 1 {
        let list: Vec<String> = sessions
            .iter()
            .map(|(s, v)| format!("start {s:.3}: {}", v.iter().map(|p| p.file_name().unwrap_or_default().to_string_lossy().into_owned()).collect::<Vec<_>>().join(", ")))
            .collect();
        return Err(InputError::file(path, format!("expected the MF4 files of one logging session (a drive), found {} sessions: {}; put each in a folder of its own", sessions.len(), list.join("; "))));
    }
    // Stable: frames of equal time keep their file order.
    frames.sort_by(|a, b| a.t.total_cmp(&b.t));
    Ok(frames)
}
