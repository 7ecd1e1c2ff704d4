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
use detector_core::stage::{NoStopwatch, Stage, Stopwatch};
use detector_core::strategy::location_shift::lstm::LstmPredictor;
use detector_core::strategy::location_shift::{KinematicPredictor, Predictor, ShiftPredictor};
use detector_core::strategy::turn::knn::classify;
use detector_core::strategy::turn::{TemplateSet, DEFAULT_TEMPLATES};
use detector_core::wire::calibration::Record;
use gnss_guard_board::pipeline::Pipeline;
use gnss_guard_board::replay::{self, Input};
use gnss_guard_board::store::Loaded;
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

/// The one pipeline every replay of this image runs in, made afresh in place for each
/// ([`Pipeline::restart`]): 31 KB, and built on the stack for each scenario its copies ran the
/// stack past the bottom of RAM.
static PIPE: static_cell::StaticCell<Pipeline<'static>> = static_cell::StaticCell::new();

/// Scenario `i` in `pipe`, rebuilt for this run with `cfg` and a fresh copy of `predictor`,
/// started from `record` as the store would load it (`None`: a car's first drive).
#[allow(clippy::too_many_arguments)]
fn replay_in<W: detector_core::stage::Stopwatch + ?Sized>(
    pipe: &mut Pipeline<'static>,
    input: &Input,
    i: usize,
    cfg: Config,
    templates: TemplateSet<'static>,
    predictor: &Predictor<'static>,
    record: Option<&Record>,
    clock: &mut dyn FnMut() -> u32,
    cost: &mut dyn FnMut(u32),
    w: &mut W,
) -> Result<replay::Outcome, replay::InputError> {
    let mut fresh = predictor.clone();
    fresh.reset();
    pipe.restart(cfg, Some(templates), fresh);
    if let Some(r) = record {
        pipe.calibrate(&Loaded::Record(*r));
    }
    replay::run_in(pipe, input, i, clock, cost, w)
}

/// SysTick ticks spent on every epoch of every drive scenario (not the outage, whose first
/// epoch after the gap carries the gap's CAN decoding), replayed with this configuration, into
/// `costs` (one buffer reused: the stack holds one 16 KiB vector, not one per run).
#[allow(clippy::too_many_arguments)]
fn epoch_costs(
    pipe: &mut Pipeline<'static>,
    input: &Input,
    cfg: Config,
    templates: TemplateSet<'static>,
    predictor: &Predictor<'static>,
    record: Option<&Record>,
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
        if replay_in(pipe, input, i, cfg, templates, predictor, record, clock, &mut cost, &mut NoStopwatch).is_err() {
            fail("replay failed");
        }
    }
}

/// SysTick ticks per stage of the data path (its own running counter; the same hardware).
struct TickWatch {
    last: u32,
    ticks: [u64; Stage::ALL.len()],
    laps: [u32; Stage::ALL.len()],
}

impl TickWatch {
    fn new() -> Self {
        TickWatch { last: SYST::get_current(), ticks: [0; Stage::ALL.len()], laps: [0; Stage::ALL.len()] }
    }
}

impl Stopwatch for TickWatch {
    fn lap(&mut self, stage: Stage) {
        let now = SYST::get_current();
        let d = self.last.wrapping_sub(now) & 0x00FF_FFFF;
        self.last = now;
        if let (Some(t), Some(n)) = (self.ticks.get_mut(stage.index()), self.laps.get_mut(stage.index())) {
            *t += d as u64;
            *n += 1;
        }
    }
}

