//! A drive given as two logs from one's own car: a CAN log and a GNSS log, decoded with a DBC and
//! a map file read at run time, aligned by their timestamps.
//!
//! - CAN: SocketCAN `candump` log files (`candump -l` writes them; `candump -L` prints the same
//!   lines): `(<seconds>.<micros>) <interface> <frame>` with `<frame>` one of `123#11223344`
//!   (standard id, three hex digits), `12345678#...` (extended id, eight), `123#R` (remote, no
//!   data) and `123##<flags><data>` (CAN FD). Interface names ending in a number (`can0`,
//!   `vcan1`) give the map's bus number. Or a Vector ASC log ([`super::asc`]; channel N is bus
//!   N - 1), a Vector BLF log ([`super::blf`]; likewise), or ASAM MDF 4 bus-logging files
//!   ([`super::mdf4`]: one `.MF4` file, or a folder of one session's files; `BusChannel` N is bus
//!   N - 1).
//! - GNSS on CAN: when the map names GNSS fields ([`super::can_gnss`]), the fixes come from the
//!   CAN log itself and no GNSS log is needed.
//! - GNSS: NMEA 0183 logs, one sentence per line, parsed by the firmware's own parser
//!   (`gnss_guard_board::gnss::NmeaFixer`: a fix per valid RMC, GGA quality and VTG honoured).
//!   Each line may start with a host timestamp, `(<seconds>)` or `<seconds>`, on the CAN log's
//!   clock; a log without them takes each fix's time from its RMC (UTC date and time of day, as
//!   UNIX seconds), which aligns with a CAN log only when the logging host kept UTC. Or a u-blox
//!   UBX binary log ([`super::ubx_log`]): each fix at its NAV-PVT's UTC time, so the CAN log's
//!   host must have kept UTC (candump's timestamps are the host's clock).
//!
//! Both files are recognised by their content, not their names. A folder holding the two logs,
//! one `.dbc` and one `.map` is a drive like any other ([`load_folder`]): `inspect`, `attack` and
//! `eval` read it too. A malformed line is an
//! [`InputError`] naming the file, the line and what was expected; with
//! [`LoadOptions::skip_bad_rows`] it is counted in [`Replay::skipped_rows`] and dropped instead.

use super::drive::{Event, Format, InputError, LoadOptions, Replay};
pub use super::candump::{candump_from_text, looks_like_candump, micros_of, parse_candump_line, read_candump, CanFrame};
use detector_core::sample::Fix;
use gnss_guard_board::gnss::NmeaFixer;
use gnss_guard_board::ubx::days_from_civil;
use gnss_guard_profile::load::Profile;
use std::path::Path;

/// Is this the content of an NMEA log (its first non-empty line holds a `$` sentence)?
pub fn looks_like_nmea(text: &str) -> bool {
    text.lines().map(str::trim).find(|l| !l.is_empty()).is_some_and(|l| split_nmea_line(l).is_ok_and(|(_, s)| s.starts_with('$')))
}

/// An NMEA log line: its host timestamp, if any, and the sentence.
fn split_nmea_line(line: &str) -> Result<(Option<f64>, &str), String> {
    let line = line.trim();
    let Some(dollar) = line.find('$') else {
        return Err(format!("expected an NMEA sentence starting with `$`, found {line:?}"));
    };
    let (head, sentence) = line.split_at(dollar);
    let head = head.trim();
    if head.is_empty() {
        return Ok((None, sentence));
    }
    let ts = head.strip_prefix('(').and_then(|s| s.strip_suffix(')')).unwrap_or(head);
    let t: f64 = ts.parse().ok().filter(|t: &f64| t.is_finite()).ok_or_else(|| format!("expected a host timestamp `<seconds>` or `(<seconds>)` before the sentence, found {head:?}"))?;
    Ok((Some(t), sentence))
}

/// Reads an NMEA log into fixes (see the module documentation for the timestamps).
pub fn read_nmea_log(path: &Path, opts: &LoadOptions) -> Result<(Vec<Fix>, usize), InputError> {
    let text = std::fs::read_to_string(path).map_err(|e| InputError::file(path, format!("cannot read as text: {e}")))?;
    nmea_log_from_text(path, &text, opts)
}

