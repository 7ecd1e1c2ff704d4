//! The alarm frames' way to the bus (`GNSS_GUARD_ALARM` in `profiles/gnss_guard.dbc`), never
//! silently dropped, and the queue the CAN transmitter task empties.
//!
//! - [`AlarmOutbox`] holds alarm frames until the CAN transmitter took them: a new frame merges
//!   into one not yet sent (fired and reasons bits OR-ed, the earliest epoch kept), a frame that
//!   could not be queued is retried and counted, and while the alarm is latched it is repeated
//!   every [`ALARM_REPEAT_S`]. The latch clears only on a clear request frame
//!   ([`crate::can::is_clear_request`]) or a power cycle.
//! - [`TxQueue`] is what the detector task hands the transmitter task: the alarm before the
//!   status pages of [`crate::health`].

use crate::can::ours::*;
use crate::can::Field;
use crate::health::{put, StatusFrames};
use detector_core::fusion::Verdict;

/// A latched alarm is repeated this often, seconds.
pub const ALARM_REPEAT_S: f64 = 1.0;

/// The content of an alarm frame (`GNSS_GUARD_ALARM`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AlarmFrame {
    pub alarm: bool,
    pub fired: u8,
    pub degraded: u8,
    /// The first 16 reasons ([`detector_core::fusion::Reason`]).
    pub reasons: u16,
    /// Reason 16 (supporting): the receiver's own spoofing flag.
    pub receiver_spoofing: bool,
    /// Reasons 17 to 22 (bit 0 = reason 17).
    pub extra_reasons: u8,
    /// Epoch of the earliest verdict merged in (24 bits on the wire).
    pub epoch: u32,
}

impl AlarmFrame {
    pub fn of(v: &Verdict) -> Self {
        AlarmFrame {
            alarm: v.alarm,
            fired: v.fired.0,
            degraded: v.degraded.0,
            reasons: v.reasons.0 as u16,
            receiver_spoofing: v.reasons.contains(detector_core::fusion::Reason::ReceiverSpoofing),
            extra_reasons: ((v.reasons.0 >> 17) & 0x3F) as u8,
            epoch: v.epoch,
        }
    }
    /// `self` with `newer` merged in: nothing either says is lost.
    pub fn merge(self, newer: AlarmFrame) -> Self {
        AlarmFrame {
            alarm: self.alarm || newer.alarm,
            fired: self.fired | newer.fired,
            degraded: newer.degraded,
            reasons: self.reasons | newer.reasons,
            receiver_spoofing: self.receiver_spoofing || newer.receiver_spoofing,
            extra_reasons: self.extra_reasons | newer.extra_reasons,
            epoch: self.epoch,
        }
    }
    pub fn encode(&self) -> (u16, [u8; 8]) {
        let mut d = [0u8; 8];
        put(&ALARM_ALARM, &mut d, self.alarm as u64, 1);
        put(&ALARM_FIRED, &mut d, self.fired as u64, 8);
        put(&ALARM_DEGRADED, &mut d, self.degraded as u64, 8);
        put(&ALARM_REASONS, &mut d, self.reasons as u64, 16);
        put(&ALARM_RECEIVER_SPOOFING, &mut d, self.receiver_spoofing as u64, 1);
        put(&ALARM_EXTRA_REASONS, &mut d, self.extra_reasons as u64, 6);
        put(&ALARM_EPOCH, &mut d, (self.epoch & 0xFF_FFFF) as u64, 24);
        (ALARM_ID, d)
    }
    pub fn decode(id: u16, data: &[u8]) -> Option<Self> {
        if id != ALARM_ID {
            return None;
        }
        let raw = |f: &Field| f.raw(data).map(|v| v as u64);
        Some(AlarmFrame {
            alarm: raw(&ALARM_ALARM)? != 0,
            fired: raw(&ALARM_FIRED)? as u8,
            degraded: raw(&ALARM_DEGRADED)? as u8,
            reasons: raw(&ALARM_REASONS)? as u16,
            receiver_spoofing: raw(&ALARM_RECEIVER_SPOOFING)? != 0,
            extra_reasons: raw(&ALARM_EXTRA_REASONS)? as u8,
            epoch: raw(&ALARM_EPOCH)? as u32,
        })
    }
}

