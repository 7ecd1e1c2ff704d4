//! The QEMU Cortex-M run (`cd firmware && cargo run --release -p qemu-run`).
//!
//! A plain cortex-m-rt image for the STM32F405 memory map (QEMU `netduinoplus2`; the embassy
//! image cannot run there because RCC is not emulated). It links the firmware's
//! board-independent logic (CAN decoding generated from the DBC, NMEA parsing, sample assembly)
//! and `detector-core`, replays a real drive's CAN frames and NMEA sentences embedded at build
//! time, clean and attacked, and checks: no alarm on the clean run, an alarm within
//! `MAX_ALARM_DELAY_S` of each onset. It prints the cost per epoch in instructions (SysTick
//! under `-icount shift=0`: 0.168 ticks per instruction) and the verdict digest that
//! `host-sim digest` must reproduce, then exits 0 (pass) or 1 through semihosting.
#![no_std]
#![no_main]

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use detector_core::fusion::Config;
use detector_core::profile::UBLOX_10HZ;
use detector_core::strategy::location_shift::{KinematicPredictor, Predictor};
use detector_core::strategy::turn::{TemplateSet, DEFAULT_TEMPLATES};
use gnss_guard_board::replay::{self, Input};
use panic_semihosting as _;
use stm32_metapac as _;

static INPUT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/input.bin"));
const DESC: &str = include_str!(concat!(env!("OUT_DIR"), "/input.txt"));
/// SysTick ticks per instruction with `-icount shift=0` on netduinoplus2 (168 MHz / 1 GHz).
const TICKS_PER_1000_INSTR: u64 = 168;
const MAX_EPOCHS: usize = 4096;
/// The firmware's CAN_RX queue (firmware/app/src/main.rs).
const CAN_RX_CAPACITY: u64 = 64;

fn fail(msg: &str) -> ! {
    hprintln!("qemu-run: {}", msg);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// SysTick ticks spent on every epoch of every drive scenario (not the outage, whose first
/// epoch after the gap carries the gap's CAN decoding), replayed with this configuration, into
/// `costs` (one buffer reused: the stack holds one 16 KiB vector, not one per run).
fn epoch_costs<'t>(
    input: &Input,
    cfg: Config,
    templates: TemplateSet<'t>,
    predictor: &Predictor<'t>,
    clock: &mut dyn FnMut() -> u32,
    costs: &mut heapless::Vec<u32, MAX_EPOCHS>,
) {
    costs.clear();
    for i in 0..input.scenarios() {
        let outage = input.scenario(i).is_ok_and(|sc| sc.kind == replay::Kind::GnssOutage);
        let mut cost = |c: u32| {
            if !outage {
                let _ = costs.push(c);
            }
        };
        if replay::run(input, i, cfg, templates, predictor, clock, &mut cost).is_err() {
            fail("replay failed");
        }
    }
}

