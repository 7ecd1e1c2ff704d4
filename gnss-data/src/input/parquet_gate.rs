//! The checks a Parquet file passes before the `parquet` crate decodes it. The crate trusts the
//! sizes and counts a file states: a 3 KB file whose dictionary page claims a billion values
//! makes it allocate 8 GB (found by our fuzz target `drive_parquet`, parquet 60.1), which no
//! `catch_unwind` can contain, and which would stop a fleet run at one corrupt file. So every
//! page header of the columns we read is parsed here first (Thrift compact protocol, only the
//! fields that size an allocation) and checked against the file and the footer:
//!
//! - at most [`MAX_ROWS`] rows in the file, and a row group's column chunks inside the file;
//! - a page's compressed size inside its column chunk, its uncompressed size at most
//!   [`MAX_PAGE_BYTES`] and at most the chunk's uncompressed size;
//! - a page's value count (dictionary entries, or values and nulls of a data page) at most the
//!   row group's rows (our columns are flat: one value or null per row).
//!
//! What passes can still be wrong (values, levels, compressed bytes); the reader refuses that
//! with the crate's error, or contains the crate's panic ([`super::drive_parquet`]).

use parquet::file::metadata::ParquetMetaData;

/// The most rows a drive file may hold: 2.3 days of the 10 Hz layout, 5.5 hours at 100 Hz.
/// Longer drives are split into files (a lake's files are one drive, or one hour, each).
pub const MAX_ROWS: i64 = 2_000_000;

/// The largest page, uncompressed (writers' pages are around 1 MiB).
pub const MAX_PAGE_BYTES: i64 = 64 << 20;

/// Checks the footer and every page header of the columns named in `columns` (top-level
/// names); `Err` says what is wrong, in words for the file's error.
pub fn check(file: &[u8], meta: &ParquetMetaData, columns: &[&str]) -> Result<(), String> {
    let rows = meta.file_metadata().num_rows();
    if !(0..=MAX_ROWS).contains(&rows) {
        return Err(format!("{rows} rows: expected at most {MAX_ROWS} in one drive file (split longer drives)"));
    }
    let mut total = 0i64;
    for (g, rg) in meta.row_groups().iter().enumerate() {
        let n = rg.num_rows();
        total = total.saturating_add(n);
        if n < 0 || total > MAX_ROWS {
            return Err(format!("row group {g}: {n} rows: expected at most {MAX_ROWS} in one drive file"));
        }
        for cc in rg.columns() {
            let name = cc.column_path().parts().first().map(String::as_str).unwrap_or("");
            if !columns.contains(&name) {
                continue;
            }
            let at = |what: String| format!("row group {g}, column `{name}`: {what}");
            let start = cc.dictionary_page_offset().unwrap_or(cc.data_page_offset());
            let (len, unc) = (cc.compressed_size(), cc.uncompressed_size());
            let end = start.checked_add(len).filter(|e| start >= 0 && len >= 0 && *e <= file.len() as i64).ok_or_else(|| at(format!("the chunk at byte {start}, {len} bytes long, is not inside the file")))?;
            if cc.num_values() > n {
                return Err(at(format!("{} values in {n} rows", cc.num_values())));
            }
            let mut pos = start;
            while pos < end {
                let bytes = file.get(pos as usize..end as usize).unwrap_or(&[]);
                let h = PageHeader::parse(bytes).map_err(|e| at(format!("the page header at byte {pos}: {e}")))?;
                let here = |what: String| at(format!("the page at byte {pos}: {what}"));
                let body_end = (pos + h.header_len as i64).checked_add(h.compressed).filter(|e| h.compressed >= 0 && *e <= end);
                let Some(body_end) = body_end else {
                    return Err(here(format!("{} compressed bytes, past the end of its chunk (byte {end})", h.compressed)));
                };
                if !(0..=MAX_PAGE_BYTES.min(unc.max(0))).contains(&h.uncompressed) {
                    return Err(here(format!("{} bytes uncompressed: expected at most {} (the chunk's size, and {MAX_PAGE_BYTES})", h.uncompressed, MAX_PAGE_BYTES.min(unc))));
                }
                if !(0..=n).contains(&h.values) {
                    return Err(here(format!("{} values: expected at most the row group's {n} rows", h.values)));
                }
                pos = body_end;
            }
        }
    }
    Ok(())
}

/// What of a page header sizes an allocation.
#[derive(Debug, Default)]
struct PageHeader {
    header_len: usize,
    uncompressed: i64,
    compressed: i64,
    /// The dictionary's entries, or a data page's values (nulls included); 0 for other pages.
    values: i64,
}

impl PageHeader {
    /// Parses the header at the start of `b` (`PageHeader` of parquet.thrift: 2
    /// uncompressed_page_size, 3 compressed_page_size, and field 1, num_values, of 5
    /// data_page_header, 7 dictionary_page_header and 8 data_page_header_v2).
    fn parse(b: &[u8]) -> Result<Self, String> {
        let mut r = Compact { b, pos: 0 };
        let mut h = PageHeader::default();
        let (mut got_unc, mut got_comp) = (false, false);
        let mut last = 0i16;
        while let Some((id, ty)) = r.field_header(&mut last)? {
            match (id, ty) {
                (2, I32) => (h.uncompressed, got_unc) = (r.varint_signed()?, true),
                (3, I32) => (h.compressed, got_comp) = (r.varint_signed()?, true),
                (5 | 7 | 8, STRUCT) => h.values = r.struct_first_i32(1)?,
                _ => r.skip(ty, 0)?,
            }
        }
        if !(got_unc && got_comp) {
            return Err("no page sizes".into());
        }
        h.header_len = r.pos;
        Ok(h)
    }
}

