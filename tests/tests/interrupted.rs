//! An interrupted run never leaves a half-written output: every output is written to a
//! temporary file and renamed. Kill `host-sim eval` at several points and check every file.

use system_tests::{data_dir, host_sim_bin};

fn complete(p: &std::path::Path) -> Result<(), String> {
    let b = std::fs::read(p).map_err(|e| e.to_string())?;
    let name = p.file_name().unwrap().to_string_lossy().into_owned();
    let ok = if name.ends_with(".json") {
        serde_json::from_slice::<serde_json::Value>(&b).is_ok()
    } else if name.ends_with(".svg") {
        String::from_utf8_lossy(&b).trim_end().ends_with("</svg>")
    } else if name.ends_with(".png") {
        b.len() > 12 && &b[b.len() - 8..b.len() - 4] == b"IEND"
    } else if name.ends_with(".md") {
        String::from_utf8_lossy(&b).contains("## Figures")
    } else {
        true
    };
    if ok { Ok(()) } else { Err(format!("{} is incomplete", p.display())) }
}

fn visible_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(visible_files(&p));
            } else if !e.file_name().to_string_lossy().starts_with('.') {
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn killing_eval_midway_leaves_only_complete_files() {
    let Some(d) = data_dir("killing_eval_midway_leaves_only_complete_files") else { return };
    let out = std::env::temp_dir().join(format!("gnss-guard-kill-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let bin = host_sim_bin();
    let mut saw_partial_run = false;
    for delay_ms in [150u64, 400, 800, 1500] {
        let mut child = std::process::Command::new(bin)
            .args(["eval", "--data", d.to_str().unwrap(), "--scenarios", "400", "--out", out.to_str().unwrap()])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(delay_ms));
        let finished = child.try_wait().unwrap().is_some();
        let _ = child.kill();
        let _ = child.wait();
        saw_partial_run |= !finished;
        for f in visible_files(&out) {
            complete(&f).unwrap();
        }
    }
    assert!(saw_partial_run, "the run was never interrupted: make it longer");
    // A complete run afterwards leaves no temporaries behind.
    let st = std::process::Command::new(bin)
        .args(["eval", "--data", d.to_str().unwrap(), "--scenarios", "5", "--out", out.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    let leftovers: Vec<_> = walk_all(&out).into_iter().filter(|p| p.to_string_lossy().contains(".tmp")).collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    let _ = std::fs::remove_dir_all(&out);
}

fn walk_all(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() { out.extend(walk_all(&p)) } else { out.push(p) }
        }
    }
    out
}
