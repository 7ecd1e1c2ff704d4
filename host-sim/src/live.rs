//! `host-sim live`: the detector on a Linux box in the car, as the data comes.
//!
//! Two reader threads, one per input, send decoded frames and fixes down one channel; the main
//! thread merges them in time order, decodes the CAN frames with the run-time profile (DBC +
//! map), synchronises, judges and prints JSON lines as they happen: one per epoch (as
//! `detect --json`), `{"status": ...}` once a second (the firmware's status frame), and at the
//! end of input or on Ctrl-C a summary with the verdict digest.
//!
//! Inputs:
//! - CAN: a SocketCAN interface (`can0`, `vcan0`; frames timed by the kernel's receive time), or
//!   `candump -L` text from stdin (`-`) or a file or FIFO (timed by their own timestamps);
//! - GNSS: a serial device (`/dev/ttyACM0`, or a pseudo-terminal) at `--baud`, stdin (`-`), or a
//!   file or FIFO. A stream whose first character is `(` or a digit is an NMEA log with host
//!   timestamps (each fix at its stamp, as `detect` reads it); any other stream is the receiver's
//!   own bytes, NMEA and UBX told apart by the firmware's framer, each fix timed on arrival
//!   (`--gnss-time arrival`, the firmware's way) or at the receiver's own UTC time
//!   (`--gnss-time receiver`: NAV-PVT's time, RMC's date and time; for a host whose clock keeps
//!   UTC, as candump's timestamps then do).
//!
//! Time order: an event is released once both inputs have reached its time (or ended). With
//! `--strict-merge` that is all; otherwise an event also leaves after waiting `--max-wait-s`
//! of wall-clock time, so a silent receiver delays the CAN side by at most that. A replay with
//! `--strict-merge` orders events exactly as `detect` does, and gives its digest.

use crate::detect::{self, PredictorKind, StatusStream};
use detector_core::fusion::{Detector, Verdict};
use detector_core::profile::ReceiverProfile;
use detector_core::sample::{Fix, Sample};
use detector_core::strategy::location_shift::Predictor;
use detector_core::sync::{SyncConfig, Synchronizer};
use detector_core::wire::calibration::Record;
use gnss_data::input::logs::{parse_candump_line, CanFrame};
use gnss_guard_board::gnss::NmeaFixer;
use gnss_guard_board::store::SavePolicy;
use gnss_guard_board::ubx::{Chunk, Framer, SpoofState, UbxFixer};
use gnss_guard_profile::load::Profile;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::{BufRead, Read, Write};
use std::path::PathBuf;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant, SystemTime};

/// Where CAN frames come from.
#[derive(Clone, Debug)]
pub enum CanSource {
    Stdin,
    /// `candump -L` text in a file or FIFO.
    File(PathBuf),
    SocketCan(String),
}

impl CanSource {
    /// `-`, an existing file, else an interface name.
    pub fn parse(arg: &str) -> Self {
        match arg {
            "-" => CanSource::Stdin,
            p if std::path::Path::new(p).exists() => CanSource::File(p.into()),
            iface => CanSource::SocketCan(iface.to_string()),
        }
    }
}

/// Where the receiver's output comes from.
#[derive(Clone, Debug)]
pub enum GnssSource {
    Stdin,
    File(PathBuf),
    Serial { path: String, baud: u32 },
    /// The receiver reports on CAN: the fixes come from the CAN frames, under the map's GNSS
    /// fields (`gnss_data::input::can_gnss`).
    Can,
}

impl GnssSource {
    /// `-`, a character device (serial, pseudo-terminal), else a file or FIFO.
    pub fn parse(arg: &str, baud: u32) -> Self {
        use std::os::unix::fs::FileTypeExt;
        match arg {
            "-" => GnssSource::Stdin,
            p if std::fs::metadata(p).is_ok_and(|m| m.file_type().is_char_device()) => GnssSource::Serial { path: p.to_string(), baud },
            p => GnssSource::File(p.into()),
        }
    }
}

