//! CSV readers with validation. See the module docs of [`crate::io`].

use crate::io::lines::LineCounter;
use crate::io::records::{Fields, Records};
use crate::io::{InputError, COV_COLUMNS};
use crate::models::wrap_angle;
use crate::types::{
    Association, FusedTrack, Id, LocalTrack, Measurement, Sensor, SensorKind, StateCov, StateVec,
    TrackStatus, TruthState, Vec2,
};
// Fx hashing: the keys are small integers from the file, a hash-flooding attack is not a
// concern of a file reader, and SipHash was a fifth of the reading time.
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Every column name a docs/formats.md reader looks up, besides the covariance cells.
const FORMATS_COLUMNS: &[&str] = &[
    "scan",
    "time",
    "sensor_id",
    "track_id",
    "fused_id",
    "target_id",
    "x",
    "vx",
    "y",
    "vy",
    "n_sources",
    "sources",
    "range",
    "bearing",
    "kind",
    "sigma_r",
    "sigma_theta",
    "sigma_x",
    "sigma_y",
    "pd",
    "bias_r",
    "bias_theta",
    "max_range",
    "clutter_density",
];

/// The hint of the ordering error: how to bring a file into scan order.
const SORT_HINT: &str = "rows must be in non-decreasing scan order (any order within a scan); \
     sort the data rows by the scan column, keeping the header first";

/// The hint of the ordering error of a file without a scan column.
const TIME_SORT_HINT: &str = "a file without a scan column must have its rows in \
     non-decreasing time order (any order within one time); sort the data rows by the time \
     column, keeping the header first";

/// File name and header of a table, for error reports.
struct Meta {
    path: PathBuf,
    headers: Vec<String>,
    /// The header's line (1 unless blank lines come first).
    header_line: u64,
}

impl Meta {
    /// An error about cell `col` (0-based) of line `line`.
    fn err(&self, line: u64, col: usize, reason: impl Into<String>) -> InputError {
        InputError::cell(&self.path, line, col + 1, &self.headers[col], reason)
    }
}

/// A CSV input with its header resolved, read one record at a time.
struct Table<R: Read> {
    meta: Meta,
    records: Records<R>,
    /// Data rows read so far.
    rows: u64,
}

/// One row being parsed, with enough context to report errors.
struct Row<'a> {
    table: &'a Meta,
    rec: Fields<'a>,
    line: u64,
}

/// An input that keeps a copy of the bytes read through it (the header's read: the
/// bytes the csv crate has read past the header go to [`Records`]).
struct Kept<R> {
    inner: R,
    bytes: Vec<u8>,
}

impl<R: Read> Read for Kept<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bytes.extend_from_slice(&buf[..n]);
        Ok(n)
    }
}

#[cfg(test)]
thread_local! {
    /// Tests: read every data row with the csv crate (the reference of [`Records`]).
    static CSV_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Tests: parse every row with the general path (the reference of the fast path,
    /// [`ScanRows::parse_line`]).
    static NO_FAST: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Tests: the measurement fast path reads every layout by its column roles.
    static NO_SIX: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Open `path` for a reader.
fn open_file(path: &Path) -> Result<File, InputError> {
    File::open(path).map_err(|e| InputError::file(path, format!("cannot open: {e}")))
}

impl<R: Read> Table<R> {
    fn new(input: R, path: &Path) -> Result<Table<R>, InputError> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(false)
            // the header here; data cells are trimmed where they are read
            // (`Row::cell`), the same ASCII trim without the csv crate's copy of every
            // record
            .trim(csv::Trim::Headers)
            // 256 KiB reads instead of the default 8 KiB: a 20th of the read calls
            .buffer_capacity(1 << 18)
            .from_reader(LineCounter::new(Kept {
                inner: input,
                bytes: Vec::new(),
            }));
        let header = match reader.byte_headers() {
            Ok(h) => h.clone(),
            Err(e) => return Err(csv_error(path, e, reader.get_mut())),
        };
        let header_line = header
            .position()
            .map_or(1, |p| reader.get_mut().line_of(p.byte()));
        let mut headers = Vec::with_capacity(header.len());
        for (i, h) in header.iter().enumerate() {
            let name = std::str::from_utf8(h).map_err(|e| InputError {
                file: path.to_path_buf(),
                line: Some(header_line),
                column: Some(i + 1),
                column_name: Some(String::from_utf8_lossy(h).into_owned()),
                reason: utf8_reason(h, e),
            })?;
            headers.push(name.trim_start_matches('\u{feff}').to_string());
        }
        if headers.iter().all(|h| h.is_empty()) {
            return Err(InputError::line(
                path,
                header_line,
                "empty file or empty header row",
            ));
        }
        // A column a reader looks up by name must be unambiguous; unknown extra columns
        // are ignored, duplicated or not.
        for (i, h) in headers.iter().enumerate() {
            let known = FORMATS_COLUMNS.contains(&h.as_str()) || COV_COLUMNS.contains(&h.as_str());
            if let Some(j) = known
                .then(|| headers[..i].iter().position(|g| g == h))
                .flatten()
            {
                return Err(InputError {
                    file: path.to_path_buf(),
                    line: Some(header_line),
                    column: Some(i + 1),
                    column_name: Some(h.clone()),
                    reason: format!(
                        "column appears twice in the header (columns {} and {})",
                        j + 1,
                        i + 1
                    ),
                });
            }
        }
        // the data rows start where the header's read stopped
        let next = reader.position().byte();
        let mut lines = reader.into_inner();
        let line = lines.line_of(next);
        let Kept { inner, mut bytes } = lines.into_inner();
        let next = usize::try_from(next).unwrap_or(usize::MAX).min(bytes.len());
        let after_cr = next > 0 && bytes[next - 1] == b'\r';
        bytes.drain(..next);
        #[cfg(test)]
        let plain = !CSV_ONLY.get();
        #[cfg(not(test))]
        let plain = true;
        let records = Records::new(bytes, inner, line, after_cr, headers.len(), plain);
        Ok(Table {
            meta: Meta {
                path: path.to_path_buf(),
                headers,
                header_line,
            },
            records,
            rows: 0,
        })
    }

    /// Index of a required column.
    fn col(&self, name: &str) -> Result<usize, InputError> {
        let m = &self.meta;
        m.headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| InputError {
                file: m.path.clone(),
                line: Some(m.header_line),
                column: None,
                column_name: Some(name.to_string()),
                reason: format!(
                    "missing required column (header has: {})",
                    m.headers.join(",")
                ),
            })
    }

    /// Index of an optional column.
    fn opt(&self, name: &str) -> Option<usize> {
        self.meta.headers.iter().position(|h| h == name)
    }

    /// Read the next data record into `self.rec`: its 1-based line, or `None` at the end.
    fn next_record(&mut self) -> Result<Option<u64>, InputError> {
        let line = self.records.next(&self.meta.path)?;
        if line.is_some() {
            self.rows += 1;
        }
        Ok(line)
    }

    /// The next data record through the caller's own parse of a plain line (see
    /// [`Records::next_parsed`]): its line, or `None` when `parse` refused it (then
    /// nothing was read).
    #[inline]
    fn next_parsed(&mut self, parse: impl FnOnce(&[u8]) -> Option<usize>) -> Option<u64> {
        let line = self.records.next_parsed(parse)?;
        self.rows += 1;
        Some(line)
    }

    /// The record last read, as a row at `line`.
    fn row(&self, line: u64) -> Row<'_> {
        Row {
            table: &self.meta,
            rec: self.records.fields(),
            line,
        }
    }

    /// Visit every data row (files without a scan column).
    fn for_each_row(
        &mut self,
        mut f: impl FnMut(&Row<'_>) -> Result<(), InputError>,
    ) -> Result<(), InputError> {
        while let Some(line) = self.next_record()? {
            f(&self.row(line))?;
        }
        Ok(())
    }
}

/// A csv crate error, with the line counted by `lines` (the crate's own line is wrong
/// for CRLF files).
pub(crate) fn csv_error<R>(path: &Path, e: csv::Error, lines: &mut LineCounter<R>) -> InputError {
    let line = e.position().map(|p| lines.line_of(p.byte()));
    let reason = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("row has {len} fields, header has {expected_len}")
        }
        csv::ErrorKind::Utf8 { err, .. } => {
            format!("invalid UTF-8 in field {}", err.field() + 1)
        }
        csv::ErrorKind::Io(io) => format!("cannot read: {io}"),
        _ => e.to_string(),
    };
    InputError {
        file: path.to_path_buf(),
        line,
        column: None,
        column_name: None,
        reason,
    }
}

/// The reason of a cell that is not UTF-8: which byte, where.
fn utf8_reason(cell: &[u8], e: std::str::Utf8Error) -> String {
    let at = e.valid_up_to();
    format!(
        "invalid UTF-8 (byte 0x{:02x} at byte {} of the cell); the file must be UTF-8 text",
        cell.get(at).copied().unwrap_or(0),
        at + 1
    )
}

