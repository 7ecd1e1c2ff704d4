//! Loading a vehicle profile: one or more DBCs (parsed with `can-dbc`; the car's and a logger's,
//! say) and a map file.
//!
//! The map file, one mapping per line (`#` starts a comment):
//! ```text
//! MESSAGE.SIGNAL[+MESSAGE.SIGNAL] detector_signal factor [bus=N]
//! ```
//! - `detector_signal`: `wheel_speed` (m/s), `steering` (deg, + left), `pedal` (%), `yaw_rate`
//!   (deg/s, + left), `long_accel` (m/s^2, + forward); or a field of the GNSS fix, for a
//!   receiver that reports on CAN: `gnss_lat`, `gnss_lon` (degrees), `gnss_speed` (m/s),
//!   `gnss_course` (degrees, 0 = north, clockwise), `gnss_h_acc` (metres, 1 sigma),
//!   `gnss_valid` (non-zero while the fix is valid). The message that carries `gnss_lat` makes
//!   the fix's epoch; the other fields are taken from the frames around it (host-sim reads
//!   them; the firmware takes its receiver on the UART and refuses a map with GNSS fields);
//! - `factor`: our unit = DBC physical value x factor (a negative factor flips a sign
//!   convention); a plain decimal, or `a/b` (e.g. `1/3.6` for km/h);
//! - `+MESSAGE.SIGNAL`: a second signal of the same message added before the factor (a
//!   steering angle and its fraction);
//! - `bus=N`: only frames from bus N (logs that record several buses);
//! - `sign=MESSAGE.SIGNAL`: negated where this signal of the same message is non-zero (a
//!   magnitude with a separate sign bit, as VW's steering angle and yaw rate).
//!
//! Multiplexed DBC signals (`m3`) are decoded only from frames whose multiplexor holds that
//! value; extended (29-bit) identifiers are kept apart from standard ones. With several DBCs a
//! message is looked up in all of them, and a name found in two is an error naming both.

use crate::field::Field;
use crate::mapping::{GnssField, GnssMapped, Mapped};
use detector_core::sample::Signal;
use std::fmt::Write as _;
use std::string::{String, ToString};
use std::vec::Vec;
use std::{format, vec};

/// What is wrong with a profile: in the DBC, or at a line of the map.
#[derive(Clone, Debug, PartialEq)]
pub enum LoadError {
    Dbc(String),
    Map { line: usize, msg: String },
}

impl core::fmt::Display for LoadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LoadError::Dbc(m) => write!(f, "not a valid DBC: {m}"),
            LoadError::Map { line, msg } => write!(f, "line {line}: {msg}"),
        }
    }
}

impl std::error::Error for LoadError {}

/// One message of a DBC, with its signals' fields.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    pub name: String,
    /// Identifier without the extended flag.
    pub id: u32,
    pub extended: bool,
    /// Payload length, bytes.
    pub size: u64,
    pub signals: Vec<SignalDef>,
}

/// One signal of a DBC message.
#[derive(Clone, Debug, PartialEq)]
pub struct SignalDef {
    pub name: String,
    pub field: Field,
    /// The multiplexor value this signal is present under (`m3`), if multiplexed.
    pub mux_value: Option<u64>,
    /// This signal is its message's multiplexor (`M`).
    pub is_multiplexor: bool,
}

fn field_of(s: &can_dbc::Signal) -> Field {
    Field::new(
        s.start_bit as u16,
        s.size as u8,
        s.byte_order == can_dbc::ByteOrder::BigEndian,
        s.value_type == can_dbc::ValueType::Signed,
        s.factor,
        s.offset,
    )
}

/// The messages of a DBC.
pub fn messages(dbc_text: &str) -> Result<Vec<Message>, LoadError> {
    let dbc = can_dbc::Dbc::try_from(dbc_text).map_err(|e| LoadError::Dbc(format!("{e:?}")))?;
    Ok(dbc
        .messages
        .iter()
        .map(|m| {
            let (id, extended) = match m.id {
                can_dbc::MessageId::Standard(id) => (id as u32, false),
                can_dbc::MessageId::Extended(id) => (id, true),
            };
            let signals = m
                .signals
                .iter()
                .map(|s| {
                    use can_dbc::MultiplexIndicator as M;
                    let (mux_value, is_multiplexor) = match s.multiplexer_indicator {
                        M::Multiplexor => (None, true),
                        M::MultiplexedSignal(v) => (Some(v), false),
                        M::MultiplexorAndMultiplexedSignal(v) => (Some(v), true),
                        M::Plain => (None, false),
                    };
                    SignalDef { name: s.name.clone(), field: field_of(s), mux_value, is_multiplexor }
                })
                .collect();
            Message { name: m.name.clone(), id, extended, size: m.size, signals }
        })
        .collect())
}

