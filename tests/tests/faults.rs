//! Sensor faults on real drives. Expected behaviour, asserted for each fault:
//! - the strategies that lose their inputs are degraded and the verdict says so (reason codes);
//! - the fault alone raises no alarm;
//! - after recovery, a real attack (a 200 m position jump) is still detected;
//! - nothing panics.
//!
//! | fault | expected |
//! |---|---|
//! | GNSS outage 1 to 30 s | epochs over 3 s are a time discontinuity: all strategies restart, no alarm |
//! | time jumps forward / backward | a discontinuity (forward) or a clock reset (backward, > 5 s): restart, no alarm |
//! | duplicated / out-of-order epochs | dropped and counted by the synchroniser, no alarm |
//! | wheel-speed frames stop | S1 and S3 degraded (`no_prediction`, `no_motion_inputs`) while stale, no alarm |
//! | steering stuck at a constant | after 10 s unchanged while moving, S2 degraded (`no_turn_inputs`), no alarm |
//! | bursts of NaN | dropped and counted, no alarm |
//! | receiver rate 10 Hz -> 1 Hz | S1's error term scales with the epoch length, no alarm |

use detector_core::fusion::{Config, Reason, Verdict};
use detector_core::geo::{destination, EARTH_RADIUS_PAPER_M};
use detector_core::sample::Signal;
use detector_core::strategy::StrategyId;
use detector_core::sync::SyncConfig;
use host_sim::input::{self, Event, LoadOptions, Replay};
use host_sim::{detect, replay};
use system_tests::data_dir;

const CSS: &str = "drives/css_canedge/denmark_2021-07-26_session0.csv";
const COMMA: &str = "drives/comma2k19/b0c9d2329ad1606b_2018-08-02--08-34-47_seg40.csv";
const OPENXC: &str = "drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv";

fn load(rel: &str) -> Option<Replay> {
    let d = data_dir(rel)?;
    Some(input::load(&d.join(rel), &LoadOptions::default()).unwrap())
}

/// Runs the full detector over `events` in the given order (no re-sorting: faults may reorder).
fn run(base: &Replay, events: Vec<Event>) -> Vec<Verdict> {
    let r = Replay { events, ..base.clone() };
    let (s, _) = replay::synchronize(&r, SyncConfig::default());
    let profile = detect::profile_of(&replay::synchronize(base, SyncConfig::default()).0);
    detect::run(&s, Config::for_profile(profile))
}

fn t0(r: &Replay) -> f64 {
    r.events[0].t()
}

/// A 200 m jump of every fix from `onset` on (what a spoofer would do).
fn jump(events: &mut [Event], onset: f64) {
    for e in events.iter_mut() {
        if let Event::Fix(f) = e {
            if f.t >= onset {
                f.pos = destination(f.pos, 90.0, 200.0, EARTH_RADIUS_PAPER_M);
            }
        }
    }
}

fn assert_clean(v: &[Verdict], what: &str) {
    let fired: Vec<_> = v.iter().filter(|x| !x.fired.is_empty()).map(|x| (x.t, x.fired, x.reasons)).collect();
    assert!(fired.is_empty(), "{what}: the fault alone raised {fired:?}");
}

fn detected_after(v: &[Verdict], onset: f64, within_s: f64) -> bool {
    v.iter().any(|x| x.t >= onset && x.t <= onset + within_s && x.fired.contains(StrategyId::LocationShift))
}

#[test]
fn gnss_outage_then_recovery() {
    for rel in [CSS, COMMA] {
        let Some(r) = load(rel) else { return };
        let t = t0(&r) + 10.0;
        for dur in [1.0, 5.0, 30.0] {
            let ev: Vec<Event> = r.events.iter().filter(|e| !(matches!(e, Event::Fix(f) if f.t >= t && f.t < t + dur))).copied().collect();
            let v = run(&r, ev.clone());
            assert_clean(&v, &format!("{rel} outage {dur} s"));
            if dur > 3.0 {
                assert!(v.iter().any(|x| x.reasons.contains(Reason::TimeDiscontinuity)), "{rel} {dur}");
            }
            let back = v.iter().filter(|x| x.t > t + dur + 2.0).take(3).all(|x| x.ran.contains(StrategyId::LocationShift));
            assert!(back, "{rel} outage {dur} s: S1 runs again after recovery");
            let mut ev = ev;
            let onset = t + dur + 5.0;
            jump(&mut ev, onset);
            assert!(detected_after(&run(&r, ev), onset, 2.0), "{rel} outage {dur} s: attack after recovery");
        }
    }
}

#[test]
fn time_jumps_forward_and_backward() {
    for rel in [CSS, COMMA] {
        let Some(r) = load(rel) else { return };
        let t = t0(&r) + 20.0;
        for shift in [100.0, -50.0] {
            let ev: Vec<Event> = r.events.iter().map(|e| {
                let mut e = *e;
                match &mut e {
                    Event::Fix(f) if f.t >= t => f.t += shift,
                    Event::Obs { t: ot, .. } if *ot >= t => *ot += shift,
                    _ => {}
                }
                e
            }).collect();
            let v = run(&r, ev.clone());
            assert_clean(&v, &format!("{rel} time jump {shift} s"));
            assert!(v.iter().any(|x| x.reasons.contains(Reason::TimeDiscontinuity)), "{rel} jump {shift}: said so");
            let mut ev = ev;
            let onset = t + shift + 20.0;
            jump(&mut ev, onset);
            assert!(detected_after(&run(&r, ev), onset, 2.0), "{rel} jump {shift}: attack afterwards");
        }
    }
}