impl Row<'_> {
    /// The cell's bytes without leading and trailing ASCII whitespace (what the csv
    /// crate's `Trim::All` would have left).
    #[inline]
    fn cell(&self, col: usize) -> &[u8] {
        self.rec.get(col).unwrap_or(b"").trim_ascii()
    }

    /// The cell's text, trimmed; an error when it is not UTF-8.
    fn raw(&self, col: usize) -> Result<&str, InputError> {
        let cell = self.cell(col);
        std::str::from_utf8(cell)
            .map(str::trim)
            .map_err(|e| self.err(col, utf8_reason(cell, e)))
    }

    fn err(&self, col: usize, reason: impl Into<String>) -> InputError {
        self.table.err(self.line, col, reason)
    }

    /// Whether the cell is empty (or blank); a cell with any other byte is not.
    fn is_empty(&self, col: usize) -> bool {
        self.cell(col).is_empty()
    }

    /// A finite float.
    ///
    /// Fast path: `fast-float2` straight on the cell's bytes (no UTF-8 check, no
    /// Unicode trim); it accepts a subset of what `str::parse::<f64>` accepts and
    /// rounds the same (correctly), which `fast_float_parse_is_std_parse` tests. Any
    /// cell it refuses, and any non-finite value, takes the `str::parse` path, so the
    /// accepted cells, the values and the error messages are those of `str::parse`.
    #[inline]
    fn f64(&self, col: usize) -> Result<f64, InputError> {
        if let Ok(v) = fast_float2::parse::<f64, _>(self.cell(col)) {
            if v.is_finite() {
                return Ok(v);
            }
        }
        self.f64_std(col)
    }

    /// [`Row::f64`] through `str::parse` (the reference, and every error).
    #[cold]
    fn f64_std(&self, col: usize) -> Result<f64, InputError> {
        let s = self.raw(col)?;
        if s.is_empty() {
            return Err(self.err(col, "empty cell, a number is required"));
        }
        let v: f64 = s
            .parse()
            .map_err(|_| self.err(col, format!("'{s}' is not a number")))?;
        if !v.is_finite() {
            return Err(self.err(col, format!("'{s}' is not finite")));
        }
        Ok(v)
    }

    /// An optional finite float (`None` when the column is absent or the cell empty).
    fn opt_f64(&self, col: Option<usize>) -> Result<Option<f64>, InputError> {
        match col {
            Some(c) if !self.is_empty(c) => self.f64(c).map(Some),
            _ => Ok(None),
        }
    }

    /// An integer. Fast path: an optional `-` and 1 to 18 ASCII digits (no overflow
    /// possible) are summed by hand; any other cell takes `str::parse::<i64>`, so the
    /// accepted cells, values and errors are `str::parse`'s (`small_int_is_std_parse`).
    #[inline]
    fn int(&self, col: usize) -> Result<i64, InputError> {
        match small_int(self.cell(col)) {
            Some(v) => Ok(v),
            None => self.int_std(col),
        }
    }

    /// [`Row::int`] through `str::parse` (the reference, and every error).
    #[cold]
    fn int_std(&self, col: usize) -> Result<i64, InputError> {
        let s = self.raw(col)?;
        s.parse::<i64>().map_err(|_| {
            if s.is_empty() {
                self.err(col, "empty cell, an integer is required")
            } else {
                self.err(col, format!("'{s}' is not an integer"))
            }
        })
    }

    fn scan(&self, col: usize) -> Result<u32, InputError> {
        let v = self.int(col)?;
        u32::try_from(v).map_err(|_| self.err(col, format!("scan {v} must be in 0..=4294967295")))
    }

    fn nonneg(&self, col: usize) -> Result<f64, InputError> {
        let v = self.f64(col)?;
        if v < 0.0 {
            return Err(self.err(col, format!("{v} must not be negative")));
        }
        Ok(v)
    }

    /// A finite number above 0 (the scenario file's rule and wording for the same value).
    fn positive(&self, col: usize) -> Result<f64, InputError> {
        let v = self.f64(col)?;
        if v <= 0.0 {
            return Err(self.err(col, format!("{v} must be a positive number")));
        }
        Ok(v)
    }
}

/// A float column whose cell repeats from row to row (a scan's time): the last cell's
/// bytes and value are kept, and a cell with the same bytes takes that value without
/// being parsed again. The same bytes give the same value and the same checks, so what
/// is accepted and every error are those of [`Row::f64`].
#[derive(Debug, Default)]
struct RepeatedF64 {
    cell: Vec<u8>,
    value: Option<f64>,
}

impl RepeatedF64 {
    /// The fast paths' time cell at the start of `rest`: the cell of an earlier row,
    /// whose value is kept, when the same text is followed by a field's end; otherwise
    /// the number at the start of `rest` ([`float_prefix`]), kept when a field's end
    /// follows it. Its value and length; `None` where `float_prefix` gives none.
    #[inline]
    fn prefix(&mut self, rest: &[u8]) -> Option<(f64, usize)> {
        match self.value {
            Some(v)
                if !self.cell.is_empty()
                    && rest.starts_with(&self.cell)
                    && empty_cell(&rest[self.cell.len()..]) =>
            {
                Some((v, self.cell.len()))
            }
            _ => {
                let (v, n) = float_prefix(rest)?;
                if empty_cell(&rest[n..]) {
                    self.cell.clear();
                    self.cell.extend_from_slice(&rest[..n]);
                    self.value = Some(v);
                }
                Some((v, n))
            }
        }
    }

    #[inline]
    fn get(&mut self, row: &Row<'_>, col: usize) -> Result<f64, InputError> {
        let cell = row.cell(col);
        if let Some(v) = self.value {
            if self.cell == cell {
                return Ok(v);
            }
        }
        let v = row.f64(col)?;
        self.cell.clear();
        self.cell.extend_from_slice(cell);
        self.value = Some(v);
        Ok(v)
    }
}

/// `-?[0-9]{1,18}` as an `i64` (hand-written: the common cell of an id or scan column,
/// without `str::parse`'s UTF-8 check and sign and overflow handling); `None` for
/// anything else.
#[inline]
pub(crate) fn small_int(b: &[u8]) -> Option<i64> {
    let (neg, digits) = match b.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, b),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v = 0i64;
    for &c in digits {
        if !c.is_ascii_digit() {
            return None;
        }
        v = v * 10 + i64::from(c - b'0');
    }
    Some(if neg { -v } else { v })
}

/// The file contract's one definition of a valid covariance, shared with the fusion
/// rules ([`crate::covariance`]).
pub use crate::covariance::{check_covariance, CovarianceError};

struct StateCols {
    state: [usize; 4],
    cov: [usize; 16],
}

impl StateCols {
    fn find<R: Read>(t: &Table<R>) -> Result<StateCols, InputError> {
        let mut cov = [0usize; 16];
        for (i, name) in COV_COLUMNS.iter().enumerate() {
            cov[i] = t.col(name)?;
        }
        Ok(StateCols {
            state: [t.col("x")?, t.col("vx")?, t.col("y")?, t.col("vy")?],
            cov,
        })
    }

    fn read(&self, row: &Row<'_>) -> Result<(StateVec, StateCov), InputError> {
        let mut s = StateVec::zeros();
        for i in 0..4 {
            s[i] = row.f64(self.state[i])?;
        }
        let mut p = StateCov::zeros();
        for i in 0..16 {
            let (r, c) = (i / 4, i % 4);
            // below the diagonal, a cell with the same bytes as its mirror above (read
            // earlier: row-major order) has its value; the parse would give the same
            // (most writers write a symmetric matrix's two copies alike)
            p[(r, c)] = if r > c && row.cell(self.cov[i]) == row.cell(self.cov[c * 4 + r]) {
                p[(c, r)]
            } else {
                row.f64(self.cov[i])?
            };
        }
        check_covariance(&p)
            .map_err(|e| InputError::line(&row.table.path, row.line, e.to_string()))?;
        Ok((s, p))
    }
}

/// Time must not go backwards within one key (a target, a track); `last` holds each
/// key's latest time and its line.
fn check_time<K: std::hash::Hash + Eq + std::fmt::Debug>(
    row: &Row<'_>,
    c_time: usize,
    last: &mut HashMap<K, (f64, u64)>,
    key: K,
    time: f64,
) -> Result<(), InputError> {
    if let Some(&(t_prev, line_prev)) = last.get(&key) {
        if time < t_prev {
            return Err(row.err(
                c_time,
                format!(
                    "time goes backwards for {key:?}: {time} after {t_prev} (line {line_prev})"
                ),
            ));
        }
    }
    last.insert(key, (time, row.line));
    Ok(())
}

/// How one file kind's rows are parsed, checked and ordered within a scan.
trait ScanRows {
    type Item;
    /// Index of the `scan` column; `None` for a file without one (local_tracks.csv and
    /// measurements.csv may omit it), whose rows are batched by time.
    fn scan_col(&self) -> Option<usize>;
    /// Index of the `time` column (read for the ordering rule of a file without scans).
    fn time_col(&self) -> usize;
    /// A new scan starts: forget what only one scan needs (duplicate sets, per-scan
    /// maps), so memory does not grow with the number of scans.
    fn start_scan(&mut self);
    /// Parse and check one row of scan `scan`.
    fn parse(&mut self, row: &Row<'_>, scan: u32) -> Result<Self::Item, InputError>;
    /// Bring one scan's rows (with their lines) into the order the reader returns.
    fn order(rows: &mut [(Self::Item, u64)]);
    /// Whether one scan's rows are in that order already (then [`ScanRows::order`] is
    /// not called and the rows are not moved again: files written by this project are).
    fn in_order(rows: &[Self::Item]) -> bool;
    /// The fast path of a file kind that has one: parse the plain line at the start of
    /// `bytes` (the unread input) if it has the common shape, every cell read without
    /// error, and keep its values for [`ScanRows::parse_kept`]; return the line's length
    /// (without its `\n`), its scan (`None` for a file without a scan column) and its
    /// time. `None` for anything else: the row is then read and parsed by the general
    /// path ([`ScanRows::parse`]), which gives every value and every error.
    #[inline]
    fn parse_line(&mut self, _bytes: &[u8]) -> Option<(usize, Option<u32>, f64)> {
        None
    }
    /// The row [`ScanRows::parse_line`] read last, of scan `scan` at line `line`,
    /// checked as [`ScanRows::parse`] checks a row.
    fn parse_kept(&mut self, meta: &Meta, line: u64, _scan: u32) -> Result<Self::Item, InputError> {
        Err(InputError::line(
            &meta.path,
            line,
            "internal error: no row parsed on the fast path",
        ))
    }
}

/// The scan-at-a-time reader behind every `*Stream`.
struct ScanReader<P: ScanRows, R: Read> {
    table: Table<R>,
    rows: P,
    /// A record already read that starts the next scan: its line, its scan and whether
    /// the fast path ([`ScanRows::parse_line`]) read it (then `rows` keeps its values,
    /// else `table` holds the record).
    pending: Option<(u64, u32, bool)>,
    /// Scan and line of the last row read (the ordering rule).
    prev: Option<(u32, u64)>,
    /// A file without a scan column: the time, scan (batch count) and line of the last
    /// row read.
    prev_time: Option<(f64, u32, u64)>,
    /// The first error: the stream returns it again rather than going on past it.
    failed: Option<InputError>,
    scratch: Vec<(P::Item, u64)>,
    /// The line of each row of the last scan returned.
    lines: Vec<u64>,
}

impl<P: ScanRows, R: Read> ScanReader<P, R> {
    fn new(table: Table<R>, rows: P) -> Self {
        ScanReader {
            table,
            rows,
            pending: None,
            prev: None,
            prev_time: None,
            failed: None,
            scratch: Vec::new(),
            lines: Vec::new(),
        }
    }

    fn next_scan(&mut self, buf: &mut Vec<P::Item>) -> Result<Option<u32>, InputError> {
        buf.clear();
        self.lines.clear();
        self.scratch.clear();
        if let Some(e) = &self.failed {
            return Err(e.clone());
        }
        match self.fill(buf) {
            Ok(Some(scan)) => {
                if !P::in_order(buf) {
                    self.scratch.extend(buf.drain(..).zip(self.lines.drain(..)));
                    P::order(&mut self.scratch);
                    for (item, line) in self.scratch.drain(..) {
                        buf.push(item);
                        self.lines.push(line);
                    }
                }
                Ok(Some(scan))
            }
            Ok(None) => Ok(None),
            Err(e) => {
                buf.clear();
                self.lines.clear();
                self.failed = Some(e.clone());
                Err(e)
            }
        }
    }

