//! Vector BLF (binary logging format) CAN logs: the CAN and CAN FD frames of `CAN_MESSAGE` (1),
//! `CAN_MESSAGE2` (86), `CAN_FD_MESSAGE` (100) and `CAN_FD_MESSAGE_64` (101) objects, inside
//! zlib-compressed or plain log containers (10); error frames and other objects are skipped.
//!
//! A reader of our own, because the Rust crate there is, `ablf` 0.2, reads only `CAN_MESSAGE2`
//! objects: the `CAN_MESSAGE` objects most writers use (python-can, and CANoe for classic frames)
//! and both CAN FD objects come back as unsupported. The layout follows python-can's reader (the
//! format is Vector's, unpublished; python-can's and Toby Lorenz's `vector_blf` are the public
//! descriptions), and `tests/tests/blf_crosscheck.rs` reads what python-can writes, frame for
//! frame. Decompression is `flate2`'s.
//!
//! Times: the file header's start time (UTC, to the millisecond) plus each object's timestamp
//! (10 us or 1 ns units, as its flags say), to the microsecond like every CAN log reader here.
//! Buses: channel N is bus N - 1, as in ASC. Errors name the file, the byte offset (of the
//! container, and of the object inside its uncompressed data) and what was expected.

use super::candump::CanFrame;
use super::drive::{InputError, LoadOptions};
use std::io::Read;
use std::path::Path;

const FILE_MAGIC: &[u8; 4] = b"LOGG";
const OBJ_MAGIC: &[u8; 4] = b"LOBJ";
const CAN_MESSAGE: u32 = 1;
const LOG_CONTAINER: u32 = 10;
const CAN_MESSAGE2: u32 = 86;
const CAN_FD_MESSAGE: u32 = 100;
const CAN_FD_MESSAGE_64: u32 = 101;
/// An id with this bit is extended.
const EXT_BIT: u32 = 0x8000_0000;
/// Largest uncompressed container we accept (writers use 128 KiB; a bomb is refused).
const MAX_CONTAINER: usize = 64 << 20;

/// Does this byte string start like a BLF file?
pub fn looks_like_blf(head: &[u8]) -> bool {
    head.starts_with(FILE_MAGIC)
}

fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at.checked_add(2)?)?.try_into().ok()?))
}
fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at.checked_add(4)?)?.try_into().ok()?))
}
fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at.checked_add(8)?)?.try_into().ok()?))
}

/// The file header's start time (a Windows SYSTEMTIME, UTC) in UNIX milliseconds; 0 when it holds
/// no date (as python-can reads it).
fn start_ms(b: &[u8]) -> i64 {
    let f = |i: usize| u16_at(b, 40 + 2 * i).map_or(0, i64::from);
    let (y, mo, d, h, mi, s, ms) = (f(0), f(1), f(3), f(4), f(5), f(6), f(7));
    if !(1..=12).contains(&mo) || !(1..=31).contains(&d) || h > 23 || mi > 59 || s > 60 || ms > 999 || y < 1970 {
        return 0;
    }
    let days = gnss_guard_board::ubx::days_from_civil(y, mo, d);
    ((days * 24 + h) * 60 + mi) * 60_000 + s * 1000 + ms
}

