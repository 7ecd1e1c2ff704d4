//! The common drive layout as Apache Parquet (a fleet's data lake: one file per drive, the
//! columns and units of the drive CSV, [`super::drive_csv`]), read and written with the
//! arrow-rs `parquet` crate.
//!
//! Any numeric column type is read (integers and floats of any width; booleans for
//! `gnss_new_fix`), nulls and `NaN` meaning "no value", as in the CSV's empty fields; the rows
//! are then the CSV's rows exactly ([`super::drive_csv::row_events`]), so a drive gives the same
//! events from either file. Uncompressed, snappy, zstd, gzip and LZ4 files are read (not brotli).
//! Errors name the file, the row (0-based, in file order, not counting a header) or the column,
//! and what was expected. Before the `parquet` crate decodes a page, its header has passed
//! [`super::parquet_gate`] (sizes and counts the crate would trust, and allocate by); a file the
//! crate still panics on is refused as corrupt ([`contained`]).

use super::drive::{Format, InputError, LoadOptions, Replay};
use super::drive_csv::{row_events, rows, RowValues, COLUMNS, REQUIRED, SIGNALS};
use arrow_array::{Array, ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::Path;
use std::sync::Arc;

/// Does this byte string start like a Parquet file?
pub fn looks_like_parquet(head: &[u8]) -> bool {
    head.starts_with(b"PAR1")
}

/// Loads a drive from a Parquet file.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Replay, InputError> {
    let bytes = std::fs::read(path).map_err(|e| InputError::file(path, format!("cannot read: {e}")))?;
    load_bytes(path, bytes, opts)
}

/// Loads a drive from a Parquet file's bytes (`name` for errors).
pub fn load_bytes(name: &Path, bytes: Vec<u8>, opts: &LoadOptions) -> Result<Replay, InputError> {
    from_bytes(name, bytes::Bytes::from(bytes), opts)
}

fn numeric(t: &DataType) -> bool {
    as_f64(&arrow_array::new_empty_array(t)).is_some()
}

/// A column's values as f64 (nulls as `None`): every integer and float width, booleans, and an
/// all-null column; `None` for any other type.
fn as_f64(a: &ArrayRef) -> Option<Vec<Option<f64>>> {
    use arrow_array::cast::AsArray;
    use arrow_array::types::*;
    macro_rules! prim {
        ($t:ty) => {
            a.as_primitive_opt::<$t>().map(|p| p.iter().map(|v| v.map(|x| x as f64)).collect())
        };
    }
    match a.data_type() {
        DataType::Float64 => prim!(Float64Type),
        DataType::Float32 => prim!(Float32Type),
        DataType::Int8 => prim!(Int8Type),
        DataType::Int16 => prim!(Int16Type),
        DataType::Int32 => prim!(Int32Type),
        DataType::Int64 => prim!(Int64Type),
        DataType::UInt8 => prim!(UInt8Type),
        DataType::UInt16 => prim!(UInt16Type),
        DataType::UInt32 => prim!(UInt32Type),
        DataType::UInt64 => prim!(UInt64Type),
        DataType::Boolean => a.as_boolean_opt().map(|b| b.iter().map(|v| v.map(|x| if x { 1.0 } else { 0.0 })).collect()),
        DataType::Null => Some(vec![None; a.len()]),
        _ => None,
    }
}

/// Runs `f`, a call into the `parquet` crate, which can panic on a corrupt file instead of
/// returning an error (known upstream: apache/arrow-rs#9742; our fuzz target `drive_parquet`
/// found two, in its definition-level and page decoding): such a panic is contained and the file
/// refused as corrupt. Only the crate's calls run inside; our own code runs outside, where a
/// panic stays a panic.
fn contained<T>(path: &Path, f: impl FnOnce() -> T) -> Result<T, InputError> {
    quiet_contained_panics();
    CONTAINED.with(|c| c.set(true));
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    CONTAINED.with(|c| c.set(false));
    out.map_err(|p| {
        let what = p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned()).unwrap_or_default();
        InputError::file(path, format!("not a readable Parquet file: the Parquet decoder failed on it ({what}); the file is corrupt"))
    })
}

thread_local! {
    static CONTAINED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// The first Parquet read wraps the process's panic hook (once): a panic on a thread inside
/// [`contained`] is not printed (the file's error says what happened); every other panic goes
/// to the hook that was there before (the default message, a test harness's, libFuzzer's abort).
fn quiet_contained_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !CONTAINED.with(|c| c.get()) {
                previous(info);
            }
        }));
    });
}