    /// Read the rows of the next scan into `buf`, their lines into `lines`.
    fn fill(&mut self, buf: &mut Vec<P::Item>) -> Result<Option<u32>, InputError> {
        let mut current = None;
        loop {
            let (line, scan, fast) = match self.pending.take() {
                Some(p) => p,
                None => {
                    let rows = &mut self.rows;
                    let mut key = (None, 0.0);
                    let fast = self.table.next_parsed(|bytes| {
                        let (n, scan, time) = rows.parse_line(bytes)?;
                        key = (scan, time);
                        Some(n)
                    });
                    let line = match fast {
                        Some(line) => line,
                        None => {
                            let Some(line) = self.table.next_record()? else {
                                break;
                            };
                            let row = self.table.row(line);
                            key = match self.rows.scan_col() {
                                Some(c) => (Some(row.scan(c)?), 0.0),
                                None => (None, row.f64(self.rows.time_col())?),
                            };
                            line
                        }
                    };
                    let scan = self.scan_of(line, key)?;
                    (line, scan, fast.is_some())
                }
            };
            match current {
                Some(c) if c != scan => {
                    self.pending = Some((line, scan, fast));
                    break;
                }
                Some(_) => {}
                None => {
                    current = Some(scan);
                    self.rows.start_scan();
                }
            }
            let item = if fast {
                self.rows.parse_kept(&self.table.meta, line, scan)?
            } else {
                self.rows.parse(&self.table.row(line), scan)?
            };
            buf.push(item);
            self.lines.push(line);
        }
        Ok(current)
    }

    /// The scan of the row at `line`, whose scan cell holds `key.0` or, in a file without
    /// a scan column, whose time is `key.1`; checks the ordering rule.
    #[inline]
    fn scan_of(&mut self, line: u64, key: (Option<u32>, f64)) -> Result<u32, InputError> {
        let meta = &self.table.meta;
        match key {
            (Some(scan), _) => {
                let c = self.rows.scan_col().unwrap_or(0);
                if let Some((prev_scan, prev_line)) = self.prev {
                    if scan < prev_scan {
                        return Err(meta.err(
                            line,
                            c,
                            format!(
                                "scan {scan} comes after scan {prev_scan} (line \
                                 {prev_line}): {SORT_HINT}"
                            ),
                        ));
                    }
                }
                self.prev = Some((scan, line));
                Ok(scan)
            }
            // no scan column: one batch per distinct time, numbered from 0
            (None, time) => {
                let c = self.rows.time_col();
                let scan = match self.prev_time {
                    None => 0,
                    Some((t, s, _)) if t == time => s,
                    Some((t, s, l)) => {
                        if time < t {
                            return Err(meta.err(
                                line,
                                c,
                                format!(
                                    "time {time} comes after time {t} (line {l}): \
                                     {TIME_SORT_HINT}"
                                ),
                            ));
                        }
                        s.checked_add(1).ok_or_else(|| {
                            meta.err(line, c, "more than 4294967296 distinct times")
                        })?
                    }
                };
                self.prev_time = Some((time, scan, line));
                Ok(scan)
            }
        }
    }
}

/// The public streams: one scan at a time, and the whole file collected.
macro_rules! scan_stream {
    ($(#[$doc:meta])* $name:ident, $rows:ty, $item:ty) => {
        $(#[$doc])*
        pub struct $name<R: Read = File>(ScanReader<$rows, R>);

        impl<R: Read> $name<R> {
            /// The rows of the next scan, into `buf` (cleared first, its capacity
            /// reused), in the order the whole-file reader returns them; the scan index,
            /// or `None` at the end of the file. After an error every later call returns
            /// the same error.
            pub fn next_scan(&mut self, buf: &mut Vec<$item>) -> Result<Option<u32>, InputError> {
                self.0.next_scan(buf)
            }

            /// The 1-based file line of each row the last [`Self::next_scan`] returned
            /// (same order as its rows), to name the line of a row in later errors.
            pub fn lines(&self) -> &[u64] {
                &self.0.lines
            }

            /// The file name used in messages.
            pub fn path(&self) -> &Path {
                &self.0.table.meta.path
            }

            /// The 1-based number of the column `name` in the header, if it has one.
            pub fn column(&self, name: &str) -> Option<usize> {
                self.0.table.opt(name).map(|c| c + 1)
            }

            /// Data rows read so far (including one read ahead of the last scan).
            pub fn rows_read(&self) -> u64 {
                self.0.table.rows
            }

            /// Every remaining row (the whole file when called first).
            pub fn collect_rows(mut self) -> Result<Vec<$item>, InputError> {
                let mut out = Vec::new();
                let mut buf = Vec::new();
                while self.next_scan(&mut buf)?.is_some() {
                    out.append(&mut buf);
                }
                Ok(out)
            }
        }
    };
}

// ---------------------------------------------------------------- sensors.csv

/// Read `sensors.csv`.
pub fn read_sensors(path: &Path) -> Result<Vec<Sensor>, InputError> {
    read_sensors_from(open_file(path)?, path)
}

/// [`read_sensors`] from any input; `path` names it in messages.
///
/// Values follow the scenario file's rule for the same keys: `sigma_r`, `sigma_theta`
/// (range_bearing) and `sigma_x`, `sigma_y` (position) must be positive, `pd` in
/// [0, 1], `max_range` and `clutter_density` >= 0, `sensor_id` >= 0, and a position
/// sensor's `bias_r`, `bias_theta` 0 (biases apply to range_bearing sensors only).
pub fn read_sensors_from<R: Read>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<Sensor>, InputError> {
    let path = path.as_ref();
    let mut t = Table::new(reader, path)?;
    let c_id = t.col("sensor_id")?;
    let c_x = t.col("x")?;
    let c_y = t.col("y")?;
    let c_pd = t.col("pd")?;
    let c_kind = t.opt("kind");
    let c_sr = t.opt("sigma_r");
    let c_st = t.opt("sigma_theta");
    let c_sx = t.opt("sigma_x");
    let c_sy = t.opt("sigma_y");
    let c_br = t.opt("bias_r");
    let c_bt = t.opt("bias_theta");
    let c_mr = t.opt("max_range");
    let c_cd = t.opt("clutter_density");
    if c_kind.is_none() && (c_sr.is_none() || c_st.is_none()) {
        // every sensor is a radar: sigma_r and sigma_theta are required
        t.col("sigma_r")?;
        t.col("sigma_theta")?;
    }
    let mut out: Vec<Sensor> = Vec::new();
    let mut seen = HashMap::default();
    t.for_each_row(|row| {
        let id = row.int(c_id)?;
        if id < 0 {
            return Err(row.err(c_id, format!("{id} must not be negative")));
        }
        if let Some(prev) = seen.insert(id, row.line) {
            return Err(row.err(
                c_id,
                format!("duplicate sensor_id {id} (first on line {prev})"),
            ));
        }
        let kind = match c_kind {
            Some(c) if !row.is_empty(c) => match row.raw(c)? {
                "range_bearing" => SensorKind::RangeBearing,
                "position" => SensorKind::Position,
                other => {
                    return Err(row.err(
                        c,
                        format!("unknown kind '{other}' (expected range_bearing or position)"),
                    ))
                }
            },
            _ => SensorKind::RangeBearing,
        };
        let need = |c: Option<usize>, name: &str| -> Result<f64, InputError> {
            match c {
                Some(c) => row.positive(c),
                None => Err(InputError::line(
                    &row.table.path,
                    row.line,
                    format!("a {} sensor needs column '{name}'", kind.as_str()),
                )),
            }
        };
        let (sa, sb) = match kind {
            SensorKind::RangeBearing => (need(c_sr, "sigma_r")?, need(c_st, "sigma_theta")?),
            SensorKind::Position => (need(c_sx, "sigma_x")?, need(c_sy, "sigma_y")?),
        };
        let pd = row.f64(c_pd)?;
        if !(0.0..=1.0).contains(&pd) {
            return Err(row.err(c_pd, format!("pd {pd} must be in [0, 1]")));
        }
        let max_range = match c_mr {
            Some(c) if !row.is_empty(c) => row.nonneg(c)?,
            _ => 0.0,
        };
        let clutter_density = match c_cd {
            Some(c) if !row.is_empty(c) => Some(row.nonneg(c)?),
            _ => None,
        };
        let bias_r = row.opt_f64(c_br)?.unwrap_or(0.0);
        let bias_theta = row.opt_f64(c_bt)?.unwrap_or(0.0);
        if kind == SensorKind::Position {
            for (c, b) in [(c_br, bias_r), (c_bt, bias_theta)] {
                if let (Some(c), true) = (c, b != 0.0) {
                    return Err(row.err(
                        c,
                        "range/bearing biases apply to range_bearing sensors only",
                    ));
                }
            }
        }
        out.push(Sensor {
            id,
            kind,
            x: row.f64(c_x)?,
            y: row.f64(c_y)?,
            sigma_a: sa,
            sigma_b: sb,
            pd,
            bias_r,
            bias_theta,
            max_range,
            clutter_density,
        });
        Ok(())
    })?;
    if out.is_empty() {
        return Err(InputError::file(
            path,
            "no sensors (the file has a header but no rows)",
        ));
    }
    Ok(out)
}

// ---------------------------------------------------------------- truth.csv

struct TruthRows {
    c_scan: Option<usize>,
    c_time: usize,
    c_tid: usize,
    cs: [usize; 4],
    /// Targets seen in the current scan.
    seen: HashSet<Id>,
    last: HashMap<Id, (f64, u64)>,
}

impl ScanRows for TruthRows {
    type Item = TruthState;
    fn scan_col(&self) -> Option<usize> {
        self.c_scan
    }
    fn time_col(&self) -> usize {
        self.c_time
    }
    fn start_scan(&mut self) {
        self.seen.clear();
    }
    fn parse(&mut self, row: &Row<'_>, scan: u32) -> Result<TruthState, InputError> {
        let time = row.f64(self.c_time)?;
        let target_id = row.int(self.c_tid)?;
        if !self.seen.insert(target_id) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!("duplicate row for scan {scan}, target_id {target_id}"),
            ));
        }
        check_time(row, self.c_time, &mut self.last, target_id, time)?;
        let mut state = StateVec::zeros();
        for i in 0..4 {
            state[i] = row.f64(self.cs[i])?;
        }
        Ok(TruthState {
            scan,
            time,
            target_id,
            state,
        })
    }
    /// The file's order within a scan.
    fn order(_: &mut [(TruthState, u64)]) {}
    fn in_order(_: &[TruthState]) -> bool {
        true
    }
}

