//! The car's calibration kept in flash across drives.
//!
//! One record ([`Record`], the `GGCR` bytes of `detector_core::wire::calibration`) under one
//! key of `sequential-storage`'s map over two flash sectors: the crate writes each new record
//! after the last and erases a sector only when the other is full (wear levelling: a 16 KiB
//! sector holds about 160 records, so a record saved every five minutes of driving erases a
//! sector about once a week), and a record cut short by a power failure is found and skipped
//! (the one before it is read). The record itself carries a CRC: bytes that read back but are not
//! a valid record (a flipped bit the crate's own checks let through, another version) are
//! reported as [`Loaded::Invalid`] and ignored, the car is learnt afresh.
//!
//! When to save is [`SavePolicy`]'s business, apart from the flash: with the car standing (an
//! STM32F405 cannot fetch code from flash while it writes or erases it, so the detector stops
//! for up to 0.8 s), no alarm latched (what a drive under attack learnt is not kept), at most
//! every [`SAVE_EVERY_S`], and only what the detector says is worth keeping
//! (`Detector::calibration_record`: calibrated, and not contradicting the stored record); a
//! drive that contradicts the stored record after a save of its own writes the stored one back
//! ([`SavePolicy::keep`]).

use detector_core::fusion::{Detector, Verdict};
use detector_core::strategy::location_shift::ShiftPredictor;
use detector_core::strategy::motion::MotionState;
use detector_core::wire::calibration::{Record, RecordError, RECORD_LEN};
use embedded_storage_async::nor_flash::NorFlash;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

/// The map's one key: it serialises to no bytes, so every item is the record (or its absence).
///
/// A one-byte key (`u8`) made `sequential-storage` 8.0.2 panic on a corrupted sector: the fuzz
/// target `calibration` found flash bytes for which `fetch_item` takes the key's length from one
/// read of an item and the item's length from another, and subtracts them (`data_len -
/// item_key_len` underflows, the slice index panics; `tests/fuzz/regressions/calibration/
/// crash-242e...`). With a key of length zero that subtraction cannot underflow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordKey;

impl sequential_storage::map::Key for RecordKey {
    fn serialize_into(&self, _buffer: &mut [u8]) -> Result<usize, sequential_storage::map::SerializationError> {
        Ok(0)
    }
    fn deserialize_from(_buffer: &[u8]) -> Result<(Self, usize), sequential_storage::map::SerializationError> {
        Ok((RecordKey, 0))
    }
}

/// The value written by a relearn request: one byte (an item of length zero is not written).
const FORGOTTEN: [u8; 1] = [0];
/// The buffer the crate serialises into: key and record, word aligned.
const BUF: usize = 128;

/// A record is saved at most this often, seconds (the calibration moves slowly: minutes of
/// driving lost to a power cut cost nothing).
pub const SAVE_EVERY_S: f64 = 300.0;
/// The car must have stood this long, seconds (flash programming stalls the detector).
pub const STAND_S: f64 = 2.0;

/// What the store held at start-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Loaded {
    /// Nothing (a new device, or after a relearn request): the car is learnt.
    None,
    Record(Record),
    /// Bytes that are not a valid record: ignored (status fault `CALIBRATION_INVALID`).
    Invalid(RecordError),
    /// The flash could not be read (status fault `CALIBRATION_STORE`).
    FlashError,
}

/// The calibration store over a flash region (see the module documentation).
pub struct Store<F: NorFlash> {
    map: MapStorage<RecordKey, F, Cache<Uncached, Uncached, Uncached, RecordKey>>,
    buf: [u8; BUF],
}

impl<F: NorFlash> Store<F> {
    /// A store over `range` (offsets into `flash`: at least two erase units, aligned), or `None`
    /// when the range cannot hold one.
    pub fn new(flash: F, range: core::ops::Range<u32>) -> Option<Self> {
        let cfg = MapConfig::try_new(range).ok()?;
        Some(Store { map: MapStorage::new(flash, cfg, Cache::new_uncached()), buf: [0; BUF] })
    }

