//! gnss-guard firmware for STM32F405RG (embassy).
//!
//! One task per concern, typed channels between them, interrupts bound in one place:
//!
//! ```text
//! can_task  (bxCAN1, 500 kbit/s, hardware filters = the profile's ids) --CanMsg-->  \
//!                                                                                    detector_task --> alarm: CAN frame, PA5, defmt
//! gnss_task (USART2 RX, DMA ring buffer, NMEA lines)                  --NmeaLine--> /       |
//!                                                                          (feeds the independent watchdog)
//! ```
//!
//! Channels drop their oldest message when full and count it, so a burst never blocks a
//! receiver. bxCAN's automatic bus-off management (ABOM, set by `enable()`) takes the controller
//! back on the bus after a bus-off; bus errors are counted. UART overrun, framing and noise errors
//! discard the partial sentence and the DMA ring buffer restarts. The watchdog is fed only by the
//! detector loop, at least every 500 ms while it is healthy.
#![no_std]
#![no_main]

use defmt::{info, warn};
use embassy_executor::Spawner;
use embassy_futures::select::{select, select3, Either, Either3};
use embassy_stm32::can::filter::{ListEntry16, Mask32};
use embassy_stm32::can::{Can, Fifo, Frame, StandardId};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::usart::{self, RingBufferedUartRx, UartRx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, can, dma, peripherals};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_time::{Instant, Timer};
use gnss_guard_board::gnss::{LineSplitter, MAX_SENTENCE};
use gnss_guard_board::pipeline::Pipeline;
use {defmt_rtt as _, panic_probe as _};

bind_interrupts!(struct Irqs {
    CAN1_RX0 => can::Rx0InterruptHandler<peripherals::CAN1>;
    CAN1_RX1 => can::Rx1InterruptHandler<peripherals::CAN1>;
    CAN1_SCE => can::SceInterruptHandler<peripherals::CAN1>;
    CAN1_TX => can::TxInterruptHandler<peripherals::CAN1>;
    USART2 => usart::InterruptHandler<peripherals::USART2>;
    DMA1_STREAM5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
});

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

/// A received NMEA sentence.
#[derive(Clone)]
struct NmeaLine {
    t_us: u64,
    line: heapless::Vec<u8, MAX_SENTENCE>,
}

static CAN_RX: Channel<CriticalSectionRawMutex, CanMsg, 64> = Channel::new();
static NMEA_RX: Channel<CriticalSectionRawMutex, NmeaLine, 8> = Channel::new();
static ALARM_TX: Channel<CriticalSectionRawMutex, (u16, [u8; 8]), 4> = Channel::new();

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

#[embassy_executor::task]
async fn can_task(mut can: Can<'static>) {
    let (mut dropped, mut bus_errors) = (0u32, 0u32);
    loop {
        match select(can.read(), ALARM_TX.receive()).await {
            Either::First(Ok(env)) => {
                if let embedded_can::Id::Standard(id) = env.frame.id() {
                    let data = env.frame.data();
                    let mut d = [0u8; 8];
                    let n = data.len().min(8);
                    d[..n].copy_from_slice(&data[..n]);
                    let msg = CanMsg { t_us: Instant::now().as_micros(), id: id.as_raw(), len: n as u8, data: d };
                    if send_drop_oldest(&CAN_RX, msg) {
                        dropped += 1;
                        warn!("CAN queue full: dropped {} frames so far", dropped);
                    }
                }
            }
            Either::First(Err(e)) => {
                // Bus-off is recovered by the controller itself (ABOM); keep reading.
                bus_errors += 1;
                warn!("CAN bus error {} (#{})", e, bus_errors);
            }
            Either::Second((id, data)) => {
                if let Ok(frame) = Frame::new_standard(id, &data) {
                    if can.try_write(&frame).is_err() {
                        warn!("CAN: alarm frame not sent, mailboxes full");
                    }
                }
            }
        }
    }
}

#[embassy_executor::task]
async fn gnss_task(mut rx: RingBufferedUartRx<'static>) {
    let mut splitter = LineSplitter::default();
    let mut buf = [0u8; 64];
    let (mut uart_errors, mut dropped) = (0u32, 0u32);
    loop {
        match rx.read(&mut buf).await {
            Ok(n) => {
                let t_us = Instant::now().as_micros();
                splitter.push(&buf[..n], |l| {
                    let mut line = heapless::Vec::new();
                    let _ = line.extend_from_slice(l);
                    if send_drop_oldest(&NMEA_RX, NmeaLine { t_us, line }) {
                        dropped += 1;
                    }
                });
            }
            Err(e) => {
                // Overrun, framing, noise or parity: the partial sentence is unusable.
                uart_errors += 1;
                splitter.discard_partial();
                warn!("GNSS UART error {} (#{}), {} lines dropped", e, uart_errors, dropped);
            }
        }
    }
}