/// A loaded profile.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    /// The vehicle signals.
    pub mappings: Vec<Mapped>,
    /// The GNSS fix's fields, where a receiver reports on CAN (empty otherwise).
    pub gnss: Vec<GnssMapped>,
}

impl Profile {
    /// The distinct (identifier, extended) pairs the mappings read: the hardware filters.
    pub fn filter_ids(&self) -> Vec<(u32, bool)> {
        let mut ids: Vec<(u32, bool)> = Vec::new();
        for m in &self.mappings {
            if !ids.contains(&(m.id, m.extended)) {
                ids.push((m.id, m.extended));
            }
        }
        ids
    }
}

/// The detector signal a map names.
pub fn signal_named(name: &str) -> Option<Signal> {
    Signal::ALL.into_iter().find(|s| s.name() == name)
}

/// The GNSS fix field a map names.
pub fn gnss_field_named(name: &str) -> Option<GnssField> {
    GnssField::ALL.into_iter().find(|s| s.name() == name)
}

fn factor(text: &str) -> Option<f64> {
    let v = match text.split_once('/') {
        Some((a, b)) => a.trim().parse::<f64>().ok()? / b.trim().parse::<f64>().ok()?,
        None => text.parse::<f64>().ok()?,
    };
    (v.is_finite() && v != 0.0).then_some(v)
}

/// Loads a profile from a DBC's text and a map's text.
pub fn load(dbc_text: &str, map_text: &str) -> Result<Profile, LoadError> {
    let msgs = messages(dbc_text)?;
    from_messages(&[("the DBC", msgs)], map_text)
}

/// Loads a profile from several DBCs (`(name, text)`: the name for errors) and a map's text.
pub fn load_dbcs(dbcs: &[(&str, &str)], map_text: &str) -> Result<Profile, LoadError> {
    let mut all = Vec::new();
    for (name, text) in dbcs {
        let msgs = messages(text).map_err(|e| match e {
            LoadError::Dbc(m) => LoadError::Dbc(format!("{name}: {m}")),
            other => other,
        })?;
        all.push((*name, msgs));
    }
    from_messages(&all, map_text)
}