scan_stream!(
    /// `truth.csv`, one scan at a time (rows in the file's order). Rows must not repeat
    /// `(scan, target_id)`; time must not go backwards within a target.
    TruthStream,
    TruthRows,
    TruthState
);

impl TruthStream<File> {
    pub fn open(path: &Path) -> Result<Self, InputError> {
        Self::from_reader(open_file(path)?, path)
    }
}

impl<R: Read> TruthStream<R> {
    /// The stream over any input; `path` names it in messages.
    pub fn from_reader(reader: R, path: impl AsRef<Path>) -> Result<Self, InputError> {
        let t = Table::new(reader, path.as_ref())?;
        let rows = TruthRows {
            c_scan: Some(t.col("scan")?),
            c_time: t.col("time")?,
            c_tid: t.col("target_id")?,
            cs: [t.col("x")?, t.col("vx")?, t.col("y")?, t.col("vy")?],
            seen: HashSet::default(),
            last: HashMap::default(),
        };
        Ok(TruthStream(ScanReader::new(t, rows)))
    }
}

/// The error of a truth file without rows: metrics against no truth would all be
/// undefined, so it is refused rather than evaluated to nothing.
pub fn no_truth_rows(path: &Path) -> InputError {
    InputError::file(path, "no truth rows (the file has a header but no rows)")
}

/// Read `truth.csv` (see [`TruthStream`]). A file with a header and no rows is an error.
pub fn read_truth(path: &Path) -> Result<Vec<TruthState>, InputError> {
    read_truth_from(open_file(path)?, path)
}

/// [`read_truth`] from any input; `path` names it in messages.
pub fn read_truth_from<R: Read>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<TruthState>, InputError> {
    let out = TruthStream::from_reader(reader, path.as_ref())?.collect_rows()?;
    if out.is_empty() {
        return Err(no_truth_rows(path.as_ref()));
    }
    Ok(out)
}

// ---------------------------------------------------------------- measurements.csv

struct MeasurementRows {
    c_scan: Option<usize>,
    c_time: usize,
    c_sid: usize,
    rb_cols: Option<(usize, usize)>,
    pos_cols: Option<(usize, usize)>,
    c_tid: Option<usize>,
    /// Whether the sensors are given (then every sensor_id must be one of them, and
    /// `sensors` holds them all from the start with their kinds).
    known_sensors: bool,
    /// Per sensor: its kind (when given), its time in the current scan and its latest
    /// scan ([`SensorSlots`]).
    sensors: SensorSlots,
    /// `(sensor, range|x bits, bearing|y bits)` of the current scan's rows.
    seen: SeenKeys,
    time: RepeatedF64,
    /// What each column is to the fast path ([`MeasurementRows::parse_line`]).
    roles: Vec<Role>,
    /// The kind of the six-column layout this project writes, when the header is that
    /// layout ([`MeasurementRows::parse_line_six`]).
    six: Option<SensorKind>,
    /// The values of the row the fast path read last.
    kept: KeptRow,
}

/// A measurements.csv column, for the fast path.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// A column no reader reads (its cell is only stepped over).
    Other,
    Scan,
    Time,
    Sensor,
    Range,
    Bearing,
    X,
    Y,
    Target,
}

/// The cells of one row as the fast path read them (`None`: an empty cell, or the
/// column is not read).
#[derive(Debug, Clone, Copy, Default)]
struct KeptRow {
    time: f64,
    sensor_id: Id,
    range: Option<f64>,
    bearing: Option<f64>,
    x: Option<f64>,
    y: Option<f64>,
    target_id: Id,
}

/// The fast path's integer cell: `-?[0-9]{1,18}` at the start of `b` (the cells
/// [`small_int`] reads), its value and length; `None` for anything else.
#[inline]
fn int_prefix(b: &[u8]) -> Option<(i64, usize)> {
    let neg = b.first() == Some(&b'-');
    let start = usize::from(neg);
    let mut v = 0i64;
    let mut i = start;
    while let Some(&c) = b.get(i) {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        if i - start == 18 {
            return None;
        }
        v = v * 10 + i64::from(d);
        i += 1;
    }
    if i == start {
        return None;
    }
    Some((if neg { -v } else { v }, i))
}

/// The fast path's float cell: what `fast-float2` reads at the start of `b`, if finite,
/// and its length; `None` for anything else. Followed by a field's end, the number is
/// the whole cell, which [`Row::f64`] reads with the same parser to the same value.
#[inline]
fn float_prefix(b: &[u8]) -> Option<(f64, usize)> {
    match fast_float2::parse_partial::<f64, _>(b) {
        Ok((v, n)) if v.is_finite() && n > 0 => Some((v, n)),
        _ => None,
    }
}

/// Whether `b` starts with an empty cell (a field's end right away).
#[inline]
fn empty_cell(b: &[u8]) -> bool {
    matches!(b.first(), Some(b',' | b'\n'))
}

/// A set of one scan's measurement keys: the keys in a vector, in the order of their
/// rows, and a hash table of their indices (`hashbrown::HashTable`). The same answers as
/// a hash set of the keys (property test `seen_keys_is_a_hash_set`), with a table of
/// 4-byte entries instead of 24-byte ones: a scan's table (thousands of rows) is touched
/// at random once per row, and the smaller entries make the read of measurements.csv
/// about 4 % faster (BENCHMARKS.md, issue 13 point 1). Holds up to `u32::MAX` keys
/// ([`Seen::Full`]).
#[derive(Default)]
struct SeenKeys {
    keys: Vec<(Id, u64, u64)>,
    table: hashbrown::HashTable<u32>,
    hasher: rustc_hash::FxBuildHasher,
}

/// What [`SeenKeys::insert`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Seen {
    /// A new key, now added.
    New,
    /// A key added before.
    Again,
    /// No room for another key (`u32::MAX` held): nothing looked up or added.
    Full,
}

impl SeenKeys {
    /// Add `key` if it is new, as `HashSet::insert` (`New` for `true`, `Again` for
    /// `false`), unless the set is full.
    #[inline]
    fn insert(&mut self, key: (Id, u64, u64)) -> Seen {
        use std::hash::BuildHasher;
        if self.keys.len() >= u32::MAX as usize {
            return Seen::Full;
        }
        let hasher = &self.hasher;
        let keys = &self.keys;
        match self.table.entry(
            hasher.hash_one(key),
            |&i| keys[i as usize] == key,
            |&i| hasher.hash_one(keys[i as usize]),
        ) {
            hashbrown::hash_table::Entry::Occupied(_) => Seen::Again,
            hashbrown::hash_table::Entry::Vacant(v) => {
                // below `u32::MAX` keys (checked above): the index fits
                v.insert(keys.len() as u32);
                self.keys.push(key);
                Seen::New
            }
        }
    }

    fn clear(&mut self) {
        self.keys.clear();
        self.table.clear();
    }
}

/// What the measurements reader keeps per sensor.
#[derive(Debug, Clone, Copy, Default)]
struct SensorSlot {
    /// The kind sensors.csv gives it.
    kind: Option<SensorKind>,
    /// Its time in the current scan.
    scan_time: Option<f64>,
    /// Its time in its latest scan, with the scan and a line of it.
    last: Option<(f64, u32, u64)>,
}

/// Per-sensor state by sensor id: a vector of slots, a map from id to slot, and the
/// slot of the previous row, asked first (a scan's rows of one sensor come together, so
/// most rows need no lookup at all). Hand-written: the hint is what makes it cheaper than
/// a map lookup per row.
#[derive(Debug, Default)]
struct SensorSlots {
    ids: Vec<Id>,
    slots: Vec<SensorSlot>,
    index: HashMap<Id, usize>,
    hint: usize,
}

impl SensorSlots {
    /// The slot of sensor `id`; a new one when `insert` and the sensor has none yet.
    #[inline]
    fn get(&mut self, id: Id, insert: bool) -> Option<&mut SensorSlot> {
        if self.ids.get(self.hint) != Some(&id) {
            self.hint = match self.index.get(&id) {
                Some(&i) => i,
                None if insert => {
                    self.index.insert(id, self.ids.len());
                    self.ids.push(id);
                    self.slots.push(SensorSlot::default());
                    self.ids.len() - 1
                }
                None => return None,
            };
        }
        self.slots.get_mut(self.hint)
    }
}