/// Where an epoch's instructions go: every non-outage scenario again, with a stopwatch at each
/// stage boundary (its own cost, a SysTick read per boundary, lands in the next stage).
fn stage_breakdown(pipe: &mut Pipeline<'static>, input: &Input, cfg: Config, templates: TemplateSet<'static>, predictor: &Predictor<'static>, clock: &mut dyn FnMut() -> u32) {
    let mut w = TickWatch::new();
    let mut epochs = 0u64;
    let mut epoch_ticks = 0u64;
    for i in 0..input.scenarios() {
        if input.scenario(i).is_ok_and(|sc| sc.kind == replay::Kind::GnssOutage) {
            continue;
        }
        let mut cost = |c: u32| {
            epochs += 1;
            epoch_ticks += c as u64;
        };
        if replay_in(pipe, input, i, cfg, templates, predictor, None, clock, &mut cost, &mut w).is_err() {
            fail("replay failed");
        }
    }
    let instr = |ticks: u64| ticks * 1000 / TICKS_PER_1000_INSTR;
    let epochs = epochs.max(1);
    hprintln!("instructions per epoch by stage (mean over {} epochs; the epoch mean is {}):", epochs, instr(epoch_ticks) / epochs);
    for st in Stage::ALL {
        let (t, n) = (w.ticks[st.index()], w.laps[st.index()]);
        if st == Stage::TurnQuery {
            hprintln!("  {:<26} {:>7}  ({} queries, {} instructions per query)", st.name(), instr(t) / epochs, n, if n > 0 { instr(t) / n as u64 } else { 0 });
        } else {
            hprintln!("  {:<26} {:>7}", st.name(), instr(t) / epochs);
        }
    }
}

/// Strategy 2's k-NN alone: a 32-point query against every template, for queries made from
/// templates of the set with a 6-degree sine added (so no query is its own template).
fn turn_query_cost(templates: TemplateSet, clock: &mut dyn FnMut() -> u32) {
    let mut costs: heapless::Vec<u32, 64> = heapless::Vec::new();
    for i in (0..templates.len()).step_by((templates.len() / 32).max(1)) {
        let (_, _, mut q) = templates.get(i);
        for (j, v) in q.iter_mut().enumerate() {
            *v += 6.0 * libm::sinf(j as f32 * 0.4 + i as f32);
        }
        let a = clock();
        core::hint::black_box(classify(&templates, core::hint::black_box(&q), 1));
        let _ = costs.push(clock().wrapping_sub(a));
    }
    costs.sort_unstable();
    if let (Some(&min), Some(&max)) = (costs.first(), costs.last()) {
        let instr = |ticks: u32| ticks as u64 * 1000 / TICKS_PER_1000_INSTR;
        hprintln!(
            "instructions per turn query (32 points, k-NN over {} templates, {} queries): min {} median {} max {}",
            templates.len(),
            costs.len(),
            instr(min),
            instr(costs[costs.len() / 2]),
            instr(max)
        );
    }
}

/// The Cortex-M4 assembly kernels against the portable reference on this very core: random
/// weights (all byte values) and activations (all i16 values, LCG), row lengths with every
/// tail, and the LSTM's two layer shapes; then the whole integer LSTM on both dot products.
/// Returns the number of cases, or the first that differs.
fn dsp_parity(predictor: &Predictor) -> Result<u32, &'static str> {
    use gnss_guard_dsp::{portable, Activations};
    let mut seed = 0x2545_f491u32;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed
    };
    let mut w = [0u8; 8 * 192];
    let mut v = [0i16; 192];
    let mut cases = 0u32;
    for round in 0..24 {
        for b in w.iter_mut() {
            *b = rnd() as u8;
        }
        for x in v.iter_mut() {
            // Every fourth round at the extremes.
            *x = if round % 4 == 3 { [i16::MIN, i16::MAX, -1, 0][rnd() as usize % 4] } else { rnd() as i16 };
        }
        let mut acts: Activations<192> = Activations::default();
        let split = rnd() as usize % 64;
        acts.load(&[&v[..split], &v[split..]]);
        for len in [0usize, 1, 3, 4, 5, 8, 13, 64, 131, 132, 191, 192] {
            let n = len.min(192);
            let (w0, w1) = (&w[..n], &w[192..192 + n]);
            if acts.dot2(w0, w1) != portable::dot2(w0, w1, &v) {
                return Err("dot2 differs from the portable kernel");
            }
            cases += 1;
        }
        let mut out = [0i32; 8];
        acts.matvec::<132>(&w, &mut out);
        for (r, o) in out.iter().enumerate() {
            if *o != portable::dot(&w[r * 132..(r + 1) * 132], &v[..132]) {
                return Err("matvec<132> differs from the portable kernel");
            }
        }
        acts.matvec::<192>(&w, &mut out);
        for (r, o) in out.iter().enumerate() {
            if *o != portable::dot(&w[r * 192..(r + 1) * 192], &v) {
                return Err("matvec<192> differs from the portable kernel");
            }
        }
        cases += 2;
    }
    if let Predictor::Lstm(l) = predictor {
        let model = l.primary.model;
        let (Ok(mut a), Ok(mut b)) = (LstmPredictor::int(model), LstmPredictor::int_portable(model)) else {
            return Err("the model is not int8");
        };
        for k in 0..32u32 {
            let x = [(rnd() % 40) as f32, (rnd() % 100) as f32, (rnd() % 400) as f32 - 200.0, (k % 30) as f32];
            if a.step_raw(x).to_bits() != b.step_raw(x).to_bits() {
                return Err("the integer LSTM differs between the DSP and portable dot products");
            }
            cases += 1;
        }
    }
    Ok(cases)
}

