//! The example's own source of CAN frames and GNSS sentences: a car driven in software, as a
//! bus and a receiver would deliver it (on a board: the CAN peripheral's FIFO and the UART).
//!
//! The car accelerates to 14 m/s, drives straight, slows for a left turn of about 90 degrees,
//! and drives on. From `SPOOF_AT_S` a spoofer shifts the position the receiver reports by
//! `SPOOF_OFFSET_M` to the east (the paper's turn-by-turn attack).

use core::fmt::Write;

/// When the spoofer starts, seconds.
pub const SPOOF_AT_S: f64 = 150.0;
/// The offset it applies, metres east.
pub const SPOOF_OFFSET_M: f64 = 120.0;
/// How long the drive lasts, seconds.
pub const DRIVE_S: f64 = 180.0;

/// This car's two CAN messages (its "DBC"): wheel speed, and steering with the pedal.
pub const ID_WHEEL_SPEED: u16 = 0x0B0;
pub const ID_STEER_PEDAL: u16 = 0x0B1;

/// A CAN data frame as the controller hands it over.
#[derive(Clone, Copy)]
pub struct Frame {
    pub t: f64,
    pub id: u16,
    pub data: [u8; 8],
}

/// Something the car's bus or receiver delivered.
pub enum Delivery {
    Can(Frame),
    /// An NMEA RMC sentence, and the time it arrived.
    Nmea(f64, heapless::String<96>),
}

/// The car's state, advanced 100 times a second.
pub struct Car {
    t: f64,
    north_m: f64,
    east_m: f64,
    heading_rad: f64,
    speed: f64,
    steer_deg: f64,
    pedal: f64,
    step: u32,
}

const DT: f64 = 0.01;
const WHEELBASE_M: f64 = 2.7;
const STEER_RATIO: f64 = 15.0;
const LAT0: f64 = 52.0;
const LON0: f64 = 5.0;

impl Car {
    pub fn new() -> Self {
        Car { t: 0.0, north_m: 0.0, east_m: 0.0, heading_rad: 0.0, speed: 0.0, steer_deg: 0.0, pedal: 0.0, step: 0 }
    }

    /// Where the driver puts the pedal and the wheel at time `t`: target speed, steering.
    fn driver(t: f64) -> (f64, f64) {
        match t {
            t if t < 60.0 => (14.0, 0.0),
            t if t < 75.0 => (8.0, 0.0),
            // The turn: the wheel turned 90 degrees left for 6 s at 8 m/s.
            t if t < 76.5 => (8.0, 60.0 * (t - 75.0)),
            t if t < 81.0 => (8.0, 90.0),
            t if t < 82.5 => (8.0, 90.0 - 60.0 * (t - 81.0)),
            _ => (14.0, 0.0),
        }
    }

    /// Advances 10 ms and returns what the bus and the receiver delivered meanwhile.
    pub fn advance(&mut self, out: &mut heapless::Vec<Delivery, 4>) -> bool {
        out.clear();
        if self.t >= DRIVE_S {
            return false;
        }
        let (target, steer) = Car::driver(self.t);
        let accel = (target - self.speed).clamp(-2.0, 1.5);
        self.pedal = if accel > 0.05 { 15.0 + 20.0 * accel } else if accel < -0.05 { 0.0 } else { 12.0 };
        self.steer_deg = steer;
        self.speed = (self.speed + accel * DT).max(0.0);
        let road_wheel = (self.steer_deg / STEER_RATIO).to_radians();
        // + = left: the heading (clockwise from north) decreases.
        self.heading_rad -= self.speed * libm::tan(road_wheel) / WHEELBASE_M * DT;
        self.north_m += self.speed * libm::cos(self.heading_rad) * DT;
        self.east_m += self.speed * libm::sin(self.heading_rad) * DT;
        self.step += 1;
        self.t = self.step as f64 * DT;
        // CAN at 20 Hz, the receiver at 1 Hz.
        if self.step.is_multiple_of(5) {
            let kmh = (self.speed * 3.6 * 100.0) as u16;
            let mut d = [0u8; 8];
            d[..2].copy_from_slice(&kmh.to_le_bytes());
            let _ = out.push(Delivery::Can(Frame { t: self.t, id: ID_WHEEL_SPEED, data: d }));
            let mut d = [0u8; 8];
            d[..2].copy_from_slice(&((self.steer_deg * 10.0) as i16).to_le_bytes());
            d[2] = (self.pedal * 2.0) as u8;
            let _ = out.push(Delivery::Can(Frame { t: self.t, id: ID_STEER_PEDAL, data: d }));
        }
        if self.step.is_multiple_of(100) {
            let _ = out.push(Delivery::Nmea(self.t, self.rmc()));
        }
        true
    }

    /// The receiver's RMC sentence now (with the spoofer's offset once it started).
    fn rmc(&self) -> heapless::String<96> {
        let east = self.east_m + if self.t >= SPOOF_AT_S { SPOOF_OFFSET_M } else { 0.0 };
        let lat = LAT0 + self.north_m / 111_320.0;
        let lon = LON0 + east / (111_320.0 * libm::cos(LAT0.to_radians()));
        let deg = self.heading_rad.to_degrees();
        let course = deg - 360.0 * libm::floor(deg / 360.0);
        let secs = self.t as u32;
        let mut body: heapless::String<96> = heapless::String::new();
        let _ = write!(
            body,
            "GPRMC,{:02}{:02}{:02}.00,A,{:02}{:08.5},N,{:03}{:08.5},E,{:.2},{:.1},010125,,,A",
            secs / 3600,
            secs / 60 % 60,
            secs % 60,
            lat as u32,
            (lat - libm::floor(lat)) * 60.0,
            lon as u32,
            (lon - libm::floor(lon)) * 60.0,
            self.speed / 0.514_444,
            course,
        );
        let sum = body.bytes().fold(0u8, |a, b| a ^ b);
        let mut s = heapless::String::new();
        let _ = write!(s, "${body}*{sum:02X}");
        s
    }
}