/// Options of a live run.
pub struct Options {
    pub profile: Option<&'static ReceiverProfile>,
    pub predictor: PredictorKind,
    pub strict_merge: bool,
    pub max_wait: Duration,
    pub sync: SyncConfig,
    /// Epochs looked at before the receiver profile is chosen from their rate (without
    /// `profile`); their verdicts follow at once then.
    pub profile_epochs: usize,
    /// Time raw GNSS fixes at the receiver's UTC time instead of their arrival.
    pub receiver_time: bool,
    /// The fixes come from the CAN frames (the map's GNSS fields), not a GNSS input.
    pub gnss_from_can: bool,
    /// The car's calibration record: read before the detector starts, saved as the board saves
    /// it (at a standstill without an alarm, at most every 5 minutes) and at the end of input.
    pub calibration: Option<Calibration>,
}

/// The car's calibration record file of a live run and what it held at the start.
#[derive(Clone, Debug)]
pub struct Calibration {
    pub path: PathBuf,
    pub stored: Option<Record>,
}

/// A live run's calibration: the file, the board's save policy, what was saved.
struct Keeper {
    file: Calibration,
    policy: SavePolicy,
    saved: Option<Record>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Stream {
    Gnss = 0,
    Can = 1,
}

enum Msg {
    Can(CanFrame),
    Fix(Fix),
    Spoof(SpoofState),
    /// A malformed input: reported, counted, and the run goes on.
    Bad(Stream, String),
    End(Stream, Option<String>),
    Stop,
}

fn now_s() -> f64 {
    SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64())
}

fn can_text_reader(name: String, r: impl BufRead, tx: Sender<Msg>) {
    for (i, line) in r.split(b'\n').enumerate() {
        let line = match line {
            Ok(l) => l,
            Err(e) => {
                let _ = tx.send(Msg::End(Stream::Can, Some(format!("{name}: read failed: {e}"))));
                return;
            }
        };
        let text = String::from_utf8_lossy(&line);
        if text.trim().is_empty() {
            continue;
        }
        let msg = match parse_candump_line(text.trim()) {
            Ok(f) => Msg::Can(f),
            Err(e) => Msg::Bad(Stream::Can, format!("{name}:{}: {e}", i + 1)),
        };
        if tx.send(msg).is_err() {
            return;
        }
    }
    let _ = tx.send(Msg::End(Stream::Can, None));
}

fn socketcan_reader(iface: String, tx: Sender<Msg>) {
    use socketcan::{CanAnyFrame, CanFdSocket, EmbeddedFrame, Socket};
    let sock = match CanFdSocket::open(&iface) {
        Ok(s) => s,
        Err(e) => {
            let _ = tx.send(Msg::End(Stream::Can, Some(format!("{iface}: cannot open the SocketCAN interface: {e}"))));
            return;
        }
    };
    loop {
        let (frame, at) = match sock.read_frame_with_timestamp() {
            Ok(x) => x,
            Err(e) => {
                let _ = tx.send(Msg::End(Stream::Can, Some(format!("{iface}: read failed: {e}"))));
                return;
            }
        };
        let t = at.duration_since(SystemTime::UNIX_EPOCH).map_or_else(|_| now_s(), |d| d.as_secs_f64());
        let (id, extended, data) = match &frame {
            CanAnyFrame::Normal(f) => (f.id(), f.is_extended(), f.data().to_vec()),
            CanAnyFrame::Fd(f) => (f.id(), f.is_extended(), f.data().to_vec()),
            CanAnyFrame::Remote(f) => (f.id(), f.is_extended(), Vec::new()),
            CanAnyFrame::Error(_) => continue,
        };
        let raw = match id {
            socketcan::Id::Standard(s) => s.as_raw() as u32,
            socketcan::Id::Extended(e) => e.as_raw(),
        };
        if tx.send(Msg::Can(CanFrame { t, iface: iface.clone(), id: raw, extended, data })).is_err() {
            return;
        }
    }
}

/// One read: the byte count (0 at the end of input), retrying interruptions and serial
/// time-outs. A pseudo-terminal whose writer closed reads EIO, or hangs up (the serial port
/// reports a broken pipe): the end of the input too.
fn read_some(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    loop {
        match r.read(buf) {
            Ok(n) => return Ok(n),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted || e.kind() == std::io::ErrorKind::TimedOut => continue,
            Err(e) if e.raw_os_error() == Some(5) || e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(0),
            Err(e) => return Err(e),
        }
    }
}