impl MeasurementRows {
    /// The checks of a row whose time, sensor and kind are read: the sensor (known, of
    /// that kind), then `cells` (the value and target id, read after the sensor's
    /// checks, so that a row's first problem is named as before), one time per sensor
    /// and scan, no duplicate, time not going backwards per sensor.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn check(
        &mut self,
        meta: &Meta,
        line: u64,
        scan: u32,
        time: f64,
        sensor_id: Id,
        kind: SensorKind,
        cells: impl FnOnce() -> Result<(Vec2, Id), InputError>,
    ) -> Result<Measurement, InputError> {
        let Some(slot) = self.sensors.get(sensor_id, !self.known_sensors) else {
            return Err(meta.err(
                line,
                self.c_sid,
                format!("sensor_id {sensor_id} is not in sensors.csv"),
            ));
        };
        if let Some(sk) = slot.kind.filter(|&sk| sk != kind) {
            return Err(meta.err(
                line,
                self.c_sid,
                format!(
                    "sensor {sensor_id} is a {} sensor but this row has {} cells",
                    sk.as_str(),
                    kind.as_str()
                ),
            ));
        }
        let (value, target_id) = cells()?;
        match slot.scan_time {
            Some(t0) if t0 != time => {
                return Err(meta.err(
                    line,
                    self.c_time,
                    format!("scan {scan} of sensor {sensor_id} has two times: {t0} and {time}"),
                ))
            }
            Some(_) => {}
            None => slot.scan_time = Some(time),
        }
        match self
            .seen
            .insert((sensor_id, value[0].to_bits(), value[1].to_bits()))
        {
            Seen::New => {}
            Seen::Again => {
                return Err(InputError::line(
                    &meta.path,
                    line,
                    "duplicate row (same scan, sensor and measurement as an earlier row)",
                ))
            }
            Seen::Full => {
                return Err(InputError::line(
                    &meta.path,
                    line,
                    "more than 4294967295 rows in one scan",
                ))
            }
        }
        // time must not go backwards as the scan index grows, per sensor
        if let Some((t_prev, s_prev, l_prev)) = slot.last {
            if s_prev != scan && time < t_prev {
                return Err(meta.err(
                    line,
                    self.c_time,
                    format!(
                        "time goes backwards for sensor {sensor_id}: scan {scan} at {time} but \
                         an earlier scan (line {l_prev}) at {t_prev}"
                    ),
                ));
            }
        }
        slot.last = Some((time, scan, line));
        Ok(Measurement {
            scan,
            time,
            sensor_id,
            kind,
            value,
            target_id,
        })
    }

    /// The fast path for any column order: each cell read by its column's [`Role`].
    #[inline]
    fn parse_line_roles(&mut self, b: &[u8]) -> Option<(usize, Option<u32>, f64)> {
        let mut r = KeptRow {
            target_id: -1,
            ..KeptRow::default()
        };
        let mut scan = None;
        let last = self.roles.len().checked_sub(1)?;
        let mut p = 0;
        for (i, &role) in self.roles.iter().enumerate() {
            let rest = b.get(p..)?;
            let n = match role {
                Role::Scan => {
                    let (v, n) = int_prefix(rest)?;
                    scan = Some(u32::try_from(v).ok()?);
                    n
                }
                Role::Sensor => {
                    let (v, n) = int_prefix(rest)?;
                    r.sensor_id = v;
                    n
                }
                Role::Target => {
                    if empty_cell(rest) {
                        0
                    } else {
                        let (v, n) = int_prefix(rest)?;
                        r.target_id = v;
                        n
                    }
                }
                Role::Time => {
                    let (v, n) = self.time.prefix(rest)?;
                    r.time = v;
                    n
                }
                Role::Range | Role::Bearing | Role::X | Role::Y => {
                    if empty_cell(rest) {
                        0
                    } else {
                        let (v, n) = float_prefix(rest)?;
                        *match role {
                            Role::Range => &mut r.range,
                            Role::Bearing => &mut r.bearing,
                            Role::X => &mut r.x,
                            _ => &mut r.y,
                        } = Some(v);
                        n
                    }
                }
                Role::Other => {
                    let n = memchr::memchr3(b',', b'\n', b'"', rest)?;
                    if rest[..n].contains(&b'\r') {
                        return None;
                    }
                    n
                }
            };
            p += n;
            let end = if i == last { b'\n' } else { b',' };
            if *b.get(p)? != end {
                return None;
            }
            p += 1;
        }
        // exactly the two cells of one kind, both numbers (any other row, valid or
        // not, is the general path's)
        match (r.range, r.bearing, r.x, r.y) {
            (Some(_), Some(_), None, None) | (None, None, Some(_), Some(_)) => {}
            _ => return None,
        }
        self.kept = r;
        Some((p - 1, scan, r.time))
    }

    /// The fast path for the layout this project writes for one sensor kind,
    /// `scan,time,sensor_id,A,B,target_id` (`A,B` = `range,bearing` or `x,y`), cell
    /// after cell without the per-column dispatch of [`MeasurementRows::parse_line_roles`]
    /// (a tenth of a measurement row's parsing). It returns what that function returns
    /// for every input (test `six_column_path_is_the_role_path`): an empty `A` or `B`
    /// cell, which that function reads and then refuses (a row needs both cells of its
    /// kind), is refused here at once.
    #[inline]
    fn parse_line_six(&mut self, b: &[u8], kind: SensorKind) -> Option<(usize, Option<u32>, f64)> {
        /// The position after the field end `c` expected at `p`.
        #[inline(always)]
        fn end(b: &[u8], p: usize, c: u8) -> Option<usize> {
            (*b.get(p)? == c).then_some(p + 1)
        }
        let (scan, n) = int_prefix(b)?;
        let scan = u32::try_from(scan).ok()?;
        let p = end(b, n, b',')?;
        let (time, n) = self.time.prefix(b.get(p..)?)?;
        let p = end(b, p + n, b',')?;
        let (sensor_id, n) = int_prefix(b.get(p..)?)?;
        let p = end(b, p + n, b',')?;
        let (a, n) = float_prefix(b.get(p..)?)?;
        let p = end(b, p + n, b',')?;
        let (c, n) = float_prefix(b.get(p..)?)?;
        let p = end(b, p + n, b',')?;
        let rest = b.get(p..)?;
        let (target_id, n) = if empty_cell(rest) {
            (-1, 0)
        } else {
            int_prefix(rest)?
        };
        let p = p + n;
        end(b, p, b'\n')?;
        let (range, bearing, x, y) = match kind {
            SensorKind::RangeBearing => (Some(a), Some(c), None, None),
            SensorKind::Position => (None, None, Some(a), Some(c)),
        };
        self.kept = KeptRow {
            time,
            sensor_id,
            range,
            bearing,
            x,
            y,
            target_id,
        };
        Some((p, Some(scan), time))
    }

    /// Never: the fast path keeps only rows with the cells of one kind.
    #[cold]
    fn kept_none(&self, meta: &Meta, line: u64) -> Result<Measurement, InputError> {
        Err(InputError::line(
            &meta.path,
            line,
            "internal error: fast path kept a row without measurement cells",
        ))
    }
}

impl ScanRows for MeasurementRows {
    type Item = Measurement;
    fn scan_col(&self) -> Option<usize> {
        self.c_scan
    }
    fn time_col(&self) -> usize {
        self.c_time
    }
    fn start_scan(&mut self) {
        self.seen.clear();
        for slot in &mut self.sensors.slots {
            slot.scan_time = None;
        }
    }
    fn parse(&mut self, row: &Row<'_>, scan: u32) -> Result<Measurement, InputError> {
        let time = self.time.get(row, self.c_time)?;
        let sensor_id = row.int(self.c_sid)?;
        let has_rb = self
            .rb_cols
            .is_some_and(|(r, b)| !row.is_empty(r) || !row.is_empty(b));
        let has_pos = self
            .pos_cols
            .is_some_and(|(x, y)| !row.is_empty(x) || !row.is_empty(y));
        let kind = match (has_rb, has_pos) {
            (true, false) => SensorKind::RangeBearing,
            (false, true) => SensorKind::Position,
            (true, true) => return Err(InputError::line(
                &row.table.path,
                row.line,
                "row has both range/bearing and x/y cells; fill only those of the sensor's kind",
            )),
            (false, false) => {
                return Err(InputError::line(
                    &row.table.path,
                    row.line,
                    "row has no measurement cells",
                ))
            }
        };
        let (rb_cols, pos_cols, c_tid) = (self.rb_cols, self.pos_cols, self.c_tid);
        self.check(row.table, row.line, scan, time, sensor_id, kind, || {
            let value = match kind {
                SensorKind::RangeBearing => {
                    let (cr, cb) = rb_cols.unwrap_or((0, 0));
                    let r = row.nonneg(cr)?;
                    Vec2::new(r, wrap_angle(row.f64(cb)?))
                }
                SensorKind::Position => {
                    let (cx, cy) = pos_cols.unwrap_or((0, 0));
                    Vec2::new(row.f64(cx)?, row.f64(cy)?)
                }
            };
            let target_id = match c_tid {
                Some(c) if !row.is_empty(c) => row.int(c)?,
                _ => -1,
            };
            Ok((value, target_id))
        })
    }
    fn parse_line(&mut self, b: &[u8]) -> Option<(usize, Option<u32>, f64)> {
        #[cfg(test)]
        if NO_FAST.get() {
            return None;
        }
        #[cfg(test)]
        if NO_SIX.get() {
            return self.parse_line_roles(b);
        }
        match self.six {
            Some(kind) => self.parse_line_six(b, kind),
            None => self.parse_line_roles(b),
        }
    }
    fn parse_kept(&mut self, meta: &Meta, line: u64, scan: u32) -> Result<Measurement, InputError> {
        let r = self.kept;
        let (kind, a, b) = match (r.range, r.bearing, r.x, r.y) {
            (Some(a), Some(b), _, _) => (SensorKind::RangeBearing, a, b),
            (_, _, Some(a), Some(b)) => (SensorKind::Position, a, b),
            _ => return self.kept_none(meta, line),
        };
        let c_range = self.rb_cols.map_or(0, |c| c.0);
        self.check(meta, line, scan, r.time, r.sensor_id, kind, || {
            let value = match kind {
                SensorKind::RangeBearing => {
                    if a < 0.0 {
                        return Err(meta.err(line, c_range, format!("{a} must not be negative")));
                    }
                    Vec2::new(a, wrap_angle(b))
                }
                SensorKind::Position => Vec2::new(a, b),
            };
            Ok((value, r.target_id))
        })
    }
    /// Stable by sensor: the file's order within a sensor is kept.
    fn order(rows: &mut [(Measurement, u64)]) {
        rows.sort_by_key(|(m, _)| m.sensor_id);
    }
    fn in_order(rows: &[Measurement]) -> bool {
        rows.is_sorted_by_key(|m| m.sensor_id)
    }
}

scan_stream!(
    /// `measurements.csv`, one scan at a time, each scan's rows stable-sorted by
    /// `sensor_id` (the file's order within a sensor is kept). When sensors are given,
    /// every `sensor_id` must be one of them and each row must carry the cells of its
    /// sensor's kind. One sensor's rows of one scan share one time, and a sensor's time
    /// must not go backwards from scan to scan. The `target_id` column is read for
    /// evaluation; trackers must not use it. Without a `scan` column the rows must be in
    /// non-decreasing time order, and each batch is the rows of one time, numbered
    /// 0, 1, 2, ... (a sensor's rows with one time are one of its scans).
    MeasurementStream,
    MeasurementRows,
    Measurement
);

impl MeasurementStream<File> {
    pub fn open(path: &Path, sensors: Option<&[Sensor]>) -> Result<Self, InputError> {
        Self::from_reader(open_file(path)?, path, sensors)
    }
}

