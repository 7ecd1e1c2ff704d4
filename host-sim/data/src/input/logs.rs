//! A drive given as two logs from one's own car: a CAN log and a GNSS log, decoded with a DBC and
//! a map file read at run time, aligned by their timestamps.
//!
//! - CAN: SocketCAN `candump` log files (`candump -l` writes them; `candump -L` prints the same
//!   lines): `(<seconds>.<micros>) <interface> <frame>` with `<frame>` one of `123#11223344`
//!   (standard id, three hex digits), `12345678#...` (extended id, eight), `123#R` (remote, no
//!   data) and `123##<flags><data>` (CAN FD). Interface names ending in a number (`can0`,
//!   `vcan1`) give the map's bus number. Or a Vector ASC log ([`super::asc`]; channel N is bus
//!   N - 1). BLF and MF4 are not read (README: no well-kept Rust reader of either was found).
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
use detector_core::sample::Fix;
use gnss_guard_board::gnss::NmeaFixer;
use gnss_guard_board::ubx::days_from_civil;
use gnss_guard_profile::load::Profile;
use std::path::Path;

/// One CAN frame of a log.
#[derive(Clone, Debug, PartialEq)]
pub struct CanFrame {
    /// Seconds, the logging host's clock.
    pub t: f64,
    /// The interface (`can0`).
    pub iface: String,
    pub id: u32,
    pub extended: bool,
    /// Empty for a remote frame.
    pub data: Vec<u8>,
}

impl CanFrame {
    /// The bus number the interface name ends in (`can1` -> 1), if any.
    pub fn bus(&self) -> Option<u8> {
        let digits: String = self.iface.chars().rev().take_while(char::is_ascii_digit).collect::<Vec<_>>().into_iter().rev().collect();
        digits.parse().ok()
    }

    /// The line `candump -l` writes for this frame.
    pub fn candump_line(&self) -> String {
        let us = micros_of(self.t);
        let id = if self.extended { format!("{:08X}", self.id) } else { format!("{:03X}", self.id) };
        let data: String = self.data.iter().map(|b| format!("{b:02X}")).collect();
        let ts = format!("({}.{:06})", us.div_euclid(1_000_000), us.rem_euclid(1_000_000));
        if self.data.len() > 8 {
            format!("{ts} {} {id}##0{data}", self.iface)
        } else {
            format!("{ts} {} {id}#{data}", self.iface)
        }
    }
}

/// Seconds as the whole microseconds a log line prints (`{:.6}`, correctly rounded). Every log
/// writer goes through this, so the candump and ASC logs of a frame carry the same microsecond.
pub fn micros_of(t: f64) -> i64 {
    format!("{t:.6}").replace('.', "").parse().unwrap_or(0)
}

/// Is this the content of a candump log (its first non-empty line is a candump frame line)?
pub fn looks_like_candump(text: &str) -> bool {
    text.lines().map(str::trim).find(|l| !l.is_empty()).is_some_and(|l| parse_candump_line(l).is_ok())
}

/// Is this the content of an NMEA log (its first non-empty line holds a `$` sentence)?
pub fn looks_like_nmea(text: &str) -> bool {
    text.lines().map(str::trim).find(|l| !l.is_empty()).is_some_and(|l| split_nmea_line(l).is_ok_and(|(_, s)| s.starts_with('$')))
}

fn hex_digit(c: u8) -> Option<u8> {
    (c as char).to_digit(16).map(|d| d as u8)
}