/// The GNSS reader: stamped NMEA lines, or the receiver's raw bytes (see the module doc).
fn gnss_reader(name: String, mut r: impl Read, receiver_time: bool, tx: Sender<Msg>) {
    let mut buf = [0u8; 4096];
    let mut first: Vec<u8> = Vec::new();
    let end = |e: Option<std::io::Error>| {
        let _ = tx.send(Msg::End(Stream::Gnss, e.map(|e| format!("{name}: read failed: {e}"))));
    };
    // Decide the kind from the first non-blank byte.
    let stamped = loop {
        match read_some(&mut r, &mut buf) {
            Ok(0) => return end(None),
            Ok(n) => {
                first.extend_from_slice(&buf[..n]);
                if let Some(b) = first.iter().find(|b| !b.is_ascii_whitespace()) {
                    break *b == b'(' || b.is_ascii_digit();
                }
            }
            Err(e) => return end(Some(e)),
        }
    };
    let mut nmea = NmeaFixer::default();
    let mut ubx = UbxFixer::default();
    let mut framer = Framer::default();
    let mut pending: Vec<u8> = Vec::new();
    let mut line_no = 0u64;
    let mut spoof = SpoofState::Unknown;
    let mut chunk = first;
    loop {
        let mut msgs = Vec::new();
        if stamped {
            pending.extend_from_slice(&chunk);
            while let Some(nl) = pending.iter().position(|b| *b == b'\n') {
                let line: Vec<u8> = pending.drain(..=nl).collect();
                line_no += 1;
                let text = String::from_utf8_lossy(&line);
                if text.trim().is_empty() {
                    continue;
                }
                match gnss_data::input::logs::nmea_line(&mut nmea, &text) {
                    Ok(Some(f)) => msgs.push(Msg::Fix(f)),
                    Ok(None) => {}
                    Err(e) => msgs.push(Msg::Bad(Stream::Gnss, format!("{name}:{line_no}: {e}"))),
                }
            }
        } else {
            let t = now_s();
            framer.push(&chunk, |c| match c {
                Chunk::Nmea(l) => {
                    let t = if receiver_time { std::str::from_utf8(l).ok().and_then(gnss_data::input::logs::rmc_utc).unwrap_or(f64::NAN) } else { t };
                    if let Some(f) = nmea.line(t, l) {
                        msgs.push(Msg::Fix(f));
                    }
                }
                Chunk::Ubx(fr) => {
                    if let Some(f) = ubx.frame((!receiver_time).then_some(t), fr) {
                        msgs.push(Msg::Fix(f));
                    }
                    if ubx.spoof != spoof {
                        spoof = ubx.spoof;
                        msgs.push(Msg::Spoof(spoof));
                    }
                }
            });
        }
        for m in msgs {
            if tx.send(m).is_err() {
                return;
            }
        }
        match read_some(&mut r, &mut buf) {
            Ok(0) => return end(None),
            Ok(n) => chunk = buf[..n].to_vec(),
            Err(e) => return end(Some(e)),
        }
    }
}

/// Orders events from both inputs by time (fixes first at equal times, then arrival order).
struct Merger {
    queue: BTreeMap<(u64, Stream, u64), (Msg, Instant)>,
    latest: [Option<f64>; 2],
    ended: [bool; 2],
    seq: u64,
}

/// `f64` to a `u64` of the same order.
fn order_key(t: f64) -> u64 {
    let b = t.to_bits();
    if b >> 63 == 1 { !b } else { b | (1 << 63) }
}

impl Merger {
    fn push(&mut self, s: Stream, t: f64, m: Msg) {
        let l = &mut self.latest[s as usize];
        *l = Some(l.map_or(t, |x| x.max(t)));
        self.seq += 1;
        self.queue.insert((order_key(t), s, self.seq), (m, Instant::now()));
    }

    /// The next event both inputs have passed (or, unless strict, that waited `max_wait`).
    fn pop(&mut self, strict: bool, max_wait: Duration) -> Option<Msg> {
        let watermark = (0..2).filter(|i| !self.ended[*i]).map(|i| self.latest[i].map_or(0, order_key)).min().unwrap_or(u64::MAX);
        let (&(k, _, _), (_, at)) = self.queue.first_key_value()?;
        if k <= watermark || (!strict && at.elapsed() >= max_wait) {
            return self.queue.pop_first().map(|(_, (m, _))| m);
        }
        None
    }
}

