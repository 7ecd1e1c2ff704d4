//! Vector ASC: the text CAN log that CANoe, CANalyzer and many loggers write.
//!
//! ```text
//! date Thu Aug 2 08:34:47.250 am 2018
//! base hex  timestamps absolute
//! internal events logged
//! Begin Triggerblock Thu Aug 2 08:34:47.250 am 2018
//!    0.000000 Start of measurement
//!    0.012345 1  0B4             Rx   d 8 00 00 00 00 00 12 34 00
//!    0.020000 1  18FEF100x       Rx   d 3 01 02 03
//!    0.030000 2  123             Rx   r
//!    0.040000 CANFD   1 Rx        123  1 0 c 12 00 01 02 03 04 05 06 07 08 09 0a 0b ...
//!    0.050000 1  ErrorFrame
//! End TriggerBlock
//! ```
//!
//! A frame's time is the `date` line (taken as UTC: ASC carries no time zone) plus its
//! timestamp, to the microsecond (`timestamps relative`: each one counts from the previous event).
//! Channel N is bus N - 1 (`can0` in candump's naming), so one map serves both logs. `base dec`
//! ids are decimal. Error frames, statistics, comments and other events are skipped; a frame
//! line that does not parse is an error naming its line.

use super::drive::{InputError, LoadOptions};
use super::candump::CanFrame;
use gnss_guard_board::ubx::{civil_from_days, days_from_civil};
use std::path::Path;

const MONTHS: [&str; 12] = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"];
const WEEKDAYS: [&str; 7] = ["Thu", "Fri", "Sat", "Sun", "Mon", "Tue", "Wed"];

/// Is this the content of an ASC log (its first non-empty line is `date ...` or `base ...`)?
pub fn looks_like_asc(text: &str) -> bool {
    text.lines().map(str::trim).find(|l| !l.is_empty()).is_some_and(|l| l.starts_with("date ") || l.starts_with("base "))
}

/// A `date` line's time (`Thu Aug 2 08:34:47.250 am 2018`, or 24-hour without am/pm) as UNIX
/// microseconds.
pub fn parse_date(text: &str) -> Result<i64, String> {
    let want = || format!("expected a date `<weekday> <month> <day> <hh:mm:ss[.mmm]> [am|pm] <year>`, found {text:?}");
    let t: Vec<&str> = text.split_whitespace().collect();
    let (mon, day, time, ampm, year) = match t.as_slice() {
        [_, mon, day, time, ampm, year] => (*mon, *day, *time, Some(*ampm), *year),
        [_, mon, day, time, year] => (*mon, *day, *time, None, *year),
        _ => return Err(want()),
    };
    let m = MONTHS.iter().position(|x| x.eq_ignore_ascii_case(mon)).ok_or_else(want)? as i64 + 1;
    let d: i64 = day.parse().ok().filter(|d| (1..=31).contains(d)).ok_or_else(want)?;
    // Up to 2200: UNIX microseconds stay below 2^53, exact in an f64 (found by the fuzzer).
    let y: i64 = year.parse().ok().filter(|y| (1970..=2200).contains(y)).ok_or_else(want)?;
    let mut hms = time.split(':');
    let (Some(h), Some(mi), Some(s), None) = (hms.next(), hms.next(), hms.next(), hms.next()) else { return Err(want()) };
    let mut h: i64 = h.parse().ok().filter(|h| (0..24).contains(h)).ok_or_else(want)?;
    let mi: i64 = mi.parse().ok().filter(|m| (0..60).contains(m)).ok_or_else(want)?;
    let sec_us = micros(s).filter(|us| (0..61_000_000).contains(us)).ok_or_else(want)?;
    match ampm.map(str::to_ascii_lowercase).as_deref() {
        None => {}
        Some(p @ ("am" | "pm")) => {
            if !(1..=12).contains(&h) {
                return Err(want());
            }
            h = h % 12 + if p == "pm" { 12 } else { 0 };
        }
        Some(_) => return Err(want()),
    }
    Ok((days_from_civil(y, m, d) * 86_400 + h * 3600 + mi * 60) * 1_000_000 + sec_us)
}

