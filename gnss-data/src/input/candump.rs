//! SocketCAN `candump` logs (`candump -l` writes them, `candump -L` prints the same lines):
//! `(<seconds>.<micros>) <interface> <frame>` with `<frame>` one of `123#11223344` (standard id,
//! three hex digits), `12345678#...` (extended id, eight), `123#R` (remote, no data) and
//! `123##<flags><data>` (CAN FD). Interface names ending in a number (`can0`, `vcan1`) give the
//! map's bus number. Also the frame type every CAN log reader returns ([`CanFrame`]).

use super::drive::{InputError, LoadOptions};
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
        let id = if self.extended { format!("{:08X}", self.id) } else { format!("{:03X}", self.id) };
        let data: String = self.data.iter().map(|b| format!("{b:02X}")).collect();
        // The microseconds `micros_of` gives (the same `{:.6}`), negative times too.
        let ts = format!("({:.6})", self.t);
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
        // Before the epoch too, and the microsecond the ASC writer takes.
        let neg = CanFrame { t: -0.5, ..r };
        assert_eq!(parse_candump_line(&neg.candump_line()).unwrap().t, -0.5);
        assert_eq!(micros_of(-0.5), -500_000);
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

}