fn from_messages(dbcs: &[(&str, Vec<Message>)], map_text: &str) -> Result<Profile, LoadError> {
    let mut mappings = Vec::new();
    let mut gnss = Vec::new();
    let mut first_gnss_line = 0;
    for (i, raw) in map_text.lines().enumerate() {
        let line = i + 1;
        let err = |msg: String| LoadError::Map { line, msg };
        let text = raw.split('#').next().unwrap_or("").trim();
        if text.is_empty() {
            continue;
        }
        let parts: Vec<&str> = text.split_whitespace().collect();
        if !(3..=5).contains(&parts.len()) {
            return Err(err(format!("expected `MESSAGE.SIGNAL[+MESSAGE.SIGNAL] detector_signal factor [bus=N] [sign=MESSAGE.SIGNAL]`, found {text:?}")));
        }
        let mut msg_of: Option<&Message> = None;
        let mut fields = vec![];
        for path in parts[0].split('+') {
            let (m, s) = path.split_once('.').ok_or_else(|| err(format!("expected MESSAGE.SIGNAL, found {path:?}")))?;
            let found: Vec<(&str, &Message)> = dbcs.iter().filter_map(|(name, msgs)| msgs.iter().find(|x| x.name == m).map(|x| (*name, x))).collect();
            let msg = match found.as_slice() {
                [] => return Err(err(format!("no message {m} in {}", dbcs.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(" or ")))),
                [(_, x)] => *x,
                [(a, _), (b, _), ..] => return Err(err(format!("message {m} is in {a} and in {b}: the map cannot tell which"))),
            };
            if msg_of.is_some_and(|o| o.name != msg.name) {
                return Err(err(format!("{path}: added signals must be in the same message")));
            }
            msg_of = Some(msg);
            let sig = msg.signals.iter().find(|x| x.name == s).ok_or_else(|| err(format!("no signal {m}.{s} in the DBC")))?;
            fields.push(sig);
        }
        let (Some(msg), [main, rest @ ..]) = (msg_of, fields.as_slice()) else { return Err(err("no signal".into())) };
        if rest.len() > 1 {
            return Err(err("at most one `+MESSAGE.SIGNAL`".into()));
        }
        let factor = factor(parts[2]).ok_or_else(|| err(format!("factor must be a non-zero number or a/b, found {:?}", parts[2])))?;
        let (mut bus, mut sign) = (None, None);
        for opt in parts.get(3..).unwrap_or(&[]) {
            if let Some(n) = opt.strip_prefix("bus=") {
                bus = Some(n.parse::<u8>().map_err(|_| err(format!("expected bus=N (0-255), found {opt:?}")))?);
            } else if let Some(path) = opt.strip_prefix("sign=") {
                let (m, sname) = path.split_once('.').ok_or_else(|| err(format!("expected sign=MESSAGE.SIGNAL, found {opt:?}")))?;
                if m != msg.name {
                    return Err(err(format!("{opt}: the sign must be in the same message")));
                }
                let f = msg.signals.iter().find(|y| y.name == sname).ok_or_else(|| err(format!("no signal {m}.{sname} in the DBC")))?;
                sign = Some(f.field);
            } else {
                return Err(err(format!("expected bus=N or sign=MESSAGE.SIGNAL, found {opt:?}")));
            }
        }
        let mux = match main.mux_value {
            None => None,
            Some(v) => {
                let m = msg.signals.iter().find(|s| s.is_multiplexor).ok_or_else(|| err(format!("{}: multiplexed, but the message has no multiplexor", main.name)))?;
                Some((m.field, v))
            }
        };
        if let Some(target) = gnss_field_named(parts[1]) {
            if !rest.is_empty() {
                return Err(err(format!("{}: a GNSS field takes one signal, without `+`", parts[1])));
            }
            gnss.push(GnssMapped { id: msg.id, extended: msg.extended, bus, field: main.field, mux, target, factor });
            if first_gnss_line == 0 {
                first_gnss_line = line;
            }
            continue;
        }
        let signal = signal_named(parts[1]).ok_or_else(|| {
            err(format!(
                "unknown detector signal {:?}: expected one of {:?} or a GNSS field {:?}",
                parts[1],
                Signal::ALL.map(|s| s.name()),
                GnssField::ALL.map(|s| s.name())
            ))
        })?;
        let m = Mapped::new(msg.id, msg.extended, bus, main.field, rest.first().map(|p| p.field), mux, signal, factor);
        mappings.push(match sign {
            Some(f) => m.with_sign(f),
            None => m,
        });
    }
    let has = |f: GnssField| gnss.iter().any(|g| g.target == f);
    let complete = has(GnssField::Lat) && has(GnssField::Lon);
    if !gnss.is_empty() && !complete {
        return Err(LoadError::Map { line: first_gnss_line, msg: "a map with GNSS fields needs both gnss_lat and gnss_lon".into() });
    }
    Ok(Profile { mappings, gnss })
}

/// A field as a Rust expression (for the firmware's build script).
pub fn rust_field(f: &Field) -> String {
    format!(
        "Field::new({}, {}, {}, {}, {:?}, {:?})",
        f.start_bit, f.size, f.big_endian, f.signed, f.factor, f.offset
    )
}

/// The mappings as a Rust `&[Mapped]` expression (for the firmware's build script).
pub fn rust_mappings(ms: &[Mapped]) -> String {
    let mut out = "&[\n".to_string();
    for m in ms {
        let _ = writeln!(
            out,
            "    Mapped::new({:#x}, {}, {:?}, {}, {}, {}, Signal::{:?}, {:?}){},",
            m.id,
            m.extended,
            m.bus,
            rust_field(&m.field),
            m.plus.map_or("None".to_string(), |p| format!("Some({})", rust_field(&p))),
            m.mux.map_or("None".to_string(), |(f, v)| format!("Some(({}, {v}))", rust_field(&f))),
            m.signal,
            m.factor,
            m.neg.map_or(String::new(), |f| format!(".with_sign({})", rust_field(&f)))
        );
    }
    out.push(']');
    out
}
