//! Helpers for the end-to-end system tests in `tests/tests/`: they run the real `host-sim`
//! binary, as a user would.

pub mod fuzz;
pub mod walk;

use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::OnceLock;

/// Path of the `host-sim` binary, built once per test run (dev profile).
pub fn host_sim_bin() -> &'static PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let st = Command::new(cargo)
            .args(["build", "-q", "-p", "host-sim", "--bin", "host-sim"])
            .current_dir(&root)
            .status()
            .expect("run cargo build");
        assert!(st.success(), "building host-sim failed");
        let target = std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or(root.join("target"));
        target.join("debug").join("host-sim")
    })
}

/// Runs `host-sim` with `args`.
pub fn host_sim(args: &[&str]) -> Output {
    Command::new(host_sim_bin()).args(args).output().expect("run host-sim")
}

/// The real-data folder, or `None` after printing why the test is skipped (a failure in CI).
pub fn data_dir(test: &str) -> Option<PathBuf> {
    host_sim::require_data(test)
}

/// A private Python venv (`target/pyvenv`) with `packages` from PyPI, made on first use: the
/// independent implementations our decoders are cross-checked against (pynmea2, cantools,
/// pyubx2, python-can, asammdf). A package whose import name differs from its PyPI name is
/// given as `import=pypi` (`can=python-can`). Installing them is part of the test command; a
/// failure to install is a test failure.
pub fn python_with(packages: &[&str]) -> PathBuf {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let target = std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or(root.join("target"));
    let venv = target.join("pyvenv");
    let py = venv.join("bin").join("python");
    if !py.exists() {
        let st = Command::new("python3").args(["-m", "venv"]).arg(&venv).status().expect("python3 -m venv");
        assert!(st.success(), "creating the Python venv at {} failed", venv.display());
    }
    let names = |p: &&str| -> (String, String) {
        match p.split_once('=') {
            Some((i, d)) => (i.to_string(), d.to_string()),
            None => (p.to_string(), p.to_string()),
        }
    };
    let imports = packages.iter().map(|p| format!("import {}", names(p).0)).collect::<Vec<_>>().join("; ");
    let have = Command::new(&py).args(["-c", &imports]).output().is_ok_and(|o| o.status.success());
    if !have {
        let dists: Vec<String> = packages.iter().map(|p| names(p).1).collect();
        let st = Command::new(&py).args(["-m", "pip", "install", "-q"]).args(&dists).status().expect("pip");
        assert!(st.success(), "pip install {packages:?} into {} failed", venv.display());
    }
    py
}

/// The comma2k19 segment re-expressed as logs by `host-sim export-logs` in a fresh temporary
/// folder (removed on drop), with the segment's DBC and the RAV4 map on bus 0.
pub struct ExportedLogs {
    pub dir: PathBuf,
    pub seg: PathBuf,
    pub dbc: PathBuf,
    pub map: PathBuf,
    /// UTC = segment time + this.
    pub offset_s: f64,
}

impl Drop for ExportedLogs {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

impl ExportedLogs {
    /// `None` (skipped, printed; a failure in CI) without the real data.
    pub fn new(test: &str) -> Option<Self> {
        let d = data_dir(test)?;
        let seg = d.join("raw/comma2k19_rav4_seg40");
        let dir = std::env::temp_dir().join(format!("gnss-guard-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let out = host_sim(&["export-logs", seg.to_str().unwrap(), "--out", dir.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        for f in ["can.log", "can.asc", "gnss.nmea", "gnss.ubx"] {
            assert!(dir.join(f).is_file(), "export-logs wrote no {f}");
        }
        let dbc = std::fs::read_dir(&seg).unwrap().flatten().map(|e| e.path()).find(|p| p.extension().is_some_and(|x| x == "dbc")).expect("the segment's DBC");
        // The firmware's RAV4 map, with bus 0 (comma logs forwarded copies of the frames on
        // buses 1 and 2; the native loader reads bus 0 only).
        let rav4 = std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../firmware/board/profiles/toyota_rav4.map")).unwrap();
        let map: String = rav4.lines().map(|l| if l.trim().is_empty() || l.starts_with('#') { format!("{l}\n") } else { format!("{l} bus=0\n") }).collect();
        let map_path = dir.join("rav4_bus0.map");
        std::fs::write(&map_path, &map).unwrap();
        let offset_s = host_sim::input::logs::comma2k19_utc_offset(&seg).unwrap();
        Some(ExportedLogs { dir, seg, dbc, map: map_path, offset_s })
    }

    pub fn path(&self, name: &str) -> String {
        self.dir.join(name).to_str().unwrap().to_string()
    }

    /// `detect --json` on two of the logs: the epoch lines and the summary line.
    pub fn detect(&self, can: &str, gnss: &str) -> (Vec<serde_json::Value>, serde_json::Value) {
        detect_json(&["--can", &self.path(can), "--gnss", &self.path(gnss), "--dbc", self.dbc.to_str().unwrap(), "--map", self.map.to_str().unwrap()])
    }
}

/// `host-sim detect --json <args>`: the epoch lines (status lines left out) and the last line.
pub fn detect_json(args: &[&str]) -> (Vec<serde_json::Value>, serde_json::Value) {
    let mut a = vec!["detect", "--json"];
    a.extend_from_slice(args);
    let out = host_sim(&a);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    let mut lines: Vec<serde_json::Value> = String::from_utf8(out.stdout).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let last = lines.pop().unwrap();
    lines.retain(|l| l.get("status").is_none());
    (lines, last)
}