/// [`read_nmea_log`] on the text of `path`: the fixes and the number of lines skipped.
pub fn nmea_log_from_text(path: &Path, text: &str, opts: &LoadOptions) -> Result<(Vec<Fix>, usize), InputError> {
    let mut fixer = NmeaFixer::default();
    let mut fixes = Vec::new();
    let mut skipped = 0;
    let mut stamped: Option<bool> = None;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i as u64 + 1;
        if raw.trim().is_empty() {
            continue;
        }
        let (ts, sentence) = match split_nmea_line(raw) {
            Ok(x) => x,
            Err(_) if opts.skip_bad_rows => {
                skipped += 1;
                continue;
            }
            Err(e) => return Err(InputError::line(path, line_no, e)),
        };
        match stamped {
            None => stamped = Some(ts.is_some()),
            Some(s) if s != ts.is_some() => {
                return Err(InputError::line(path, line_no, format!(
                    "expected every line {} a host timestamp, as the first line", if s { "with" } else { "without" })));
            }
            _ => {}
        }
        // Without host timestamps, the RMC's own UTC date and time of day.
        let t = match ts {
            Some(t) => t,
            None => match gnss_guard_board::nmea::parse(sentence.as_bytes()) {
                Ok(gnss_guard_board::nmea::Sentence::Rmc(r)) => match utc_of(&r) {
                    Some(t) => t,
                    None => return Err(InputError::line(path, line_no, "expected an RMC with a date and a time (the log has no host timestamps)")),
                },
                _ => f64::NAN,
            },
        };
        let fix = match feed(&mut fixer, t, sentence) {
            Ok(f) => f,
            Err(_) if opts.skip_bad_rows => {
                skipped += 1;
                continue;
            }
            Err(e) => return Err(InputError::line(path, line_no, e)),
        };
        if let Some(f) = fix {
            fixes.push(f);
        }
    }
    if fixes.is_empty() {
        return Err(InputError::file(path, "expected NMEA RMC sentences with a valid fix, found none"));
    }
    Ok((fixes, skipped))
}

/// Reads a CAN log, recognised by its content: candump, Vector ASC, Vector BLF or MDF 4 (a file,
/// or a folder of one session's MF4 files); its frames in time order, and the lines or objects
/// skipped.
pub fn read_can_log(can: &Path, opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    if can.is_dir() {
        return Ok((super::mdf4::read_mdf4_drive(can)?, 0));
    }
    let bytes = std::fs::read(can).map_err(|e| InputError::file(can, format!("cannot read: {e}")))?;
    can_log_from_bytes(can, bytes, opts)
}

/// [`read_can_log`] on a file's bytes.
pub fn can_log_from_bytes(can: &Path, bytes: Vec<u8>, opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    if super::mdf4::looks_like_mdf4(&bytes) {
        let mut frames = super::mdf4::mdf4_from_bytes(can, bytes)?.frames;
        frames.sort_by(|a, b| a.t.total_cmp(&b.t));
        return Ok((frames, 0));
    }
    if super::blf::looks_like_blf(&bytes) {
        let (mut frames, skipped) = super::blf::blf_from_bytes(can, &bytes, opts)?;
        frames.sort_by(|a, b| a.t.total_cmp(&b.t));
        return Ok((frames, skipped));
    }
    let text = String::from_utf8_lossy(&bytes);
    if looks_like_candump(&text) {
        candump_from_text(can, &text, opts)
    } else if super::asc::looks_like_asc(&text) {
        super::asc::asc_from_text(can, &text, opts)
    } else {
        Err(InputError::line(can, 1, "expected a CAN log: SocketCAN candump (`(<seconds>) can0 123#...`), Vector ASC (`date ...` first), Vector BLF (`LOGG` first) or ASAM MDF 4 (`MDF     ` or `UnFinMF ` first)"))
    }
}

/// Reads a GNSS log, recognised by its content: u-blox UBX or NMEA. The fixes, the lines or
/// frames skipped, and what the log said beyond its fixes (for the replay's notes).
pub fn read_gnss_log(gnss: &Path, opts: &LoadOptions) -> Result<(Vec<Fix>, usize, Vec<String>), InputError> {
    let bytes = std::fs::read(gnss).map_err(|e| InputError::file(gnss, format!("cannot read: {e}")))?;
    if super::ubx_log::looks_like_ubx(&bytes) {
        let (log, skipped) = super::ubx_log::ubx_log_from_bytes(gnss, &bytes, opts)?;
        let note = log.note();
        return Ok((log.fixes, skipped, vec![note]));
    }
    let text = String::from_utf8_lossy(&bytes);
    if !looks_like_nmea(&text) {
        return Err(InputError::line(gnss, 1, "expected an NMEA log (`$GPRMC,...` per line, optionally after a host timestamp) or a u-blox UBX log (frames starting B5 62)"));
    }
    let (fixes, skipped) = nmea_log_from_text(gnss, &text, opts)?;
    Ok((fixes, skipped, Vec::new()))
}