#[entry]
fn main() -> ! {
    let Some(mut cp) = cortex_m::Peripherals::take() else { fail("peripherals taken twice") };
    cp.SYST.set_clock_source(SystClkSource::Core);
    cp.SYST.set_reload(0x00FF_FFFF);
    cp.SYST.clear_current();
    cp.SYST.enable_counter();

    hprintln!("input: {}", DESC);
    let Ok(input) = Input::parse(INPUT) else { fail("the embedded input is malformed") };
    let Ok(templates) = TemplateSet::parse(DEFAULT_TEMPLATES) else { fail("the turn templates are malformed") };
    let predictor = Predictor::default_lstm();
    if !matches!(predictor, Predictor::Lstm(_)) {
        fail("the LSTM model is malformed");
    }
    let cfg = Config::for_predictor(&UBLOX_10HZ, &predictor);

    let mut last = SYST::get_current();
    let mut total: u32 = 0;
    let mut clock = move || {
        let now = SYST::get_current();
        total = total.wrapping_add(last.wrapping_sub(now) & 0x00FF_FFFF);
        last = now;
        total
    };
    let mut costs: heapless::Vec<u32, MAX_EPOCHS> = heapless::Vec::new();
    let mut digests: heapless::Vec<gnss_guard_board::pipeline::Digest, 8> = heapless::Vec::new();
    let mut all = true;
    let mut longest_call = 0u32;
    for i in 0..input.scenarios() {
        let Ok(sc) = input.scenario(i) else { fail("bad scenario") };
        let outage = sc.kind == replay::Kind::GnssOutage;
        let mut cost = |c: u32| {
            if !outage {
                let _ = costs.push(c);
            }
        };
        let Ok(o) = replay::run(&input, i, cfg, templates, &predictor, &mut clock, &mut cost) else { fail("replay failed") };
        let pass = o.pass(&sc, replay::MAX_ALARM_DELAY_S);
        all &= pass;
        let _ = digests.push(o.digest);
        longest_call = longest_call.max(o.longest_call);
        hprintln!("{}", replay::describe(sc.name, &o, pass).as_str());
    }
    let instr = |ticks: u32| ticks as u64 * 1000 / TICKS_PER_1000_INSTR;
    let report = |label: &str, costs: &mut heapless::Vec<u32, MAX_EPOCHS>| {
        costs.sort_unstable();
        if let (Some(&min), Some(&max)) = (costs.first(), costs.last()) {
            hprintln!("{}: min {} median {} max {}", label, instr(min), instr(costs[costs.len() / 2]), instr(max));
        }
    };
    report("instructions per epoch", &mut costs);
    // CAN reception while the detector task holds the CPU: the receive task preempts it and
    // queues frames in CAN_RX (64), which the detector task drains between calls. At 500 kbit/s
    // the shortest frame (no data, no bit stuffing) is 47 bits: 94 us.
    let call = instr(longest_call);
    let call_us = call as f64 / 168.0;
    let frames = libm::ceil(call_us / 94.0) as u64;
    hprintln!(
        "longest pipeline call: {} instructions ({:.2} ms at 168 MHz, one instruction per cycle); a saturated 500 kbit/s bus delivers at most {} frames meanwhile, CAN_RX holds {}",
        call,
        call_us / 1000.0,
        frames,
        CAN_RX_CAPACITY
    );
    if frames >= CAN_RX_CAPACITY {
        all = false;
        hprintln!("qemu-run: the CAN queue could overflow during the longest call: FAIL");
    }
    // The cost of the paper's strategies alone: the same scenarios without the track check.
    let mut paper_cfg = cfg;
    paper_cfg.track.enabled = false;
    epoch_costs(&input, paper_cfg, templates, &predictor, &mut clock, &mut costs);
    report("instructions per epoch (paper strategies only)", &mut costs);
    // Strategy 1's predictors alone: the same scenarios with the kinematic predictor, and the
    // LSTM's integer step by itself on the inputs of a cruising car.
    let kin = Predictor::Kinematic(KinematicPredictor::default());
    let kin_cfg = Config::for_predictor(&UBLOX_10HZ, &kin);
    epoch_costs(&input, kin_cfg, templates, &kin, &mut clock, &mut costs);
    report("instructions per epoch (kinematic predictor)", &mut costs);
    if let Predictor::Lstm(mut l) = predictor {
        costs.clear();
        for k in 0..64u32 {
            let x = [25.0 + (k % 7) as f32 * 0.1, 20.0, (k % 11) as f32 - 5.0, 25.0];
            let a = clock();
            core::hint::black_box(l.primary.step_raw(core::hint::black_box(x)));
            let _ = costs.push(clock().wrapping_sub(a));
        }
        report("instructions per LSTM step (integer kernel)", &mut costs);
    }
    hprintln!("verdict digest: {:016x}", replay::combine(&digests));
    hprintln!("qemu-run: {}", if all { "PASS" } else { "FAIL" });
    debug::exit(if all { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}
