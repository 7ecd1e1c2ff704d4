//! GNSS fixes from CAN: a receiver that reports on the bus (a logger's, as CSS's CANedge and
//! CANmod.gps do, or a car's own head unit). The map names which DBC signals carry the fix's
//! fields (`gnss_lat`, `gnss_lon`, `gnss_speed`, `gnss_course`, `gnss_h_acc`, `gnss_valid`;
//! see `gnss_guard_profile::load`).
//!
//! A receiver sends one epoch's fields in several messages a few milliseconds apart (the
//! CANedge: position, then speed 1.6 ms later, then attitude). The message that carries the
//! latitude makes the epoch, at its frame's time; every other field is taken from the frame
//! nearest to it within [`EPOCH_WINDOW_S`] (and within half the interval between position
//! messages, so no field is borrowed from the next epoch). A fix whose valid flag (where the map
//! has one) is 0, or whose position is out of range, is dropped: a receiver without a fix sends
//! placeholder coordinates.

use super::candump::CanFrame;
use detector_core::geo::LatLon;
use detector_core::sample::Fix;
use gnss_guard_profile::{decode_gnss, GnssField, GnssMapped};

/// The farthest a field's frame may be from its epoch's position frame, seconds.
pub const EPOCH_WINDOW_S: f64 = 0.25;

/// The fixes `frames` (in time order) carry under `gnss` mappings, in time order.
pub fn fixes_from_can(frames: &[CanFrame], gnss: &[GnssMapped]) -> Vec<Fix> {
    let mut a = Assembler::new(gnss.to_vec());
    let mut out = Vec::new();
    for f in frames {
        out.extend(a.push(f));
    }
    out.extend(a.finish());
    out
}

/// Fixes assembled from frames as they come (`host-sim live`; [`fixes_from_can`] over a log is
/// this same assembler, so both give the same fixes). An epoch is complete once the stream has
/// passed its position frame by twice [`EPOCH_WINDOW_S`]: by then the next position frame, which
/// bounds its window, has come if it is near.
pub struct Assembler {
    gnss: Vec<GnssMapped>,
    has_valid: bool,
    /// Decoded fields of the last seconds, in time order.
    events: std::collections::VecDeque<(f64, GnssField, f64)>,
    /// The last completed epoch's time (it bounds the next one's window).
    prev_lat_t: Option<f64>,
}

impl Assembler {
    /// An assembler for these mappings.
    pub fn new(gnss: Vec<GnssMapped>) -> Self {
        let has_valid = gnss.iter().any(|g| g.target == GnssField::Valid);
        Assembler { gnss, has_valid, events: Default::default(), prev_lat_t: None }
    }

    /// One frame (frames in time order): the fixes it completes.
    pub fn push(&mut self, f: &CanFrame) -> Vec<Fix> {
        let out = self.complete_before(f.t - 2.0 * EPOCH_WINDOW_S);
        for (field, v) in decode_gnss(&self.gnss, f.id, f.extended, f.bus(), &f.data) {
            self.events.push_back((f.t, field, v));
        }
        out
    }

    /// The end of the stream: the fixes still open.
    pub fn finish(mut self) -> Vec<Fix> {
        self.complete_before(f64::INFINITY)
    }

    /// Completes every epoch whose position frame is before `until`, and forgets what no open
    /// epoch can need any more.
    fn complete_before(&mut self, until: f64) -> Vec<Fix> {
        let mut out = Vec::new();
        while let Some(k) = self.events.iter().position(|e| e.1 == GnssField::Lat) {
            let (t, _, lat) = self.events[k];
            if t >= until {
                break;
            }
            let next = self.events.iter().skip(k + 1).find(|e| e.1 == GnssField::Lat && e.0 > t).map_or(f64::INFINITY, |n| n.0 - t);
            let prev = self.prev_lat_t.map_or(f64::INFINITY, |p| t - p);
            let w = EPOCH_WINDOW_S.min(0.5 * prev.min(next));
            if let Some(fix) = self.fix_at(t, lat, w) {
                out.push(fix);
            }
            self.prev_lat_t = Some(t);
            // This latitude is done; events older than the next epoch's widest window go.
            self.events.remove(k);
            while self.events.front().is_some_and(|e| e.0 < t - EPOCH_WINDOW_S) {
                self.events.pop_front();
            }
        }
        while self.events.front().is_some_and(|e| e.0 < until - 2.0 * EPOCH_WINDOW_S && e.1 != GnssField::Lat) {
            self.events.pop_front();
        }
        out
    }

