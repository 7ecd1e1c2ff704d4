//! Issue #17, live on Linux: `host-sim live` fed the exported comma2k19 logs through stdin (CAN,
//! `candump -L` text) and a pseudo-terminal (GNSS, opened as a serial port) reproduces the digest
//! that `detect` gives on the same logs: NMEA with host timestamps, and the receiver's raw UBX
//! bytes timed at the receiver's own UTC time. A `vcan` interface is used where the kernel
//! offers one (skipped with the reason printed where not). Ctrl-C ends a run cleanly with its
//! summary.

use rustix::fd::OwnedFd;
use std::io::Write;
use std::process::{Child, Command, Stdio};
use system_tests::{host_sim_bin, ExportedLogs};

/// A pseudo-terminal in raw mode: the master, the slave's path, and a slave descriptor kept
/// open until the reader has opened its own.
fn pty() -> (OwnedFd, String, OwnedFd) {
    use rustix::pty::{grantpt, openpt, ptsname, unlockpt, OpenptFlags};
    // Close-on-exec: a master inherited by a child would keep the terminal from hanging up.
    let m = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC).unwrap();
    grantpt(&m).unwrap();
    unlockpt(&m).unwrap();
    let path = ptsname(&m, Vec::new()).unwrap().into_string().unwrap();
    let s = rustix::fs::open(&path, rustix::fs::OFlags::RDWR | rustix::fs::OFlags::NOCTTY | rustix::fs::OFlags::CLOEXEC, rustix::fs::Mode::empty()).unwrap();
    let mut t = rustix::termios::tcgetattr(&s).unwrap();
    t.make_raw();
    rustix::termios::tcsetattr(&s, rustix::termios::OptionalActions::Now, &t).unwrap();
    (m, path, s)
}

fn live(x: &ExportedLogs, gnss: &str, extra: &[&str]) -> Child {
    Command::new(host_sim_bin())
        .args(["live", "--can", "-", "--gnss", gnss, "--dbc", x.dbc.to_str().unwrap(), "--map", x.map.to_str().unwrap()])
        .args(extra)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run host-sim live")
}

/// Feeds the CAN log on stdin and `gnss_bytes` into the pseudo-terminal; the summary line.
fn run_through_pty(x: &ExportedLogs, gnss_bytes: Vec<u8>, extra: &[&str]) -> serde_json::Value {
    let (master, slave_path, slave) = pty();
    let mut child = live(x, &slave_path, extra);
    let can = std::fs::read(x.path("can.log")).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let can_writer = std::thread::spawn(move || stdin.write_all(&can));
    let gnss_writer = std::thread::spawn(move || {
        // Give the reader time to open the port before the test's own slave closes.
        std::thread::sleep(std::time::Duration::from_millis(300));
        drop(slave);
        let mut f = std::fs::File::from(master);
        f.write_all(&gnss_bytes)?;
        f.flush()?;
        // Let the reader drain the terminal before the master closes (its close is the end).
        std::thread::sleep(std::time::Duration::from_millis(500));
        Ok::<_, std::io::Error>(())
    });
    can_writer.join().unwrap().unwrap();
    gnss_writer.join().unwrap().unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "live: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    serde_json::from_str(text.lines().last().unwrap()).unwrap()
}

#[test]
fn live_through_stdin_and_a_pty_reproduces_the_digest() {
    let Some(x) = ExportedLogs::new("live_through_stdin_and_a_pty_reproduces_the_digest") else { return };
    let (epochs, nmea_last) = x.detect("can.log", "gnss.nmea");
    let (_, ubx_last) = x.detect("can.log", "gnss.ubx");
    // NMEA with host timestamps, as the logs carry them.
    let s = run_through_pty(&x, std::fs::read(x.path("gnss.nmea")).unwrap(), &["--strict-merge"]);
    assert_eq!(s["summary"]["epochs"].as_u64(), Some(epochs.len() as u64), "{s}");
    assert_eq!(s["digest"], nmea_last["digest"], "live (stdin + pty, NMEA) differs from detect");
    assert_eq!(s["inputs"]["can_frames"].as_u64(), Some(std::fs::read_to_string(x.path("can.log")).unwrap().lines().count() as u64));
    // The receiver's own UBX bytes, each fix at its UTC time.
    let s = run_through_pty(&x, std::fs::read(x.path("gnss.ubx")).unwrap(), &["--strict-merge", "--gnss-time", "receiver"]);
    assert_eq!(s["digest"], ubx_last["digest"], "live (stdin + pty, UBX) differs from detect");
    assert_eq!(s["inputs"]["receiver_spoofing"], "unknown");
}

