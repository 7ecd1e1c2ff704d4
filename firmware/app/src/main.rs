//! gnss-guard firmware for STM32F405RG (embassy).
//!
//! One task per concern, typed channels between them, interrupts bound in one place:
//!
//! ```text
//! can_rx_task  (interrupt executor, preempts the others) bxCAN FIFO -> CanMsg -> CAN_RX ---\
//! gnss_task    USART2 RX, DMA ring buffer, NMEA + UBX -> GnssMsg -> GNSS_RX --------------> detector_task
//!                                                                                           | pipeline: synchroniser, detector,
//! can_tx_task  <- TX_QUEUE (alarm first, status pages) <- TX_WAKE <--------------------------/ status, alarm outbox; PA5; watchdog
//! store_task   <- STORE_CMD (the calibration record to keep, or forget) <----------------------/
//! ```
//!
//! - Reception cannot overflow unseen while a detector step runs: `can_rx_task` runs on an
//!   interrupt executor (UART4's vector, unused otherwise, priority 6), so it preempts a
//!   detector step in thread mode and moves frames from bxCAN's 3-frame hardware FIFO into
//!   `CAN_RX` (64 frames) within microseconds. At 500 kbit/s the shortest frame (no data, no
//!   stuffing) takes 94 us: 64 frames cover 6 ms of a saturated bus, more than the longest epoch
//!   (QEMU: `longest epoch` line). The hardware overrun flags (FOVR0/1) and bus errors are
//!   counted as overruns, `CAN_RX` drops its oldest message when full and counts it; both go out
//!   in the status frame (page 1).
//! - The watchdog (IWDG, 2 s) is fed by the detector loop only when
//!   `gnss_guard_board::health::WatchdogGate` allows: an epoch within the last 5 s, or GNSS
//!   silent and reported as blind. A hung loop, or a pipeline that receives fixes but stops
//!   producing epochs, is reset.
//! - A failed GNSS UART or CAN start-up is a reported fault (status page 2, defmt), not silence.
//! - Alarm frames are never silently dropped: the transmit queue merges an alarm into one not
//!   yet sent and takes back one the mailboxes could not take (counted as a retry); while the
//!   alarm is latched it is repeated once a second. Only a clear request frame
//!   (`GNSS_GUARD_CLEAR`, KEY 0xC1EA) or a power cycle clears the latch.
//! - The car's calibration is kept in flash sectors 1 and 2 (`gnss_guard_board::store`,
//!   sequential-storage: wear levelled, safe against power cuts): read once at start-up (a bad
//!   record is ignored and reported, status page 2), saved by `store_task` when the pipeline's
//!   policy says so (the car standing, no alarm, at most every five minutes: the STM32F405
//!   cannot fetch code while it programs its flash), forgotten on a relearn request
//!   (`GNSS_GUARD_CLEAR`, KEY 0xCA1B). `memory.x` keeps the code out of those sectors.
#![no_std]
#![no_main]

use core::cell::RefCell;
use core::sync::atomic::{AtomicU32, Ordering};
use defmt::{error, info, warn};
use cortex_m_rt::entry;
use embassy_executor::{Executor, InterruptExecutor, SendSpawner, Spawner};
use embassy_futures::select::{select3, Either3};
use embassy_stm32::can::filter::ListEntry16;
use embassy_stm32::can::{Can, CanRx, CanTx, Fifo, Frame, StandardId};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::usart::{self, RingBufferedUartRx, UartRx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, can, dma, pac, peripherals};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant, Timer};
use gnss_guard_board::gnss::MAX_SENTENCE;
use gnss_guard_board::ubx::{self, Chunk, Framer};
use gnss_guard_board::health::{Faults, ResetCause, WatchdogGate};
use gnss_guard_board::outbox::{TxFrame, TxQueue};
use gnss_guard_board::pipeline::Pipeline;
use gnss_guard_board::store::{Loaded, Store};
use {defmt_rtt as _, panic_probe as _};

bind_interrupts!(struct Irqs {
    CAN1_RX0 => can::Rx0InterruptHandler<peripherals::CAN1>;
    CAN1_RX1 => can::Rx1InterruptHandler<peripherals::CAN1>;
    CAN1_SCE => can::SceInterruptHandler<peripherals::CAN1>;
    CAN1_TX => can::TxInterruptHandler<peripherals::CAN1>;
    USART2 => usart::InterruptHandler<peripherals::USART2>;
    DMA1_STREAM5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
    FLASH => embassy_stm32::flash::InterruptHandler;
});

