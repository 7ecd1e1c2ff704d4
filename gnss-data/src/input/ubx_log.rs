//! u-blox UBX binary logs (what u-center, `ubxtool` or `cat /dev/ttyACM0` record): the
//! receiver's byte stream, UBX frames possibly interleaved with NMEA sentences. Decoded by the
//! firmware's own framer and fixer ([`gnss_guard_board::ubx`]): a fix per NAV-PVT with one (its
//! UTC time as UNIX seconds, `hAcc` as the fix's accuracy), the receiver's spoofing detection
//! state from NAV-STATUS. NMEA sentences in the stream are counted and left out (the NAV-PVTs
//! carry the same fixes, more precisely). A frame whose checksum fails, or a stream cut inside a
//! frame, is an error naming the byte offset.

use super::drive::{InputError, LoadOptions};
use detector_core::sample::Fix;
use gnss_guard_board::ubx::{Chunk, Framer, NavPvt, SpoofState, UbxFixer, NAV, NAV_PVT, NAV_PVT_LEN, NAV_STATUS, NAV_STATUS_LEN};
use std::path::Path;

/// What a UBX log held.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UbxLog {
    pub fixes: Vec<Fix>,
    /// Every NAV-PVT read, with or without a fix (accuracies for `inspect`).
    pub pvts: Vec<NavPvt>,
    /// NAV-STATUS messages per spoofing-detection state: unknown/off, none, indicated, multiple.
    pub spoof_states: [usize; 4],
    /// NAV-PVTs without a usable fix.
    pub no_fix: usize,
    /// NMEA sentences in the stream, left out.
    pub nmea_sentences: usize,
    /// UBX frames of other messages.
    pub other_frames: usize,
}

impl UbxLog {
    /// One line for a replay's notes.
    pub fn note(&self) -> String {
        let [u, n, i, m] = self.spoof_states;
        format!(
            "UBX: {} fixes from {} NAV-PVT ({} without a fix); receiver spoofing detection over {} NAV-STATUS: {u} unknown/off, {n} none, {i} indicated, {m} multiple; {} NMEA sentences and {} other frames left out",
            self.fixes.len(), self.pvts.len(), self.no_fix, u + n + i + m, self.nmea_sentences, self.other_frames
        )
    }
}

/// Is this a UBX stream (a frame with a valid checksum within its first 64 KiB)?
pub fn looks_like_ubx(bytes: &[u8]) -> bool {
    let mut fr = Framer::default();
    let mut found = false;
    fr.push(bytes.get(..65_536).unwrap_or(bytes), |c| found |= matches!(c, Chunk::Ubx(_)));
    found
}

/// Reads a UBX log (see the module documentation); with `skip_bad_rows`, bad frames are counted
/// in the second value instead.
pub fn ubx_log_from_bytes(path: &Path, bytes: &[u8], opts: &LoadOptions) -> Result<(UbxLog, usize), InputError> {
    let mut fr = Framer::default();
    let mut fixer = UbxFixer::default();
    let mut log = UbxLog::default();
    for (offset, b) in bytes.iter().enumerate() {
        fr.push(std::slice::from_ref(b), |c| match c {
            Chunk::Nmea(_) => log.nmea_sentences += 1,
            Chunk::Ubx(f) => {
                let fix = fixer.frame(None, f);
                match (f.class, f.id, f.payload.len()) {
                    (NAV, NAV_PVT, NAV_PVT_LEN) => {
                        log.pvts.extend(fixer.last_pvt);
                        match fix {
                            Some(x) => log.fixes.push(x),
                            None => log.no_fix += 1,
                        }
                    }
                    (NAV, NAV_STATUS, NAV_STATUS_LEN) => log.spoof_states[fixer.spoof as usize] += 1,
                    _ => log.other_frames += 1,
                }
            }
        });
        if fr.counters.bad_checksum > 0 && !opts.skip_bad_rows {
            return Err(InputError::file(path, format!("byte offset {offset}: a UBX frame ending here fails its checksum (expected the Fletcher sum of class, id, length and payload)")));
        }
    }
    if fr.pending() && !opts.skip_bad_rows {
        return Err(InputError::file(path, format!("byte offset {}: the log ends inside a UBX frame (expected the rest of the frame and its checksum)", bytes.len())));
    }
    if log.fixes.is_empty() {
        return Err(InputError::file(path, "expected UBX NAV-PVT messages with a valid fix and UTC time, found none"));
    }
    let skipped = fr.counters.bad_checksum as usize + usize::from(fr.pending());
    Ok((log, skipped))
}