/// The FPU's square root (`VSQRT.F32`, what [`gnss_guard_dsp::sqrtf`] is on this target) against
/// libm's integer one, bit for bit: zeros, infinities, NaNs, subnormals, the largest values and
/// a stride through every exponent of both signs (a NaN need only be a NaN). Returns the number
/// of inputs, or the first that differs.
fn sqrt_parity() -> Result<u32, &'static str> {
    if !gnss_guard_dsp::HARDWARE_SQRT {
        return Err("this build does not use the FPU's square root");
    }
    let same = |bits: u32| {
        let x = f32::from_bits(bits);
        let (h, r) = (gnss_guard_dsp::sqrtf(core::hint::black_box(x)), libm::sqrtf(x));
        if r.is_nan() { h.is_nan() } else { h.to_bits() == r.to_bits() }
    };
    let mut cases = 0u32;
    for bits in [0u32, 0x8000_0000, 1, 0x8000_0001, 0x007F_FFFF, 0x0080_0000, 0x3F80_0000, 0x4080_0000, 0x7F7F_FFFF, 0x7F80_0000, 0xFF80_0000, 0x7FC0_0000, 0xFFC0_0001, 0x7F80_0001, 0xBF80_0000] {
        if !same(bits) {
            return Err("sqrtf: an edge case differs from libm");
        }
        cases += 1;
    }
    let mut bits = 0u32;
    while bits < 0xFFFF_0000 {
        if !same(bits) {
            return Err("sqrtf differs from libm");
        }
        cases += 1;
        bits += 0x1_0001; // about 65,500 inputs: every exponent, both signs, varied mantissas
    }
    Ok(cases)
}

/// The detector's sine, cosine (alone and together) and tangent (`detector_core::trig`, without libm's reduction of
/// huge arguments) against libm's on the target: every 0x1_0001th f32 below the bound of
/// `2^28 pi/2`, both signs, the same bits; beyond it a finite sine, and NaN for infinity.
fn trig_parity() -> Result<u32, &'static str> {
    use core::hint::black_box;
    use detector_core::trig;
    let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    let mut cases = 0u32;
    let mut bits = 0u32;
    while bits < 0x4DC9_0FDB {
        for x in [f32::from_bits(bits), -f32::from_bits(bits)] {
            let x = black_box(x);
            let (sn, cs) = trig::sincosf(x);
            if !(same(trig::sinf(x), libm::sinf(x)) && same(trig::cosf(x), libm::cosf(x)) && same(trig::tanf(x), libm::tanf(x)) && same(sn, libm::sinf(x)) && same(cs, libm::cosf(x))) {
                return Err("sinf, cosf, sincosf or tanf differs from libm");
            }
            cases += 1;
        }
        bits += 0x1_0001;
    }
    let huge = trig::sinf(black_box(1e30));
    if !((-1.0..=1.0).contains(&huge) && trig::cosf(black_box(f32::INFINITY)).is_nan()) {
        return Err("sinf beyond the bound is not within [-1, 1], or the cosine of infinity not NaN");
    }
    Ok(cases)
}