/// Alarm frames waiting for the CAN transmitter. See the module documentation.
#[derive(Clone, Copy, Debug, Default)]
pub struct AlarmOutbox {
    pending: Option<AlarmFrame>,
    latched: Option<AlarmFrame>,
    last_sent_t: Option<f64>,
    /// Frames merged into one not yet sent.
    pub merged: u32,
    /// Frames the transmitter could not take at once (retried).
    pub retries: u32,
    /// Frames handed to the transmitter.
    pub sent: u32,
}

impl AlarmOutbox {
    /// Every verdict: a strategy fired, or the alarm latched, makes a frame.
    pub fn on_verdict(&mut self, v: &Verdict) {
        let f = AlarmFrame::of(v);
        if !v.fired.is_empty() || (v.alarm && self.latched.is_none()) {
            self.pending = Some(match self.pending {
                Some(p) => {
                    self.merged = self.merged.saturating_add(1);
                    p.merge(f)
                }
                None => f,
            });
        }
        if v.alarm {
            self.latched = Some(self.latched.map_or(f, |l| l.merge(f)));
        }
    }

    /// The frame to send at `now`: a pending one, else the latched alarm once per
    /// [`ALARM_REPEAT_S`]. Hand it to the transmitter, then report [`AlarmOutbox::sent`] or
    /// [`AlarmOutbox::failed`].
    pub fn next(&mut self, now: f64) -> Option<AlarmFrame> {
        if self.pending.is_some() {
            return self.pending.take();
        }
        let l = self.latched?;
        let due = self.last_sent_t.is_none_or(|t| now < t || now - t >= ALARM_REPEAT_S || (now - t).is_nan());
        due.then_some(AlarmFrame { fired: 0, ..l })
    }

    /// The transmitter took the frame at `now`.
    pub fn sent(&mut self, now: f64) {
        self.sent = self.sent.saturating_add(1);
        self.last_sent_t = Some(now);
    }

    /// The transmitter could not take `f`: it goes back, merged with anything newer.
    pub fn failed(&mut self, f: AlarmFrame) {
        self.retries = self.retries.saturating_add(1);
        self.pending = Some(match self.pending {
            Some(p) => f.merge(p),
            None => f,
        });
    }

    /// The clear request: the latch and anything pending are dropped.
    pub fn clear(&mut self) {
        self.pending = None;
        self.latched = None;
    }

    pub fn latched(&self) -> bool {
        self.latched.is_some()
    }
}

/// A frame for the CAN transmitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TxFrame {
    Alarm(AlarmFrame),
    Status((u16, [u8; 8])),
}

impl TxFrame {
    pub fn encode(&self) -> (u16, [u8; 8]) {
        match self {
            TxFrame::Alarm(a) => a.encode(),
            TxFrame::Status(f) => *f,
        }
    }
}

/// Frames waiting for the CAN transmitter task (the detector task fills it, the transmitter
/// empties it): the alarm before the status pages. A newer alarm merges into a queued one;
/// newer status frames replace older ones (they carry fresher numbers); a frame the
/// transmitter could not take goes back, the alarm merged with anything newer.
#[derive(Clone, Debug)]
pub struct TxQueue {
    alarm: Option<AlarmFrame>,
    status: heapless::Deque<(u16, [u8; 8]), 3>,
    /// Status frames replaced before they were sent.
    pub status_replaced: u32,
    /// Alarm frames that went back (the mailboxes were full).
    pub alarm_retries: u32,
}