impl<R: Read> MeasurementStream<R> {
    /// The stream over any input; `path` names it in messages.
    pub fn from_reader(
        reader: R,
        path: impl AsRef<Path>,
        sensors: Option<&[Sensor]>,
    ) -> Result<Self, InputError> {
        let path = path.as_ref();
        let t = Table::new(reader, path)?;
        let c_scan = t.opt("scan");
        let c_time = t.col("time")?;
        let c_sid = t.col("sensor_id")?;
        let rb_cols = t.opt("range").zip(t.opt("bearing"));
        let pos_cols = t.opt("x").zip(t.opt("y"));
        if rb_cols.is_none() && pos_cols.is_none() {
            return Err(InputError {
                file: path.to_path_buf(),
                line: Some(t.meta.header_line),
                column: None,
                column_name: Some("range,bearing / x,y".into()),
                reason: "missing measurement columns: need range and bearing, or x and y".into(),
            });
        }
        let roles = {
            let mut roles = vec![Role::Other; t.meta.headers.len()];
            let mut set = |c: Option<usize>, role| {
                if let Some(c) = c {
                    roles[c] = role;
                }
            };
            set(c_scan, Role::Scan);
            set(Some(c_time), Role::Time);
            set(Some(c_sid), Role::Sensor);
            set(rb_cols.map(|c| c.0), Role::Range);
            set(rb_cols.map(|c| c.1), Role::Bearing);
            set(pos_cols.map(|c| c.0), Role::X);
            set(pos_cols.map(|c| c.1), Role::Y);
            set(t.opt("target_id"), Role::Target);
            roles
        };
        // the layout this project writes, read in a straight line (`parse_line_six`)
        let six = {
            use Role::*;
            match roles[..] {
                [Scan, Time, Sensor, Range, Bearing, Target] => Some(SensorKind::RangeBearing),
                [Scan, Time, Sensor, X, Y, Target] => Some(SensorKind::Position),
                _ => None,
            }
        };
        let rows = MeasurementRows {
            c_scan,
            c_time,
            c_sid,
            rb_cols,
            pos_cols,
            c_tid: t.opt("target_id"),
            known_sensors: sensors.is_some(),
            sensors: {
                let mut slots = SensorSlots::default();
                for s in sensors.unwrap_or(&[]) {
                    if let Some(slot) = slots.get(s.id, true) {
                        slot.kind = Some(s.kind);
                    }
                }
                slots
            },
            seen: SeenKeys::default(),
            time: RepeatedF64::default(),
            roles,
            six,
            kept: KeptRow::default(),
        };
        Ok(MeasurementStream(ScanReader::new(t, rows)))
    }
}

/// Read `measurements.csv` (see [`MeasurementStream`]): rows in scan order, each scan
/// stable-sorted by `sensor_id`.
pub fn read_measurements(
    path: &Path,
    sensors: Option<&[Sensor]>,
) -> Result<Vec<Measurement>, InputError> {
    MeasurementStream::open(path, sensors)?.collect_rows()
}

/// [`read_measurements`] from any input; `path` names it in messages.
pub fn read_measurements_from<R: Read>(
    reader: R,
    path: impl AsRef<Path>,
    sensors: Option<&[Sensor]>,
) -> Result<Vec<Measurement>, InputError> {
    MeasurementStream::from_reader(reader, path, sensors)?.collect_rows()
}

// ---------------------------------------------------------------- local_tracks.csv

struct LocalTrackRows {
    c_scan: Option<usize>,
    c_time: usize,
    c_sid: usize,
    c_tid: usize,
    sc: StateCols,
    /// `(sensor, track)` of the current scan and its line, once the scan's rows are
    /// out of `(sensor, track)` order ([`LocalTrackRows::ascending`]).
    seen: HashMap<(Id, Id), u64>,
    /// While the current scan's keys have been strictly increasing (files this project
    /// writes: always), they are distinct by that alone: the keys and lines go here
    /// instead of `seen`, a push rather than a hash per row, and move into `seen` at the
    /// first key that does not increase (so the same row fails, with the same message).
    ascending: Vec<((Id, Id), u64)>,
    /// Whether the current scan's keys are still strictly increasing.
    in_order: bool,
    last: HashMap<(Id, Id), (f64, u64)>,
    time: RepeatedF64,
}

impl LocalTrackRows {
    /// Record `key` at `line` for the current scan; the line of an earlier row of this
    /// scan with the same key, if any.
    #[inline]
    fn see(&mut self, key: (Id, Id), line: u64) -> Option<u64> {
        if self.in_order {
            if self.ascending.last().is_none_or(|&(k, _)| k < key) {
                self.ascending.push((key, line));
                return None;
            }
            self.in_order = false;
            self.seen.extend(self.ascending.drain(..));
        }
        self.seen.insert(key, line)
    }
}

impl ScanRows for LocalTrackRows {
    type Item = LocalTrack;
    fn scan_col(&self) -> Option<usize> {
        self.c_scan
    }
    fn time_col(&self) -> usize {
        self.c_time
    }
    fn start_scan(&mut self) {
        self.seen.clear();
        self.ascending.clear();
        self.in_order = true;
    }
    fn parse(&mut self, row: &Row<'_>, scan: u32) -> Result<LocalTrack, InputError> {
        let time = self.time.get(row, self.c_time)?;
        let sensor_id = row.int(self.c_sid)?;
        let track_id = row.int(self.c_tid)?;
        if let Some(prev) = self.see((sensor_id, track_id), row.line) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!("duplicate row: scan {scan}, sensor {sensor_id}, track {track_id} already on line {prev}"),
            ));
        }
        check_time(
            row,
            self.c_time,
            &mut self.last,
            (sensor_id, track_id),
            time,
        )?;
        let (state, cov) = self.sc.read(row)?;
        Ok(LocalTrack {
            scan,
            time,
            sensor_id,
            track_id,
            state,
            cov,
        })
    }
    fn order(rows: &mut [(LocalTrack, u64)]) {
        rows.sort_by_key(|(l, _)| (l.sensor_id, l.track_id));
    }
    fn in_order(rows: &[LocalTrack]) -> bool {
        rows.is_sorted_by_key(|l| (l.sensor_id, l.track_id))
    }
}

scan_stream!(
    /// `local_tracks.csv`, one scan at a time, each scan's rows sorted by
    /// `(sensor_id, track_id)`. A `(sensor_id, track_id)` appears once per scan; time
    /// must not go backwards within one `(sensor_id, track_id)`. Without a `scan` column
    /// the rows must be in non-decreasing time order, and each batch is the rows of one
    /// time, numbered 0, 1, 2, ... (so a track's time strictly increases).
    LocalTrackStream,
    LocalTrackRows,
    LocalTrack
);

impl LocalTrackStream<File> {
    pub fn open(path: &Path) -> Result<Self, InputError> {
        Self::from_reader(open_file(path)?, path)
    }
}

impl<R: Read> LocalTrackStream<R> {
    /// The stream over any input; `path` names it in messages.
    pub fn from_reader(reader: R, path: impl AsRef<Path>) -> Result<Self, InputError> {
        let t = Table::new(reader, path.as_ref())?;
        let rows = LocalTrackRows {
            c_scan: t.opt("scan"),
            c_time: t.col("time")?,
            c_sid: t.col("sensor_id")?,
            c_tid: t.col("track_id")?,
            sc: StateCols::find(&t)?,
            seen: HashMap::default(),
            ascending: Vec::new(),
            in_order: true,
            last: HashMap::default(),
            time: RepeatedF64::default(),
        };
        Ok(LocalTrackStream(ScanReader::new(t, rows)))
    }
}

/// Read `local_tracks.csv` (see [`LocalTrackStream`]): rows sorted by
/// `(scan, sensor_id, track_id)`.
pub fn read_local_tracks(path: &Path) -> Result<Vec<LocalTrack>, InputError> {
    LocalTrackStream::open(path)?.collect_rows()
}

/// [`read_local_tracks`] from any input; `path` names it in messages.
pub fn read_local_tracks_from<R: Read>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<LocalTrack>, InputError> {
    LocalTrackStream::from_reader(reader, path)?.collect_rows()
}

// ---------------------------------------------------------------- fused_tracks.csv

struct FusedTrackRows {
    c_scan: Option<usize>,
    c_time: usize,
    c_fid: usize,
    c_n: usize,
    c_src: Option<usize>,
    c_status: Option<usize>,
    sc: StateCols,
    /// `fused_id`s of the current scan and their lines.
    seen: HashMap<Id, u64>,
    last: HashMap<Id, (f64, u64)>,
}

impl ScanRows for FusedTrackRows {
    type Item = FusedTrack;
    fn scan_col(&self) -> Option<usize> {
        self.c_scan
    }
    fn time_col(&self) -> usize {
        self.c_time
    }
    fn start_scan(&mut self) {
        self.seen.clear();
    }
    fn parse(&mut self, row: &Row<'_>, scan: u32) -> Result<FusedTrack, InputError> {
        let time = row.f64(self.c_time)?;
        let fused_id = row.int(self.c_fid)?;
        if let Some(prev) = self.seen.insert(fused_id, row.line) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!("duplicate row: scan {scan}, fused_id {fused_id} already on line {prev}"),
            ));
        }
        check_time(row, self.c_time, &mut self.last, fused_id, time)?;
        let (state, cov) = self.sc.read(row)?;
        let n = row.int(self.c_n)?;
        if n < 0 {
            return Err(row.err(self.c_n, "n_sources must not be negative"));
        }
        let mut sources = Vec::new();
        if let Some(c) = self.c_src {
            let s = row.raw(c)?;
            if !s.is_empty() {
                for part in s.split('|') {
                    let parsed = part.split_once(':').and_then(|(a, b)| {
                        Some((a.trim().parse::<Id>().ok()?, b.trim().parse::<Id>().ok()?))
                    });
                    match parsed {
                        Some(p) => sources.push(p),
                        None => {
                            return Err(
                                row.err(c, format!("'{part}' is not a sensor:track_id pair"))
                            )
                        }
                    }
                }
                if sources.len() as i64 != n {
                    return Err(row.err(
                        c,
                        format!("{} sources listed but n_sources is {n}", sources.len()),
                    ));
                }
            }
        }
        // optional; `confirmed` when absent
        let status = match self.c_status {
            Some(c) => {
                let s = row.raw(c)?;
                TrackStatus::parse(s.trim()).ok_or_else(|| {
                    row.err(
                        c,
                        format!("'{s}' is not a status (expected tentative or confirmed)"),
                    )
                })?
            }
            None => TrackStatus::Confirmed,
        };
        Ok(FusedTrack {
            scan,
            time,
            fused_id,
            state,
            cov,
            sources,
            status,
        })
    }
    fn order(rows: &mut [(FusedTrack, u64)]) {
        rows.sort_by_key(|(f, _)| f.fused_id);
    }
    fn in_order(rows: &[FusedTrack]) -> bool {
        rows.is_sorted_by_key(|f| f.fused_id)
    }
}

scan_stream!(
    /// `fused_tracks.csv`, one scan at a time, each scan's rows sorted by `fused_id`. A
    /// `fused_id` appears once per scan; time must not go backwards within one
    /// `fused_id`.
    FusedTrackStream,
    FusedTrackRows,
    FusedTrack
);

impl FusedTrackStream<File> {
    pub fn open(path: &Path) -> Result<Self, InputError> {
        Self::from_reader(open_file(path)?, path)
    }
}

impl<R: Read> FusedTrackStream<R> {
    /// The stream over any input; `path` names it in messages.
    pub fn from_reader(reader: R, path: impl AsRef<Path>) -> Result<Self, InputError> {
        let t = Table::new(reader, path.as_ref())?;
        let rows = FusedTrackRows {
            c_scan: Some(t.col("scan")?),
            c_time: t.col("time")?,
            c_fid: t.col("fused_id")?,
            c_n: t.col("n_sources")?,
            c_src: t.opt("sources"),
            c_status: t.opt("status"),
            sc: StateCols::find(&t)?,
            seen: HashMap::default(),
            last: HashMap::default(),
        };
        Ok(FusedTrackStream(ScanReader::new(t, rows)))
    }
}