/// An RMC sentence's UTC date and time as UNIX seconds (`None` for other sentences, or an RMC
/// without both).
pub fn rmc_utc(sentence: &str) -> Option<f64> {
    match gnss_guard_board::nmea::parse(sentence.as_bytes()) {
        Ok(gnss_guard_board::nmea::Sentence::Rmc(r)) => utc_of(&r),
        _ => None,
    }
}

/// A parsed RMC's UTC date and time as UNIX seconds (`None` without both).
fn utc_of(r: &gnss_guard_board::nmea::Rmc) -> Option<f64> {
    let ((d, m, y), tod) = (r.date?, r.time_s?);
    Some(days_from_civil(2000 + y as i64, m as i64, d as i64) as f64 * 86_400.0 + tod)
}

/// One sentence through `fixer` at time `t`: a fix, nothing, or what is wrong with it.
fn feed(fixer: &mut NmeaFixer, t: f64, sentence: &str) -> Result<Option<Fix>, String> {
    let before = fixer.counters.rejected.saturating_add(fixer.counters.overlong);
    let fix = fixer.line(t, sentence.as_bytes());
    if fixer.counters.rejected.saturating_add(fixer.counters.overlong) != before {
        let why = match gnss_guard_board::nmea::parse(sentence.as_bytes()) {
            Err(e) => format!("{e:?}"),
            Ok(_) => "a position out of range".to_string(),
        };
        return Err(format!("expected a valid NMEA sentence, found one that fails: {why}"));
    }
    Ok(fix)
}

/// One line of an NMEA log with host timestamps through `fixer` (what `host-sim live` reads):
/// a fix, nothing, or what is wrong with the line.
pub fn nmea_line(fixer: &mut NmeaFixer, line: &str) -> Result<Option<Fix>, String> {
    let (ts, sentence) = split_nmea_line(line)?;
    let t = ts.ok_or("expected a host timestamp `(<seconds>)` before the sentence, as on the first line")?;
    feed(fixer, t, sentence)
}

/// A drive from a CAN log and a GNSS log, decoded with `profile` (DBCs and a map file); without
/// a GNSS log, the fixes the CAN log carries under the map's GNSS fields.
pub fn load(can: &Path, gnss: Option<&Path>, profile: &Profile, opts: &LoadOptions) -> Result<Replay, InputError> {
    let (frames, skipped_can) = read_can_log(can, opts)?;
    let (fixes, skipped_gnss, notes) = match gnss {
        Some(g) => {
            let (f, s, mut n) = read_gnss_log(g, opts)?;
            if !profile.gnss.is_empty() {
                n.push("GNSS from the GNSS log; the map's GNSS fields on CAN are not used".into());
            }
            (f, s, n)
        }
        None => {
            if profile.gnss.is_empty() {
                return Err(InputError::file(can, "expected a GNSS log, or GNSS fields (gnss_lat, gnss_lon, ...) in the map for a receiver that reports on CAN"));
            }
            let fixes = super::can_gnss::fixes_from_can(&frames, &profile.gnss);
            if fixes.is_empty() {
                return Err(InputError::file(can, "expected GNSS fixes on CAN under the map's GNSS fields, found no valid one"));
            }
            let note = format!("GNSS from CAN: {} fixes", fixes.len());
            (fixes, 0, vec![note])
        }
    };
    let mut r = Replay::new(can, Format::Logs, events_of(&frames, fixes, profile), skipped_can + skipped_gnss);
    r.notes = notes;
    Ok(r)
}

/// A logs folder's DBCs and map: its only `.map` and its `.dbc` files (`None` unless there is
/// exactly one map and at least one DBC). Such a folder is one drive of one's own car, for
/// `inspect`, `detect`, `attack` and `eval` alike; its other files are the CAN log (candump,
/// ASC, BLF, or one session's MF4 files) and the GNSS log (none where the map reads GNSS from
/// CAN), told apart by content.
pub fn folder_profile(dir: &Path) -> Option<(Vec<std::path::PathBuf>, std::path::PathBuf)> {
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir).ok()?.flatten().map(|e| e.path()).filter(|p| p.is_file()).collect();
    files.sort();
    let with = |ext: &str| -> Vec<std::path::PathBuf> { files.iter().filter(|p| p.extension().is_some_and(|x| x == ext)).cloned().collect() };
    let (dbcs, maps) = (with("dbc"), with("map"));
    match maps.as_slice() {
        [map] if !dbcs.is_empty() => Some((dbcs, map.clone())),
        _ => None,
    }
}