/// The per-epoch geodesy, f64 (soft float on the M4) against the f32 forms the detector runs:
/// instructions per call, 64 calls each on a 2.2 m shift.
fn geodesy_cost(clock: &mut dyn FnMut() -> u32) {
    use core::hint::black_box;
    use detector_core::geo::{bearing_f32_deg, haversine_f32_m, haversine_m, initial_bearing_deg, LatLon, EARTH_RADIUS_PAPER_M};
    let (a, b) = (LatLon::new(37.4, -122.1), LatLon::new(37.40001, -122.10002));
    let mut per_call = |f: &mut dyn FnMut()| {
        let t = clock();
        for _ in 0..64 {
            f();
        }
        clock().wrapping_sub(t) as u64 * 1000 / TICKS_PER_1000_INSTR / 64
    };
    let h64 = per_call(&mut || {
        black_box(haversine_m(black_box(a), black_box(b), EARTH_RADIUS_PAPER_M));
    });
    let h32 = per_call(&mut || {
        black_box(haversine_f32_m(black_box(a), black_box(b), EARTH_RADIUS_PAPER_M));
    });
    let b64 = per_call(&mut || {
        black_box(initial_bearing_deg(black_box(a), black_box(b)));
    });
    let b32 = per_call(&mut || {
        black_box(bearing_f32_deg(black_box(a), black_box(b)));
    });
    hprintln!("instructions per call: haversine f64 {} / f32 {}, bearing f64 {} / f32 {}", h64, h32, b64, b32);
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
    match dsp_parity(&predictor) {
        Ok(n) => hprintln!("DSP kernels (SXTB16/SMLAD assembly) against the portable kernel: {} cases, all identical", n),
        Err(e) => fail(e),
    }
    match sqrt_parity() {
        Ok(n) => hprintln!("square root (VSQRT.F32) against libm's sqrtf: {} inputs, all identical", n),
        Err(e) => fail(e),
    }
    match trig_parity() {
        Ok(n) => hprintln!("sine, cosine and tangent against libm's: {} inputs, all identical", n),
        Err(e) => fail(e),
    }

    let mut last = SYST::get_current();
    let mut total: u32 = 0;
    let mut clock = move || {
        let now = SYST::get_current();
        total = total.wrapping_add(last.wrapping_sub(now) & 0x00FF_FFFF);
        last = now;
        total
    };
    let pipe = PIPE.init_with(|| Pipeline::new(cfg, Some(templates), predictor.clone()));
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
        let Ok(o) = replay_in(pipe, &input, i, cfg, templates, &predictor, None, &mut clock, &mut cost, &mut NoStopwatch) else { fail("replay failed") };
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
    stage_breakdown(pipe, &input, cfg, templates, &predictor, &mut clock);
    turn_query_cost(templates, &mut clock);
    geodesy_cost(&mut clock);
    // The cost of the paper's strategies alone: the same scenarios without the track check.
    let mut paper_cfg = cfg;
    paper_cfg.track.enabled = false;
    epoch_costs(pipe, &input, paper_cfg, templates, &predictor, None, &mut clock, &mut costs);
    report("instructions per epoch (paper strategies only)", &mut costs);
    // Strategy 1's predictors alone: the same scenarios with the kinematic predictor, and the
    // LSTM's integer step by itself on the inputs of a cruising car.
    let kin = Predictor::Kinematic(KinematicPredictor::default());
    let kin_cfg = Config::for_predictor(&UBLOX_10HZ, &kin);
    epoch_costs(pipe, &input, kin_cfg, templates, &kin, None, &mut clock, &mut costs);
    report("instructions per epoch (kinematic predictor)", &mut costs);
    // A car's next drive: the same scenarios started from a stored calibration, whose
    // calibrated paths a first drive's first minute does not reach.
    let record = replay::stored_record();
    if record.plausible().is_err() {
        // The store would refuse it and the run would measure a first drive again.
        fail("the stored calibration for the cost run is not plausible");
    }
    epoch_costs(pipe, &input, cfg, templates, &predictor, Some(&record), &mut clock, &mut costs);
    report("instructions per epoch (from a stored calibration)", &mut costs);
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