impl TxQueue {
    pub const fn new() -> Self {
        TxQueue { alarm: None, status: heapless::Deque::new(), status_replaced: 0, alarm_retries: 0 }
    }
    pub fn push_alarm(&mut self, f: AlarmFrame) {
        self.alarm = Some(self.alarm.map_or(f, |q| q.merge(f)));
    }
    pub fn push_status(&mut self, frames: StatusFrames) {
        self.status_replaced = self.status_replaced.saturating_add(self.status.len() as u32);
        self.status.clear();
        for f in frames {
            let _ = self.status.push_back(f);
        }
    }
    /// The next frame to transmit.
    pub fn pop(&mut self) -> Option<TxFrame> {
        if let Some(a) = self.alarm.take() {
            return Some(TxFrame::Alarm(a));
        }
        self.status.pop_front().map(TxFrame::Status)
    }
    /// The transmitter could not take `f`.
    pub fn give_back(&mut self, f: TxFrame) {
        match f {
            TxFrame::Alarm(a) => {
                self.alarm_retries = self.alarm_retries.saturating_add(1);
                self.alarm = Some(self.alarm.map_or(a, |newer| a.merge(newer)));
            }
            TxFrame::Status(s) => {
                if self.status.is_full() {
                    self.status_replaced = self.status_replaced.saturating_add(1);
                } else {
                    let _ = self.status.push_front(s);
                }
            }
        }
    }
    pub fn is_empty(&self) -> bool {
        self.alarm.is_none() && self.status.is_empty()
    }
}

impl Default for TxQueue {
    fn default() -> Self {
        TxQueue::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::tests::verdict;
    use crate::health::Health;
    use detector_core::strategy::StrategyId;

    #[test]
    fn alarm_frames_are_merged_retried_repeated_and_cleared_only_on_request() {
        let mut o = AlarmOutbox::default();
        o.on_verdict(&verdict(10, None, false));
        assert_eq!(o.next(1.0), None, "nothing fired, nothing latched");
        o.on_verdict(&verdict(11, Some(StrategyId::LocationShift), true));
        o.on_verdict(&verdict(12, Some(StrategyId::Motion), true));
        // Two frames before the transmitter got one: merged, nothing lost.
        let f = o.next(1.1).unwrap();
        assert_eq!((f.alarm, f.fired, f.epoch), (true, 0b101, 11));
        assert_eq!(o.merged, 1);
        // The transmitter's mailboxes are full: it comes back, merged with what came since.
        o.failed(f);
        o.on_verdict(&verdict(13, Some(StrategyId::Track), true));
        let f = o.next(1.2).unwrap();
        assert_eq!((f.fired, f.epoch), (0b1101, 11));
        assert_eq!(o.retries, 1);
        o.sent(1.2);
        // Latched: repeated once a second, not more often.
        assert_eq!(o.next(1.5), None);
        let r = o.next(2.2).unwrap();
        assert!(r.alarm && r.fired == 0);
        o.sent(2.2);
        assert_eq!(o.next(2.5), None);
        assert!(o.next(3.3).is_some());
        // Round trip through the DBC fields.
        let (id, d) = f.encode();
        assert_eq!(AlarmFrame::decode(id, &d), Some(f));
        // Only the clear request ends it.
        let mut q = TxQueue::default();
        q.push_status(Health::default().status_due(0.0).unwrap());
        q.push_alarm(AlarmFrame { alarm: true, fired: 1, degraded: 0, reasons: 1, receiver_spoofing: false, extra_reasons: 0, epoch: 5 });
        // The alarm goes first; when the mailboxes are full it comes back merged with a newer one.
        let first = q.pop().unwrap();
        assert!(matches!(first, TxFrame::Alarm(_)));
        q.push_alarm(AlarmFrame { alarm: true, fired: 4, degraded: 0, reasons: 4, receiver_spoofing: true, extra_reasons: 4, epoch: 6 });
        q.give_back(first);
        assert_eq!(q.pop(), Some(TxFrame::Alarm(AlarmFrame { alarm: true, fired: 5, degraded: 0, reasons: 5, receiver_spoofing: true, extra_reasons: 4, epoch: 5 })));
        assert_eq!(q.alarm_retries, 1);
        for _ in 0..3 {
            assert!(matches!(q.pop(), Some(TxFrame::Status(_))));
        }
        assert!(q.is_empty());
        o.clear();
        assert_eq!(o.next(10.0), None);
        assert!(!o.latched());
    }
}