/// Loads a profile from DBC files and a map file; errors name the file (and the map's line).
pub fn load_profile(dbcs: &[std::path::PathBuf], map: &Path) -> Result<Profile, InputError> {
    let read = |p: &Path| std::fs::read_to_string(p).map_err(|e| InputError::file(p, format!("cannot read as text: {e}")));
    let mut texts = Vec::new();
    for d in dbcs {
        let text = read(d)?;
        gnss_guard_profile::load::messages(&text).map_err(|e| InputError::file(d, e.to_string()))?;
        let name = d.file_name().map_or_else(|| d.display().to_string(), |n| n.to_string_lossy().into_owned());
        texts.push((name, text));
    }
    let named: Vec<(&str, &str)> = texts.iter().map(|(n, t)| (n.as_str(), t.as_str())).collect();
    gnss_guard_profile::load::load_dbcs(&named, &read(map)?).map_err(|e| InputError::file(map, e.to_string()))
}

/// Loads a logs folder ([`folder_profile`]): its CAN log and GNSS log among its other files
/// (hidden files and `*.md`/`*.txt` notes are ignored).
pub fn load_folder(dir: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    let (dbcs, map) = folder_profile(dir).ok_or_else(|| InputError::file(dir, "expected a logs folder: one .map, one or more .dbc, a CAN log and a GNSS log (or GNSS on CAN)"))?;
    let profile = load_profile(&dbcs, &map)?;
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| InputError::file(dir, format!("cannot list: {e}")))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_file() && p != &map && !dbcs.contains(p))
        .filter(|p| !p.file_name().is_some_and(|n| n.to_string_lossy().starts_with('.')) && !p.extension().is_some_and(|x| x == "md" || x == "txt"))
        .collect();
    files.sort();
    let (mut can, mut gnss, mut mf4) = (Vec::new(), Vec::new(), 0);
    for f in files {
        let head: Vec<u8> = {
            use std::io::Read;
            let mut b = Vec::new();
            std::fs::File::open(&f).and_then(|h| h.take(65_536).read_to_end(&mut b)).map_err(|e| InputError::file(&f, format!("cannot read: {e}")))?;
            b
        };
        let text = String::from_utf8_lossy(&head);
        if super::mdf4::looks_like_mdf4(&head) {
            mf4 += 1;
        } else if super::blf::looks_like_blf(&head) || looks_like_candump(&text) || super::asc::looks_like_asc(&text) {
            can.push(f);
        } else if super::ubx_log::looks_like_ubx(&head) || looks_like_nmea(&text) {
            gnss.push(f);
        } else {
            return Err(InputError::line(&f, 1, "expected a CAN log (candump, ASC, BLF, MF4) or a GNSS log (NMEA, UBX) in this logs folder"));
        }
    }
    let names = |v: &[std::path::PathBuf]| v.iter().map(|p| p.file_name().unwrap_or_default().to_string_lossy().into_owned()).collect::<Vec<_>>().join(", ");
    // MF4 files: the folder itself is the CAN log (one session's files).
    let can_log = match (can.as_slice(), mf4) {
        ([c], 0) => c.clone(),
        ([], n) if n > 0 => dir.to_path_buf(),
        _ => return Err(InputError::file(dir, format!("expected one CAN log and one GNSS log (the CAN log may be MF4 files of one session; GNSS on CAN needs no GNSS log), found CAN logs [{}] and {mf4} MF4 files", names(&can)))),
    };
    let gnss_log = match gnss.as_slice() {
        [g] => Some(g.as_path()),
        [] if !profile.gnss.is_empty() => None,
        _ => return Err(InputError::file(dir, format!("expected one CAN log and one GNSS log (none where the map reads GNSS on CAN), found GNSS logs [{}]", names(&gnss)))),
    };
    let mut r = load(&can_log, gnss_log, &profile, opts)?;
    r.path = dir.to_path_buf();
    Ok(r)
}

