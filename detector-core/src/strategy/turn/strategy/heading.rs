//! The GNSS-only heading check: over a window with no steering segment, GNSS turned by more
//! than `straight_turn_deg` beyond the course change the steering implies (the wheel did not do
//! that turn). A child of `strategy`, whose state it reads; see the [turn module's
//! documentation](crate::strategy::turn).

use super::{TurnMismatch, TurnOutcome, TurnStrategy, VEHICLE_LATE_S};
use crate::strategy::turn::segmenter::TICK_S;
use crate::wire::templates::{TurnClass, QUERY_LEN};

/// The heading check judges a window only when the car covered this much in it, metres: at
/// walking pace a receiver whose position wanders by metres in town (a smooth 6.5 m error)
/// turns its bearings by 90 degrees.
const HEADING_MIN_TRAVEL_M: f32 = 30.0;
/// ... and stayed above this speed all through it, m/s, by the wheels and by the GNSS itself
/// (slowing to a stop, the bearings of such a receiver swing by tens of degrees).
const HEADING_MIN_SPEED_MPS: f32 = 5.0;

/// The heading check's `now` window ends this long before the newest tick, seconds. It judges
/// alone while the wheel is straight, on the premise that a turn's recorded steering passes
/// `settle_deg` before its course turns; that lead is short on a car whose vehicle signals are
/// already late (sddi_commuter, 1.1 s late: at 63.0 s of `nl_20210217_072036` the wheel reads
/// 12.8 deg, 49 deg at 63.5 s, while the GNSS course turns 22 deg between the fixes at 62.6 and
/// 63.5 s), so a little more delay puts the course first. The nuisance suite's vehicle-late on
/// that car (its own 1.1 s plus 0.2 to 1.5 s) did: seed 5's false alarm, the course turned by
/// 66 deg at the newest fix with the steering still on its way. Ending the window 1 s earlier
/// lets the steering arrive first: a sharp turn at 5.5 m/s with its steering 1.8 or 2.2 s late
/// fired it before, and no longer does (`a_sharp_turn_whose_steering_arrives_late_is_no_gnss_only_turn`
/// in `tests/turns.rs`); every `now` detection comes 1 s later.
const NOW_LAG_S: f32 = 1.0;

/// The course change the steering implies (the bicycle model's, at the configured ratio and
/// wheelbase) is a car's own only up to a factor: steering ratios run from 12 to 20, racks of
/// variable ratio are quicker off centre, and understeer at speed takes some of it. The
/// sddi_commuter car's turns of 49 to 103 deg read as 39 to 58 deg at ratio 15, so a turn whose
/// steering stays under `start_deg` is `held`'s to judge and its GNSS course runs ahead of the
/// model by tens of degrees (0.62 of the threshold at 2204 s of `nl_20210215_170017`), and a
/// receiver's wander of 7 m in town adds the rest (nuisance seeds 429032188 and 433032302: 68
/// and 63 deg). The GNSS course turning the way the steering does, by once to twice the
/// model's change, is the steering's turn: only the part beyond that band counts. Not below
/// once: from half, a GNSS turn mirrored against the steering's counts a quarter less, and
/// `eval` lost a wrong turn (91 -> 90; 88 with the straight-wheel window widened too).
const IMPLIED_GAIN: (f32, f32) = (1.0, 2.0);

/// How far the GNSS course change `ch` lies beyond the steering's implied change `implied`
/// taken at every gain of [`IMPLIED_GAIN`], degrees (NaN where either is).
fn beyond_implied(ch: f32, implied: f32) -> f32 {
    let (a, b) = (IMPLIED_GAIN.0 * implied, IMPLIED_GAIN.1 * implied);
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    if ch < lo {
        lo - ch
    } else if ch > hi {
        ch - hi
    } else if ch <= hi {
        0.0
    } else {
        // Unknown (NaN) course or steering: no judgement.
        f32::NAN
    }
}

/// The ticks the heading check looks back over at most (its window, margins and the vehicle
/// signals' lag: 64 with the defaults).
const HEADING_TICKS: usize = 80;

/// Whole 5 Hz ticks in `s` seconds.
fn ticks_of(s: f32) -> usize {
    (s / TICK_S as f32 + 1e-3) as usize
}