/// One candump log line.
pub fn parse_candump_line(line: &str) -> Result<CanFrame, String> {
    let mut parts = line.split_whitespace();
    let ts = parts.next().ok_or("expected `(<seconds>) <interface> <id>#<data>`, found an empty line")?;
    let t: f64 = ts
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .and_then(|s| s.parse().ok())
        .filter(|t: &f64| t.is_finite())
        .ok_or_else(|| format!("expected a timestamp `(<seconds>.<micros>)`, found {ts:?}"))?;
    let iface = parts.next().ok_or("expected an interface name after the timestamp")?.to_string();
    let frame = parts.next().ok_or("expected a frame `<id>#<data>` after the interface")?;
    // An optional trailing direction flag (`R` / `T`, newer candump) is allowed.
    if let Some(extra) = parts.next() {
        if !matches!(extra, "R" | "T") || parts.next().is_some() {
            return Err(format!("unexpected text after the frame: {extra:?}"));
        }
    }
    let (id_s, rest) = frame.split_once('#').ok_or_else(|| format!("expected `<id>#<data>`, found {frame:?}"))?;
    let extended = match id_s.len() {
        3 => false,
        8 => true,
        _ => return Err(format!("expected a 3-digit (standard) or 8-digit (extended) hex id, found {id_s:?}")),
    };
    let id = u32::from_str_radix(id_s, 16).map_err(|_| format!("expected a hex id, found {id_s:?}"))?;
    if (!extended && id > 0x7FF) || id > 0x1FFF_FFFF {
        return Err(format!("id {id_s} out of range for a {} frame", if extended { "29-bit" } else { "11-bit" }));
    }
    let (payload, max) = match rest.strip_prefix('#') {
        // CAN FD: one hex digit of flags, then up to 64 bytes.
        Some(fd) => {
            let mut c = fd.chars();
            c.next().filter(char::is_ascii_hexdigit).ok_or_else(|| format!("expected a CAN FD flags digit after `##`, found {fd:?}"))?;
            (c.as_str(), 64)
        }
        None if rest.starts_with('R') => return Ok(CanFrame { t, iface, id, extended, data: Vec::new() }),
        None => (rest, 8),
    };
    // Bytes, not chars: a non-ASCII character must be an error, never a slice inside it.
    let hex: Vec<u8> = payload.bytes().filter(|c| *c != b'.').collect();
    if !hex.len().is_multiple_of(2) || hex.len() / 2 > max {
        return Err(format!("expected up to {max} data bytes as pairs of hex digits, found {payload:?}"));
    }
    let data = hex
        .chunks_exact(2)
        .map(|p| Some((hex_digit(p[0])? << 4) | hex_digit(p[1])?))
        .collect::<Option<Vec<u8>>>()
        .ok_or_else(|| format!("expected hex data bytes, found {payload:?}"))?;
    Ok(CanFrame { t, iface, id, extended, data })
}

/// Reads a candump log. Lines are kept in file order (candump writes them in time order).
pub fn read_candump(path: &Path, opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    let text = std::fs::read_to_string(path).map_err(|e| InputError::file(path, format!("cannot read as text: {e}")))?;
    candump_from_text(path, &text, opts)
}