/// Reads a BLF log's bytes: its CAN frames, and the objects skipped as unreadable (with
/// `skip_bad_rows`; otherwise the first is an error).
pub fn blf_from_bytes(path: &Path, b: &[u8], opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    let at = |off: usize, what: String| InputError::file(path, format!("byte {off}: {what}"));
    if !looks_like_blf(b) {
        return Err(at(0, "expected a BLF file (`LOGG` first)".into()));
    }
    let header = u32_at(b, 4).ok_or_else(|| at(4, "expected the file header's size".into()))? as usize;
    if header < 72 || header > b.len() {
        return Err(at(4, format!("expected a file header of 72 to {} bytes, found {header}", b.len())));
    }
    let start_ns = i128::from(start_ms(b)) * 1_000_000;
    let mut frames = Vec::new();
    let mut skipped = 0;
    // The objects inside the containers, as one stream: an object may span two containers.
    let mut stream: Vec<u8> = Vec::new();

    let mut pos = header;
    while pos < b.len() {
        // Padding between outer objects: up to 3 bytes before the next `LOBJ`.
        let Some(rel) = b.get(pos..(pos + 8).min(b.len())).and_then(|w| w.windows(4).position(|x| x == OBJ_MAGIC)) else {
            if b.len() - pos < 8 {
                break; // trailing padding
            }
            return Err(at(pos, "expected an object (`LOBJ`)".into()));
        };
        pos += rel;
        let (size, kind) = match (u32_at(b, pos + 8), u32_at(b, pos + 12)) {
            (Some(s), Some(k)) => (s as usize, k),
            _ => return Err(at(pos, "expected an object header of 16 bytes, found the end of the file".into())),
        };
        if size < 16 || pos.checked_add(size).is_none_or(|e| e > b.len()) {
            return Err(at(pos, format!("expected an object size from 16 to the {} bytes left, found {size}", b.len() - pos)));
        }
        let body = &b[pos + 16..pos + size];
        if kind == LOG_CONTAINER {
            let method = u16_at(body, 0).ok_or_else(|| at(pos, "expected a log container's header".into()))?;
            let data = body.get(16..).unwrap_or(&[]);
            match method {
                0 => stream.extend_from_slice(data),
                2 => {
                    let mut out = Vec::new();
                    let mut z = flate2::read::ZlibDecoder::new(data).take(MAX_CONTAINER as u64 + 1);
                    if let Err(e) = z.read_to_end(&mut out) {
                        if !opts.skip_bad_rows {
                            return Err(at(pos, format!("expected zlib-compressed objects in this container: {e}")));
                        }
                        skipped += 1;
                    }
                    if out.len() > MAX_CONTAINER {
                        return Err(at(pos, format!("expected a container of at most {MAX_CONTAINER} bytes uncompressed")));
                    }
                    stream.extend_from_slice(&out);
                }
                m => return Err(at(pos, format!("expected compression method 0 (none) or 2 (zlib), found {m}"))),
            }
            let (n, bad) = inner_objects(path, pos, &stream, start_ns, opts, &mut frames)?;
            skipped += bad;
            stream.drain(..n);

        }
        // An outer object that is not a container (rare: writers put everything in containers)
        // carries no frame we read.
        pos += size + size % 4;
    }
    Ok((frames, skipped))
}