#[test]
fn duplicated_and_out_of_order_epochs() {
    for rel in [CSS, COMMA] {
        let Some(r) = load(rel) else { return };
        let mut ev = Vec::new();
        let mut k = 0;
        for e in &r.events {
            ev.push(*e);
            if matches!(e, Event::Fix(_)) {
                k += 1;
                if k % 5 == 0 {
                    ev.push(*e); // duplicate
                }
            }
        }
        // Swap some adjacent fixes.
        let fix_idx: Vec<usize> = ev.iter().enumerate().filter(|(_, e)| matches!(e, Event::Fix(_))).map(|(i, _)| i).collect();
        for w in fix_idx.windows(2).step_by(37).take(10) {
            ev.swap(w[0], w[1]);
        }
        let base = Replay { events: ev.clone(), ..r.clone() };
        let (_, counters) = replay::synchronize(&base, SyncConfig::default());
        assert!(counters.fixes_out_of_order > 0, "{rel}: dropped and counted");
        assert_clean(&run(&r, ev), &format!("{rel} duplicates / out of order"));
    }
}

#[test]
fn wheel_speed_frames_stop() {
    for rel in [CSS, COMMA] {
        let Some(r) = load(rel) else { return };
        let t = t0(&r) + 20.0;
        let ev: Vec<Event> = r.events.iter().filter(|e| !matches!(e, Event::Obs { sig: Signal::WheelSpeed, t: ot, .. } if *ot >= t && *ot < t + 20.0)).copied().collect();
        let v = run(&r, ev);
        assert_clean(&v, &format!("{rel} wheel speed stale"));
        let mid: Vec<_> = v.iter().filter(|x| x.t > t + 3.0 && x.t < t + 18.0).collect();
        assert!(!mid.is_empty());
        for x in mid {
            assert!(x.degraded.contains(StrategyId::LocationShift) && x.degraded.contains(StrategyId::Motion), "{rel} at {}", x.t);
            assert!(x.reasons.contains(Reason::NoPrediction) && x.reasons.contains(Reason::NoMotionInputs));
        }
    }
}

#[test]
fn steering_stuck_at_a_constant() {
    for rel in [OPENXC, COMMA] {
        let Some(r) = load(rel) else { return };
        let t = t0(&r) + 10.0;
        let ev: Vec<Event> = r.events.iter().map(|e| match *e {
            Event::Obs { sig: Signal::Steering, t: ot, .. } if ot >= t => Event::Obs { sig: Signal::Steering, t: ot, v: 12.0 },
            o => o,
        }).collect();
        let v = run(&r, ev);
        assert_clean(&v, &format!("{rel} steering stuck"));
        assert!(v.iter().any(|x| x.t > t + 15.0 && x.degraded.contains(StrategyId::Turn) && x.reasons.contains(Reason::NoTurnInputs)), "{rel}: S2 degraded, said so");
    }
}

#[test]
fn bursts_of_nan() {
    for rel in [CSS, COMMA, OPENXC] {
        let Some(r) = load(rel) else { return };
        let t = t0(&r) + 20.0;
        let ev: Vec<Event> = r.events.iter().map(|e| match *e {
            Event::Obs { sig, t: ot, .. } if ot >= t && ot < t + 5.0 => Event::Obs { sig, t: ot, v: f32::NAN },
            Event::Fix(mut f) if f.t >= t + 8.0 && f.t < t + 10.0 => { f.pos.lat_deg = f64::NAN; f.speed_mps = Some(f32::NAN); Event::Fix(f) }
            o => o,
        }).collect();
        let base = Replay { events: ev.clone(), ..r.clone() };
        let (_, c) = replay::synchronize(&base, SyncConfig::default());
        assert!(c.obs_invalid > 0, "{rel}: NaN observations counted");
        assert_clean(&run(&r, ev), &format!("{rel} NaN burst"));
    }
}

#[test]
fn receiver_switches_from_10_to_1_hz() {
    let Some(r) = load(COMMA) else { return };
    let t = t0(&r) + 20.0;
    let mut k = 0;
    let ev: Vec<Event> = r.events.iter().filter(|e| match e {
        Event::Fix(f) if f.t >= t => { k += 1; k % 10 == 0 }
        _ => true,
    }).copied().collect();
    let v = run(&r, ev.clone());
    assert_clean(&v, "10 Hz -> 1 Hz");
    assert!(v.iter().filter(|x| x.t > t + 3.0).all(|x| x.ran.contains(StrategyId::LocationShift)), "S1 keeps running at 1 Hz");
    let mut ev = ev;
    let onset = t + 20.0;
    jump(&mut ev, onset);
    assert!(detected_after(&run(&r, ev), onset, 2.0));
}