    /// The stored record. A store the crate finds corrupted (bytes no write of ours left, or a
    /// sector damaged) is erased after it is reported: the car is learnt afresh and the next
    /// save has clean sectors to write to.
    pub async fn load(&mut self) -> Loaded {
        match self.map.fetch_item::<&[u8]>(&mut self.buf, &RecordKey).await {
            Ok(None) => Loaded::None,
            Ok(Some([] | [0])) => Loaded::None,
            Ok(Some(bytes)) => match Record::decode(bytes) {
                Ok(r) => Loaded::Record(r),
                Err(e) => Loaded::Invalid(e),
            },
            Err(sequential_storage::Error::Corrupted { .. }) => {
                let _ = self.map.erase_all().await;
                Loaded::FlashError
            }
            Err(_) => Loaded::FlashError,
        }
    }

    /// Keeps `r` (written after the last one; a sector erased when the other is full), and reads
    /// it back: a store whose corruption only shows on reading (found by the fuzz target
    /// `calibration`: a write into a damaged sector succeeded, the read then failed) is erased
    /// and written once more.
    pub async fn save(&mut self, r: &Record) -> Result<(), StoreError> {
        let bytes: [u8; RECORD_LEN] = r.encode();
        for _ in 0..2 {
            let wrote = self.map.store_item(&mut self.buf, &RecordKey, &&bytes[..]).await;
            if wrote.is_ok() && matches!(self.map.fetch_item::<&[u8]>(&mut self.buf, &RecordKey).await, Ok(Some(b)) if b == bytes) {
                return Ok(());
            }
            self.map.erase_all().await.map_err(|_| StoreError)?;
        }
        Err(StoreError)
    }

    /// The flash back (the store's cache goes with it).
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }

    /// Forgets the record (a relearn request): an empty value is written after it.
    pub async fn forget(&mut self) -> Result<(), StoreError> {
        self.map.store_item(&mut self.buf, &RecordKey, &&FORGOTTEN[..]).await.map_err(|_| StoreError)
    }
}

/// The flash failed (or the crate found it corrupted beyond repair).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StoreError;

/// When to save the calibration. See the module documentation.
#[derive(Clone, Copy, Debug, Default)]
pub struct SavePolicy {
    /// When the wheels began to stand (reset when they move or nothing says).
    standing_since: Option<f64>,
    last_save_t: Option<f64>,
    /// The drive contradicted the stored record after a save of its own: the stored record is
    /// to be written back at the next save (`restoring`), once (`restored`).
    restoring: bool,
    restored: bool,
}

impl SavePolicy {
    /// Every verdict, at time `now` (the device's clock): whether to ask the detector for its
    /// record and save it now.
    pub fn due(&mut self, now: f64, v: &Verdict) -> bool {
        let standing = v.motion.is_some_and(|m| m.wheel == MotionState::Standing);
        if !standing || !now.is_finite() {
            self.standing_since = None;
            return false;
        }
        let since = *self.standing_since.get_or_insert(now);
        let stood = now - since >= STAND_S;
        let quiet = !v.alarm;
        let spaced = self.last_save_t.is_none_or(|t| now - t >= SAVE_EVERY_S || now < t || t.is_nan());
        stood && quiet && spaced
    }

    /// A save was made (or attempted) at `now`.
    pub fn saved(&mut self, now: f64) {
        self.last_save_t = Some(now);
    }

    /// Every verdict: when a save is due, the record `make` gives (the detector's, if it has one
    /// to keep), and the save's turn taken only then: a standstill with nothing to keep (a
    /// first drive not yet calibrated) held css_canedge session 0's calibration, learnt by its
    /// stop at 301 s, back past its stop at 43 s for five minutes, to the end of its log.
    pub fn offer<R>(&mut self, now: f64, v: &Verdict, make: impl FnOnce() -> Option<R>) -> Option<R> {
        let r = if self.due(now, v) { make() } else { None };
        if r.is_some() {
            self.saved(now);
            self.restored |= self.restoring;
            self.restoring = false;
        }
        r
    }