/// The detector side: synchroniser, profile choice, detector, output.
struct Judge<'w, W: Write> {
    sync: Synchronizer,
    det: Option<Detector<'static, Predictor<'static>>>,
    profile: Option<&'static ReceiverProfile>,
    kind: PredictorKind,
    waiting: Vec<Sample>,
    profile_epochs: usize,
    verdicts: Vec<Verdict>,
    status: StatusStream,
    keeper: Option<Keeper>,
    out: &'w mut W,
}

impl<W: Write> Judge<'_, W> {
    fn sample(&mut self, s: Sample) -> std::io::Result<()> {
        if self.det.is_some() {
            return self.judge(&s);
        }
        self.waiting.push(s);
        if self.profile.is_none() && self.waiting.len() < self.profile_epochs {
            return Ok(());
        }
        self.start()
    }

    /// Chooses the profile (from the waiting epochs' rate unless given), makes the detector and
    /// judges the waiting epochs.
    fn start(&mut self) -> std::io::Result<()> {
        let p = self.profile.unwrap_or_else(|| detect::profile_of(&self.waiting));
        self.profile = Some(p);
        let mut d = Detector::new(detect::config(p, self.kind), detect::predictor(self.kind)).with_turns(detect::default_templates());
        if let Some(r) = self.keeper.as_ref().and_then(|k| k.file.stored.as_ref()) {
            d = d.with_calibration(r);
        }
        self.det = Some(d);
        for s in std::mem::take(&mut self.waiting) {
            self.judge(&s)?;
        }
        Ok(())
    }

    fn judge(&mut self, s: &Sample) -> std::io::Result<()> {
        let Some(det) = self.det.as_mut() else { return Ok(()) };
        let v = det.step(s);
        let mut st = Vec::new();
        self.status.on_verdict(&v, &mut st);
        for (_, s) in st {
            writeln!(self.out, "{}", json!({ "status": s }))?;
        }
        writeln!(self.out, "{}", detect::verdict_json(&v))?;
        // As the board saves it (`SavePolicy::keep`), the file whole or not at all.
        if let Some(k) = self.keeper.as_mut() {
            if let Some(r) = k.policy.keep(v.t, &v, det) {
                let path = &k.file.path;
                match crate::output::write_atomic(path, |w| w.write_all(&r.encode())) {
                    Ok(()) => writeln!(self.out, "{}", json!({ "calibration": { "saved": path.display().to_string(), "t": v.t } }))?,
                    Err(e) => eprintln!("calibration: {}: cannot write: {e}", path.display()),
                }
                k.saved = Some(r);
            }
        }
        self.out.flush()?;
        self.verdicts.push(v);
        Ok(())
    }

    /// The end of input (or Ctrl-C): the car's record kept as `detect --calibration` keeps it
    /// ([`detect::record_at_the_end`]); a drive that contradicts the stored record after a save
    /// of its own writes the stored one back. What happened, as `detect` says it.
    fn keep_calibration(&self) -> anyhow::Result<Option<Value>> {
        let (Some(k), Some(det)) = (self.keeper.as_ref(), self.det.as_ref()) else {
            return Ok(self.keeper.as_ref().map(|k| json!({ "loaded": k.file.stored.is_some(), "written": false, "said": "no epoch judged" })));
        };
        let learnt = detect::record_at_the_end(det, self.verdicts.last(), k.saved);
        if let (true, Some(r), Some(_)) = (det.track().calibration().contradiction().is_some(), k.file.stored.as_ref(), k.saved) {
            crate::output::write_atomic(&k.file.path, |w| w.write_all(&r.encode())).map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", k.file.path.display()))?;
        }
        detect::write_calibration(&k.file.path, k.file.stored.as_ref(), learnt.as_ref(), &self.verdicts).map(Some)
    }

    fn finish(&mut self) -> std::io::Result<()> {
        let mut rest = Vec::new();
        self.sync.flush(&mut |s: &Sample| rest.push(*s));
        for s in rest {
            self.sample(s)?;
        }
        if self.det.is_none() && !self.waiting.is_empty() {
            self.start()?;
        }
        Ok(())
    }
}

/// Counters of a live run, printed in its summary.
#[derive(Default)]
struct Counts {
    frames: u64,
    fixes: u64,
    bad: [u64; 2],
    spoof: SpoofState,
    spoof_changes: u64,
}

