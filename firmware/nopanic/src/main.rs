//! The no-panic proof (`cd firmware && cargo build --release -p nopanic`).
//!
//! This image runs the firmware's per-epoch path exactly as `firmware/app` does (a CAN frame in,
//! UART bytes split into NMEA sentences in, the synchroniser, all strategies with the LSTM's
//! integer kernel and the turn templates, verdicts, the alarm outbox, the status frames, the
//! transmit queue and the watchdog gate; UART bytes told apart into NMEA and UBX by the framer;
//! the car's calibration record decoded from any bytes at start-up, the pipeline started from it,
//! the record offered for saving and encoded) on input the optimiser can assume nothing about
//! (`core::hint::black_box`). It links `panic-never`, whose panic handler calls an undefined
//! symbol: if any panic path (an index the compiler cannot prove in range, an `unwrap`, an
//! integer overflow check, a division by zero) survives optimisation anywhere in that path, in
//! our code or in a dependency, the link fails. It is never run; `tests/run-all.sh` builds it,
//! and `tests/nopanic-report.sh` names the source lines of any panic call left.
#![no_std]
#![no_main]

use core::hint::black_box;
use detector_core::fusion::{Config, Verdict};
use detector_core::profile::UBLOX_10HZ;
use detector_core::strategy::location_shift::Predictor;
use detector_core::strategy::turn::{TemplateSet, DEFAULT_TEMPLATES};
use gnss_guard_board::ubx::{Chunk, Framer};
use gnss_guard_board::health::WatchdogGate;
use gnss_guard_board::outbox::TxQueue;
use gnss_guard_board::pipeline::Pipeline;
#[cfg(not(feature = "find-panics"))]
use panic_never as _;
use stm32_metapac as _;

#[cfg(feature = "find-panics")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {
        cortex_m::asm::udf();
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let predictor = Predictor::default_lstm();
    let cfg = Config::for_predictor(&UBLOX_10HZ, &predictor);
    let templates = TemplateSet::parse(DEFAULT_TEMPLATES).ok();
    let mut p = Pipeline::new(cfg, templates, predictor);
    // Start-up: whatever bytes the store read, decoded and loaded.
    let stored: [u8; 96] = black_box([0; 96]);
    let len: usize = black_box(76);
    let loaded = match detector_core::wire::calibration::Record::decode(stored.get(..len).unwrap_or(&stored)) {
        Ok(r) => gnss_guard_board::store::Loaded::Record(r),
        Err(e) => gnss_guard_board::store::Loaded::Invalid(e),
    };
    p.calibrate(&loaded);
    let mut split = Framer::default();
    let mut gate = WatchdogGate::default();
    let mut txq = TxQueue::default();
    let mut sink = |v: &Verdict| {
        black_box(v);
    };
    loop {
        // Opaque input: any time, any id, any payload of any length, any UART bytes.
        let t: f64 = black_box(0.0);
        let id: u32 = black_box(0);
        let frame: [u8; 8] = black_box([0; 8]);
        let len: usize = black_box(8);
        if gnss_guard_board::can::wanted(id) {
            p.on_can(t, id, frame.get(..len).unwrap_or(&frame), &mut sink);
        }
        let bytes: [u8; 64] = black_box([0; 64]);
        let n: usize = black_box(64);
        if black_box(false) {
            split.lines.discard_partial();
        }
        split.push(bytes.get(..n).unwrap_or(&bytes), |c| match c {
            Chunk::Nmea(line) => p.on_nmea(t, line, &mut sink),
            Chunk::Ubx(f) => p.on_ubx(t, f.class, f.id, f.payload, &mut sink),
        });
        p.uart_errors = split.lines.dropped.saturating_add(split.counters.bad_checksum);
        // What the detector task owes the bus, through the transmit queue.
        let out = p.poll(t);
        if let Some(a) = out.alarm {
            txq.push_alarm(a);
            p.alarm.sent(t);
        }
        if let Some(s) = out.status {
            txq.push_status(s);
        }
        while let Some(f) = txq.pop() {
            black_box(f.encode());
            if black_box(false) {
                txq.give_back(f);
                break;
            }
        }
        black_box(gate.may_feed(&p.health, t));
        // What the store task is handed.
        if let Some(r) = p.take_calibration() {
            black_box(r.encode());
        }
        black_box(p.take_forget());
        if black_box(false) {
            p.finish(t, &mut sink);
        }
    }
}
