//! Drives as Parquet through the command line: every real drive converted to Parquet gives its
//! CSV's verdicts; a folder of Parquet drives is a data set (`inspect`, `eval`); `attack` and
//! `nuisance` write Parquet; `detect --out` writes the verdicts as a table; a raw original
//! converted keeps every event; a corrupt file is a clear error.

use arrow_array::cast::AsArray;
use arrow_array::types::Float64Type;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::{Path, PathBuf};
use system_tests::{data_dir, detect_json, host_sim};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gnss-guard-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn ok(args: &[&str]) -> String {
    let o = host_sim(args);
    assert!(o.status.success(), "host-sim {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn drive_csvs(d: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(d.join("drives")).unwrap().flatten().flat_map(|src| std::fs::read_dir(src.path()).unwrap().flatten().map(|e| e.path())).filter(|p| p.extension().is_some_and(|e| e == "csv")).collect();
    v.sort();
    v
}

#[test]
fn every_real_drive_converted_to_parquet_gives_the_csvs_verdicts() {
    let Some(d) = data_dir("every_real_drive_converted_to_parquet_gives_the_csvs_verdicts") else { return };
    let out = tmp("parquet-convert");
    let csvs = drive_csvs(&d);
    assert!(csvs.len() >= 35, "{} drives", csvs.len());
    for csv in &csvs {
        let pq = out.join(csv.file_stem().unwrap()).with_extension("parquet");
        ok(&["convert", s(csv), "-o", s(&pq)]);
        let (_, a) = detect_json(&[s(csv)]);
        let (_, b) = detect_json(&[s(&pq)]);
        assert_eq!(a["digest"], b["digest"], "{}", csv.display());
        assert_eq!(a["summary"], b["summary"], "{}", csv.display());
    }
    eprintln!("{} drives: the Parquet file's digest = the CSV's", csvs.len());
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_folder_of_parquet_drives_is_a_data_set() {
    let Some(d) = data_dir("a_folder_of_parquet_drives_is_a_data_set") else { return };
    let out = tmp("parquet-dataset");
    // Four sources (both GNSS rates, CAN and OBD-II speed) as CSV and as Parquet, same folders.
    for (kind, ext) in [("csv", "csv"), ("pq", "parquet")] {
        for src in ["openxc_ford", "comma2k19", "udacity_ch2", "css_canedge"] {
            let dir = out.join(kind).join("drives").join(src);
            std::fs::create_dir_all(&dir).unwrap();
            for f in std::fs::read_dir(d.join("drives").join(src)).unwrap().flatten() {
                let to = dir.join(f.path().file_stem().unwrap()).with_extension(ext);
                ok(&["convert", s(&f.path()), "-o", s(&to)]);
            }
        }
    }
    // inspect: the same drives, the same numbers; only the format differs.
    let (ic, ip) = (ok(&["inspect", "--json", s(&out.join("csv"))]), ok(&["inspect", "--json", s(&out.join("pq"))]));
    let norm = |t: &str| -> Vec<serde_json::Value> {
        t.lines()
            .map(|l| {
                let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
                let o = v.as_object_mut().unwrap();
                o.remove("path");
                o.remove("format");
                v
            })
            .collect()
    };
    assert_eq!(norm(&ic).len(), 5);
    assert_eq!(norm(&ic), norm(&ip));
    assert!(ip.contains("drive-parquet"));
    // eval: the same report (but for the data folder's name and the wall-clock DTW timing).
    for kind in ["csv", "pq"] {
        ok(&["eval", "--data", s(&out.join(kind)), "--scenarios", "3", "--nuisance-variants", "2", "--out", s(&out.join(format!("eval-{kind}")))]);
    }
    let report = |kind: &str| -> serde_json::Value {
        let mut r: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join(format!("eval-{kind}/report.json"))).unwrap()).unwrap();
        r["data_dir"] = serde_json::Value::Null;
        for k in ["us_per_query_pruned", "us_per_query_reference"] {
            r["turns"][k] = serde_json::Value::Null;
        }
        r
    };
    let (rc, rp) = (report("csv"), report("pq"));
    assert!(rc["clean"]["drives"].as_u64() == Some(5), "{}", rc["clean"]);
    assert_eq!(rc, rp, "eval on the Parquet folder differs from eval on the CSV folder");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn attack_and_nuisance_write_parquet_with_the_csvs_verdicts() {
    let Some(d) = data_dir("attack_and_nuisance_write_parquet_with_the_csvs_verdicts") else { return };
    let out = tmp("parquet-transform");
    let drive = d.join("drives/openxc_ford/dearborn_2012-03-26_drivingnew.csv");
    for (cmd, extra) in [("attack", ["--kind", "overshoot"]), ("nuisance", ["--kind", "combined"])] {
        let (c, p) = (out.join(format!("{cmd}.csv")), out.join(format!("{cmd}.parquet")));
        for f in [&c, &p] {
            ok(&[cmd, s(&drive), extra[0], extra[1], "--seed", "4", "-o", s(f)]);
        }
        assert_eq!(detect_json(&[s(&c)]).1["digest"], detect_json(&[s(&p)]).1["digest"], "{cmd}");
    }
    // The attack's ground truth is a column of the table.
    let f = std::fs::File::open(out.join("attack.parquet")).unwrap();
    let b = ParquetRecordBatchReaderBuilder::try_new(f).unwrap();
    assert!(b.schema().index_of("attack_active").is_ok());
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn detect_out_writes_the_verdicts_as_a_parquet_table() {
    let Some(d) = data_dir("detect_out_writes_the_verdicts_as_a_parquet_table") else { return };
    let out = tmp("parquet-verdicts");
    let drive = d.join("drives/comma2k19/b0c9d2329ad1606b_2018-08-02--08-34-47_seg40.csv");
    let attacked = out.join("attacked.csv");
    ok(&["attack", s(&drive), "--kind", "turn-by-turn", "--seed", "2", "-o", s(&attacked)]);
    let table = out.join("verdicts.parquet");
    let (epochs, last) = detect_json(&[s(&attacked), "--out", s(&table)]);
    let f = std::fs::File::open(&table).unwrap();
    let batches: Vec<_> = ParquetRecordBatchReaderBuilder::try_new(f).unwrap().build().unwrap().map(|b| b.unwrap()).collect();
    let rows: usize = batches.iter().map(|b| b.num_rows()).sum();
    assert_eq!(rows, epochs.len());
    assert_eq!(rows as u64, last["summary"]["epochs"].as_u64().unwrap());
    let (mut k, mut alarms) = (0, 0);
    for b in &batches {
        let (t, alarm, fired) = (b.column_by_name("t").unwrap().as_primitive::<Float64Type>(), b.column_by_name("alarm").unwrap().as_boolean(), b.column_by_name("fired").unwrap().as_list::<i32>());
        for i in 0..b.num_rows() {
            let e = &epochs[k];
            assert_eq!(t.value(i), e["t"].as_f64().unwrap(), "epoch {k}: t");
            assert_eq!(alarm.value(i), e["alarm"].as_bool().unwrap(), "epoch {k}: alarm");
            let names: Vec<String> = fired.value(i).as_string::<i32>().iter().map(|x| x.unwrap().to_string()).collect();
            let want: Vec<String> = e["fired"].as_array().unwrap().iter().map(|x| x.as_str().unwrap().to_string()).collect();
            assert_eq!(names, want, "epoch {k}: fired");
            alarms += usize::from(alarm.value(i));
            k += 1;
        }
    }
    assert!(alarms > 0, "the attack raised no alarm");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn raw_originals_converted_keep_every_event() {
    let Some(d) = data_dir("raw_originals_converted_keep_every_event") else { return };
    let out = tmp("parquet-raw");
    for raw in [d.join("raw/comma2k19_rav4_seg40"), d.join("raw/openxc_ford/drivingnew.jsonl")] {
        let pq = out.join("raw.parquet");
        ok(&["convert", s(&raw), "-o", s(&pq)]);
        // The layout counts time from the drive's first event, so the epochs' times (and with
        // them the digest) move by a constant; every verdict is the same.
        let (a, _) = detect_json(&[s(&raw)]);
        let (b, _) = detect_json(&[s(&pq)]);
        assert_eq!(a.len(), b.len(), "{}", raw.display());
        let shift = a[0]["t"].as_f64().unwrap() - b[0]["t"].as_f64().unwrap();
        for (k, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!((x["t"].as_f64().unwrap() - y["t"].as_f64().unwrap() - shift).abs() < 1e-6, "{}: epoch {k}: time", raw.display());
            for f in ["alarm", "fired", "ran", "degraded", "reasons"] {
                assert_eq!(x[f], y[f], "{}: epoch {k}: {f}", raw.display());
            }
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_corrupt_parquet_file_is_a_clear_error() {
    let out = tmp("parquet-corrupt");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    // A file the parquet crate panicked on (found by the fuzz target; its page headers refuse
    // it now), and a truncated file.
    let crash = out.join("crash.parquet");
    std::fs::copy(root.join("fuzz/regressions/drive_parquet/crash-7203774892f78498cbc09a9341af418b03ba77f1"), &crash).unwrap();
    let seed = std::fs::read(root.join("fuzz/seeds/drive_parquet/float64_snappy.parquet")).unwrap();
    let truncated = out.join("truncated.parquet");
    std::fs::write(&truncated, &seed[..seed.len() / 2]).unwrap();
    for (f, what) in [(&crash, "row group 0, column `"), (&truncated, "")] {
        let o = host_sim(&["detect", s(f)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(&format!("{}: not a readable Parquet file: {what}", f.display())), "{err}");
        assert!(!err.contains("panicked"), "the contained panic is not printed: {err}");
    }
    let _ = std::fs::remove_dir_all(&out);
}