fn from_bytes(path: &Path, file: bytes::Bytes, opts: &LoadOptions) -> Result<Replay, InputError> {
    let unreadable = |e: &dyn std::fmt::Display| InputError::file(path, format!("not a readable Parquet file: {e}"));
    let builder = contained(path, || ParquetRecordBatchReaderBuilder::try_new(file.clone()))?.map_err(|e| unreadable(&e))?;
    let schema = builder.schema().clone();
    let col = |name: &str| schema.index_of(name).ok();
    for r in REQUIRED {
        if col(r).is_none() {
            return Err(InputError::file(path, format!("missing column `{r}` (a drive must have the columns {REQUIRED:?})")));
        }
    }
    // Only the layout's columns are read (a lake's files may carry others).
    let wanted: Vec<(usize, &str)> = COLUMNS.iter().filter_map(|n| col(n).map(|i| (i, *n))).collect();
    for (i, n) in &wanted {
        let t = schema.field(*i).data_type();
        if !numeric(t) {
            return Err(InputError::file(path, format!("column `{n}`: expected numbers, found the type {t}")));
        }
    }
    let names: Vec<&str> = wanted.iter().map(|(_, n)| *n).collect();
    super::parquet_gate::check(&file, builder.metadata(), &names).map_err(|e| unreadable(&e))?;
    let mask = parquet::arrow::ProjectionMask::roots(builder.parquet_schema(), wanted.iter().map(|(i, _)| *i));
    let mut reader = contained(path, || builder.with_projection(mask).with_batch_size(65_536).build())?.map_err(|e| unreadable(&e))?;
    let mut events = Vec::new();
    let mut skipped = 0usize;
    let mut last_t = f64::NEG_INFINITY;
    let mut row0 = 0usize;
    while let Some(batch) = contained(path, || reader.next())? {
        let batch = batch.map_err(|e| InputError::file(path, format!("row {row0}: unreadable rows: {e}")))?;
        let get = |name: &str| -> Result<Option<Vec<Option<f64>>>, InputError> {
            let Some(a) = batch.column_by_name(name) else { return Ok(None) };
            as_f64(a).map(Some).ok_or_else(|| InputError::file(path, format!("column `{name}`: expected numbers, found the type {}", a.data_type())))
        };
        let (t, lat, lon, new_fix) = (get("t_s")?, get("lat_deg")?, get("lon_deg")?, get("gnss_new_fix")?);
        let (age, speed, course) = (get("gnss_fix_age_s")?, get("gnss_speed_mps")?, get("gnss_course_deg")?);
        let mut sigs: Vec<Option<Vec<Option<f64>>>> = Vec::new();
        for (n, _) in SIGNALS {
            sigs.push(get(n)?);
        }
        let at = |a: &Option<Vec<Option<f64>>>, i: usize| a.as_ref().and_then(|a| a.get(i).copied().flatten()).filter(|v| !v.is_nan());
        for i in 0..batch.num_rows() {
            let mut v = RowValues { t: at(&t, i), lat: at(&lat, i), lon: at(&lon, i), new_fix: at(&new_fix, i), age: at(&age, i), speed: at(&speed, i), course: at(&course, i), signals: [None; 5] };
            for (k, s) in sigs.iter().enumerate() {
                v.signals[k] = at(s, i);
            }
            let shown = |x: Option<f64>| x.map_or("null".to_string(), |x| x.to_string());
            match row_events(&v, || (shown(v.lat), shown(v.lon)), last_t) {
                Ok((tt, evs)) => {
                    last_t = tt;
                    events.extend(evs);
                }
                Err(_) if opts.skip_bad_rows => skipped += 1,
                Err(msg) => return Err(InputError::file(path, format!("row {}: {msg}", row0 + i))),
            }
        }
        row0 += batch.num_rows();
    }
    if events.is_empty() {
        return Err(InputError::file(path, "no data rows: expected at least one row"));
    }
    Ok(Replay::new(path, Format::DriveParquet, events, skipped))
}

/// The layout's Arrow schema (every column a nullable f64; `gnss_new_fix` an i8, and
/// `attack_active` when written).
pub fn schema(with_attack: bool) -> Schema {
    let mut fields: Vec<Field> = COLUMNS.iter().map(|n| Field::new(*n, if *n == "gnss_new_fix" { DataType::Int8 } else { DataType::Float64 }, true)).collect();
    if with_attack {
        fields.push(Field::new("attack_active", DataType::Int8, false));
    }
    Schema::new(fields)
}