/// Read `fused_tracks.csv` (see [`FusedTrackStream`]): rows sorted by `(scan, fused_id)`.
pub fn read_fused_tracks(path: &Path) -> Result<Vec<FusedTrack>, InputError> {
    FusedTrackStream::open(path)?.collect_rows()
}

/// [`read_fused_tracks`] from any input; `path` names it in messages.
pub fn read_fused_tracks_from<R: Read>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<FusedTrack>, InputError> {
    FusedTrackStream::from_reader(reader, path)?.collect_rows()
}

// ---------------------------------------------------------------- associations.csv

struct AssociationRows {
    c_scan: Option<usize>,
    c_sid: usize,
    c_tid: usize,
    c_fid: usize,
    /// `(sensor, track)` of the current scan and its line.
    seen: HashMap<(Id, Id), u64>,
}

impl ScanRows for AssociationRows {
    type Item = Association;
    fn scan_col(&self) -> Option<usize> {
        self.c_scan
    }
    fn time_col(&self) -> usize {
        // the scan column is required: never read for the time rule
        self.c_sid
    }
    fn start_scan(&mut self) {
        self.seen.clear();
    }
    fn parse(&mut self, row: &Row<'_>, scan: u32) -> Result<Association, InputError> {
        let a = Association {
            scan,
            sensor_id: row.int(self.c_sid)?,
            track_id: row.int(self.c_tid)?,
            fused_id: row.int(self.c_fid)?,
        };
        if let Some(prev) = self.seen.insert((a.sensor_id, a.track_id), row.line) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!(
                    "duplicate row: scan {}, sensor {}, track {} already on line {prev}",
                    a.scan, a.sensor_id, a.track_id
                ),
            ));
        }
        Ok(a)
    }
    fn order(rows: &mut [(Association, u64)]) {
        rows.sort_by_key(|(a, _)| *a);
    }
    fn in_order(rows: &[Association]) -> bool {
        rows.is_sorted()
    }
}

scan_stream!(
    /// `associations.csv`, one scan at a time, each scan's rows sorted by
    /// `(sensor_id, track_id)`. A `(sensor_id, track_id)` appears once per scan.
    AssociationStream,
    AssociationRows,
    Association
);

impl AssociationStream<File> {
    pub fn open(path: &Path) -> Result<Self, InputError> {
        Self::from_reader(open_file(path)?, path)
    }
}

impl<R: Read> AssociationStream<R> {
    /// The stream over any input; `path` names it in messages.
    pub fn from_reader(reader: R, path: impl AsRef<Path>) -> Result<Self, InputError> {
        let t = Table::new(reader, path.as_ref())?;
        let rows = AssociationRows {
            c_scan: Some(t.col("scan")?),
            c_sid: t.col("sensor_id")?,
            c_tid: t.col("track_id")?,
            c_fid: t.col("fused_id")?,
            seen: HashMap::default(),
        };
        Ok(AssociationStream(ScanReader::new(t, rows)))
    }
}

/// Read `associations.csv` (see [`AssociationStream`]): rows sorted.
pub fn read_associations(path: &Path) -> Result<Vec<Association>, InputError> {
    AssociationStream::open(path)?.collect_rows()
}