/// The event stream of decoded frames and fixes (fixes first, as every loader orders them).
pub fn events_of(frames: &[CanFrame], fixes: Vec<Fix>, profile: &Profile) -> Vec<Event> {
    let mut events: Vec<Event> = fixes.into_iter().map(Event::Fix).collect();
    for f in frames {
        for (sig, v) in gnss_guard_profile::decode(&profile.mappings, f.id, f.extended, f.bus(), &f.data) {
            events.push(Event::Obs { sig, t: f.t, v });
        }
    }
    events
}

fn checksum(body: &str) -> u8 {
    body.bytes().fold(0, |c, b| c ^ b)
}

fn dm(deg: f64, pos: char, neg: char, width: usize) -> (String, char) {
    let a = deg.abs();
    let d = a.floor();
    let m = (a - d) * 60.0;
    (format!("{:0width$}{:09.6}", d as u32, m, width = width), if deg >= 0.0 { pos } else { neg })
}

/// GGA and RMC sentences for a fix (time of day from `secs`; minutes with six decimals, speed in
/// knots with three, course with two: what the QEMU run carries). The RMC's date is fixed
/// (2018-08-02): the QEMU run's clock is not UTC.
pub fn nmea_sentences(f: &Fix, secs: f64) -> [String; 2] {
    sentences_dated(f, secs, "020818")
}

/// [`nmea_sentences`] for a fix at UNIX time `unix_s`: the RMC carries its real UTC date, so the
/// log reads back without host timestamps too.
pub fn nmea_sentences_utc(f: &Fix, unix_s: f64) -> [String; 2] {
    let (y, m, d) = gnss_guard_board::ubx::civil_from_days(unix_s.div_euclid(86_400.0) as i64);
    sentences_dated(f, unix_s, &format!("{d:02}{m:02}{:02}", y.rem_euclid(100)))
}

fn sentences_dated(f: &Fix, secs: f64, date: &str) -> [String; 2] {
    let tod = secs.rem_euclid(86_400.0);
    let hms = format!("{:02}{:02}{:05.2}", (tod / 3600.0) as u32, ((tod % 3600.0) / 60.0) as u32, tod % 60.0);
    let (la, ns) = dm(f.pos.lat_deg, 'N', 'S', 2);
    let (lo, ew) = dm(f.pos.lon_deg, 'E', 'W', 3);
    let gga = format!("GPGGA,{hms},{la},{ns},{lo},{ew},1,12,0.8,10.0,M,0.0,M,,");
    let spd = f.speed_mps.map_or(String::new(), |v| format!("{:.3}", v / 0.514_444));
    let crs = f.course_deg.map_or(String::new(), |c| format!("{:.2}", c));
    let rmc = format!("GPRMC,{hms},A,{la},{ns},{lo},{ew},{spd},{crs},{date},,,A");
    [gga, rmc].map(|b| format!("${b}*{:02X}", checksum(&b)))
}

/// A comma2k19 segment re-expressed as the logs of one's own car, all on one clock: the
/// segment's own (seconds since the logger booted) shifted by `offset_s` onto UTC, so that a UBX
/// log, whose fixes carry only their UTC time, aligns with the CAN logs.
pub struct ExportedLogs {
    /// UTC = segment time + `offset_s` (the first u-blox fix's UTC time, to the millisecond).
    pub offset_s: f64,
    /// The real raw CAN frames (every bus, interface `can<src>`) as a candump log.
    pub candump: String,
    /// The same frames as a Vector ASC log (channel = src + 1).
    pub asc: String,
    /// The u-blox fixes as NMEA (GGA + RMC per fix, [`nmea_sentences_utc`]) with host timestamps.
    pub nmea: String,
    /// The u-blox fixes as UBX (NAV-PVT + NAV-STATUS per fix; see [`super::ubx_log::ubx_stream`]).
    pub ubx: Vec<u8>,
}

/// The segment's UTC offset: the first u-blox fix's UTC time (column 3, ms) minus its time on
/// the segment's clock, rounded to the millisecond.
pub fn comma2k19_utc_offset(seg: &Path) -> Result<f64, InputError> {
    use super::comma2k19::read_npy;
    let (_, t) = read_npy::<f64>(seg, "GNSS/live_gnss_ublox/t")?;
    let (shape, v) = read_npy::<f64>(seg, "GNSS/live_gnss_ublox/value")?;
    let w = shape.get(1).copied().unwrap_or(0) as usize;
    match (t.first(), v.get(3)) {
        (Some(t0), Some(utc_ms)) if w >= 4 && utc_ms.is_finite() && t0.is_finite() => Ok((utc_ms - t0 * 1000.0).round() / 1000.0),
        _ => Err(InputError::array(seg, "GNSS/live_gnss_ublox/value", "expected a first fix with its UTC time in column 3")),
    }
}

