//! Firmware entry point (STM32F405RG, embassy).
//!
//! For now this only brings the board up and proves that `detector-core` links into a
//! Cortex-M4F image; the CAN, GNSS and detector tasks arrive with the firmware issue.
#![no_std]
#![no_main]

use defmt::info;
use embassy_executor::Spawner;
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_time::Timer;
use {defmt_rtt as _, panic_probe as _};

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = embassy_stm32::init(Default::default());
    // PA5: the alarm output pin (an LED on most F4 boards).
    let mut alarm = Output::new(p.PA5, Level::Low, Speed::Low);
    let d = detector_core::geo::haversine_m(
        detector_core::geo::LatLon::new(48.0, 11.0),
        detector_core::geo::LatLon::new(48.001, 11.0),
        detector_core::geo::EARTH_RADIUS_PAPER_M,
    );
    info!("gnss-guard firmware up; geodesy self-check {} m", d);
    loop {
        alarm.set_low();
        Timer::after_secs(1).await;
    }
}