    fn fix_at(&self, t: f64, lat: f64, w: f64) -> Option<Fix> {
        let near = |field: GnssField| -> Option<f64> {
            self.events
                .iter()
                .filter(|e| e.1 == field && (e.0 - t).abs() <= w)
                .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()).then(a.0.total_cmp(&b.0)))
                .map(|e| e.2)
        };
        let lon = near(GnssField::Lon)?;
        if self.has_valid && near(GnssField::Valid).is_none_or(|v| v == 0.0) {
            return None;
        }
        let pos = LatLon::new(lat, lon);
        if !pos.is_valid() || (lat == 0.0 && lon == 0.0) {
            return None;
        }
        let f32_of = |v: Option<f64>| v.map(|x| x as f32).filter(|x| x.is_finite());
        Some(Fix {
            t,
            pos,
            speed_mps: f32_of(near(GnssField::Speed)),
            course_deg: f32_of(near(GnssField::Course)),
            h_acc_m: f32_of(near(GnssField::HAcc)).filter(|a| *a > 0.0),
            receiver_spoofing: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gnss_guard_profile::Field;

    fn map(id: u32, start: u16, size: u8, factor: f64, target: GnssField) -> GnssMapped {
        GnssMapped { id, extended: false, bus: None, field: Field::new(start, size, false, false, factor, 0.0), mux: None, target, factor: 1.0 }
    }

    fn frame(t: f64, id: u32, data: Vec<u8>) -> CanFrame {
        CanFrame { t, iface: "can0".into(), id, extended: false, data }
    }

    #[test]
    fn an_epoch_is_its_position_frame_with_the_fields_around_it() {
        // Position (lat, lon as 32-bit 1e-7 deg) on 0x10, valid flag on 0x10 byte 0 bit 0 of a
        // third message, speed (0.01 m/s) on 0x11 a few ms later.
        let gnss = [
            map(0x10, 0, 32, 1e-7, GnssField::Lat),
            map(0x10, 32, 32, 1e-7, GnssField::Lon),
            map(0x11, 0, 16, 0.01, GnssField::Speed),
            map(0x12, 0, 1, 1.0, GnssField::Valid),
        ];
        let pos = |lat: f64, lon: f64| {
            let mut d = ((lat * 1e7) as u32).to_le_bytes().to_vec();
            d.extend(((lon * 1e7) as u32).to_le_bytes());
            d
        };
        let frames = vec![
            frame(0.0, 0x12, vec![0]),
            frame(0.001, 0x10, pos(48.1, 11.5)), // not valid yet: dropped
            frame(0.003, 0x11, vec![0, 0]),
            frame(1.0, 0x12, vec![1]),
            frame(1.001, 0x10, pos(48.1000100, 11.5)),
            frame(1.0026, 0x11, 1234u16.to_le_bytes().to_vec()),
            frame(2.0, 0x12, vec![1]),
            frame(2.001, 0x10, pos(0.0, 0.0)), // a placeholder: dropped
        ];
        let fixes = fixes_from_can(&frames, &gnss);
        assert_eq!(fixes.len(), 1);
        let f = fixes[0];
        assert_eq!(f.t, 1.001);
        assert!((f.pos.lat_deg - 48.10001).abs() < 1e-7 && (f.pos.lon_deg - 11.5).abs() < 1e-7, "{:?}", f.pos);
        assert_eq!(f.speed_mps, Some(12.34));
        assert_eq!(f.course_deg, None);
    }

    #[test]
    fn a_field_is_never_borrowed_from_the_next_epoch_and_streaming_is_the_log() {
        // Position at 10 Hz; speed 90 ms after each position: nearer the next epoch (10 ms).
        let gnss = [map(0x10, 0, 32, 1e-7, GnssField::Lat), map(0x10, 32, 32, 1e-7, GnssField::Lon), map(0x11, 0, 16, 0.01, GnssField::Speed)];
        let mut frames = Vec::new();
        for k in 0..20u32 {
            let t = f64::from(k) * 0.1;
            let mut d = Vec::new();
            d.extend((((48.0 + f64::from(k) * 1e-5) * 1e7).round() as u32).to_le_bytes());
            d.extend(((11.0f64 * 1e7) as u32).to_le_bytes());
            frames.push(frame(t, 0x10, d));
            frames.push(frame(t + 0.09, 0x11, (k as u16 * 100).to_le_bytes().to_vec()));
        }
        let batch = fixes_from_can(&frames, &gnss);
        assert_eq!(batch.len(), 20);
        // Each epoch's window is half the 0.1 s interval: its own speed frame (90 ms later) is
        // outside it, and the previous one's (10 ms earlier) is the nearest inside.
        assert_eq!(batch[0].speed_mps, None);
        assert_eq!(batch[5].speed_mps, Some(4.0));
        // Frame by frame, as live feeds it: the same fixes.
        let mut a = Assembler::new(gnss.to_vec());
        let mut live = Vec::new();
        for f in &frames {
            live.extend(a.push(f));
        }
        live.extend(a.finish());
        assert_eq!(live, batch);
    }
}