/// A replay as one Arrow record batch in the layout ([`super::drive_csv::rows`]).
pub fn batch(r: &Replay, attack_from: Option<f64>) -> Result<RecordBatch, arrow_schema::ArrowError> {
    let rows = rows(r, attack_from);
    let mut cols: Vec<ArrayRef> = Vec::new();
    for (k, name) in COLUMNS.iter().enumerate() {
        if *name == "gnss_new_fix" {
            cols.push(Arc::new(arrow_array::Int8Array::from_iter(rows.iter().map(|(v, _)| v[k].map(|x| x as i8)))));
        } else {
            cols.push(Arc::new(Float64Array::from_iter(rows.iter().map(|(v, _)| v[k]))));
        }
    }
    if attack_from.is_some() {
        cols.push(Arc::new(arrow_array::Int8Array::from_iter_values(rows.iter().map(|(_, a)| i8::from(a.unwrap_or(false))))));
    }
    RecordBatch::try_new(Arc::new(schema(attack_from.is_some())), cols)
}

/// Writes a replay as a Parquet file in the layout (snappy-compressed), with `attack_active`
/// when `attack_from` is given. Reading it back gives the same events, times counted from the
/// first, except where rows share a time: they become one row (each signal's last value).
pub fn write(r: &Replay, attack_from: Option<f64>, out: impl std::io::Write + Send) -> std::io::Result<()> {
    write_batch(&batch(r, attack_from).map_err(std::io::Error::other)?, out)
}