    /// The drive contradicts the stored record (every verdict from then on): if this drive has
    /// saved a record of its own before (what it learnt while the contradiction's test was still
    /// gathering its evidence), the next save writes the stored record back ([`Self::restoring`]):
    /// a drive that contradicts the record leaves it as it was.
    pub fn contradicted(&mut self) {
        self.restoring = self.last_save_t.is_some() && !self.restored;
    }

    /// The next save is the stored record's, written back (see [`Self::contradicted`]).
    pub fn restoring(&self) -> bool {
        self.restoring
    }

    /// Every verdict of `det` at `now`: the record to save now, if any (the detector's own, or
    /// the stored one written back). The board's pipeline and `host-sim detect --calibration`
    /// both keep the car's calibration through this.
    pub fn keep<P: ShiftPredictor>(&mut self, now: f64, v: &Verdict, det: &Detector<'_, P>) -> Option<Record> {
        let cal = det.track().calibration();
        if cal.contradiction().is_some() {
            self.contradicted();
        }
        let restore = self.restoring.then(|| cal.stored().copied()).flatten();
        self.offer(now, v, || restore.or_else(|| det.calibration_record()))
    }
}

/// A NOR flash in memory for the host tests and the fuzz target: erased bytes are 0xFF, a write
/// must be word aligned onto erased bytes (a flash that cannot rewrite), every erase and write is
/// counted (wear), and the power can be cut after a given number of operations (the operation
/// in flight writes half its bytes, everything after fails until [`MockFlash::power_on`]).
#[cfg(any(test, feature = "mock-flash"))]
pub mod mock {
    extern crate std;
    use embedded_storage_async::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};
    use std::vec::Vec;

    /// `PAGES` pages of `PAGE` bytes, written in words of 4.
    pub struct MockFlash<const PAGES: usize, const PAGE: usize> {
        pub bytes: Vec<u8>,
        pub erases: Vec<u32>,
        pub writes: u64,
        /// Operations left before the power fails (`None`: it never does).
        pub power_for: Option<u32>,
        off: bool,
    }

    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum MockError {
        OutOfBounds,
        NotAligned,
        NotErased,
        PowerOff,
    }

    impl NorFlashError for MockError {
        fn kind(&self) -> NorFlashErrorKind {
            match self {
                MockError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
                MockError::NotAligned => NorFlashErrorKind::NotAligned,
                _ => NorFlashErrorKind::Other,
            }
        }
    }

    impl<const PAGES: usize, const PAGE: usize> Default for MockFlash<PAGES, PAGE> {
        fn default() -> Self {
            MockFlash { bytes: std::vec![0xFF; PAGES * PAGE], erases: std::vec![0; PAGES], writes: 0, power_for: None, off: false }
        }
    }

    impl<const PAGES: usize, const PAGE: usize> MockFlash<PAGES, PAGE> {
        /// Power back on (the contents as the cut left them).
        pub fn power_on(&mut self) {
            self.off = false;
            self.power_for = None;
        }
        /// One operation: false (and the power off) when the power fails during it.
        fn spend(&mut self) -> Result<bool, MockError> {
            if self.off {
                return Err(MockError::PowerOff);
            }
            match self.power_for.as_mut() {
                Some(0) => {
                    self.off = true;
                    Ok(false)
                }
                Some(n) => {
                    *n -= 1;
                    Ok(true)
                }
                None => Ok(true),
            }
        }
    }

    impl<const PAGES: usize, const PAGE: usize> ErrorType for MockFlash<PAGES, PAGE> {
        type Error = MockError;
    }

    impl<const PAGES: usize, const PAGE: usize> ReadNorFlash for MockFlash<PAGES, PAGE> {
        const READ_SIZE: usize = 1;
        async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), MockError> {
            if self.off {
                return Err(MockError::PowerOff);
            }
            let src = self.bytes.get(offset as usize..offset as usize + bytes.len()).ok_or(MockError::OutOfBounds)?;
            bytes.copy_from_slice(src);
            Ok(())
        }
        fn capacity(&self) -> usize {
            PAGES * PAGE
        }
    }

    impl<const PAGES: usize, const PAGE: usize> NorFlash for MockFlash<PAGES, PAGE> {
        const WRITE_SIZE: usize = 4;
        const ERASE_SIZE: usize = PAGE;
        async fn erase(&mut self, from: u32, to: u32) -> Result<(), MockError> {
            let (from, to) = (from as usize, to as usize);
            if from % PAGE != 0 || to % PAGE != 0 || from > to {
                return Err(MockError::NotAligned);
            }
            if to > PAGES * PAGE {
                return Err(MockError::OutOfBounds);
            }
            for page in from / PAGE..to / PAGE {
                let whole = self.spend()?;
                let end = if whole { (page + 1) * PAGE } else { page * PAGE + PAGE / 2 };
                self.bytes[page * PAGE..end].fill(0xFF);
                self.erases[page] += 1;
                if !whole {
                    return Err(MockError::PowerOff);
                }
            }
            Ok(())
        }
        async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), MockError> {
            let o = offset as usize;
            if !o.is_multiple_of(4) || !bytes.len().is_multiple_of(4) {
                return Err(MockError::NotAligned);
            }
            let dst = self.bytes.get(o..o + bytes.len()).ok_or(MockError::OutOfBounds)?;
            if dst.iter().any(|b| *b != 0xFF) {
                return Err(MockError::NotErased);
            }
            let whole = self.spend()?;
            let n = if whole { bytes.len() } else { (bytes.len() / 2) & !3 };
            self.bytes[o..o + n].copy_from_slice(&bytes[..n]);
            self.writes += 1;
            if whole { Ok(()) } else { Err(MockError::PowerOff) }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::mock::MockFlash;
    use super::*;
    use embassy_futures::block_on;

    type Flash = MockFlash<4, 2048>;
    const RANGE: core::ops::Range<u32> = 2048..6144;

    fn record(n: u16) -> Record {
        Record {
            scale: 0.99 + n as f32 * 1e-5,
            delay_s: [0.375, 0.25],
            learnt_s: 600.0 * n as f32,
            drives: n,
            gyro_bias_degps: 0.39,
            gyro_bias_weight_s: 40.0,
            gyro_scale_error: -0.01,
            gyro_scale_sd: 0.004,
            noise_s0_m: [1.2, 1.4],
            noise_k: [0.011, 0.012],
            velocity_sigma_mps: [0.14, 0.2],
            nominal_dt_s: 1.0,
            anchor_scale: 0.99,
            anchor_delay_s: [0.375, 0.25],
            anchor_gyro_scale_error: -0.01,
            anchor_noise_s0_m: [1.2, 1.4],
            anchor_noise_k: [0.011, 0.012],
            anchor_velocity_sigma_mps: [0.14, 0.2],
        }
    }

    #[test]
    fn records_read_back_and_the_latest_wins() {
        let mut s = Store::new(Flash::default(), RANGE).unwrap();
        assert_eq!(block_on(s.load()), Loaded::None);
        for n in 1..=5 {
            block_on(s.save(&record(n))).unwrap();
            assert_eq!(block_on(s.load()), Loaded::Record(record(n)));
        }
        block_on(s.forget()).unwrap();
        assert_eq!(block_on(s.load()), Loaded::None);
        // A range outside two aligned erase units is refused.
        assert!(Store::new(Flash::default(), 2048..4096).is_none());
        assert!(Store::new(Flash::default(), 100..6144).is_none());
    }

    /// A record an older firmware kept (version 1, 76 bytes, without the anchors) is read after
    /// the update, its own scale and delays its anchors, and the next save writes this version:
    /// the car's calibration survives the update.
    #[test]
    fn a_version_1_record_survives_the_update() {
        let mut s = Store::new(Flash::default(), RANGE).unwrap();
        let r = record(3);
        let mut v1 = r.encode()[..76].to_vec();
        v1[4..6].copy_from_slice(&1u16.to_le_bytes());
        v1[6..8].copy_from_slice(&64u16.to_le_bytes());
        let crc = detector_core::wire::crc32::crc32(&v1[..72]);
        v1[72..].copy_from_slice(&crc.to_le_bytes());
        block_on(s.map.store_item(&mut s.buf, &RecordKey, &&v1[..])).unwrap();
        let Loaded::Record(got) = block_on(s.load()) else { panic!("a version 1 record is read") };
        assert_eq!((got.scale, got.delay_s, got.drives), (r.scale, r.delay_s, r.drives));
        assert_eq!((got.anchor_scale, got.anchor_delay_s, got.anchor_gyro_scale_error), (r.scale, r.delay_s, r.gyro_scale_error));
        block_on(s.save(&got)).unwrap();
        assert_eq!(block_on(s.load()), Loaded::Record(got));
        let mut buf = [0u8; BUF];
        let bytes = block_on(s.map.fetch_item::<&[u8]>(&mut buf, &RecordKey)).unwrap().unwrap();
        assert_eq!((bytes.len(), &bytes[4..6]), (RECORD_LEN, &detector_core::wire::calibration::VERSION.to_le_bytes()[..]));
    }

    #[test]
    fn wear_is_levelled_over_both_sectors() {
        let mut s = Store::new(Flash::default(), RANGE).unwrap();
        for n in 0..2000u16 {
            block_on(s.save(&record(n % 500 + 1))).unwrap();
        }
        assert_eq!(block_on(s.load()), Loaded::Record(record(1999 % 500 + 1)));
        let flash = s.into_flash();
        let (a, b) = (flash.erases[1], flash.erases[2]);
        // Only the two sectors of the range, each erased, within one of each other.
        assert_eq!((flash.erases[0], flash.erases[3]), (0, 0));
        assert!(a > 10 && b > 10 && a.abs_diff(b) <= 1, "erases {a} {b}");
        // About 2 KiB over a record of 92 bytes and its item header between erases.
        assert!((2000 / (a + b) as usize) >= 15, "{} records per erase", 2000 / (a + b));
    }

    #[test]
    fn a_power_cut_anywhere_leaves_the_old_record_or_the_new() {
        // Fill to just before a sector switch too, so that cuts land in erases as well.
        for filled in [3u16, 21, 22, 23] {
            let mut cut_at = 0;
            loop {
                let mut flash = Flash::default();
                {
                    let mut s = Store::new(&mut flash, RANGE).unwrap();
                    for n in 1..=filled {
                        block_on(s.save(&record(n))).unwrap();
                    }
                }
                flash.power_for = Some(cut_at);
                let done = {
                    let mut s = Store::new(&mut flash, RANGE).unwrap();
                    block_on(s.save(&record(filled + 1))).is_ok()
                };
                flash.power_on();
                let mut s = Store::new(&mut flash, RANGE).unwrap();
                let got = block_on(s.load());
                assert!(got == Loaded::Record(record(filled)) || got == Loaded::Record(record(filled + 1)), "filled {filled}, cut after {cut_at}: {got:?}");
                // And the store keeps working.
                block_on(s.save(&record(100))).unwrap();
                assert_eq!(block_on(s.load()), Loaded::Record(record(100)));
                if done {
                    break;
                }
                cut_at += 1;
            }
        }
    }

    #[test]
    fn a_corrupted_store_is_erased_and_a_save_reads_back() {
        // The fuzz target's find (tests/fuzz/regressions/calibration): sectors holding these
        // bytes, cycled, took a write that then failed to read.
        extern crate std;
        let pattern: std::vec::Vec<u8> = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/fuzz/regressions/calibration/crash-797e10b5b78ed443b458c2df7b4acbb3c191f7a1")).unwrap();
        let mut f: MockFlash<2, 1024> = MockFlash::default();
        for (b, x) in f.bytes.iter_mut().zip(pattern.iter().cycle()) {
            *b = *x;
        }
        let mut s = Store::new(f, 0..2048).unwrap();
        let _ = block_on(s.load());
        block_on(s.save(&record(3))).unwrap();
        assert_eq!(block_on(s.load()), Loaded::Record(record(3)));
    }

    #[test]
    fn damaged_bytes_are_reported_not_trusted() {
        let mut flash = Flash::default();
        {
            let mut s = Store::new(&mut flash, RANGE).unwrap();
            block_on(s.save(&record(7))).unwrap();
        }
        // Every bit of the record's bytes, flipped in turn (1 -> 0, as a flash can), is either
        // caught by the crate (the record before it, here none) or by the record's own checks.
        let at = flash.bytes.windows(4).position(|w| w == b"GGCR").unwrap();
        for i in 0..RECORD_LEN * 8 {
            let mut f = Flash::default();
            f.bytes.copy_from_slice(&flash.bytes);
            let byte = at + i / 8;
            let bit = 1u8 << (i % 8);
            if f.bytes[byte] & bit == 0 {
                continue;
            }
            f.bytes[byte] &= !bit;
            let mut s = Store::new(&mut f, RANGE).unwrap();
            match block_on(s.load()) {
                Loaded::Record(r) => panic!("bit {i}: a damaged record was trusted: {r:?}"),
                Loaded::None | Loaded::Invalid(_) | Loaded::FlashError => {}
            }
        }
    }

    #[test]
    fn saves_wait_for_a_standstill_without_alarm_and_are_spaced() {
        use detector_core::fusion::{Reasons, Verdict};
        use detector_core::strategy::motion::MotionOutcome;
        use detector_core::strategy::StrategySet;
        let v = |wheel: MotionState, alarm: bool| Verdict {
            epoch: 0,
            t: 0.0,
            ran: StrategySet::EMPTY,
            fired: StrategySet::EMPTY,
            degraded: StrategySet::EMPTY,
            reasons: Reasons::default(),
            shift: None,
            motion: Some(MotionOutcome { wheel, gnss: wheel, disagree_s: 0.0, disagreement: None, fired: false }),
            turn: None,
            turn_heading: None,
            track: None,
            learning: false,
            alarm,
            first_alarm: None,
        };
        let mut p = SavePolicy::default();
        assert!(!p.due(0.0, &v(MotionState::Moving, false)));
        assert!(!p.due(1.0, &v(MotionState::Standing, false)));
        assert!(p.due(3.5, &v(MotionState::Standing, false)));
        p.saved(3.5);
        assert!(!p.due(100.0, &v(MotionState::Standing, false)), "too soon");
        assert!(!p.due(400.0, &v(MotionState::Standing, true)), "alarm latched");
        assert!(p.due(401.0, &v(MotionState::Standing, false)));
        assert!(!p.due(f64::NAN, &v(MotionState::Standing, false)));
        // Nothing to keep at a due moment: the next standstill may still save.
        let mut p = SavePolicy::default();
        p.due(0.0, &v(MotionState::Standing, false));
        assert_eq!(p.offer(3.0, &v(MotionState::Standing, false), || None::<u8>), None);
        p.due(50.0, &v(MotionState::Moving, false));
        p.due(60.0, &v(MotionState::Standing, false));
        assert_eq!(p.offer(63.0, &v(MotionState::Standing, false), || Some(1u8)), Some(1));
        assert_eq!(p.offer(64.0, &v(MotionState::Standing, false), || Some(2u8)), None, "too soon");
        // Contradicted after that save: the next save is the stored record's, once.
        p.contradicted();
        assert!(p.restoring());
        assert_eq!(p.offer(400.0, &v(MotionState::Standing, false), || Some(0u8)), Some(0));
        p.contradicted();
        assert!(!p.restoring(), "written back once");
        // Contradicted before any save of the drive's own: nothing to write back.
        let mut p = SavePolicy::default();
        p.contradicted();
        assert!(!p.restoring());
    }
}
