//! Line numbers of CSV records, counted from the bytes themselves.
//!
//! The csv crate's own line count (`Position::line`) is wrong for CRLF files (a record
//! after a CRLF is counted on the line before), so the readers count lines here
//! instead: [`LineCounter`] wraps the input, notes where every line terminator ends as
//! the bytes pass through, and answers "which line holds byte `b`" from a record's byte
//! offset (`Position::byte`). Terminators are counted as the csv crate splits records:
//! `\n`, `\r\n` (one terminator) and a lone `\r`. A terminator ends just after its
//! first byte: the csv crate reports a record that follows a CRLF at the offset of the
//! LF, which then belongs to the record's line.
//!
//! Hand-written because no crate offers a line index over a stream: queries come in
//! increasing byte order (records are read front to back), so only the terminators
//! between the last query and the read position are kept — at most one csv read buffer
//! of them — and memory does not grow with the file.

use std::collections::VecDeque;
use std::io::{self, Read};

/// A reader that counts line terminators as bytes pass through it.
#[derive(Debug)]
pub(crate) struct LineCounter<R> {
    inner: R,
    /// Bytes read so far.
    offset: u64,
    /// The offset just after the first byte of each terminator not yet passed by a query.
    ends: VecDeque<u64>,
    /// Terminators already passed by a query.
    passed: u64,
    /// Whether the last byte read was a `\r` (a `\n` after it is the same terminator).
    after_cr: bool,
}

impl<R> LineCounter<R> {
    pub(crate) fn new(inner: R) -> Self {
        LineCounter {
            inner,
            offset: 0,
            ends: VecDeque::new(),
            passed: 0,
            after_cr: false,
        }
    }

    /// A counter for input that continues a file: `passed` terminators came before
    /// it, and `after_cr` tells whether the byte before it was a `\r`.
    pub(crate) fn resume(inner: R, passed: u64, after_cr: bool) -> Self {
        LineCounter {
            inner,
            offset: 0,
            ends: VecDeque::new(),
            passed,
            after_cr,
        }
    }

    /// The input, and the bytes read so far.
    pub(crate) fn into_inner(self) -> R {
        self.inner
    }

    /// The 1-based line holding byte `byte` (one more than the count of terminators
    /// that end at or before it). Queries must not decrease.
    pub(crate) fn line_of(&mut self, byte: u64) -> u64 {
        while self.ends.front().is_some_and(|&e| e <= byte) {
            self.ends.pop_front();
            self.passed += 1;
        }
        self.passed + 1
    }
}

impl<R: Read> Read for LineCounter<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        let data = &buf[..n];
        // only the terminator bytes are visited (memchr), not every byte
        for i in memchr::memchr2_iter(b'\r', b'\n', data) {
            let after_cr = match i {
                0 => self.after_cr,
                _ => data[i - 1] == b'\r',
            };
            if data[i] == b'\r' || !after_cr {
                self.ends.push_back(self.offset + i as u64 + 1);
            }
        }
        if let Some(&last) = data.last() {
            self.after_cr = last == b'\r';
        }
        self.offset += n as u64;
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Read all of `text` through a counter in chunks of `chunk` bytes, then ask the
    /// line of each offset in `queries`.
    fn lines(text: &[u8], chunk: usize, queries: &[u64]) -> Vec<u64> {
        struct Chunks<'a>(&'a [u8], usize);
        impl Read for Chunks<'_> {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                let n = self.0.len().min(self.1).min(buf.len());
                buf[..n].copy_from_slice(&self.0[..n]);
                self.0 = &self.0[n..];
                Ok(n)
            }
        }
        let mut c = LineCounter::new(Chunks(text, chunk));
        let mut sink = Vec::new();
        c.read_to_end(&mut sink).expect("read");
        queries.iter().map(|&q| c.line_of(q)).collect()
    }

    #[test]
    fn lf_crlf_and_lone_cr_in_any_chunking() {
        for chunk in [1, 2, 3, 64] {
            // line starts: LF at 0, 2, 4
            assert_eq!(lines(b"a\nb\nc\n", chunk, &[0, 2, 4]), [1, 2, 3]);
            // CRLF: lines start at 0, 3, 6; the LF before a line is on it too
            assert_eq!(
                lines(b"a\r\nb\r\nc\r\n", chunk, &[0, 2, 3, 5, 6]),
                [1, 2, 2, 3, 3]
            );
            // lone CR at 0, 2, 4
            assert_eq!(lines(b"a\rb\rc", chunk, &[0, 2, 4]), [1, 2, 3]);
            // mixed, with an empty line: a CRLF, b LF, (empty) CRLF, c
            assert_eq!(lines(b"a\r\nb\n\r\nc", chunk, &[0, 3, 5, 7]), [1, 2, 3, 4]);
        }
    }
}