/// Writes one record batch as a snappy-compressed Parquet file.
pub fn write_batch(b: &RecordBatch, out: impl std::io::Write + Send) -> std::io::Result<()> {
    let props = parquet::file::properties::WriterProperties::builder().set_compression(parquet::basic::Compression::SNAPPY).build();
    let mut w = parquet::arrow::ArrowWriter::try_new(out, b.schema(), Some(props)).map_err(std::io::Error::other)?;
    w.write(b).map_err(std::io::Error::other)?;
    w.close().map_err(std::io::Error::other)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::{BooleanArray, Float32Array, Int16Array, Int8Array, StringArray};
    use parquet::basic::{Compression, GzipLevel, ZstdLevel};
    use parquet::file::properties::WriterProperties;

    fn file(cols: Vec<(&str, ArrayRef)>, compression: Compression) -> Vec<u8> {
        let b = RecordBatch::try_from_iter(cols).unwrap();
        let mut out = Vec::new();
        let props = WriterProperties::builder().set_compression(compression).set_max_row_group_row_count(Some(3)).build();
        let mut w = parquet::arrow::ArrowWriter::try_new(&mut out, b.schema(), Some(props)).unwrap();
        w.write(&b).unwrap();
        w.close().unwrap();
        out
    }

    fn f64s(v: &[f64]) -> ArrayRef {
        Arc::new(Float64Array::from(v.to_vec()))
    }

    fn drive(compression: Compression) -> Vec<u8> {
        file(
            vec![
                ("t_s", f64s(&[0.0, 0.1, 0.2, 0.3, 1.0])),
                ("lat_deg", f64s(&[48.0, 48.0, 48.0, 48.0, 48.0001])),
                ("lon_deg", f64s(&[11.0; 5])),
                ("gnss_new_fix", Arc::new(Int8Array::from(vec![1, 0, 0, 0, 1]))),
                ("veh_speed_mps", f64s(&[10.0, 10.1, f64::NAN, 10.2, 10.3])),
                ("yaw_rate_degps", Arc::new(Float32Array::from(vec![Some(0.5), None, Some(0.5), Some(0.5), Some(0.5)]))),
            ],
            compression,
        )
    }

    fn load(bytes: Vec<u8>) -> Result<Replay, InputError> {
        load_bytes(Path::new("t.parquet"), bytes, &LoadOptions::default())
    }

    #[test]
    fn every_codec_reads_the_same_events_and_nulls_and_nan_are_no_value() {
        let plain = load(drive(Compression::UNCOMPRESSED)).unwrap();
        // 2 fixes, 4 wheel speeds (the NaN is none), 4 yaw rates (the null is none).
        assert_eq!((plain.fixes().count(), plain.events.len()), (2, 10));
        for c in [Compression::SNAPPY, Compression::ZSTD(ZstdLevel::default()), Compression::GZIP(GzipLevel::default()), Compression::LZ4_RAW] {
            assert_eq!(load(drive(c)).unwrap().events, plain.events, "{c:?}");
        }
    }

    #[test]
    fn integer_boolean_and_narrow_columns_read_as_numbers_and_other_columns_are_ignored() {
        let b = file(
            vec![
                ("t_s", Arc::new(Float32Array::from(vec![0.0, 1.0]))),
                ("lat_deg", f64s(&[48.0, 48.0001])),
                ("lon_deg", f64s(&[11.0, 11.0])),
                ("gnss_new_fix", Arc::new(BooleanArray::from(vec![true, true]))),
                ("veh_speed_mps", Arc::new(Int16Array::from(vec![Some(9), None]))),
                ("driver", Arc::new(StringArray::from(vec!["a", "b"]))),
            ],
            Compression::SNAPPY,
        );
        let r = load(b).unwrap();
        assert_eq!(r.fixes().count(), 2);
        assert_eq!(r.events.len(), 3);
    }

    #[test]
    fn errors_name_the_file_the_column_or_the_row() {
        let no_lat = file(vec![("t_s", f64s(&[0.0])), ("lon_deg", f64s(&[11.0])), ("gnss_new_fix", f64s(&[1.0]))], Compression::SNAPPY);
        let e = load(no_lat).unwrap_err().to_string();
        assert!(e.starts_with("t.parquet: missing column `lat_deg`"), "{e}");
        let text = file(vec![("t_s", f64s(&[0.0])), ("lat_deg", Arc::new(StringArray::from(vec!["48.0"]))), ("lon_deg", f64s(&[11.0])), ("gnss_new_fix", f64s(&[1.0]))], Compression::SNAPPY);
        let e = load(text).unwrap_err().to_string();
        assert!(e.contains("column `lat_deg`: expected numbers, found the type Utf8"), "{e}");
        let backwards = file(vec![("t_s", f64s(&[0.0, 2.0, 1.0])), ("lat_deg", f64s(&[48.0; 3])), ("lon_deg", f64s(&[11.0; 3])), ("gnss_new_fix", f64s(&[1.0, 0.0, 0.0]))], Compression::SNAPPY);
        let e = load(backwards.clone()).unwrap_err().to_string();
        assert!(e.starts_with("t.parquet: row 2: time goes backwards"), "{e}");
        let skipped = load_bytes(Path::new("t.parquet"), backwards, &LoadOptions { skip_bad_rows: true, ..LoadOptions::default() }).unwrap();
        assert_eq!(skipped.skipped_rows, 1);
        let e = load(b"PAR1 and nothing".to_vec()).unwrap_err().to_string();
        assert!(e.starts_with("t.parquet: not a readable Parquet file"), "{e}");
    }

    #[test]
    fn the_fuzzers_findings_are_refused_with_their_reason() {
        // Two files the parquet crate panicked on, and one (a dictionary claiming a billion
        // entries in a 3 KB file) it allocated 8 GB for: each stopped at its page header now.
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/fuzz/regressions/drive_parquet");
        let mut n = 0;
        for f in std::fs::read_dir(dir).unwrap().flatten() {
            let Err(e) = load(std::fs::read(f.path()).unwrap()) else { continue };
            let e = e.to_string();
            assert!(e.starts_with("t.parquet: not a readable Parquet file: row group 0, column `"), "{}: {e}", f.path().display());
            n += 1;
        }
        assert!(n >= 3, "{n} refused");
    }

    #[test]
    fn a_panic_inside_the_parquet_crate_is_contained_silently() {
        let e = contained(Path::new("t.parquet"), || -> u8 { panic!("offset + len out of bounds") }).unwrap_err().to_string();
        assert_eq!(e, "t.parquet: not a readable Parquet file: the Parquet decoder failed on it (offset + len out of bounds); the file is corrupt");
        // And the thread is out of the containment afterwards.
        assert!(!CONTAINED.with(|c| c.get()));
    }

    #[test]
    fn written_drives_read_back_to_the_same_events() {
        let r = load(drive(Compression::SNAPPY)).unwrap();
        let mut out = Vec::new();
        write(&r, Some(0.5), &mut out).unwrap();
        assert_eq!(load(out).unwrap().events, r.events);
    }
}