/// A decimal number of seconds as microseconds: exact for up to six decimals, rounded beyond.
pub fn micros(s: &str) -> Option<i64> {
    let (int, frac) = s.split_once('.').unwrap_or((s, ""));
    if int.is_empty() || !int.bytes().all(|c| c.is_ascii_digit()) || !frac.bytes().all(|c| c.is_ascii_digit()) || int.len() > 12 {
        return None;
    }
    if frac.len() <= 6 {
        let f: i64 = if frac.is_empty() { 0 } else { frac.parse::<i64>().ok()? * 10i64.pow(6 - frac.len() as u32) };
        return Some(int.parse::<i64>().ok()? * 1_000_000 + f);
    }
    let v: f64 = s.parse().ok()?;
    Some((v * 1e6).round() as i64)
}

/// The ASC `date` text for UNIX microseconds (12-hour clock with milliseconds, as CANoe writes).
pub fn format_date(us: i64) -> String {
    let (s, frac_us) = (us.div_euclid(1_000_000), us.rem_euclid(1_000_000));
    let (days, tod) = (s.div_euclid(86_400), s.rem_euclid(86_400));
    let (y, m, d) = civil_from_days(days);
    let (h, mi, sec) = (tod / 3600, tod % 3600 / 60, tod % 60);
    let (h12, ampm) = (if h % 12 == 0 { 12 } else { h % 12 }, if h < 12 { "am" } else { "pm" });
    format!("{} {} {d} {h12:02}:{mi:02}:{sec:02}.{:03} {ampm} {y}", WEEKDAYS[days.rem_euclid(7) as usize], MONTHS[(m - 1) as usize], frac_us / 1000)
}

/// Microseconds to seconds, correctly rounded: the same `f64` as parsing the decimal text, so an
/// ASC and a candump log of the same frames give the same times.
pub fn seconds(us: i64) -> f64 {
    us as f64 / 1e6
}

fn hex_byte(s: &str, base16: bool) -> Option<u8> {
    if base16 {
        (s.len() <= 2).then(|| u8::from_str_radix(s, 16).ok()).flatten()
    } else {
        s.parse().ok()
    }
}

/// Reads an ASC log: its frames (times as UNIX seconds, see the module documentation) and the
/// number of lines skipped under `skip_bad_rows`.
pub fn asc_from_text(path: &Path, text: &str, opts: &LoadOptions) -> Result<(Vec<CanFrame>, usize), InputError> {
    let mut base16 = true;
    let mut relative = false;
    let mut date_us: Option<i64> = None;
    let mut last_us: i64 = 0;
    let mut frames = Vec::new();
    let mut skipped = 0;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i as u64 + 1;
        let line = raw.trim();
        let err = |msg: String| InputError::line(path, line_no, msg);
        if line.is_empty() || line.starts_with("//") {
            continue;
        }
        if let Some(d) = line.strip_prefix("date ") {
            date_us = Some(parse_date(d).map_err(err)?);
            continue;
        }
        if let Some(b) = line.strip_prefix("base ") {
            let t: Vec<&str> = b.split_whitespace().collect();
            match t.as_slice() {
                [base, "timestamps", kind] if matches!(*base, "hex" | "dec") && matches!(*kind, "absolute" | "relative") => {
                    base16 = *base == "hex";
                    relative = *kind == "relative";
                }
                _ => return Err(err(format!("expected `base hex|dec timestamps absolute|relative`, found {line:?}"))),
            }
            continue;
        }
        if line.ends_with("internal events logged") || line.starts_with("End TriggerBlock") {
            continue;
        }
        if let Some(d) = line.strip_prefix("Begin Triggerblock") {
            if !d.trim().is_empty() {
                date_us = Some(parse_date(d.trim()).map_err(err)?);
            }
            continue;
        }
        let Some(date) = date_us else {
            return Err(err("expected a `date ...` line before the first event".into()));
        };
        match parse_event(line, base16) {
            Ok(ev) => {
                let t_us = if relative { last_us.saturating_add(ev.t_us) } else { ev.t_us };
                last_us = t_us;
                if let Some((ch, id, extended, data)) = ev.frame {
                    let t = seconds(date.saturating_add(t_us));
                    frames.push(CanFrame { t, iface: format!("can{}", ch.saturating_sub(1)), id, extended, data });
                }
            }
            Err(_) if opts.skip_bad_rows => skipped += 1,
            Err(e) => return Err(err(e)),
        }
    }
    if frames.is_empty() {
        return Err(InputError::file(path, "expected ASC CAN frame lines `<t> <channel> <id> Rx d <dlc> <bytes>`, found none"));
    }
    Ok((frames, skipped))
}