/// The calibration store: flash sectors 1 and 2 (offsets into bank 1 region 1, whose sectors
/// are 16 KiB: one erases in at most 0.8 s, inside the watchdog's 2 s).
const STORE_RANGE: core::ops::Range<u32> = 0x4000..0xC000;
type StoreFlash = embassy_stm32::flash::Bank1Region1<'static, embassy_stm32::flash::Async>;

/// What the detector task asks of the store.
enum StoreCmd {
    Save(detector_core::wire::calibration::Record),
    Forget,
}

const CAN_BITRATE: u32 = 500_000;
const GNSS_BAUD: u32 = 115_200;

/// A received CAN frame.
#[derive(Clone, Copy)]
struct CanMsg {
    t_us: u64,
    id: u16,
    len: u8,
    data: [u8; 8],
}

/// What the receiver sent: an NMEA sentence or a checked UBX frame (told apart on the UART by
/// `gnss_guard_board::ubx::Framer`).
#[derive(Clone)]
enum GnssBody {
    Nmea(heapless::Vec<u8, MAX_SENTENCE>),
    Ubx { class: u8, id: u8, payload: heapless::Vec<u8, { ubx::MAX_PAYLOAD }> },
}

#[derive(Clone)]
struct GnssMsg {
    t_us: u64,
    body: GnssBody,
}

static EXECUTOR_CAN: InterruptExecutor = InterruptExecutor::new();
static EXECUTOR_MAIN: static_cell::StaticCell<Executor> = static_cell::StaticCell::new();
static CAN: static_cell::StaticCell<Can<'static>> = static_cell::StaticCell::new();
static CAN_RX: Channel<CriticalSectionRawMutex, CanMsg, 64> = Channel::new();
static GNSS_RX: Channel<CriticalSectionRawMutex, GnssMsg, 8> = Channel::new();
static TX_QUEUE: Mutex<CriticalSectionRawMutex, RefCell<TxQueue>> = Mutex::new(RefCell::new(TxQueue::new()));
static STORE_CMD: Channel<CriticalSectionRawMutex, StoreCmd, 2> = Channel::new();
/// The store failed a save or a forget (reported in status page 2 by the detector task).
static STORE_FAILED: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

#[interrupt]
#[allow(non_snake_case)]
unsafe fn UART4() {
    // SAFETY: UART4 is not used; its vector only runs the CAN receive executor, as
    // `InterruptExecutor::on_interrupt` requires.
    unsafe { EXECUTOR_CAN.on_interrupt() }
}
static TX_WAKE: Signal<CriticalSectionRawMutex, ()> = Signal::new();

// Counters the receive tasks keep for the status frame.
static CAN_DROPPED: AtomicU32 = AtomicU32::new(0);
static CAN_OVERRUNS: AtomicU32 = AtomicU32::new(0);
static UART_ERRORS: AtomicU32 = AtomicU32::new(0);

fn bump(c: &AtomicU32) {
    // Saturating: fetch_update never fails with a `Some` closure.
    let _ = c.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |v| Some(v.saturating_add(1)));
}

/// Sends, dropping the oldest message when the channel is full; returns whether one was dropped.
fn send_drop_oldest<T, const N: usize>(ch: &Channel<CriticalSectionRawMutex, T, N>, msg: T) -> bool {
    match ch.try_send(msg) {
        Ok(()) => false,
        Err(embassy_sync::channel::TrySendError::Full(msg)) => {
            let _ = ch.try_receive();
            let _ = ch.try_send(msg);
            true
        }
    }
}

/// bxCAN's receive FIFO overrun flags: counted and cleared.
fn check_fifo_overruns() {
    for fifo in 0..2 {
        if pac::CAN1.rfr(fifo).read().fovr() {
            pac::CAN1.rfr(fifo).write(|w| w.set_fovr(true));
            bump(&CAN_OVERRUNS);
        }
    }
}

#[embassy_executor::task]
async fn can_rx_task(mut rx: CanRx<'static>) {
    loop {
        let env = rx.read().await;
        check_fifo_overruns();
        match env {
            Ok(env) => {
                if let embedded_can::Id::Standard(id) = env.frame.id() {
                    let data = env.frame.data();
                    let mut d = [0u8; 8];
                    let n = data.len().min(8);
                    d[..n].copy_from_slice(&data[..n]);
                    let msg = CanMsg { t_us: env.ts.as_micros(), id: id.as_raw(), len: n as u8, data: d };
                    if send_drop_oldest(&CAN_RX, msg) {
                        bump(&CAN_DROPPED);
                    }
                }
            }
            Err(e) => {
                // Bus-off is recovered by the controller itself (ABOM); keep reading.
                bump(&CAN_OVERRUNS);
                warn!("CAN bus error {}", e);
            }
        }
    }
}