/// Runs until both inputs end, or Ctrl-C; prints JSON lines on `out`, input errors on stderr.
pub fn run(can: CanSource, gnss: GnssSource, profile: &Profile, opts: &Options, out: &mut impl Write) -> anyhow::Result<()> {
    let (tx, rx) = mpsc::channel::<Msg>();
    {
        let tx = tx.clone();
        ctrlc::set_handler(move || {
            let _ = tx.send(Msg::Stop);
        })?;
    }
    let (ctx, gtx) = (tx.clone(), tx);
    let rt = opts.receiver_time;
    match can {
        CanSource::Stdin => std::thread::spawn(move || can_text_reader("stdin".into(), std::io::stdin().lock(), ctx)),
        CanSource::File(p) => {
            let f = std::fs::File::open(&p).map_err(|e| anyhow::anyhow!("{}: cannot open: {e}", p.display()))?;
            std::thread::spawn(move || can_text_reader(p.display().to_string(), std::io::BufReader::new(f), ctx))
        }
        CanSource::SocketCan(iface) => std::thread::spawn(move || socketcan_reader(iface, ctx)),
    };
    match gnss {
        GnssSource::Stdin => std::thread::spawn(move || gnss_reader("stdin".into(), std::io::stdin().lock(), rt, gtx)),
        GnssSource::File(p) => {
            let f = std::fs::File::open(&p).map_err(|e| anyhow::anyhow!("{}: cannot open: {e}", p.display()))?;
            std::thread::spawn(move || gnss_reader(p.display().to_string(), f, rt, gtx))
        }
        GnssSource::Serial { path, baud } => {
            let port = serialport::new(&path, baud).timeout(Duration::from_secs(1)).open().map_err(|e| anyhow::anyhow!("{path}: cannot open the serial port at {baud} baud: {e}"))?;
            std::thread::spawn(move || gnss_reader(path, port, rt, gtx))
        }
        GnssSource::Can => {
            anyhow::ensure!(!profile.gnss.is_empty(), "GNSS from CAN needs GNSS fields (gnss_lat, gnss_lon, ...) in the map");
            // No stream of its own: it ends at once, and the fixes come with the CAN frames.
            std::thread::spawn(move || {
                let _ = gtx.send(Msg::End(Stream::Gnss, None));
            })
        }
    };
    merge_and_judge(rx, profile, opts, out)
}

/// GNSS from CAN: the fixes the frames carry, assembled as they come; the frames are held as
/// long as an epoch takes to complete, so frames and fixes reach the synchroniser in time order.
struct FromCan {
    asm: gnss_data::input::can_gnss::Assembler,
    held: std::collections::VecDeque<CanFrame>,
}

impl FromCan {
    /// One frame in: what is ready, in time order (fixes before frames of the same time).
    fn push(&mut self, f: CanFrame) -> Vec<Msg> {
        let fixes = self.asm.push(&f);
        let until = f.t - 2.0 * gnss_data::input::can_gnss::EPOCH_WINDOW_S;
        self.held.push_back(f);
        let mut frames = Vec::new();
        while self.held.front().is_some_and(|h| h.t < until) {
            frames.extend(self.held.pop_front());
        }
        merged(fixes, frames)
    }

    /// The end of the stream: everything still held.
    fn finish(self) -> Vec<Msg> {
        let frames = self.held.into_iter().collect();
        merged(self.asm.finish(), frames)
    }
}

fn merged(fixes: Vec<Fix>, frames: Vec<CanFrame>) -> Vec<Msg> {
    let mut out: Vec<(f64, u8, Msg)> = fixes.into_iter().map(|x| (x.t, 0, Msg::Fix(x))).chain(frames.into_iter().map(|f| (f.t, 1, Msg::Can(f)))).collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    out.into_iter().map(|(_, _, m)| m).collect()
}

