//! A minimal `no_std` integration of `detector-core` on a Cortex-M4F: the car's CAN frames and
//! the receiver's NMEA sentences come from the integrator's own code (`car`: a car driven in
//! software; `decode`: this car's CAN messages and RMC), go through the core's synchroniser, and
//! every synchronised epoch is judged by the full detector (the LSTM and the turn templates read
//! in place from flash). It prints the verdicts' outcome over semihosting and exits 0 when the
//! clean part raised no alarm, the left turn was judged a left turn and the spoofer was found
//! within 5 s, else 1.
//!
//! Run it in QEMU: `cd firmware && cargo run --release -p detector-core-cortex-m-example`.
#![no_std]
#![no_main]

mod car;
mod decode;

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use detector_core::fusion::{Config, Detector, Verdict};
use detector_core::profile::LOGGER_1HZ;
use detector_core::sample::Sample;
use detector_core::strategy::location_shift::Predictor;
use detector_core::strategy::turn::{TemplateSet, TurnOutcome, DEFAULT_TEMPLATES};
use detector_core::strategy::StrategyId;
use detector_core::sync::{SyncConfig, Synchronizer};
use panic_semihosting as _;
use stm32_metapac as _;

/// What the run saw.
#[derive(Default)]
struct Tally {
    epochs: u32,
    turns_judged: u32,
    last_turn: Option<TurnOutcome>,
    first_alarm: Option<Verdict>,
}

impl Tally {
    fn add(&mut self, v: Verdict) {
        self.epochs += 1;
        if v.turn.is_some() {
            self.turns_judged += 1;
            self.last_turn = v.turn;
        }
        if v.alarm && self.first_alarm.is_none() {
            self.first_alarm = Some(v);
        }
    }
}

#[entry]
fn main() -> ! {
    // The model and the templates are `static` bytes in flash, read in place.
    let predictor = Predictor::default_lstm();
    let lstm = matches!(predictor, Predictor::Lstm(_));
    let cfg = Config::for_predictor(&LOGGER_1HZ, &predictor);
    let mut det = Detector::new(cfg, predictor);
    if let Ok(t) = TemplateSet::parse(DEFAULT_TEMPLATES) {
        det = det.with_turns(t);
    }
    let mut sync = Synchronizer::new(SyncConfig::default());
    let mut tally = Tally::default();
    let mut judge = |s: &Sample| tally.add(det.step(s));

    let mut car = car::Car::new();
    let mut delivered = heapless::Vec::new();
    while car.advance(&mut delivered) {
        for d in &delivered {
            match d {
                car::Delivery::Can(f) => {
                    for (signal, value) in decode::can(f) {
                        sync.push_obs(signal, f.t, value, &mut judge);
                    }
                }
                car::Delivery::Nmea(t, s) => {
                    if let Some(fix) = decode::rmc(*t, s) {
                        sync.push_fix(fix, &mut judge);
                    }
                }
            }
        }
    }
    sync.flush(&mut judge);

    hprintln!("core-example: {} epochs judged (LSTM predictor: {})", tally.epochs, lstm);
    let turn_ok = match tally.last_turn {
        Some(t) => {
            hprintln!("turn judged: steering says {}, GNSS course changed {} deg, mismatch {}", t.steering.name(), t.gnss_change_deg as i32, t.mismatch.is_some());
            tally.turns_judged == 1 && t.steering.name() == "left" && t.mismatch.is_none()
        }
        None => false,
    };
    let pass = match tally.first_alarm {
        Some(v) => {
            hprintln!("first alarm at {} s (spoofer from {} s), fired:", v.t, car::SPOOF_AT_S);
            for s in StrategyId::ALL.iter().filter(|s| v.fired.contains(**s)) {
                hprintln!("  {}", s.name());
            }
            for r in v.reasons.iter() {
                hprintln!("  reason {}", r.name());
            }
            v.t >= car::SPOOF_AT_S && v.t <= car::SPOOF_AT_S + 5.0
        }
        None => {
            hprintln!("no alarm");
            false
        }
    };
    let pass = pass && lstm && turn_ok;
    hprintln!("core-example: {}", if pass { "PASS" } else { "FAIL" });
    debug::exit(if pass { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}