#[embassy_executor::task]
async fn can_tx_task(mut tx: CanTx<'static>) {
    loop {
        TX_WAKE.wait().await;
        while let Some(f) = TX_QUEUE.lock(|q| q.borrow_mut().pop()) {
            let (id, data) = f.encode();
            let Ok(frame) = Frame::new_standard(id, &data) else { continue };
            if tx.try_write(&frame).is_err() {
                // Mailboxes full: the frame goes back (an alarm merged with anything newer)
                // and is retried when a mailbox frees.
                TX_QUEUE.lock(|q| q.borrow_mut().give_back(f));
                if matches!(f, TxFrame::Alarm(_)) {
                    warn!("CAN: alarm frame queued for retry, mailboxes full");
                }
                tx.flush_any().await;
            }
        }
    }
}

#[embassy_executor::task]
async fn gnss_task(mut rx: RingBufferedUartRx<'static>) {
    let mut framer = Framer::default();
    let mut buf = [0u8; 64];
    loop {
        match rx.read(&mut buf).await {
            Ok(n) => {
                let t_us = Instant::now().as_micros();
                let before = framer.lines.dropped.saturating_add(framer.counters.bad_checksum);
                framer.push(&buf[..n], |c| {
                    let body = match c {
                        Chunk::Nmea(l) => GnssBody::Nmea(heapless::Vec::from_slice(l).unwrap_or_default()),
                        Chunk::Ubx(f) => GnssBody::Ubx { class: f.class, id: f.id, payload: heapless::Vec::from_slice(f.payload).unwrap_or_default() },
                    };
                    if send_drop_oldest(&GNSS_RX, GnssMsg { t_us, body }) {
                        bump(&UART_ERRORS);
                    }
                });
                let after = framer.lines.dropped.saturating_add(framer.counters.bad_checksum);
                for _ in before..after {
                    bump(&UART_ERRORS);
                }
            }
            Err(e) => {
                // Overrun, framing, noise or parity: the partial sentence is unusable.
                bump(&UART_ERRORS);
                framer.lines.discard_partial();
                warn!("GNSS UART error {}", e);
            }
        }
    }
}

#[embassy_executor::task]
async fn store_task(mut store: Store<StoreFlash>) {
    loop {
        let ok = match STORE_CMD.receive().await {
            StoreCmd::Save(r) => store.save(&r).await.is_ok(),
            StoreCmd::Forget => store.forget().await.is_ok(),
        };
        if ok {
            info!("calibration kept in flash");
        } else {
            error!("calibration store failed");
            STORE_FAILED.store(true, Ordering::Relaxed);
        }
    }
}

