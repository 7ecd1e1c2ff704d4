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
/// independent implementations our decoders are cross-checked against (pynmea2, cantools).
/// Installing them is part of the test command; a failure to install is a test failure.
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
    let imports = packages.iter().map(|p| format!("import {p}")).collect::<Vec<_>>().join("; ");
    let have = Command::new(&py).args(["-c", &imports]).output().is_ok_and(|o| o.status.success());
    if !have {
        let st = Command::new(&py).args(["-m", "pip", "install", "-q"]).args(packages).status().expect("pip");
        assert!(st.success(), "pip install {packages:?} into {} failed", venv.display());
    }
    py
}
