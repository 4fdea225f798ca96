//! The data records of a CSV table: a line splitter of our own for the common case,
//! the csv crate for everything else.
//!
//! The files this project reads and writes are plain: one record per `\n`-terminated
//! line, fields split on commas, no quotes, no `\r`. [`Records`] splits such lines itself
//! (memchr over a 256 KiB buffer, one pass per line for the commas and the two bytes
//! that make a line unusual), which costs a fraction of the csv crate's general
//! tokeniser. At the first line that is not plain (a `"` or `\r` anywhere in it, an empty
//! line, a field count that is not the header's) it hands the rest of the input, from
//! the start of that line, to the csv crate for good, so every record and every error
//! from there on are the csv crate's, with lines counted by [`LineCounter`] as before.
//! A plain line splits the same way under both (no quoting, no escapes, no trimming of
//! data cells), which `plain_lines_split_as_the_csv_crate_splits_them` tests.
//!
//! Hand-written because the csv crate has no cheaper mode for unquoted input and no
//! other crate offers a fallback to it mid-stream.

use crate::io::lines::LineCounter;
use crate::io::InputError;
use std::io::{Chain, Cursor, Read};
use std::path::Path;

/// Where the bytes after the header go once the csv crate takes over.
type Rest<R> = Chain<Cursor<Vec<u8>>, R>;

/// The cells of the record last read.
pub(crate) enum Fields<'a> {
    /// A plain line and the end of each field in it (a comma follows every field but
    /// the last).
    Line(&'a [u8], &'a [usize]),
    /// A record read by the csv crate.
    Csv(&'a csv::ByteRecord),
}

impl Fields<'_> {
    /// Field `i`'s bytes, untrimmed.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> Option<&[u8]> {
        match self {
            Fields::Line(line, ends) => {
                let end = *ends.get(i)?;
                let start = if i == 0 { 0 } else { ends[i - 1] + 1 };
                line.get(start..end)
            }
            Fields::Csv(rec) => rec.get(i),
        }
    }
}

/// The plain-line splitter's state.
struct Plain<R> {
    inner: R,
    buf: Vec<u8>,
    /// The unread bytes are `buf[pos..end]`.
    pos: usize,
    end: usize,
    eof: bool,
    /// The line of the next record.
    line: u64,
    /// Whether the byte before `buf[pos]` is a `\r` (only ever at the header's end:
    /// plain lines hold none).
    after_cr: bool,
}

enum Mode<R> {
    Plain(Plain<R>),
    Csv(csv::Reader<LineCounter<Rest<R>>>),
    /// Only while switching.
    Switching,
}

/// The data records of a table whose header has been read.
pub(crate) struct Records<R> {
    mode: Mode<R>,
    /// The header's field count.
    n_fields: usize,
    /// The current plain line is `buf[line.0..line.1]`.
    line: (usize, usize),
    ends: Vec<usize>,
    rec: csv::ByteRecord,
}

/// 256 KiB reads: a 20th of the read calls of 8 KiB ones.
const CAPACITY: usize = 1 << 18;

impl<R: Read> Records<R> {
    /// The records of `inner`, whose bytes `head` (already read from the input) come
    /// first; `line` is the line `head` starts on, `after_cr` whether the byte before
    /// `head` was a `\r`; `n_fields` the header's field count. `plain` false sends
    /// everything to the csv crate (the reference in tests).
    pub(crate) fn new(
        head: Vec<u8>,
        inner: R,
        line: u64,
        after_cr: bool,
        n_fields: usize,
        plain: bool,
    ) -> Self {
        let end = head.len();
        let mut buf = head;
        if buf.len() < CAPACITY {
            buf.resize(CAPACITY, 0);
        }
        let mut records = Records {
            mode: Mode::Plain(Plain {
                inner,
                buf,
                pos: 0,
                end,
                eof: false,
                line,
                after_cr,
            }),
            n_fields,
            line: (0, 0),
            ends: Vec::with_capacity(n_fields),
            rec: csv::ByteRecord::new(),
        };
        if !plain {
            records.switch();
        }
        records
    }

    /// Hand the unread bytes to the csv crate.
    fn switch(&mut self) {
        let Mode::Plain(p) = std::mem::replace(&mut self.mode, Mode::Switching) else {
            return;
        };
        let mut buf = p.buf;
        buf.truncate(p.end);
        buf.drain(..p.pos);
        let lines = LineCounter::resume(
            Cursor::new(buf).chain(p.inner),
            p.line.saturating_sub(1),
            p.after_cr,
        );
        // Data rows only (the header was read), and the field count checked here
        // against the header's, with the csv crate's own message.
        let reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .buffer_capacity(CAPACITY)
            .from_reader(lines);
        self.mode = Mode::Csv(reader);
    }