/// See [`ExportedLogs`].
pub fn comma2k19_as_logs(seg: &Path) -> Result<ExportedLogs, InputError> {
    use super::comma2k19::read_npy;
    let offset_s = comma2k19_utc_offset(seg)?;
    let (_, t) = read_npy::<f64>(seg, "CAN/raw_can/t")?;
    let (_, a) = read_npy::<i64>(seg, "CAN/raw_can/address")?;
    let (_, s) = read_npy::<i64>(seg, "CAN/raw_can/src")?;
    let (_, d) = read_npy::<Vec<u8>>(seg, "CAN/raw_can/data")?;
    if a.len() != t.len() || s.len() != t.len() || d.len() != t.len() {
        return Err(InputError::array(seg, "CAN/raw_can", "expected t, address, src and data of equal length"));
    }
    let mut frames = Vec::new();
    for i in 0..t.len() {
        let (Ok(id), Ok(src)) = (u32::try_from(a[i]), u8::try_from(s[i])) else { continue };
        if !t[i].is_finite() || id > 0x7FF || d[i].len() > 8 {
            continue;
        }
        frames.push(CanFrame { t: t[i] + offset_s, iface: format!("can{src}"), id, extended: false, data: d[i].clone() });
    }
    let mut candump = String::new();
    for f in &frames {
        candump += &f.candump_line();
        candump.push('\n');
    }
    let timed: Vec<(i64, &CanFrame)> = frames.iter().map(|f| (micros_of(f.t), f)).collect();
    let asc = super::asc::asc_text(&timed);
    let native = super::comma2k19::load(seg)?;
    let mut nmea = String::new();
    let fixes: Vec<(f64, &Fix)> = native.fixes().map(|f| (f.t + offset_s, f)).collect();
    for (t, f) in &fixes {
        for sentence in nmea_sentences_utc(f, *t) {
            nmea += &format!("({t:.6}) {sentence}\n");
        }
    }
    let ubx = super::ubx_log::ubx_stream(&fixes, gnss_guard_board::ubx::SpoofState::Unknown);
    Ok(ExportedLogs { offset_s, candump, asc, nmea, ubx })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nmea_lines_with_and_without_timestamps() {
        assert_eq!(split_nmea_line("(12.5) $GPRMC,x").unwrap(), (Some(12.5), "$GPRMC,x"));
        assert_eq!(split_nmea_line("12.5 $GPRMC,x").unwrap(), (Some(12.5), "$GPRMC,x"));
        assert_eq!(split_nmea_line("$GPRMC,x").unwrap(), (None, "$GPRMC,x"));
        assert!(split_nmea_line("GPRMC").unwrap_err().contains("starting with `$`"));
        assert!(split_nmea_line("abc $GPRMC").unwrap_err().contains("host timestamp"));
    }

    #[test]
    fn a_log_with_gst_gives_its_fixes_the_receivers_accuracy() {
        let f = Fix { t: 0.0, pos: detector_core::geo::LatLon::new(48.0, 11.0), speed_mps: Some(10.0), course_deg: Some(90.0), h_acc_m: None, receiver_spoofing: false };
        let gst = |hms: &str| format!("$GPGST,{hms},0.9,2.0,1.5,30.0,0.6,0.8,1.9*{:02X}", checksum(&format!("GPGST,{hms},0.9,2.0,1.5,30.0,0.6,0.8,1.9")));
        let t0 = 1_533_180_079.0;
        let mut text = String::new();
        for (i, hms) in ["032119.00", "032120.00", "032121.00"].iter().enumerate() {
            text += &nmea_sentences_utc(&f, t0 + i as f64).join("\n");
            text += &format!("\n{}\n", gst(hms));
        }
        let (fixes, skipped) = nmea_log_from_text(Path::new("g.nmea"), &text, &LoadOptions::default()).unwrap();
        assert_eq!(skipped, 0);
        let acc: Vec<Option<f32>> = fixes.iter().map(|f| f.h_acc_m).collect();
        assert_eq!(acc, [None, Some(1.0), Some(1.0)], "each RMC takes the previous epoch's GST: sqrt(0.6^2 + 0.8^2)");
    }
}