/// The UBX stream a receiver would have sent for these fixes: per fix a NAV-PVT (3D fix,
/// gnssFixOK, position to 1e-7 deg, speed to mm/s, heading to 1e-5 deg, UTC time of `t_utc`) and
/// a NAV-STATUS with the given spoofing state. The accuracies are written as 0 (not reported)
/// when the source carries none, and read back as none.
pub fn ubx_stream(fixes: &[(f64, &Fix)], spoof: SpoofState) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf = [0u8; 128];
    for (t_utc, f) in fixes {
        let mut p = NavPvt {
            fix_type: 3,
            flags: 1,
            lat_e7: (f.pos.lat_deg * 1e7).round() as i32,
            lon_e7: (f.pos.lon_deg * 1e7).round() as i32,
            h_acc_mm: f.h_acc_m.map_or(0, |a| (a * 1000.0).round() as u32),
            g_speed_mm_s: f.speed_mps.map_or(0, |v| (v * 1000.0).round() as i32),
            head_mot_e5: f.course_deg.map_or(0, |c| (c as f64 * 1e5).round() as i32),
            ..Default::default()
        };
        p.set_utc(*t_utc);
        if let Some(n) = gnss_guard_board::ubx::encode(NAV, NAV_PVT, &p.to_payload(), &mut buf) {
            out.extend_from_slice(&buf[..n]);
        }
        let mut status = [0u8; NAV_STATUS_LEN];
        status[..4].copy_from_slice(&p.itow_ms.to_le_bytes());
        status[4] = 3;
        status[5] = 1 | 4 | 8;
        status[7] = (spoof as u8) << 3;
        if let Some(n) = gnss_guard_board::ubx::encode(NAV, NAV_STATUS, &status, &mut buf) {
            out.extend_from_slice(&buf[..n]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use detector_core::geo::LatLon;

    #[test]
    fn a_written_stream_reads_back_with_its_rounding() {
        let f = Fix { t: 0.0, pos: LatLon::new(37.720_997_71, -122.472_305_33), speed_mps: Some(7.8234), course_deg: Some(2.140_004), h_acc_m: Some(1.2345), receiver_spoofing: false };
        let bytes = ubx_stream(&[(1_533_198_887.25, &f), (1_533_198_887.35, &f)], SpoofState::Indicated);
        assert!(looks_like_ubx(&bytes));
        let (log, skipped) = ubx_log_from_bytes(Path::new("g.ubx"), &bytes, &LoadOptions::default()).unwrap();
        assert_eq!((log.fixes.len(), skipped, log.spoof_states), (2, 0, [0, 0, 2, 0]));
        let g = log.fixes[1];
        assert_eq!(g.t, 1_533_198_887.0 + 0.35);
        assert_eq!((g.pos.lat_deg, g.pos.lon_deg), (377_209_977.0 * 1e-7, -1_224_723_053.0 * 1e-7));
        assert_eq!((g.speed_mps, g.course_deg, g.h_acc_m), (Some(7.823), Some(2.14), Some(1.235)));
        assert!(log.note().contains("2 indicated"));
    }

    #[test]
    fn bad_frames_name_the_offset() {
        let f = Fix { t: 0.0, pos: LatLon::new(48.0, 11.0), speed_mps: Some(1.0), course_deg: Some(0.0), h_acc_m: None, receiver_spoofing: false };
        let mut bytes = ubx_stream(&[(1e9, &f)], SpoofState::None);
        bytes[30] ^= 0x40;
        let e = ubx_log_from_bytes(Path::new("g.ubx"), &bytes, &LoadOptions::default()).unwrap_err().to_string();
        assert!(e.contains("g.ubx") && e.contains("byte offset 99") && e.contains("checksum"), "{e}");
        let good = ubx_stream(&[(1e9, &f)], SpoofState::None);
        let e = ubx_log_from_bytes(Path::new("g.ubx"), &good[..good.len() - 3], &LoadOptions::default()).unwrap_err().to_string();
        assert!(e.contains("ends inside a UBX frame"), "{e}");
        let e = ubx_log_from_bytes(Path::new("g.ubx"), b"$GPGGA,1*00\r\n", &LoadOptions::default()).unwrap_err().to_string();
        assert!(e.contains("expected UBX NAV-PVT"), "{e}");
    }
}