#[embassy_executor::task]
async fn detector_task(mut alarm_pin: Output<'static>, mut wdg: IndependentWatchdog<'static, peripherals::IWDG>, mut faults: Faults, reset_cause: ResetCause, restarts: u32, loaded: Loaded) {
    // Strategy 1: the LSTM with the built-in model, or the kinematic predictor if it is invalid.
    let predictor = detector_core::strategy::location_shift::Predictor::default_lstm();
    if !matches!(predictor, detector_core::strategy::location_shift::Predictor::Lstm(_)) {
        error!("LSTM model invalid: strategy 1 uses the kinematic predictor");
        faults.set(Faults::MODEL_INVALID);
    }
    let cfg = detector_core::fusion::Config::for_predictor(&detector_core::profile::UBLOX_10HZ, &predictor);
    let templates = detector_core::strategy::turn::TemplateSet::parse(detector_core::strategy::turn::DEFAULT_TEMPLATES).ok();
    if templates.is_none() {
        error!("turn templates invalid: strategy 2 disabled");
        faults.set(Faults::TEMPLATES_INVALID);
    }
    let mut p = Pipeline::new(cfg, templates, predictor);
    p.health.faults = faults;
    p.calibrate(&loaded);
    p.health.reset_cause = reset_cause;
    p.health.counters.restarts = restarts;
    let mut gate = WatchdogGate::default();
    loop {
        let mut on_verdict = |v: &detector_core::fusion::Verdict| {
            if !v.fired.is_empty() {
                warn!("SPOOFING ALARM epoch {} fired {=u8:b} reasons {=u32:b}", v.epoch, v.fired.0, v.reasons.0);
            }
        };
        // Woken by a frame, a sentence, or every 100 ms for the status and alarm repeats.
        match select3(CAN_RX.receive(), GNSS_RX.receive(), Timer::after(Duration::from_millis(100))).await {
            Either3::First(m) => p.on_can(m.t_us as f64 * 1e-6, m.id as u32, &m.data[..m.len as usize], &mut on_verdict),
            Either3::Second(g) => match &g.body {
                GnssBody::Nmea(line) => p.on_nmea(g.t_us as f64 * 1e-6, line, &mut on_verdict),
                GnssBody::Ubx { class, id, payload } => {
                    let was = p.ubx.spoof;
                    p.on_ubx(g.t_us as f64 * 1e-6, *class, *id, payload, &mut on_verdict);
                    if p.ubx.spoof != was {
                        warn!("receiver's own spoofing detection: {}", p.ubx.spoof.name());
                    }
                }
            },
            Either3::Third(()) => {}
        }
        let now = Instant::now().as_micros() as f64 * 1e-6;
        p.health.counters.can_dropped = CAN_DROPPED.load(Ordering::Relaxed);
        p.health.counters.can_overruns = CAN_OVERRUNS.load(Ordering::Relaxed);
        p.uart_errors = UART_ERRORS.load(Ordering::Relaxed);
        p.alarm.retries = TX_QUEUE.lock(|q| q.borrow().alarm_retries);
        let out = p.poll(now);
        if out.alarm.is_some() || out.status.is_some() {
            TX_QUEUE.lock(|q| {
                let mut q = q.borrow_mut();
                if let Some(a) = out.alarm {
                    q.push_alarm(a);
                }
                if let Some(s) = out.status {
                    q.push_status(s);
                }
            });
            if out.alarm.is_some() {
                p.alarm.sent(now);
            }
            TX_WAKE.signal(());
        }
        // The calibration to keep (or forget), to the store task; its failures back.
        if let Some(r) = p.take_calibration() {
            let _ = STORE_CMD.try_send(StoreCmd::Save(r));
        }
        if p.take_forget() {
            info!("relearn request: the stored calibration is forgotten");
            let _ = STORE_CMD.try_send(StoreCmd::Forget);
        }
        if STORE_FAILED.swap(false, Ordering::Relaxed) {
            p.store_failed();
        }
        if p.alarm.latched() {
            alarm_pin.set_high();
        } else {
            alarm_pin.set_low();
        }
        if gate.may_feed(&p.health, now) {
            wdg.pet();
        }
    }
}

/// The cause of the last reset (RCC CSR), then the flags cleared; and the count of resets since
/// power-on, kept in the RTC backup register 0 (it survives resets, not power loss).
fn boot_record() -> (ResetCause, u32) {
    let csr = pac::RCC.csr().read();
    let cause = if csr.borrstf() || csr.porrstf() {
        ResetCause::PowerOn
    } else if csr.wdgrstf() {
        ResetCause::IndependentWatchdog
    } else if csr.wwdgrstf() {
        ResetCause::WindowWatchdog
    } else if csr.sftrstf() {
        ResetCause::Software
    } else if csr.lpwrrstf() {
        ResetCause::LowPower
    } else if csr.padrstf() {
        ResetCause::Pin
    } else {
        ResetCause::Unknown
    };
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
    // Backup domain: PWR clock on, write protection off.
    pac::RCC.apb1enr().modify(|w| w.set_pwren(true));
    pac::PWR.cr1().modify(|w| w.set_dbp(true));
    let restarts = if cause == ResetCause::PowerOn { 0 } else { pac::RTC.bkpr(0).read().bkp().saturating_add(1) };
    pac::RTC.bkpr(0).write(|w| w.set_bkp(restarts));
    (cause, restarts)
}

#[entry]
fn main() -> ! {
    let p = embassy_stm32::init(Default::default());
    interrupt::UART4.set_priority(Priority::P6);
    let can_spawner = EXECUTOR_CAN.start(interrupt::UART4);
    let executor = EXECUTOR_MAIN.init(Executor::new());
    executor.run(|spawner| spawner.spawn(start(spawner, can_spawner, p).expect("start task spawns once")))
}

