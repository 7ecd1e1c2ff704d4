//! A raw comma2k19 segment: `processed_log/<group>/<signal>/{t,value}` NumPy arrays (no extension).
//!
//! GNSS fixes come from `GNSS/live_gnss_ublox` (columns: lat, lon, speed m/s, UTC ms, altitude,
//! bearing deg). Vehicle signals are decoded from the real CAN frames in `CAN/raw_can` with the
//! segment's DBC (`*.dbc` in the segment folder) and the RAV4 map ([`super::can::RAV4_MAP`]);
//! frames from bus 0 only (comma logs the forwarded copies on other buses). All times are the
//! log's monotonic clock, seconds.

use super::can::{Decoder, RAV4_MAP};
use super::drive::{Event, Format, InputError, Replay};
use detector_core::geo::LatLon;
use detector_core::sample::Fix;
use std::path::{Path, PathBuf};

pub(crate) fn read_npy<T: npyz::Deserialize>(root: &Path, rel: &str) -> Result<(Vec<u64>, Vec<T>), InputError> {
    let p = root.join("processed_log").join(rel);
    let bytes = std::fs::read(&p).map_err(|e| InputError::array(root, rel, format!("cannot read {}: {e}", p.display())))?;
    let npy = npyz::NpyFile::new(&bytes[..]).map_err(|e| InputError::array(root, rel, format!("expected a NumPy .npy array: {e}")))?;
    let shape = npy.shape().to_vec();
    let data = npy.into_vec::<T>().map_err(|e| InputError::array(root, rel, format!("unexpected dtype or truncated data: {e}")))?;
    Ok((shape, data))
}

fn find_dbc(root: &Path) -> Result<PathBuf, InputError> {
    let mut dbcs: Vec<PathBuf> = std::fs::read_dir(root)
        .map_err(|e| InputError::file(root, format!("cannot list: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "dbc"))
        .collect();
    dbcs.sort();
    dbcs.into_iter().next().ok_or_else(|| InputError::file(root, "expected a .dbc file describing the CAN frames in the segment folder"))
}

pub fn load(root: &Path) -> Result<Replay, InputError> {
    let mut events = Vec::new();
    // GNSS
    let gt_name = "GNSS/live_gnss_ublox/t";
    let gv_name = "GNSS/live_gnss_ublox/value";
    let (_, gt) = read_npy::<f64>(root, gt_name)?;
    let (gshape, gv) = read_npy::<f64>(root, gv_name)?;
    if gshape.len() != 2 || gshape[1] < 6 || gshape[0] as usize != gt.len() {
        return Err(InputError::array(root, gv_name, format!(
            "expected shape ({}, 6) matching {gt_name}, found {gshape:?}", gt.len())));
    }
    let w = gshape[1] as usize;
    let mut last = f64::NEG_INFINITY;
    for (i, &t) in gt.iter().enumerate() {
        let row = &gv[i * w..(i + 1) * w];
        if !t.is_finite() || t < last {
            return Err(InputError::array(root, gt_name, format!("row {i}: expected finite, non-decreasing time, found {t} after {last}")));
        }
        last = t;
        let pos = LatLon::new(row[0], row[1]);
        if !pos.is_valid() {
            return Err(InputError::array(root, gv_name, format!("row {i}: expected lat/lon in range, found {}, {}", row[0], row[1])));
        }
        events.push(Event::Fix(Fix { t, pos, speed_mps: Some(row[2] as f32), course_deg: Some(row[5] as f32), h_acc_m: None, receiver_spoofing: false }));
    }
    // CAN
    let dbc_path = find_dbc(root)?;
    let text = std::fs::read_to_string(&dbc_path).map_err(|e| InputError::file(&dbc_path, format!("cannot read: {e}")))?;
    let dec = Decoder::new(&text, RAV4_MAP).map_err(|e| InputError::file(&dbc_path, e.to_string()))?;
    let (_, ct) = read_npy::<f64>(root, "CAN/raw_can/t")?;
    let (_, addr) = read_npy::<i64>(root, "CAN/raw_can/address")?;
    let (_, src) = read_npy::<i64>(root, "CAN/raw_can/src")?;
    let (_, data) = read_npy::<Vec<u8>>(root, "CAN/raw_can/data")?;
    if addr.len() != ct.len() || src.len() != ct.len() || data.len() != ct.len() {
        return Err(InputError::array(root, "CAN/raw_can", format!(
            "expected t, address, src and data of equal length, found {}, {}, {}, {}", ct.len(), addr.len(), src.len(), data.len())));
    }
    for i in 0..ct.len() {
        if src[i] != 0 || !ct[i].is_finite() {
            continue;
        }
        for (sig, v) in dec.decode(addr[i] as u32, &data[i]) {
            events.push(Event::Obs { sig, t: ct[i], v });
        }
    }
    Ok(Replay::new(root, Format::Comma2k19, events, 0))
}