fn merge_and_judge(rx: Receiver<Msg>, profile: &Profile, opts: &Options, out: &mut impl Write) -> anyhow::Result<()> {
    let mut m = Merger { queue: BTreeMap::new(), latest: [None; 2], ended: [false; 2], seq: 0 };
    let mut j = Judge {
        sync: Synchronizer::new(opts.sync),
        det: None,
        profile: opts.profile,
        kind: opts.predictor,
        waiting: Vec::new(),
        profile_epochs: opts.profile_epochs.max(1),
        verdicts: Vec::new(),
        status: StatusStream::default(),
        keeper: opts.calibration.clone().map(|file| Keeper { file, policy: SavePolicy::default(), saved: None }),
        out,
    };
    let mut c = Counts::default();
    let mut from_can = opts.gnss_from_can.then(|| FromCan { asm: gnss_data::input::can_gnss::Assembler::new(profile.gnss.clone()), held: Default::default() });
    let mut errors: Vec<String> = Vec::new();
    let mut stopped = false;
    let tick = opts.max_wait.max(Duration::from_millis(10));
    while !(m.ended[0] && m.ended[1]) {
        match rx.recv_timeout(tick) {
            Ok(Msg::Can(f)) => m.push(Stream::Can, f.t, Msg::Can(f)),
            Ok(Msg::Fix(f)) => m.push(Stream::Gnss, f.t, Msg::Fix(f)),
            Ok(Msg::Spoof(s)) => {
                c.spoof = s;
                c.spoof_changes += 1;
                writeln!(j.out, "{}", json!({ "receiver_spoofing": s.name(), "t": now_s() }))?;
            }
            Ok(Msg::Bad(s, e)) => {
                c.bad[s as usize] += 1;
                eprintln!("input error: {e}");
            }
            Ok(Msg::End(s, e)) => {
                m.ended[s as usize] = true;
                if let Some(e) = e {
                    eprintln!("error: {e}");
                    errors.push(e);
                }
            }
            Ok(Msg::Stop) => {
                stopped = true;
                break;
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        while let Some(msg) = m.pop(opts.strict_merge, opts.max_wait) {
            route(msg, profile, &mut from_can, &mut j, &mut c)?;
        }
    }
    // End of input (or Ctrl-C): everything still queued, in order.
    m.ended = [true, true];
    while let Some(msg) = m.pop(true, Duration::ZERO) {
        route(msg, profile, &mut from_can, &mut j, &mut c)?;
    }
    if let Some(fc) = from_can {
        for msg in fc.finish() {
            release(msg, profile, &mut j, &mut c)?;
        }
    }
    j.finish()?;
    let p = j.profile.unwrap_or(&detector_core::profile::LOGGER_1HZ);
    let summary = detect::summarize(&j.verdicts, p);
    let inputs: Value = json!({
        "can_frames": c.frames, "fixes": c.fixes, "can_errors": c.bad[Stream::Can as usize],
        "gnss_errors": c.bad[Stream::Gnss as usize], "receiver_spoofing": c.spoof.name(),
        "receiver_spoofing_changes": c.spoof_changes, "stopped_by_signal": stopped, "errors": errors,
    });
    let calibration = j.keep_calibration()?;
    let mut last = json!({ "summary": summary, "inputs": inputs, "digest": detect::digest_hex(&j.verdicts) });
    if let Some(c) = calibration {
        last["calibration"] = c;
    }
    writeln!(j.out, "{last}")?;
    j.out.flush()?;
    if let Some(e) = errors.first() {
        anyhow::bail!("{e}");
    }
    Ok(())
}

/// A merged message to the synchroniser; CAN frames through the GNSS assembler first when the
/// fixes come from CAN.
fn route<W: Write>(msg: Msg, profile: &Profile, from_can: &mut Option<FromCan>, j: &mut Judge<'_, W>, c: &mut Counts) -> std::io::Result<()> {
    match (msg, from_can.as_mut()) {
        (Msg::Can(f), Some(fc)) => {
            for m in fc.push(f) {
                release(m, profile, j, c)?;
            }
            Ok(())
        }
        (msg, _) => release(msg, profile, j, c),
    }
}

fn release<W: Write>(msg: Msg, profile: &Profile, j: &mut Judge<'_, W>, c: &mut Counts) -> std::io::Result<()> {
    let mut samples = Vec::new();
    let mut emit = |s: &Sample| samples.push(*s);
    match msg {
        Msg::Fix(f) => {
            c.fixes += 1;
            j.sync.push_fix(f, &mut emit);
        }
        Msg::Can(f) => {
            c.frames += 1;
            for (sig, v) in gnss_guard_profile::decode(&profile.mappings, f.id, f.extended, f.bus(), &f.data) {
                j.sync.push_obs(sig, f.t, v, &mut emit);
            }
        }
        _ => {}
    }
    for s in samples {
        j.sample(s)?;
    }
    Ok(())
}
