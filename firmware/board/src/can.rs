//! CAN decoding from the vehicle profile's DBC, and our own messages from `profiles/gnss_guard.dbc`
//! (see `build.rs`; the status and alarm frames are made in [`crate::health`]).

use detector_core::sample::Signal;
pub use gnss_guard_profile::{Field, Mapped};

include!(concat!(env!("OUT_DIR"), "/profile.rs"));

/// Every detector signal carried by one frame, in our units (at most one per mapping).
pub fn decode(id: u32, data: &[u8]) -> impl Iterator<Item = (Signal, f32)> + '_ {
    gnss_guard_profile::decode(SIGNALS, id, false, None, data)
}

/// Is this standard id one the profile needs, or our clear request (what the hardware filters
/// accept)?
pub fn wanted(id: u32) -> bool {
    id == ours::CLEAR_ID as u32 || FILTER_IDS.iter().any(|&f| f as u32 == id)
}

/// Encodes a detector value into the profile's frame for `signal` (used to synthesise frames
/// for the simulated drive). Returns the id, or `None` when the profile has no such signal.
pub fn encode(signal: Signal, value: f32, data: &mut [u8; 8]) -> Option<u32> {
    let m = SIGNALS.iter().find(|m| m.signal == signal)?;
    m.field.put(data, value as f64 / m.factor).then_some(m.id)
}

/// The key a clear request must carry (`GNSS_GUARD_CLEAR.KEY`).
pub const CLEAR_KEY: i64 = 0xC1EA;

/// Is this frame our clear request (the only thing that clears a latched alarm)?
pub fn is_clear_request(id: u32, data: &[u8]) -> bool {
    id == ours::CLEAR_ID as u32 && ours::CLEAR_KEY.raw(data) == Some(CLEAR_KEY)
}

/// A clear request frame.
pub fn clear_request() -> (u16, [u8; 8]) {
    request(CLEAR_KEY)
}

/// The key a relearn request must carry (`GNSS_GUARD_CLEAR.KEY`): the stored calibration is
/// forgotten and the car learnt afresh (after a tyre change; never done silently).
pub const RELEARN_KEY: i64 = 0xCA1B;

/// Is this frame our relearn request?
pub fn is_relearn_request(id: u32, data: &[u8]) -> bool {
    id == ours::CLEAR_ID as u32 && ours::CLEAR_KEY.raw(data) == Some(RELEARN_KEY)
}

/// A relearn request frame.
pub fn relearn_request() -> (u16, [u8; 8]) {
    request(RELEARN_KEY)
}

fn request(key: i64) -> (u16, [u8; 8]) {
    let mut d = [0u8; 8];
    let _ = ours::CLEAR_KEY.put_raw(&mut d, key);
    (ours::CLEAR_ID, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_profile_decodes_known_frames() {
        // SPEED 0xB4: 0x1234 * 0.01 km/h at bytes 5..6
        let got: heapless::Vec<_, 2> = decode(0xB4, &[0, 0, 0, 0, 0, 0x12, 0x34, 0]).collect();
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].0, Signal::WheelSpeed);
        assert!((got[0].1 - 46.60 / 3.6).abs() < 1e-3);
        assert!(wanted(0x25) && !wanted(0x123));
        assert!(decode(0xB4, &[0, 0]).next().is_none(), "short frame: no value, no panic");
    }

    #[test]
    fn encode_round_trips_every_signal() {
        for (sig, v) in [(Signal::WheelSpeed, 13.5f32), (Signal::Steering, -121.5), (Signal::Pedal, 35.0), (Signal::YawRate, -7.32), (Signal::LongAccel, 1.25)] {
            let mut d = [0u8; 8];
            let id = encode(sig, v, &mut d).unwrap();
            let back: heapless::Vec<_, 2> = decode(id, &d).collect();
            assert_eq!(back[0].0, sig);
            assert!((back[0].1 - v).abs() < 0.3, "{sig:?}: {v} -> {}", back[0].1);
        }
    }

    #[test]
    fn our_frames_layout() {
        let f = ours::ALARM_FIRED;
        let mut d = [0u8; 8];
        assert!(f.put_raw(&mut d, 5));
        assert_eq!(d[1], 5);
        assert_eq!(f.raw(&d), Some(5));
        let (id, d) = clear_request();
        assert!(is_clear_request(id as u32, &d) && wanted(id as u32));
        assert!(!is_clear_request(id as u32, &[0, 0]), "a wrong key clears nothing");
        assert!(!is_clear_request(id as u32, &[]), "a short frame clears nothing");
    }
}