struct Parsed {
    t_us: i64,
    /// `(channel, id, extended, data)` for a frame; `None` for another event.
    frame: Option<(u8, u32, bool, Vec<u8>)>,
}

fn parse_id(s: &str, base16: bool) -> Result<(u32, bool), String> {
    let (digits, extended) = match s.strip_suffix(['x', 'X']) {
        Some(d) => (d, true),
        None => (s, false),
    };
    let id = if base16 { u32::from_str_radix(digits, 16).ok() } else { digits.parse().ok() };
    let id = id.ok_or_else(|| format!("expected a CAN id ({}, `x` after an extended one), found {s:?}", if base16 { "hex" } else { "decimal" }))?;
    if (!extended && id > 0x7FF) || id > 0x1FFF_FFFF {
        return Err(format!("id {s} out of range for a {} frame", if extended { "29-bit" } else { "11-bit" }));
    }
    Ok((id, extended))
}

fn parse_bytes(tokens: &[&str], n: usize, base16: bool) -> Result<Vec<u8>, String> {
    let bytes = tokens.get(..n).ok_or_else(|| format!("expected {n} data bytes, found {}", tokens.len()))?;
    bytes.iter().map(|b| hex_byte(b, base16).ok_or_else(|| format!("expected a data byte, found {b:?}"))).collect()
}

fn channel(s: &str) -> Option<u8> {
    s.parse().ok().filter(|c| *c >= 1)
}

fn parse_event(line: &str, base16: bool) -> Result<Parsed, String> {
    let t: Vec<&str> = line.split_whitespace().collect();
    let ts = t.first().copied().unwrap_or("");
    let t_us = micros(ts).ok_or_else(|| format!("expected an event `<seconds> ...`, found {line:?}"))?;
    let other = Ok(Parsed { t_us, frame: None });
    let dir = |s: Option<&&str>| matches!(s.copied(), Some("Rx" | "Tx" | "TxRq"));
    match t.get(1).copied() {
        Some("CANFD") => {
            // <t> CANFD <ch> <dir> <id> [<name>] <brs> <esi> <dlc> <len> <bytes...> ...
            let ch = t.get(2).and_then(|c| channel(c)).ok_or_else(|| format!("expected a channel after CANFD, found {line:?}"))?;
            if !dir(t.get(3)) {
                return Err(format!("expected Rx or Tx after the channel, found {line:?}"));
            }
            let (id, extended) = parse_id(t.get(4).copied().unwrap_or(""), base16)?;
            let mut k = 5;
            if !matches!(t.get(k).copied(), Some("0" | "1")) {
                k += 1; // the symbolic name
            }
            let len: usize = t.get(k + 3).and_then(|l| l.parse().ok()).filter(|l| *l <= 64).ok_or_else(|| format!("expected `<brs> <esi> <dlc> <data length 0-64>` after the id, found {line:?}"))?;
            let data = parse_bytes(t.get(k + 4..).unwrap_or(&[]), len, base16)?;
            Ok(Parsed { t_us, frame: Some((ch, id, extended, data)) })
        }
        Some(c) if channel(c).is_some() => {
            let ch = channel(c).unwrap_or(1);
            let Some(id_s) = t.get(2).copied() else { return Err(format!("expected an id after the channel, found {line:?}")) };
            if !id_s.bytes().next().is_some_and(|b| b.is_ascii_hexdigit()) || !dir(t.get(3)) {
                // ErrorFrame, Statistic:, SV: and other events on a channel.
                return other;
            }
            let (id, extended) = parse_id(id_s, base16)?;
            match t.get(4).copied() {
                Some("r") => Ok(Parsed { t_us, frame: Some((ch, id, extended, Vec::new())) }),
                Some("d") => {
                    let dlc: usize = t.get(5).and_then(|d| d.parse().ok()).filter(|d| *d <= 8).ok_or_else(|| format!("expected a DLC 0-8 after `d`, found {line:?}"))?;
                    let data = parse_bytes(t.get(6..).unwrap_or(&[]), dlc, base16)?;
                    Ok(Parsed { t_us, frame: Some((ch, id, extended, data)) })
                }
                _ => Err(format!("expected `d <dlc> <bytes>` or `r` after the direction, found {line:?}")),
            }
        }
        _ => other,
    }
}