/// [`read_candump`] on the text of `path`: the frames and the number of lines skipped.
pub fn candump_from_text(path: &Path, text: &str, opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    let mut frames = Vec::new();
    let mut skipped = 0;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        match parse_candump_line(line) {
            Ok(f) => frames.push(f),
            Err(_) if opts.skip_bad_rows => skipped += 1,
            Err(e) => return Err(InputError::line(path, i as u64 + 1, e)),
        }
    }
    if frames.is_empty() {
        return Err(InputError::file(path, "expected candump log lines `(<seconds>) <interface> <id>#<data>`, found none"));
    }
    Ok((frames, skipped))
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
                Ok(gnss_guard_board::nmea::Sentence::Rmc(_)) => match rmc_utc(sentence) {
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

/// Reads a CAN log, recognised by its content: candump or Vector ASC.
pub fn read_can_log(can: &Path, opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    let bytes = std::fs::read(can).map_err(|e| InputError::file(can, format!("cannot read: {e}")))?;
    let text = String::from_utf8_lossy(&bytes);
    if looks_like_candump(&text) {
        candump_from_text(can, &text, opts)
    } else if super::asc::looks_like_asc(&text) {
        super::asc::asc_from_text(can, &text, opts)
    } else {
        Err(InputError::line(can, 1, "expected a SocketCAN candump log (`(<seconds>) can0 123#...`) or a Vector ASC log (`date ...` first); BLF and MF4 are not read"))
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
        Ok(gnss_guard_board::nmea::Sentence::Rmc(r)) => {
            let ((d, m, y), tod) = (r.date?, r.time_s?);
            Some(days_from_civil(2000 + y as i64, m as i64, d as i64) as f64 * 86_400.0 + tod)
        }
        _ => None,
    }
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

/// A drive from a CAN log and a GNSS log, decoded with `profile` (a DBC and a map file).
pub fn load(can: &Path, gnss: &Path, profile: &Profile, opts: &LoadOptions) -> Result<Replay, InputError> {
    let (frames, skipped_can) = read_can_log(can, opts)?;
    let (fixes, skipped_gnss, notes) = read_gnss_log(gnss, opts)?;
    let mut r = Replay::new(can, Format::Logs, events_of(&frames, fixes, profile), skipped_can + skipped_gnss);
    r.notes = notes;
    Ok(r)
}

/// A logs folder's DBC and map: its only `.dbc` and only `.map` file (`None` unless exactly one
/// of each). Such a folder is one drive of one's own car, for `inspect`, `detect`, `attack` and
/// `eval` alike; its other files are the CAN log and the GNSS log, told apart by content.
pub fn folder_profile(dir: &Path) -> Option<(std::path::PathBuf, std::path::PathBuf)> {
    let files: Vec<std::path::PathBuf> = std::fs::read_dir(dir).ok()?.flatten().map(|e| e.path()).filter(|p| p.is_file()).collect();
    let with = |ext: &str| -> Vec<&std::path::PathBuf> { files.iter().filter(|p| p.extension().is_some_and(|x| x == ext)).collect() };
    match (with("dbc").as_slice(), with("map").as_slice()) {
        ([dbc], [map]) => Some(((*dbc).clone(), (*map).clone())),
        _ => None,
    }
}

/// Loads a logs folder ([`folder_profile`]): the one CAN log and the one GNSS log among its
/// other files (hidden files and `*.md`/`*.txt` notes are ignored).
pub fn load_folder(dir: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    let (dbc, map) = folder_profile(dir).ok_or_else(|| InputError::file(dir, "expected a logs folder: one .dbc, one .map, a CAN log and a GNSS log"))?;
    let read = |p: &Path| std::fs::read_to_string(p).map_err(|e| InputError::file(p, format!("cannot read as text: {e}")));
    let profile = gnss_guard_profile::load::load(&read(&dbc)?, &read(&map)?).map_err(|e| InputError::file(&map, e.to_string()))?;
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| InputError::file(dir, format!("cannot list: {e}")))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_file() && p != &dbc && p != &map)
        .filter(|p| !p.file_name().is_some_and(|n| n.to_string_lossy().starts_with('.')) && !p.extension().is_some_and(|x| x == "md" || x == "txt"))
        .collect();
    files.sort();
    let (mut can, mut gnss) = (Vec::new(), Vec::new());
    for f in files {
        let head: Vec<u8> = {
            use std::io::Read;
            let mut b = Vec::new();
            std::fs::File::open(&f).and_then(|h| h.take(65_536).read_to_end(&mut b)).map_err(|e| InputError::file(&f, format!("cannot read: {e}")))?;
            b
        };
        let text = String::from_utf8_lossy(&head);
        if looks_like_candump(&text) || super::asc::looks_like_asc(&text) {
            can.push(f);
        } else if super::ubx_log::looks_like_ubx(&head) || looks_like_nmea(&text) {
            gnss.push(f);
        } else {
            return Err(InputError::line(&f, 1, "expected a CAN log (candump, ASC) or a GNSS log (NMEA, UBX) in this logs folder"));
        }
    }
    let names = |v: &[std::path::PathBuf]| v.iter().map(|p| p.file_name().unwrap_or_default().to_string_lossy().into_owned()).collect::<Vec<_>>().join(", ");
    match (can.as_slice(), gnss.as_slice()) {
        ([c], [g]) => {
            let mut r = load(c, g, &profile, opts)?;
            r.path = dir.to_path_buf();
            Ok(r)
        }
        _ => Err(InputError::file(dir, format!("expected one CAN log and one GNSS log, found CAN logs [{}] and GNSS logs [{}]", names(&can), names(&gnss)))),
    }
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
            let us = micros_of(*t);
            nmea += &format!("({}.{:06}) {sentence}\n", us.div_euclid(1_000_000), us.rem_euclid(1_000_000));
        }
    }
    let ubx = super::ubx_log::ubx_stream(&fixes, gnss_guard_board::ubx::SpoofState::Unknown);
    Ok(ExportedLogs { offset_s, candump, asc, nmea, ubx })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candump_lines_of_every_kind() {
        let f = parse_candump_line("(1436509052.249713) can0 0B4#0000000000123400").unwrap();
        assert_eq!((f.t, f.iface.as_str(), f.id, f.extended, f.bus()), (1436509052.249713, "can0", 0xB4, false, Some(0)));
        assert_eq!(f.data, [0, 0, 0, 0, 0, 0x12, 0x34, 0]);
        assert_eq!(f.candump_line(), "(1436509052.249713) can0 0B4#0000000000123400");
        let e = parse_candump_line("(1.000000) vcan1 18FEF100#01.02.03 R").unwrap();
        assert_eq!((e.id, e.extended, e.bus(), e.data.clone()), (0x18FE_F100, true, Some(1), vec![1, 2, 3]));
        let r = parse_candump_line("(2.5) can0 123#R").unwrap();
        assert!(r.data.is_empty());
        let fd_line = format!("(3.0) can0 123##1{}", (0..12).map(|i| format!("{i:02X}")).collect::<String>());
        let fd = parse_candump_line(&fd_line).unwrap();
        assert_eq!(fd.data, (0..12).collect::<Vec<u8>>());
        assert_eq!(fd.candump_line(), "(3.000000) can0 123##0000102030405060708090A0B");
    }

    #[test]
    fn candump_errors_say_what_was_expected() {
        for (line, want) in [
            ("1.0 can0 123#00", "timestamp"),
            ("(1.0) can0", "frame"),
            ("(1.0) can0 12#00", "3-digit"),
            ("(1.0) can0 800#00", "out of range"),
            ("(1.0) can0 123#0", "pairs of hex"),
            ("(1.0) can0 123#001122334455667788", "up to 8"),
            ("(1.0) can0 123#GG", "hex data"),
            ("(1.0) can0 123#00 X", "unexpected"),
            ("(nan) can0 123#00", "timestamp"),
            // Found by the fuzzer: a multi-byte character inside the data once panicked.
            ("(1.0) can0 123#0\u{fffd}0", "pairs of hex"),
            ("(1.0) can0 123#\u{e9}", "hex data"),
        ] {
            let e = parse_candump_line(line).unwrap_err();
            assert!(e.contains(want), "{line}: {e}");
        }
    }

    #[test]
    fn nmea_lines_with_and_without_timestamps() {
        assert_eq!(split_nmea_line("(12.5) $GPRMC,x").unwrap(), (Some(12.5), "$GPRMC,x"));
        assert_eq!(split_nmea_line("12.5 $GPRMC,x").unwrap(), (Some(12.5), "$GPRMC,x"));
        assert_eq!(split_nmea_line("$GPRMC,x").unwrap(), (None, "$GPRMC,x"));
        assert!(split_nmea_line("GPRMC").unwrap_err().contains("starting with `$`"));
        assert!(split_nmea_line("abc $GPRMC").unwrap_err().contains("host timestamp"));
    }
}