/// [`read_associations`] from any input; `path` names it in messages.
pub fn read_associations_from<R: Read>(
    reader: R,
    path: impl AsRef<Path>,
) -> Result<Vec<Association>, InputError> {
    AssociationStream::from_reader(reader, path)?.collect_rows()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Cells over the characters of numbers, signs, exponents and the words std also
    /// accepts (`inf`, `infinity`, `nan`), so most are near misses of a number.
    fn numberish() -> impl Strategy<Value = String> {
        prop::collection::vec(
            prop::sample::select(vec![
                '0', '1', '5', '9', '.', '-', '+', 'e', 'E', 'i', 'n', 'f', 'a', 't', 'y', 'I',
                'N', '_', 'x',
            ]),
            0..24,
        )
        .prop_map(|c| c.into_iter().collect())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20000))]

        /// Wherever the fast float parser accepts a cell, `str::parse` accepts it too and
        /// gives the same bits (the reader falls back to `str::parse` elsewhere).
        #[test]
        fn fast_float_parse_is_std_parse(s in numberish()) {
            if let Ok(v) = fast_float2::parse::<f64, _>(s.as_bytes()) {
                let std = s.parse::<f64>();
                prop_assert!(std.is_ok(), "fast accepts {s:?}, std does not");
                let w = std.unwrap_or(0.0);
                prop_assert!(v.to_bits() == w.to_bits() || (v.is_nan() && w.is_nan()), "{s:?}: {v} vs {w}");
            }
        }

        /// Numbers as writers and other tools print them: every f64 in shortest form,
        /// in `{:e}` form and with 17 significant digits, parse to the same bits.
        #[test]
        fn fast_float_parse_of_printed_numbers(bits in any::<u64>()) {
            let v = f64::from_bits(bits);
            prop_assume!(v.is_finite());
            let mut ryu = ryu::Buffer::new();
            for s in [ryu.format(v).to_string(), format!("{v:e}"), format!("{v:.17e}"), format!("{v}")] {
                let fast = fast_float2::parse::<f64, _>(s.as_bytes());
                prop_assert_eq!(fast.ok().map(f64::to_bits), s.parse::<f64>().ok().map(f64::to_bits), "{}", s);
            }
        }

        /// The hand-written integer fast path gives `str::parse`'s value wherever it
        /// answers.
        #[test]
        fn small_int_is_std_parse(s in prop::collection::vec(
            prop::sample::select(vec!['0', '1', '7', '9', '-', '+', ' ', 'x']), 0..22
        ).prop_map(|c| c.into_iter().collect::<String>()), v in any::<i64>()) {
            if let Some(fast) = small_int(s.as_bytes()) {
                prop_assert_eq!(Some(fast), s.parse::<i64>().ok());
            }
            let t = v.to_string();
            if t.trim_start_matches('-').len() <= 18 {
                prop_assert_eq!(small_int(t.as_bytes()), Some(v));
            }
        }
    }

    /// An input handing out at most `chunk` bytes per read (0: all at once).
    struct Chunks(std::io::Cursor<Vec<u8>>, usize);

    impl Read for Chunks {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = if self.1 == 0 {
                buf.len()
            } else {
                self.1.min(buf.len())
            };
            self.0.read(&mut buf[..n])
        }
    }

    /// Everything a stream returns (each scan's rows and lines, then the error or the
    /// end), as text; with `csv_only` every data row read by the csv crate.
    fn stream_all(text: &[u8], chunk: usize, local: bool, csv_only: bool) -> String {
        CSV_ONLY.set(csv_only);
        let input = Chunks(std::io::Cursor::new(text.to_vec()), chunk);
        let mut out = String::new();
        macro_rules! drain {
            ($open:expr) => {
                match $open {
                    Err(e) => out.push_str(&format!("open: {e:?}")),
                    Ok(mut s) => {
                        let mut buf = Vec::new();
                        loop {
                            match s.next_scan(&mut buf) {
                                Ok(Some(scan)) => out.push_str(&format!(
                                    "scan {scan}: {buf:?} lines {:?}\n",
                                    s.lines()
                                )),
                                Ok(None) => break,
                                Err(e) => {
                                    out.push_str(&format!("error: {e:?} / {e}"));
                                    break;
                                }
                            }
                        }
                    }
                }
            };
        }
        if local {
            drain!(LocalTrackStream::from_reader(input, "local_tracks.csv"));
        } else {
            drain!(MeasurementStream::from_reader(
                input,
                "measurements.csv",
                None
            ));
        }
        CSV_ONLY.set(false);
        out
    }

    /// A CSV text: a header, then rows of valid cells, some replaced by near misses
    /// (quotes, commas, CR, LF, blanks, junk), joined by any line terminator.
    fn csv_text(local: bool) -> impl Strategy<Value = Vec<u8>> {
        let cell = prop_oneof![
            8 => Just(None),
            1 => prop::collection::vec(
                prop::sample::select(vec![
                    "0", "1", "-", ".", "e", " ", "\"", ",", "\r", "\n", "x", "\"\"", "7.5",
                ]),
                0..4,
            )
            .prop_map(|v| Some(v.concat())),
        ];
        let n = if local { 24 } else { 6 };
        let row = (
            0u32..3,
            0i64..3,
            0i64..4,
            1.0f64..1e5,
            -3.0f64..3.0,
            prop::collection::vec(cell, n),
            prop::sample::select(vec![
                "\n", "\n", "\n", "\n", "\r\n", "\r", "\n\n", "", " \n",
            ]),
        );
        (
            prop::collection::vec(row, 0..40),
            any::<bool>(),
            any::<bool>(),
        )
            .prop_map(move |(rows, crlf_header, last_terminator)| {
                let mut text = if local {
                    crate::io::LocalTrackWriter::<Vec<u8>>::header()
                } else {
                    "scan,time,sensor_id,range,bearing,target_id".to_string()
                };
                text.push_str(if crlf_header { "\r\n" } else { "\n" });
                let mut scan = 0;
                let count = rows.len();
                for (k, (step, sensor, id, a, b, junk, end)) in rows.into_iter().enumerate() {
                    scan += step / 2;
                    let mut cells: Vec<String> = if local {
                        let mut c = vec![
                            scan.to_string(),
                            format!("{scan}.0"),
                            sensor.to_string(),
                            id.to_string(),
                            a.to_string(),
                            b.to_string(),
                            (-a).to_string(),
                            "1.5".to_string(),
                        ];
                        for i in 0..16 {
                            c.push(if i % 5 == 0 {
                                format!("{}", a + 1.0)
                            } else {
                                "0.0".into()
                            });
                        }
                        c
                    } else {
                        vec![
                            scan.to_string(),
                            format!("{scan}.0"),
                            sensor.to_string(),
                            a.to_string(),
                            b.to_string(),
                            id.to_string(),
                        ]
                    };
                    for (c, j) in cells.iter_mut().zip(junk) {
                        if let Some(j) = j {
                            *c = j;
                        }
                    }
                    text.push_str(&cells.join(","));
                    if k + 1 < count || last_terminator {
                        text.push_str(end);
                    }
                }
                text.into_bytes()
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1500))]

        /// The plain-line splitter (`io::records`) and the csv crate give the same rows,
        /// lines and located errors, on valid and invalid files, in any read chunking.
        #[test]
        fn plain_lines_split_as_the_csv_crate_splits_them(
            local in any::<bool>(),
            text in csv_text(false),
            ltext in csv_text(true),
            chunk in prop::sample::select(vec![0usize, 1, 3, 17, 64]),
        ) {
            let text = if local { ltext } else { text };
            let plain = stream_all(&text, chunk, local, false);
            let csv = stream_all(&text, chunk, local, true);
            prop_assert_eq!(plain, csv, "{}", String::from_utf8_lossy(&text));
        }
    }

    /// A measurements.csv text for the fast path's test: the header's columns in any
    /// order (scan, target_id, x/y, range/bearing and an unknown column each optional),
    /// rows of valid cells from small value sets (so duplicates, two times per scan and
    /// time going backwards occur) with some cells replaced by near misses of what the
    /// fast path reads (blanks, signs, exponents, 19 digits, non-finite words, quotes,
    /// CR, extra commas), LF or CRLF or no terminator.
    fn measurement_text() -> impl Strategy<Value = Vec<u8>> {
        let junk = prop::sample::select(vec![
            "",
            " ",
            " 1",
            "1 ",
            "+1",
            "-1",
            "-0",
            "1e",
            "1e3",
            "1.5e-2",
            "0x1",
            ".5",
            "5.",
            "-",
            "nan",
            "inf",
            "-inf",
            "1e400",
            "1234567890123456789",
            "123456789012345678",
            "-4294967296",
            "4294967296",
            "\"1\"",
            "1\r",
            ",",
            "1,2",
            "\"",
            "é",
            "_1",
        ]);
        let cell = prop_oneof![40 => Just(None), 1 => junk.prop_map(|j| Some(j.to_string()))];
        let row = (
            0u32..3,
            prop::sample::select(vec![0i64, 1, 2, 3]),
            prop_oneof![
                8 => Just(None),
                1 => prop::sample::select(vec!["0.0", "0.5", "1.0", "1", "2.25"]).prop_map(Some),
            ],
            prop_oneof![
                8 => Just(None),
                1 => prop::sample::select(vec![0.0f64, 1.5, 1e5, 14167.515651117861, -2.0]).prop_map(Some),
            ],
            prop::sample::select(vec![0.0f64, -3.0, 0.788787128797067, 7.0, 1e-300]),
            any::<bool>(),
            prop::collection::vec(cell, 9),
            prop::sample::select(vec!["\n", "\n", "\n", "\n", "\r\n", "\n\n"]),
        );
        // any subset in any order (time and sensor_id always), or one of the six-column
        // layouts this project writes (`MeasurementRows::parse_line_six`)
        let shuffled = (
            Just(vec![
                "scan",
                "time",
                "sensor_id",
                "range",
                "bearing",
                "x",
                "y",
                "target_id",
                "is_clutter",
            ])
            .prop_shuffle(),
            prop::collection::vec(any::<bool>(), 9),
        )
            .prop_map(|(cols, keep)| {
                cols.into_iter()
                    .zip(keep)
                    .filter(|(c, k)| *k || *c == "time" || *c == "sensor_id")
                    .map(|(c, _)| c)
                    .collect::<Vec<&str>>()
            });
        let columns = prop_oneof![
            2 => shuffled,
            1 => Just(vec!["scan", "time", "sensor_id", "range", "bearing", "target_id"]),
            1 => Just(vec!["scan", "time", "sensor_id", "x", "y", "target_id"]),
        ];
        (columns, prop::collection::vec(row, 0..40), any::<bool>()).prop_map(
            |(cols, rows, last_terminator)| {
                let mut text = cols.join(",");
                text.push('\n');
                let mut scan = 0;
                let count = rows.len();
                for (k, (step, sensor, time, a, b, pos, junk, end)) in rows.into_iter().enumerate()
                {
                    scan += step / 2;
                    let cells: Vec<String> = cols
                        .iter()
                        .zip(junk)
                        .map(|(c, j)| {
                            j.unwrap_or_else(|| match *c {
                                "scan" => scan.to_string(),
                                // a sensor's scans at its own phase, or a drawn time
                                "time" => time.map_or_else(
                                    || format!("{scan}.{}", sensor * 25),
                                    str::to_string,
                                ),
                                "sensor_id" => sensor.to_string(),
                                "range" if !pos => a.unwrap_or(1000.0 + k as f64 / 3.0).to_string(),
                                "bearing" if !pos => b.to_string(),
                                "x" if pos => a.unwrap_or(k as f64 / 7.0).to_string(),
                                "y" if pos => b.to_string(),
                                "target_id" => (k % 3).to_string(),
                                "is_clutter" => "false".to_string(),
                                _ => String::new(),
                            })
                        })
                        .collect();
                    text.push_str(&cells.join(","));
                    if k + 1 < count || last_terminator {
                        text.push_str(end);
                    }
                }
                text.into_bytes()
            },
        )
    }

    /// Everything a measurement stream returns (as [`stream_all`]), with or without the
    /// fast path, with or without sensors (0 and 2 range-bearing, 1 position).
    fn measurements_all(text: &[u8], chunk: usize, with_sensors: bool, fast: bool) -> String {
        measurements_all_with(text, chunk, with_sensors, fast, true)
    }

    /// [`measurements_all`], with the six-column fast path or without it (`six`: then the
    /// fast path reads every layout by its column roles).
    fn measurements_all_with(
        text: &[u8],
        chunk: usize,
        with_sensors: bool,
        fast: bool,
        six: bool,
    ) -> String {
        NO_FAST.set(!fast);
        NO_SIX.set(!six);
        let sensors: Vec<Sensor> = (0..3)
            .map(|id| Sensor {
                id,
                kind: if id == 1 {
                    SensorKind::Position
                } else {
                    SensorKind::RangeBearing
                },
                x: 0.0,
                y: 0.0,
                sigma_a: 1.0,
                sigma_b: 1.0,
                pd: 1.0,
                bias_r: 0.0,
                bias_theta: 0.0,
                max_range: 0.0,
                clutter_density: None,
            })
            .collect();
        let input = Chunks(std::io::Cursor::new(text.to_vec()), chunk);
        let mut out = String::new();
        match MeasurementStream::from_reader(
            input,
            "measurements.csv",
            with_sensors.then_some(&sensors[..]),
        ) {
            Err(e) => out.push_str(&format!("open: {e:?}")),
            Ok(mut s) => {
                let mut buf = Vec::new();
                loop {
                    match s.next_scan(&mut buf) {
                        Ok(Some(scan)) => out.push_str(&format!(
                            "scan {scan}: {buf:?} lines {:?} rows {}\n",
                            s.lines(),
                            s.rows_read()
                        )),
                        Ok(None) => break,
                        Err(e) => {
                            out.push_str(&format!("error: {e:?} / {e}"));
                            break;
                        }
                    }
                }
            }
        }
        NO_FAST.set(false);
        NO_SIX.set(false);
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]

        /// The fast path of measurements.csv and the general path give the same rows,
        /// lines, row counts and located errors, on valid and invalid files, with any
        /// column order, in any read chunking.
        #[test]
        fn measurement_fast_path_is_the_general_path(
            text in measurement_text(),
            sensors in any::<bool>(),
            chunk in prop::sample::select(vec![0usize, 1, 7, 64]),
        ) {
            let fast = measurements_all(&text, chunk, sensors, true);
            let general = measurements_all(&text, chunk, sensors, false);
            prop_assert_eq!(fast, general, "{}", String::from_utf8_lossy(&text));
        }

        /// [`SeenKeys`] answers as a hash set of the keys, across clears.
        #[test]
        fn seen_keys_is_a_hash_set(
            ops in prop::collection::vec(
                prop_oneof![
                    20 => (0i64..3, 0u64..6, prop::sample::select(vec![0u64, 1, u64::MAX]))
                        .prop_map(Some),
                    1 => Just(None),
                ],
                0..400,
            ),
        ) {
            let mut seen = SeenKeys::default();
            let mut set = HashSet::default();
            for op in ops {
                match op {
                    Some(key) => {
                        let want = if set.insert(key) { Seen::New } else { Seen::Again };
                        prop_assert_eq!(seen.insert(key), want);
                    }
                    None => {
                        seen.clear();
                        set.clear();
                    }
                }
            }
        }

        /// The six-column fast path and the fast path by column roles return the same
        /// for every line: the same rows, lines and errors from the stream, and
        /// `parse_line` the same length, scan, time and kept values line by line.
        #[test]
        fn six_column_path_is_the_role_path(
            text in measurement_text(),
            sensors in any::<bool>(),
            chunk in prop::sample::select(vec![0usize, 1, 7, 64]),
        ) {
            let six = measurements_all_with(&text, chunk, sensors, true, true);
            let roles = measurements_all_with(&text, chunk, sensors, true, false);
            prop_assert_eq!(six, roles, "{}", String::from_utf8_lossy(&text));
            let s = MeasurementStream::from_reader(&text[..], "m.csv", None);
            if let Ok(MeasurementStream(mut r)) = s {
                if let Some(kind) = r.rows.six {
                    let body = &text[text.iter().position(|&c| c == b'\n').map_or(text.len(), |i| i + 1)..];
                    for start in 0..body.len() {
                        let line = &body[start..];
                        let a = r.rows.parse_line_six(line, kind);
                        let kept_six = format!("{:?}", r.rows.kept);
                        let b = r.rows.parse_line_roles(line);
                        let kept_roles = format!("{:?}", r.rows.kept);
                        prop_assert_eq!(a, b);
                        if a.is_some() {
                            prop_assert_eq!(kept_six, kept_roles);
                        }
                    }
                }
            }
        }
    }

    /// A file larger than the splitter's buffer, read in odd chunks, with a quote late
    /// in it: the same rows and lines as the csv crate's.
    #[test]
    fn plain_lines_across_buffer_refills_and_a_late_switch() {
        let mut text = String::from("scan,time,sensor_id,range,bearing,target_id\n");
        for k in 0..25_000 {
            text.push_str(&format!(
                "{},{}.0,{},{}.25,0.{},{}\n",
                k / 40,
                k / 40,
                k % 4,
                1000 + k,
                k,
                k
            ));
        }
        text.push_str("700,700.0,1,\"5.5\",0.5,1\n700,700.0,1,6.5,0.5,1\n");
        assert!(text.len() > 2 * (1 << 18));
        for chunk in [0, 7, 4096] {
            let plain = stream_all(text.as_bytes(), chunk, false, false);
            assert_eq!(plain, stream_all(text.as_bytes(), chunk, false, true));
            assert!(
                plain.contains("scan 700"),
                "{}",
                &plain[plain.len().saturating_sub(300)..]
            );
        }
    }
}