#[embassy_executor::task]
async fn detector_task(mut alarm_pin: Output<'static>, mut wdg: IndependentWatchdog<'static, peripherals::IWDG>) {
    // Strategy 1: the LSTM with the built-in model, or the kinematic predictor if it is invalid.
    let predictor = detector_core::strategy::location_shift::Predictor::default_lstm();
    if !matches!(predictor, detector_core::strategy::location_shift::Predictor::Lstm(_)) {
        warn!("LSTM model invalid: strategy 1 uses the kinematic predictor");
    }
    let cfg = detector_core::fusion::Config::for_predictor(&detector_core::profile::UBLOX_10HZ, &predictor);
    let templates = detector_core::strategy::turn::TemplateSet::parse(detector_core::strategy::turn::DEFAULT_TEMPLATES).ok();
    if templates.is_none() {
        warn!("turn templates invalid: strategy 2 disabled");
    }
    let mut p = Pipeline::new(cfg, templates, predictor);
    let mut latched = false;
    loop {
        let mut on_verdict = |v: &detector_core::fusion::Verdict| {
            if !v.fired.is_empty() || v.alarm {
                let _ = ALARM_TX.try_send(gnss_guard_board::can::alarm_frame(v));
            }
            if !v.fired.is_empty() {
                warn!("SPOOFING ALARM epoch {} fired {=u8:b} reasons {=u16:b}", v.epoch, v.fired.0, v.reasons.0);
            }
            if v.alarm && !latched {
                latched = true;
            }
        };
        match select3(CAN_RX.receive(), NMEA_RX.receive(), Timer::after_millis(500)).await {
            Either3::First(m) => p.on_can(m.t_us as f64 * 1e-6, m.id as u32, &m.data[..m.len as usize], &mut on_verdict),
            Either3::Second(n) => p.on_nmea(n.t_us as f64 * 1e-6, &n.line, &mut on_verdict),
            Either3::Third(()) => {}
        }
        if latched {
            alarm_pin.set_high();
        }
        wdg.pet();
    }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(Default::default());
    info!("gnss-guard: profile {}, {} CAN ids filtered", gnss_guard_board::can::PROFILE, gnss_guard_board::can::FILTER_IDS.len());

    // Alarm pin (PA5) and watchdog (2 s), fed only by the detector loop.
    let alarm_pin = Output::new(p.PA5, Level::Low, Speed::Low);
    let mut wdg = IndependentWatchdog::new(p.IWDG, 2_000_000);
    wdg.unleash();

    // CAN1 on PA11/PA12 at 500 kbit/s; hardware filters: the profile's ids, 4 per bank.
    let mut can = Can::new(p.CAN1, p.PA11, p.PA12, Irqs);
    {
        let mut f = can.modify_filters();
        let ids = gnss_guard_board::can::FILTER_IDS;
        if ids.is_empty() {
            f.enable_bank(0, Fifo::Fifo0, Mask32::accept_all());
        }
        for (bank, chunk) in ids.chunks(4).enumerate() {
            let entry = |k: usize| {
                let id = chunk.get(k).or(chunk.first()).copied().unwrap_or(0);
                ListEntry16::data_frames_with_id(StandardId::new(id).unwrap_or(StandardId::ZERO))
            };
            f.enable_bank(bank as u8, Fifo::Fifo0, [entry(0), entry(1), entry(2), entry(3)]);
        }
    }
    can.set_bitrate(CAN_BITRATE);
    can.enable().await;

    // GNSS receiver on USART2 RX (PA3), DMA ring buffer.
    let mut ucfg = usart::Config::default();
    ucfg.baudrate = GNSS_BAUD;
    static DMA_BUF: static_cell::StaticCell<[u8; 512]> = static_cell::StaticCell::new();
    let gnss = match UartRx::new(p.USART2, p.PA3, p.DMA1_CH5, Irqs, ucfg) {
        Ok(rx) => Some(rx.into_ring_buffered(DMA_BUF.init([0; 512]))),
        Err(_) => {
            warn!("GNSS UART configuration refused");
            None
        }
    };

    spawner.spawn(detector_task(alarm_pin, wdg).expect("detector task spawns once"));
    spawner.spawn(can_task(can).expect("CAN task spawns once"));
    if let Some(rx) = gnss {
        spawner.spawn(gnss_task(rx).expect("GNSS task spawns once"));
    }
}