/// Parses the complete objects at the front of `s` (an object cut by the container's end waits
/// for the next container): the bytes consumed and the objects skipped as unreadable.
fn inner_objects(path: &Path, container: usize, s: &[u8], start_ns: i128, opts: &LoadOptions, out: &mut Vec<CanFrame>) -> Result<(usize, usize), InputError> {
    let err = |off: usize, what: String| InputError::file(path, format!("container at byte {container}, object at byte {off} of its data: {what}"));
    let mut pos = 0usize;
    let mut skipped = 0;
    loop {
        // Objects are padded to four bytes (some writers pad by the size modulo 4).
        let Some(rel) = s.get(pos..(pos + 8).min(s.len())).and_then(|w| w.windows(4).position(|x| x == OBJ_MAGIC)) else {
            if s.len().saturating_sub(pos) < 8 {
                return Ok((pos, skipped)); // the rest continues in the next container
            }
            return Err(err(pos, "expected an object (`LOBJ`)".into()));
        };
        let p = pos + rel;
        let (Some(hsize), Some(hver), Some(size), Some(kind)) = (u16_at(s, p + 4), u16_at(s, p + 6), u32_at(s, p + 8), u32_at(s, p + 12)) else {
            return Ok((p, skipped));
        };
        let (hsize, size) = (hsize as usize, size as usize);
        if size < 16 || hsize < 16 || hsize > size {
            return Err(err(p, format!("expected an object of at least its header's {hsize} bytes (and 16), found {size}")));
        }
        if p + size > s.len() {
            return Ok((p, skipped)); // continues in the next container
        }
        let obj = &s[p..p + size];
        pos = p + size;
        // The header after the base: flags, and the timestamp (v1 at 24, v2 at 24 too).
        let (flags, ts) = match hver {
            1 | 2 => (u32_at(obj, 16), u64_at(obj, 24)),
            _ => {
                skipped += 1;
                continue;
            }
        };
        let (Some(flags), Some(ts)) = (flags, ts) else {
            if !opts.skip_bad_rows {
                return Err(err(p, "expected an object header with a timestamp".into()));
            }
            skipped += 1;
            continue;
        };
        let header = if hver == 1 { 32 } else { 40 };
        let ns = if flags == 1 { i128::from(ts) * 10_000 } else { i128::from(ts) };
        let t = ((start_ns + ns + 500).div_euclid(1000)) as f64 / 1e6;
        let body = obj.get(header..).unwrap_or(&[]);
        let before = out.len();
        let frame = match kind {
            CAN_MESSAGE | CAN_MESSAGE2 => {
                // channel u16, flags u8, dlc u8, id u32, data [8]
                let (Some(ch), Some(&fl), Some(&dlc), Some(id)) = (u16_at(body, 0), body.get(2), body.get(3), u32_at(body, 4)) else {
                    return Err(err(p, "expected a CAN message of 16 bytes".into()));
                };
                let data = body.get(8..16).ok_or_else(|| err(p, "expected a CAN message's 8 data bytes".into()))?;
                let remote = fl & 0x80 != 0;
                Some((ch, id, if remote { &[][..] } else { &data[..(dlc as usize).min(8)] }))
            }
            CAN_FD_MESSAGE => {
                // channel u16, flags u8, dlc u8, id u32, frame length u32, bit count u8, fd flags
                // u8, valid bytes u8, 5 reserved, data [64]
                let (Some(ch), Some(&fl), Some(id), Some(&valid)) = (u16_at(body, 0), body.get(2), u32_at(body, 4), body.get(14)) else {
                    return Err(err(p, "expected a CAN FD message".into()));
                };
                let data = body.get(20..20 + (valid as usize).min(64)).ok_or_else(|| err(p, format!("expected {valid} data bytes of a CAN FD message")))?;
                Some((ch, id, if fl & 0x80 != 0 { &[][..] } else { data }))
            }
            CAN_FD_MESSAGE_64 => {
                // channel u8, dlc u8, valid bytes u8, tx count u8, id u32, frame length u32,
                // flags u32, ... (40 bytes), data; ext_data_offset u8 at 35
                let (Some(&ch), Some(&valid), Some(id), Some(fd_flags), Some(&ext)) = (body.first(), body.get(2), u32_at(body, 4), u32_at(body, 12), body.get(35)) else {
                    return Err(err(p, "expected a CAN FD 64 message".into()));
                };
                if valid > 64 {
                    if !opts.skip_bad_rows {
                        return Err(err(p, format!("expected at most 64 data bytes in a CAN FD 64 message, found {valid}")));
                    }
                    skipped += 1;
                    continue;
                }
                let end = if ext != 0 { ext as usize } else { size };
                let avail = end.saturating_sub(hsize).saturating_sub(40).min(valid as usize);
                let data = body.get(40..40 + avail).ok_or_else(|| err(p, format!("expected {avail} data bytes of a CAN FD 64 message")))?;
                // Valid bytes beyond the object are zeros, as CANoe and python-can read them.
                out.push(CanFrame {
                    t,
                    iface: format!("can{}", u16::from(ch).saturating_sub(1)),
                    id: id & !EXT_BIT,
                    extended: id & EXT_BIT != 0,
                    data: if fd_flags & 0x10 != 0 { Vec::new() } else { data.iter().copied().chain(std::iter::repeat_n(0, valid as usize - avail)).collect() },
                });
                None
            }
            _ => None,
        };
        if let Some((ch, id, data)) = frame {
            out.push(CanFrame { t, iface: format!("can{}", ch.saturating_sub(1)), id: id & !EXT_BIT, extended: id & EXT_BIT != 0, data: data.to_vec() });
        }
        // A standard frame's id has 11 bits, an extended one's 29.
        if let Some(f) = out.get(before..).and_then(|new| new.first()).filter(|f| f.id > if f.extended { 0x1FFF_FFFF } else { 0x7FF }) {
            let what = format!("expected a {} id, found {:#x}", if f.extended { "29-bit extended" } else { "11-bit standard" }, f.id);
            if !opts.skip_bad_rows {
                return Err(err(p, what));
            }
            out.pop();
            skipped += 1;
        }
    }
}

/// Reads a BLF log.
pub fn read_blf(path: &Path, opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    let bytes = std::fs::read(path).map_err(|e| InputError::file(path, format!("cannot read: {e}")))?;
    blf_from_bytes(path, &bytes, opts)
}