/// Brings the peripherals up, reports what failed, and spawns the tasks.
#[embassy_executor::task]
async fn start(spawner: Spawner, can_spawner: SendSpawner, p: embassy_stm32::Peripherals) {
    let (reset_cause, restarts) = boot_record();
    info!("gnss-guard: profile {}, {} CAN ids filtered, reset cause {}, {} restarts", gnss_guard_board::can::PROFILE, gnss_guard_board::can::FILTER_IDS.len(), reset_cause as u8, restarts);
    let mut faults = Faults::default();

    // Alarm pin (PA5) and watchdog (2 s), fed only by the detector loop through its gate.
    let alarm_pin = Output::new(p.PA5, Level::Low, Speed::Low);
    let mut wdg = IndependentWatchdog::new(p.IWDG, 2_000_000);
    wdg.unleash();

    // CAN1 on PA11/PA12 at 500 kbit/s; hardware filters: the profile's ids and our clear
    // request, 4 per bank.
    let can = CAN.init(Can::new(p.CAN1, p.PA11, p.PA12, Irqs));
    {
        let mut f = can.modify_filters();
        let ids = gnss_guard_board::can::FILTER_IDS.iter().copied().chain([gnss_guard_board::can::ours::CLEAR_ID]);
        let mut bank = 0u8;
        let mut chunk: heapless::Vec<u16, 4> = heapless::Vec::new();
        let entries = |chunk: &heapless::Vec<u16, 4>| {
            let e = |k: usize| {
                let id = chunk.get(k).or(chunk.first()).copied().unwrap_or(0);
                ListEntry16::data_frames_with_id(StandardId::new(id).unwrap_or(StandardId::ZERO))
            };
            [e(0), e(1), e(2), e(3)]
        };
        for id in ids {
            let _ = chunk.push(id);
            if chunk.is_full() {
                f.enable_bank(bank, Fifo::Fifo0, entries(&chunk));
                bank += 1;
                chunk.clear();
            }
        }
        if !chunk.is_empty() {
            f.enable_bank(bank, Fifo::Fifo0, entries(&chunk));
        }
    }
    can.set_bitrate(CAN_BITRATE);
    // Leaving initialisation needs 11 recessive bits on the bus: without a bus (no transceiver,
    // no power) that never happens, which is a fault to report, not a hang.
    if embassy_time::with_timeout(Duration::from_millis(500), can.enable()).await.is_err() {
        error!("CAN start-up failed: no bus after 500 ms");
        faults.set(Faults::CAN_START);
    }
    let (tx, rx) = can.split();

    // GNSS receiver on USART2 RX (PA3), DMA ring buffer.
    let mut ucfg = usart::Config::default();
    ucfg.baudrate = GNSS_BAUD;
    static DMA_BUF: static_cell::StaticCell<[u8; 512]> = static_cell::StaticCell::new();
    let gnss = match UartRx::new(p.USART2, p.PA3, p.DMA1_CH5, Irqs, ucfg) {
        Ok(rx) => Some(rx.into_ring_buffered(DMA_BUF.init([0; 512]))),
        Err(_) => {
            error!("GNSS UART start-up failed: configuration refused");
            faults.set(Faults::UART_START);
            None
        }
    };

    // The car's calibration, read once before the detector starts.
    let region = embassy_stm32::flash::Flash::new(p.FLASH, Irqs).into_regions().bank1_region1;
    let mut store = Store::new(region, STORE_RANGE);
    let loaded = match store.as_mut() {
        Some(s) => s.load().await,
        None => Loaded::FlashError,
    };
    match loaded {
        Loaded::Record(r) => info!("calibration from flash: {} drives, scale {}", r.drives, r.scale),
        Loaded::None => info!("no calibration in flash: this drive learns the car"),
        Loaded::Invalid(e) => error!("calibration record invalid at byte {}: ignored", e.offset()),
        Loaded::FlashError => error!("calibration store unreadable"),
    }

    spawner.spawn(detector_task(alarm_pin, wdg, faults, reset_cause, restarts, loaded).expect("detector task spawns once"));
    if let Some(s) = store {
        spawner.spawn(store_task(s).expect("store task spawns once"));
    }
    can_spawner.spawn(can_rx_task(rx).expect("CAN receive task spawns once"));
    spawner.spawn(can_tx_task(tx).expect("CAN transmit task spawns once"));
    if let Some(rx) = gnss {
        spawner.spawn(gnss_task(rx).expect("GNSS task spawns once"));
    }
}
