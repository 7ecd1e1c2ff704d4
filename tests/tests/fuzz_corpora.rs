//! Replays the committed fuzz corpora and crash regressions through the same harnesses the
//! `cargo fuzz` targets use (`tests/fuzz/`, see its README). Seconds, not minutes.

use std::path::Path;
use system_tests::fuzz::TARGETS;

#[test]
fn fuzz_corpora_and_regressions_replay_cleanly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut total = 0;
    for (name, harness) in TARGETS {
        let mut n = 0;
        for sub in ["seeds", "corpus", "regressions"] {
            let dir = root.join(sub).join(name);
            let Ok(rd) = std::fs::read_dir(&dir) else { continue };
            let mut files: Vec<_> = rd.flatten().map(|e| e.path()).collect();
            files.sort();
            for f in files {
                // (a file a running fuzzer just removed is not a failure)
                let Ok(data) = std::fs::read(&f) else { continue };
                harness(&data);
                n += 1;
            }
        }
        assert!(n > 0, "no corpus for fuzz target {name}");
        total += n;
    }
    eprintln!("replayed {total} fuzz inputs");
}