    /// Read the next record: its 1-based line, or `None` at the end.
    pub(crate) fn next(&mut self, path: &Path) -> Result<Option<u64>, InputError> {
        if let Mode::Plain(_) = self.mode {
            match self.next_plain(path)? {
                Some(line) => return Ok(Some(line)),
                None if matches!(self.mode, Mode::Plain(_)) => return Ok(None),
                None => {}
            }
        }
        let Mode::Csv(reader) = &mut self.mode else {
            return Ok(None);
        };
        match reader.read_byte_record(&mut self.rec) {
            Ok(false) => Ok(None),
            Ok(true) => {
                let byte = self.rec.position().map_or(0, |p| p.byte());
                let line = reader.get_mut().line_of(byte);
                if self.rec.len() != self.n_fields {
                    return Err(InputError {
                        file: path.to_path_buf(),
                        line: Some(line),
                        column: None,
                        column_name: None,
                        reason: format!(
                            "row has {} fields, header has {}",
                            self.rec.len(),
                            self.n_fields
                        ),
                    });
                }
                Ok(Some(line))
            }
            Err(e) => Err(super::reader::csv_error(path, e, reader.get_mut())),
        }
    }

    /// A caller's own parse of the next line, straight from the buffer: `parse` gets the
    /// unread bytes (from the start of the next line) and returns the length of the
    /// line it read, without its `\n`, when it is a plain line with the header's field
    /// count that ends in a `\n` inside those bytes; then the line is taken as read
    /// and its 1-based line is returned. `None` (the parse refused, the buffer holds
    /// no whole line, or the csv crate has taken over) reads nothing: the line is then
    /// read by [`Records::next`] as before.
    #[inline]
    pub(crate) fn next_parsed(
        &mut self,
        parse: impl FnOnce(&[u8]) -> Option<usize>,
    ) -> Option<u64> {
        let Mode::Plain(p) = &mut self.mode else {
            return None;
        };
        let unread = p.buf.get(p.pos..p.end)?;
        let len = parse(unread)?;
        debug_assert_eq!(unread.get(len), Some(&b'\n'));
        let start = p.pos;
        p.pos += len + 1;
        p.after_cr = false;
        // no field ends: [`Records::fields`] is not asked for a line parsed here
        self.ends.clear();
        self.line = (start, start + len);
        let line = p.line;
        p.line += 1;
        Some(line)
    }

    /// The next plain line; `None` at the end or after switching to the csv crate.
    #[inline]
    fn next_plain(&mut self, path: &Path) -> Result<Option<u64>, InputError> {
        loop {
            let Mode::Plain(p) = &mut self.mode else {
                return Ok(None);
            };
            let (start, end) = match memchr::memchr(b'\n', &p.buf[p.pos..p.end]) {
                Some(n) => (p.pos, p.pos + n),
                None if p.eof && p.pos == p.end => return Ok(None),
                // the last line, without a terminator
                None if p.eof => (p.pos, p.end),
                None => {
                    p.buf.copy_within(p.pos..p.end, 0);
                    p.end -= p.pos;
                    p.pos = 0;
                    if p.end == p.buf.len() {
                        // a line longer than the buffer
                        p.buf.resize(2 * p.buf.len(), 0);
                    }
                    let n = loop {
                        match p.inner.read(&mut p.buf[p.end..]) {
                            Ok(n) => break n,
                            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                            Err(e) => {
                                return Err(InputError {
                                    file: path.to_path_buf(),
                                    line: None,
                                    column: None,
                                    column_name: None,
                                    reason: format!("cannot read: {e}"),
                                })
                            }
                        }
                    };
                    p.eof = n == 0;
                    p.end += n;
                    continue;
                }
            };
            if !split(&p.buf[start..end], self.n_fields, &mut self.ends) {
                self.switch();
                return Ok(None);
            }
            p.pos = (end + 1).min(p.end);
            p.after_cr = false;
            self.line = (start, end);
            let line = p.line;
            p.line += 1;
            return Ok(Some(line));
        }
    }

    /// The cells of the record last read.
    #[inline]
    pub(crate) fn fields(&self) -> Fields<'_> {
        match &self.mode {
            Mode::Plain(p) => Fields::Line(&p.buf[self.line.0..self.line.1], &self.ends),
            _ => Fields::Csv(&self.rec),
        }
    }
}

/// Split `line` into `ends` (the end of each field) if it is plain (not empty, no `"`,
/// no `\r`) and has `n_fields` fields.
#[inline]
fn split(line: &[u8], n_fields: usize, ends: &mut Vec<usize>) -> bool {
    ends.clear();
    if line.is_empty() {
        return false;
    }
    for i in memchr::memchr3_iter(b',', b'"', b'\r', line) {
        if line[i] != b',' {
            return false;
        }
        ends.push(i);
    }
    ends.push(line.len());
    ends.len() == n_fields
}
