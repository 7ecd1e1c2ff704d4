//! An interrupted run never leaves a half-written output, nor a temporary: `host-sim eval` is
//! killed (SIGKILL, nothing can be cleaned up) while it writes its report and figures, and
//! every file then present, dot-named ones included, must be complete and none a temporary.

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
        false // nothing else is written: an unknown file is a leftover
    };
    if ok { Ok(()) } else { Err(format!("{} is incomplete or unexpected", p.display())) }
}

/// Every file under `dir`, hidden ones included.
fn all_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() { out.extend(all_files(&p)) } else { out.push(p) }
        }
    }
    out
}

fn check(dir: &std::path::Path) {
    for f in all_files(dir) {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!host_sim::output::is_temporary(&name) && !name.contains(".tmp"), "temporary left behind: {}", f.display());
        complete(&f).unwrap();
    }
}

#[test]
fn killing_eval_while_it_writes_leaves_only_complete_files() {
    let Some(d) = data_dir("killing_eval_while_it_writes_leaves_only_complete_files") else { return };
    let base = std::env::temp_dir().join(format!("gnss-guard-kill-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let bin = host_sim_bin();
    let mut mid_write = 0;
    // Killed at once when the first output appears, and 100 and 300 ms into the writing
    // (which takes about 0.5 s for the report and 56 figures).
    for (k, delay_ms) in [0u64, 100, 300].into_iter().enumerate() {
        let out = base.join(format!("run{k}"));
        let mut child = std::process::Command::new(bin)
            .args(["eval", "--data", d.to_str().unwrap(), "--scenarios", "10", "--nuisance-variants", "1", "--out", out.to_str().unwrap()])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let t0 = std::time::Instant::now();
        while !out.join("report.json").exists() {
            assert!(child.try_wait().unwrap().is_none(), "eval finished before its first output was seen");
            assert!(t0.elapsed().as_secs() < 600, "eval wrote nothing in 10 minutes");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        std::thread::sleep(std::time::Duration::from_millis(delay_ms));
        let _ = child.kill();
        let _ = child.wait();
        let files = all_files(&out);
        if !out.join("report.md").exists() {
            mid_write += 1;
        }
        eprintln!("killed {delay_ms} ms into writing: {} files present", files.len());
        check(&out);
    }
    assert!(mid_write >= 1, "no run was killed while writing: the test proves nothing");
    // A complete run over a killed one's folder: everything there, nothing else.
    let out = base.join("run2");
    let st = std::process::Command::new(bin)
        .args(["eval", "--data", d.to_str().unwrap(), "--scenarios", "10", "--nuisance-variants", "1", "--out", out.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(st.success());
    check(&out);
    assert!(out.join("report.md").exists());
    let _ = std::fs::remove_dir_all(&base);
}