impl TurnStrategy<'_> {
    /// Over the last `heading_window_s` of driving (every tick at known steering and at least
    /// `min_speed_mps`), GNSS turned by more than `straight_turn_deg` beyond what the steering
    /// implies: the wheel did not do that turn.
    pub(super) fn gnss_only_check(&mut self, derived: bool) -> Option<TurnOutcome> {
        let c = self.cfg;
        let last = *self.seg.ticks().next_back()?;
        let newest = self.seg.len().checked_sub(1)?;
        // Ages in ticks (the ring holds consecutive ticks TICK_S apart since its restart):
        // integer comparisons instead of a soft-float subtraction per tick on the Cortex-M4.
        let span = ticks_of(c.heading_window_s);
        let margin = ticks_of(c.heading_margin_s());
        let late = ticks_of(VEHICLE_LATE_S);
        let lag = ticks_of(NOW_LAG_S);
        let total = (late.max(lag) + span + margin).min(HEADING_TICKS - 1);
        // Two windows of GNSS course, each `span` ticks:
        // - `now`, ending `lag` ticks ago, judged while the wheel stays straight (below
        //   `settle_deg`) over it, the margin before it and the ticks since: a late steering
        //   signal cannot hide a turn there, since a turn's steering passes `settle_deg` before
        //   its course passes `straight_turn_deg` (by `NOW_LAG_S` more than the car's own
        //   lead);
        // - `held`, ending `late` ticks ago so that its steering has arrived when the vehicle
        //   signals are late, judged while no steering segment runs (the wheel below
        //   `start_deg`: its turn is the bicycle model's to imply).
        let held_end = newest.checked_sub(late)?;
        let (mut now_ok, mut held_ok) = (true, true);
        let (mut now_travel, mut held_travel, mut now_implied) = (0.0f32, 0.0f32, 0.0f32);
        let min_speed = HEADING_MIN_SPEED_MPS.max(c.min_speed_mps);
        let now_last = lag + span + margin;
        for (age, t) in self.seg.ticks().rev().take(total + 1).enumerate() {
            // Moving while the GNSS course is read (at walking pace a 1 Hz receiver's bearings
            // swing), by the wheels and by the GNSS's own speed (late wheels still read the
            // speed before the car braked); unknown (NaN) steering or wheel speed fails too, an
            // unknown GNSS speed (no step yet) does not.
            let moving = t.speed >= min_speed && t.gnss_speed.partial_cmp(&min_speed) != Some(core::cmp::Ordering::Less);
            let a = libm::fabsf(t.steer);
            if now_ok {
                if !(a < c.settle_deg && moving) {
                    now_ok = false;
                } else if age == now_last {
                    // The wheel straight all through: `now` judges alone (see below), and `held`,
                    // whose older ticks are left unread, does not.
                    held_ok = false;
                    break;
                }
            }
            if held_ok && !(a < c.start_deg && (moving || age < late)) {
                held_ok = false;
            }
            if !(now_ok || held_ok) {
                return None;
            }
            // A tick's distance and turn come after it: the window's last tick adds none.
            if age > lag && age <= lag + span {
                now_travel += t.speed;
                now_implied += t.implied_deg;
            }
            if age > late && age <= late + span {
                held_travel += t.speed;
            }
        }
        let (now_travel, held_travel) = (now_travel * TICK_S as f32, held_travel * TICK_S as f32);
        let history = (last.t - self.seg.ticks().next()?.t) as f32;
        let settled = |extra: f32| history >= extra + c.heading_window_s + c.heading_margin_s() - 0.5;
        // Travel too short (or unknown) for the bearings to mean anything fails a window.
        now_ok &= settled(NOW_LAG_S) && now_travel >= HEADING_MIN_TRAVEL_M;
        held_ok &= settled(VEHICLE_LATE_S) && held_travel >= HEADING_MIN_TRAVEL_M;
        let (mut change, mut implied, mut beyond, mut from, mut end) = (0.0f32, now_implied, 0.0f32, 0usize, newest);
        let mut held_best = 0.0f32;
        if now_ok {
            let to = newest.checked_sub(lag)?;
            from = to.checked_sub(span)?;
            end = to;
            change = self.seg.course_change(from, to);
            beyond = libm::fabsf(change - implied);
        }
        // With the wheel straight all through, `now` has judged: a late signal changes nothing.
        if held_ok && !now_ok {
            // Compared with the steering's window shifted either way by the lags allowed (the
            // vehicle signals up to `late` ticks late: younger; the GNSS up to the margin:
            // older); the closest of them counts.
            let (f, e) = (held_end.checked_sub(span)?, held_end);
            let ch = self.seg.course_change(f, e);
            // Per age, the course change the steering implies over the tick (bicycle model).
            let mut implied_at = [0.0f32; HEADING_TICKS];
            for (v, t) in implied_at.iter_mut().zip(self.seg.ticks().rev()).take(total + 1) {
                *v = t.implied_deg;
            }
            // The steering's implied change over `span` ticks from age `lo` on.
            let sum = |lo: usize| implied_at.iter().skip(lo).take(span).sum::<f32>();
            let mut run = sum(1);
            let mut best = f32::INFINITY;
            for lo in 1..=total.saturating_sub(span) + 1 {
                if lo > 1 {
                    run += implied_at.get(lo + span - 1).copied().unwrap_or(0.0) - implied_at.get(lo - 1).copied().unwrap_or(0.0);
                }
                best = best.min(beyond_implied(ch, run));
            }
            held_best = best;
            if best > c.straight_turn_deg {
                (change, implied, beyond, from, end) = (ch, sum(late + 1), best, f, e);
            }
        }
        // How near it came, for the record (`heading_share`): `held` judged against the
        // closest of its shifted windows.
        let judged = if now_ok { Some(beyond) } else { held_ok.then_some(held_best) };
        if let Some(b) = judged.filter(|b| b.is_finite()) {
            let share = b / c.straight_turn_deg.max(1e-3);
            self.heading_share = Some(self.heading_share.map_or(share, |s| s.max(share)));
        }
        let (first, window_end) = (self.seg.tick(from)?, self.seg.tick(end)?);
        // One alarm per window.
        if beyond > c.straight_turn_deg && last.t - self.last_gnss_only_alarm_t > c.heading_window_s as f64 {
            self.last_gnss_only_alarm_t = last.t;
            return Some(TurnOutcome {
                steering: TurnClass::None,
                distance: 0.0,
                gnss_change_deg: change,
                steering_change_deg: implied,
                mismatch: Some(TurnMismatch::GnssTurnWheelStraight),
                derived,
                query: [0.0; QUERY_LEN],
                start_t: first.t,
                end_t: window_end.t,
            });
        }
        None
    }
}