/// An ASC log of `frames` (classic CAN; times as UNIX microseconds), the `date` line at the
/// earliest frame's millisecond (frames out of time order stay in their order, each after the
/// date; found by the fuzzer). Channel = bus + 1.
pub fn asc_text(frames: &[(i64, &CanFrame)]) -> String {
    let start = frames.iter().map(|(us, _)| us.div_euclid(1000) * 1000).min().unwrap_or(0);
    let date = format_date(start);
    let mut out = format!("date {date}\nbase hex  timestamps absolute\ninternal events logged\n// version 9.0.0\nBegin Triggerblock {date}\n   0.000000 Start of measurement\n");
    for (us, f) in frames {
        let rel = us - start;
        let id = if f.extended { format!("{:X}x", f.id) } else { format!("{:X}", f.id) };
        let ch = f.bus().map_or(1, |b| b as u32 + 1);
        let data: Vec<String> = f.data.iter().map(|b| format!("{b:02X}")).collect();
        out += &format!("{:4}.{:06} {ch}  {id:<15} Rx   d {} {}\n", rel / 1_000_000, rel % 1_000_000, f.data.len(), data.join(" "));
    }
    out += "End TriggerBlock\n";
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_both_ways() {
        let us = parse_date("Thu Aug 2 08:34:47.250 am 2018").unwrap();
        assert_eq!(us, 1_533_198_887_250_000);
        assert_eq!(format_date(us), "Thu Aug 2 08:34:47.250 am 2018");
        assert_eq!(parse_date("Thu Aug 2 12:00:00 am 2018").unwrap() % 86_400_000_000, 0);
        assert_eq!(parse_date("Thu Aug 2 12:00:00 pm 2018").unwrap() % 86_400_000_000, 43_200_000_000);
        assert_eq!(parse_date("Thu Aug 2 20:34:47 2018").unwrap(), 1_533_242_087_000_000);
        assert_eq!(format_date(parse_date("Thu Aug 2 20:34:47 2018").unwrap()), "Thu Aug 2 08:34:47.000 pm 2018");
        for bad in ["Thu Aug 2 08:34:47", "Thu Foo 2 08:34:47 2018", "Thu Aug 2 13:00:00 pm 2018", "Thu Aug 2 08:61:00 2018"] {
            assert!(parse_date(bad).unwrap_err().contains("expected a date"), "{bad}");
        }
        assert_eq!(micros("12.345678"), Some(12_345_678));
        assert_eq!(micros("12.3"), Some(12_300_000));
        assert_eq!(micros("7"), Some(7_000_000));
        assert_eq!(micros("-1.0"), None);
        assert_eq!(micros("1.0e3"), None);
    }

    #[test]
    fn every_kind_of_line() {
        let text = "date Thu Aug 2 08:34:47.250 am 2018\nbase hex  timestamps absolute\ninternal events logged\n\
            Begin Triggerblock Thu Aug 2 08:34:47.250 am 2018\n   0.000000 Start of measurement\n\
            0.012345 1  0B4             Rx   d 8 00 00 00 00 00 12 34 00  Length = 0 BitCount = 0 ID = 180\n\
            0.020000 2  18FEF100x       Rx   d 3 01 02 03\n   0.030000 1  123  Tx   r\n   0.035000 1  ErrorFrame\n\
            0.036000 1  Statistic: D 0 R 0\n\
            0.040000 CANFD   1 Rx 123  Name  1 0 c 12 00 01 02 03 04 05 06 07 08 09 0a 0b  0 0 1000 0 0 0 0 0\nEnd TriggerBlock\n";
        let (f, skipped) = asc_from_text(Path::new("x.asc"), text, &LoadOptions::default()).unwrap();
        assert_eq!((f.len(), skipped), (4, 0));
        assert_eq!((f[0].t, f[0].id, f[0].extended, f[0].bus()), (1_533_198_887.262345, 0xB4, false, Some(0)));
        assert_eq!(f[0].data, [0, 0, 0, 0, 0, 0x12, 0x34, 0]);
        assert_eq!((f[1].id, f[1].extended, f[1].bus(), f[1].data.clone()), (0x18FE_F100, true, Some(1), vec![1, 2, 3]));
        assert!(f[2].data.is_empty());
        assert_eq!(f[3].data, (0..12).collect::<Vec<u8>>());
        // Relative timestamps and decimal ids.
        let rel = "date Thu Aug 2 08:34:47 2018\nbase dec  timestamps relative\n0.5 1 180 Rx d 1 255\n0.25 1 180 Rx d 1 1\n";
        let (f, _) = asc_from_text(Path::new("x.asc"), rel, &LoadOptions::default()).unwrap();
        assert_eq!((f[0].id, f[0].data[0], f[1].t - f[0].t), (180, 255, 0.25));
    }

    #[test]
    fn errors_name_the_line() {
        let head = "date Thu Aug 2 08:34:47 2018\nbase hex  timestamps absolute\n";
        for (body, want) in [
            ("0.1 1 0B4 Rx d 8 00 11\n", "expected 8 data bytes"),
            ("0.1 1 0B4 Rx d 9 00\n", "DLC 0-8"),
            ("0.1 1 800 Rx d 1 00\n", "out of range"),
            ("0.1 1 0B4 Rx d 1 GG\n", "data byte"),
            ("0.1 1 0B4 Rx q\n", "after the direction"),
            ("x.1 1 0B4 Rx d 1 00\n", "expected an event"),
        ] {
            let e = asc_from_text(Path::new("x.asc"), &format!("{head}{body}"), &LoadOptions::default()).unwrap_err();
            assert!(e.to_string().starts_with("x.asc:3:") && e.to_string().contains(want), "{body}: {e}");
        }
        let e = asc_from_text(Path::new("x.asc"), "base hex  timestamps absolute\n0.1 1 0B4 Rx d 1 00\n", &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("x.asc:2:") && e.to_string().contains("date"), "{e}");
    }

    #[test]
    fn written_logs_read_back() {
        let frames = [CanFrame { t: 0.0, iface: "can0".into(), id: 0xB4, extended: false, data: vec![1, 2] }, CanFrame { t: 0.0, iface: "can2".into(), id: 0x1234, extended: true, data: vec![] }];
        let t0 = 1_533_198_887_250_123;
        let text = asc_text(&[(t0, &frames[0]), (t0 + 1_000_001, &frames[1])]);
        let (back, _) = asc_from_text(Path::new("x.asc"), &text, &LoadOptions::default()).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].t, seconds(t0));
        assert_eq!(back[1].t, seconds(t0 + 1_000_001));
        assert_eq!((back[1].bus(), back[1].id, back[1].extended), (Some(2), 0x1234, true));
        // The same f64 as the candump text of the same microsecond.
        assert_eq!(seconds(t0), "1533198887.250123".parse::<f64>().unwrap());
    }
}