#[test]
fn live_ends_cleanly_on_ctrl_c_and_reports_bad_lines() {
    let Some(x) = ExportedLogs::new("live_ends_cleanly_on_ctrl_c_and_reports_bad_lines") else { return };
    // GNSS from a pseudo-terminal that never closes: only Ctrl-C ends the run.
    let (master, slave_path, slave) = pty();
    let mut child = live(&x, &slave_path, &[]);
    let mut stdin = child.stdin.take().unwrap();
    let mut can = std::fs::read_to_string(x.path("can.log")).unwrap();
    can.insert_str(0, "(1.0) can0 0B4#GG\n");
    stdin.write_all(can.as_bytes()).unwrap();
    let mut m = std::fs::File::from(master);
    m.write_all(&std::fs::read(x.path("gnss.nmea")).unwrap()[..20_000]).unwrap();
    // Ctrl-C once the first verdict is out.
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(child.stdout.take().unwrap()));
    let mut seen = Vec::new();
    for l in lines.by_ref() {
        let l = l.unwrap();
        let first = l.starts_with("{\"alarm\"") || l.contains("\"epoch\"");
        seen.push(l);
        if first {
            break;
        }
    }
    drop(slave);
    let pid = rustix::process::Pid::from_raw(child.id() as i32).unwrap();
    rustix::process::kill_process(pid, rustix::process::Signal::INT).unwrap();
    seen.extend(lines.map(|l| l.unwrap()));
    let out = child.wait_with_output().unwrap();
    drop(m);
    drop(stdin);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "live after Ctrl-C: {err}");
    assert!(err.contains("stdin:1:") && err.contains("hex data"), "{err}");
    let s: serde_json::Value = serde_json::from_str(seen.last().unwrap()).unwrap();
    assert_eq!(s["inputs"]["stopped_by_signal"], true, "{s}");
    assert_eq!(s["inputs"]["can_errors"], 1);
    assert!(s["summary"]["epochs"].as_u64().unwrap() > 0, "{s}");
}

#[test]
fn live_reads_a_vcan_interface_where_the_kernel_offers_one() {
    let Some(x) = ExportedLogs::new("live_reads_a_vcan_interface_where_the_kernel_offers_one") else { return };
    let iface = "vcangg0";
    let add = Command::new("ip").args(["link", "add", "dev", iface, "type", "vcan"]).output();
    let up = Command::new("ip").args(["link", "set", "up", iface]).output();
    match (&add, &up) {
        (Ok(a), Ok(u)) if a.status.success() && u.status.success() => {}
        _ => {
            let why = add.map_or_else(|e| e.to_string(), |o| String::from_utf8_lossy(&o.stderr).trim().to_string());
            eprintln!("SKIPPED live_reads_a_vcan_interface_where_the_kernel_offers_one: cannot create a vcan interface here ({why})");
            return;
        }
    }
    // Frames sent now are timed by the kernel now: the GNSS side is the receiver's raw NMEA,
    // timed on arrival too, so both share the host's clock (a digest of a real-time run is not
    // reproducible; what is checked is that every frame arrives and epochs are judged).
    let mut child = Command::new(host_sim_bin())
        .args(["live", "--can", iface, "--gnss", "-", "--dbc", x.dbc.to_str().unwrap(), "--map", x.map.to_str().unwrap()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    let frames: Vec<String> = std::fs::read_to_string(x.path("can.log")).unwrap().lines().take(2000).map(String::from).collect();
    let nmea: Vec<String> = std::fs::read_to_string(x.path("gnss.nmea")).unwrap().lines().take(40).map(|l| l.split_once(' ').unwrap().1.to_string()).collect();
    let mut stdin = child.stdin.take().unwrap();
    for (i, f) in frames.iter().enumerate() {
        let frame = f.split_whitespace().nth(2).unwrap();
        assert!(Command::new("cansend").args([iface, frame]).status().is_ok_and(|s| s.success()), "cansend (can-utils) is needed with vcan");
        if i % 50 == 0 {
            writeln!(stdin, "{}", nmea[(i / 50) % nmea.len()]).unwrap();
        }
    }
    drop(stdin);
    std::thread::sleep(std::time::Duration::from_millis(500));
    let pid = rustix::process::Pid::from_raw(child.id() as i32).unwrap();
    rustix::process::kill_process(pid, rustix::process::Signal::INT).unwrap();
    let out = child.wait_with_output().unwrap();
    let _ = Command::new("ip").args(["link", "del", iface]).status();
    let text = String::from_utf8(out.stdout).unwrap();
    let s: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    assert_eq!(s["inputs"]["can_frames"].as_u64(), Some(frames.len() as u64), "{s}");
}

/// `live --calibration` keeps the car's record as `detect --calibration` does (the board's
/// save rule, then the end of input as the car parked): from the same stored record (the QEMU
/// run's, plausible values for the RAV4, not learnt), the same digest and the same record
/// written back, one drive more.
#[test]
fn live_keeps_the_calibration_record_as_detect_does() {
    use detector_core::wire::calibration::Record;
    let Some(x) = ExportedLogs::new("live_keeps_the_calibration_record_as_detect_does") else { return };
    let stored = gnss_guard_board::replay::stored_record();
    let (by_detect, by_live) = (x.path("detect.ggcr"), x.path("live.ggcr"));
    std::fs::write(&by_detect, stored.encode()).unwrap();
    std::fs::write(&by_live, stored.encode()).unwrap();
    let (_, last) = system_tests::detect_json(&["--can", &x.path("can.log"), "--gnss", &x.path("gnss.nmea"), "--dbc", x.dbc.to_str().unwrap(), "--map", x.map.to_str().unwrap(), "--calibration", &by_detect]);
    let s = run_through_pty(&x, std::fs::read(x.path("gnss.nmea")).unwrap(), &["--strict-merge", "--calibration", &by_live]);
    assert_eq!(s["digest"], last["digest"], "{s}");
    assert_eq!((s["calibration"]["loaded"].as_bool(), s["calibration"]["written"].as_bool()), (Some(true), Some(true)), "{s}");
    let kept = std::fs::read(&by_live).unwrap();
    assert_eq!(kept, std::fs::read(&by_detect).unwrap(), "live and detect keep different records");
    assert_eq!(Record::decode(&kept).unwrap().drives, 5);
}