const I32: u8 = 5;
const STRUCT: u8 = 12;
/// Deeper nesting than any Parquet header has.
const MAX_DEPTH: usize = 8;

/// A Thrift compact-protocol reader over a byte slice: every read is bounded by it.
struct Compact<'a> {
    b: &'a [u8],
    pos: usize,
}

impl Compact<'_> {
    fn byte(&mut self) -> Result<u8, String> {
        let x = *self.b.get(self.pos).ok_or("ends inside the header")?;
        self.pos += 1;
        Ok(x)
    }

    fn varint(&mut self) -> Result<u64, String> {
        let mut v = 0u64;
        for shift in (0..70).step_by(7) {
            let x = self.byte()?;
            v |= u64::from(x & 0x7F).checked_shl(shift).unwrap_or(0);
            if x & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err("a varint longer than 10 bytes".into())
    }

    fn varint_signed(&mut self) -> Result<i64, String> {
        let v = self.varint()?;
        Ok((v >> 1) as i64 ^ -((v & 1) as i64))
    }

    /// The next field's id and type, or `None` at the struct's end.
    fn field_header(&mut self, last: &mut i16) -> Result<Option<(i16, u8)>, String> {
        let x = self.byte()?;
        if x == 0 {
            return Ok(None);
        }
        let (delta, ty) = (x >> 4, x & 0x0F);
        let id = if delta == 0 { self.varint_signed()? as i16 } else { last.wrapping_add(i16::from(delta)) };
        *last = id;
        Ok(Some((id, ty)))
    }

    /// A struct's field `want` when it is an i32 (0 when it is absent); the rest skipped.
    fn struct_first_i32(&mut self, want: i16) -> Result<i64, String> {
        let mut last = 0i16;
        let mut out = 0;
        while let Some((id, ty)) = self.field_header(&mut last)? {
            if id == want && ty == I32 {
                out = self.varint_signed()?;
            } else {
                self.skip(ty, 1)?;
            }
        }
        Ok(out)
    }

    fn skip_bytes(&mut self, n: u64) -> Result<(), String> {
        let end = usize::try_from(n).ok().and_then(|n| self.pos.checked_add(n)).filter(|e| *e <= self.b.len()).ok_or("ends inside the header")?;
        self.pos = end;
        Ok(())
    }

    /// Skips one value of type `ty` (`depth`: how deep in structs and containers it lies).
    fn skip(&mut self, ty: u8, depth: usize) -> Result<(), String> {
        if depth > MAX_DEPTH {
            return Err("nested too deep".into());
        }
        match ty {
            1 | 2 => Ok(()),
            3 => self.skip_bytes(1),
            4..=6 => self.varint().map(|_| ()),
            7 => self.skip_bytes(8),
            8 => {
                let n = self.varint()?;
                self.skip_bytes(n)
            }
            9 | 10 => {
                let x = self.byte()?;
                let (n, et) = if x >> 4 == 15 { (self.varint()?, x & 0x0F) } else { (u64::from(x >> 4), x & 0x0F) };
                self.skip_many(n, &[et], depth)
            }
            11 => {
                let n = self.varint()?;
                if n == 0 {
                    return Ok(());
                }
                let kv = self.byte()?;
                self.skip_many(n, &[kv >> 4, kv & 0x0F], depth)
            }
            STRUCT => {
                let mut last = 0i16;
                while let Some((_, t)) = self.field_header(&mut last)? {
                    self.skip(t, depth + 1)?;
                }
                Ok(())
            }
            t => Err(format!("unknown Thrift type {t}")),
        }
    }

    /// Skips `n` containers' elements of the types `tys` (each at least a byte: a count larger
    /// than what is left ends the header early instead of looping).
    fn skip_many(&mut self, n: u64, tys: &[u8], depth: usize) -> Result<(), String> {
        if n > (self.b.len() - self.pos) as u64 {
            return Err("a container longer than the header".into());
        }
        for _ in 0..n {
            for &t in tys {
                match t {
                    // Booleans in containers are one byte each.
                    1 | 2 => self.skip_bytes(1)?,
                    t => self.skip(t, depth + 1)?,
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_data_page_header_and_a_dictionary_header_parse() {
        // type DATA_PAGE, uncompressed 160, compressed 150, data_page_header { num_values 40,
        // encoding 0, definition 3, repetition 3 }.
        let b = [0x15, 0x00, 0x15, 0xC0, 0x02, 0x15, 0xAC, 0x02, 0x2C, 0x15, 0x50, 0x15, 0x00, 0x15, 0x06, 0x15, 0x06, 0x00, 0x00];
        let h = PageHeader::parse(&b).unwrap();
        assert_eq!((h.uncompressed, h.compressed, h.values, h.header_len), (160, 150, 40, b.len()));
        // type DICTIONARY_PAGE, 16 and 16 bytes, dictionary_page_header { num_values 2 }.
        let d = [0x15, 0x04, 0x15, 0x20, 0x15, 0x20, 0x4C, 0x15, 0x04, 0x15, 0x00, 0x00, 0x00];
        let h = PageHeader::parse(&d).unwrap();
        assert_eq!((h.uncompressed, h.compressed, h.values), (16, 16, 2));
    }

    #[test]
    fn truncated_and_looping_headers_are_errors() {
        assert!(PageHeader::parse(&[0x15, 0x00, 0x15]).is_err());
        // A list claiming 2^60 elements in a few bytes.
        assert!(PageHeader::parse(&[0x19, 0xF5, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x0F]).is_err());
        // Structs nested past any real header.
        assert!(PageHeader::parse(&[0x1C; 64]).is_err());
    }
}
