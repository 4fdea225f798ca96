//! A quick first pass over a CSV file for the `(sensor_id, time)` of every row, which is
//! all `trackfuse track` and `trackfuse fuse` need before they stream the file for real
//! (each sensor's report clock, [`crate::clock::ReportTimes`]).
//!
//! The validating streams ([`crate::io::LocalTrackStream`], ...) parse and check every
//! cell of every row (22 floats and a covariance check per local-track row); a first pass
//! through them cost about as much as the real one. This pass splits the lines itself and
//! parses two cells, and it reads only what it reads exactly: files without a quote
//! character, LF or CRLF line ends, every row with the header's number of fields, both
//! cells taken by the same fast parsers as [`crate::io`]'s readers (which agree with
//! `str::parse`, proven by their property tests). On anything else (a quote, a lone CR,
//! a short row, a cell those parsers refuse) it returns `Ok(None)` and the caller reads
//! the file with the validating stream, which gives the same times or the exact located
//! error. A file it accepts may still be invalid elsewhere (a bad covariance): the real
//! pass, which validates every cell, reports that.
//!
//! Hand-written because the csv crate's tokeniser is the general state machine (quotes,
//! escapes, every terminator) and was the larger half of this pass's cost; the cases it
//! exists for send the file to it (the fallback above).

use super::reader::small_int;
use super::InputError;
use crate::clock::ReportTimes;
use std::io::Read;
use std::path::Path;

/// Bytes read at once.
const CHUNK: usize = 1 << 20;

/// Every row's `(sensor_id, time)` of the CSV file at `path` (a header with both columns,
/// any others), as [`ReportTimes`], and the number of data rows; `Ok(None)` when the file is not one this pass reads
/// exactly (module docs): read it with the validating stream. An error only when the
/// file cannot be opened or read.
pub fn quick_report_times(path: &Path) -> Result<Option<(ReportTimes, u64)>, InputError> {
    let file = std::fs::File::open(path)
        .map_err(|e| InputError::file(path, format!("cannot open: {e}")))?;
    quick_report_times_from(file, path)
}

/// [`quick_report_times`] from any input; `path` names it in messages.
pub fn quick_report_times_from<R: Read>(
    mut input: R,
    path: &Path,
) -> Result<Option<(ReportTimes, u64)>, InputError> {
    let mut buf: Vec<u8> = Vec::with_capacity(CHUNK + 4096);
    let mut start = 0; // first byte of buf not yet consumed
    let mut eof = false;
    let mut layout: Option<Layout> = None;
    let mut times = ReportTimes::default();
    let mut rows = 0u64;
    loop {
        // the complete lines in buf[start..]; at the end of the input, the rest too
        let avail = &buf[start..];
        if memchr::memchr(b'"', avail).is_some() {
            return Ok(None);
        }
        let mut consumed = 0;
        for line_end in memchr::memchr_iter(b'\n', avail) {
            let line = &avail[consumed..line_end];
            consumed = line_end + 1;
            if !take_line(line, &mut layout, &mut times, &mut rows) {
                return Ok(None);
            }
        }
        if eof {
            let rest = &avail[consumed..];
            if !rest.is_empty() && !take_line(rest, &mut layout, &mut times, &mut rows) {
                return Ok(None);
            }
            break;
        }
        start += consumed;
        // keep the partial line, read more behind it
        buf.drain(..start);
        start = 0;
        let len = buf.len();
        buf.resize(len + CHUNK, 0);
        let n = loop {
            match input.read(&mut buf[len..]) {
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(InputError::file(path, format!("cannot read: {e}"))),
            }
        };
        buf.truncate(len + n);
        eof = n == 0;
    }
    Ok(layout.is_some().then_some((times, rows)))
}

/// The header's field count and the two columns read.
struct Layout {
    fields: usize,
    sensor: usize,
    time: usize,
}

/// One line without its LF: the header (the first non-empty line) or a data row.
/// `false` when the line is one this pass does not read exactly.
fn take_line(
    line: &[u8],
    layout: &mut Option<Layout>,
    times: &mut ReportTimes,
    rows: &mut u64,
) -> bool {
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    // a byte-order mark before the header (the validating reader drops it too)
    let line = match layout {
        None => line.strip_prefix("\u{feff}".as_bytes()).unwrap_or(line),
        Some(_) => line,
    };
    if line.is_empty() {
        return true; // the csv crate skips empty lines, before the header too
    }
    if memchr::memchr(b'\r', line).is_some() {
        return false; // a lone CR ends a record for the csv crate
    }
    match layout {
        None => {
            let mut l = Layout {
                fields: 0,
                sensor: usize::MAX,
                time: usize::MAX,
            };
            for (i, name) in line.split(|&b| b == b',').enumerate() {
                let name = name.trim_ascii();
                // the first of a repeated name (the validating reader refuses those)
                if name == b"sensor_id" && l.sensor == usize::MAX {
                    l.sensor = i;
                }
                if name == b"time" && l.time == usize::MAX {
                    l.time = i;
                }
                l.fields = i + 1;
            }
            if l.sensor == usize::MAX || l.time == usize::MAX {
                return false;
            }
            *layout = Some(l);
            true
        }
        Some(l) => {
            // the fields are the pieces between commas (as `split(',')` gives them): the
            // commas found with `memchr` (SIMD) up to the later of the two cells, then
            // only counted; a row of local tracks has 24 fields, the two cells are
            // usually among the first four
            let (mut sensor, mut time) = (None, None);
            let last = l.sensor.max(l.time);
            let mut commas = memchr::memchr_iter(b',', line);
            let mut cell_start = 0;
            let mut n = 0;
            loop {
                let end = commas.next();
                let cell = &line[cell_start..end.unwrap_or(line.len())];
                if n == l.sensor {
                    sensor = small_int(cell.trim_ascii());
                } else if n == l.time {
                    time = fast_float2::parse::<f64, _>(cell.trim_ascii())
                        .ok()
                        .filter(|v: &f64| v.is_finite());
                }
                n += 1;
                match end {
                    None => break,
                    Some(_) if n > last => {
                        // the fields after this comma: one more than the commas left
                        n += 1 + commas.count();
                        break;
                    }
                    Some(e) => cell_start = e + 1,
                }
            }
            match (n == l.fields, sensor, time) {
                (true, Some(s), Some(t)) => {
                    times.add(s, t);
                    *rows += 1;
                    true
                }
                _ => false,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::LocalTrackStream;
    use std::collections::BTreeMap;

    /// The clocks of the validating stream over `text` (`None` on an error).
    fn full(text: &str) -> Option<BTreeMap<i64, crate::clock::ReportClock>> {
        let mut s = LocalTrackStream::from_reader(text.as_bytes(), "t.csv").ok()?;
        let mut times = ReportTimes::default();
        let mut buf = Vec::new();
        while s.next_scan(&mut buf).ok()?.is_some() {
            for t in &buf {
                times.add(t.sensor_id, t.time);
            }
        }
        Some(times.clocks())
    }

    fn quick(text: &str) -> Option<BTreeMap<i64, crate::clock::ReportClock>> {
        quick_report_times_from(text.as_bytes(), Path::new("t.csv"))
            .expect("no I/O error")
            .map(|(t, _)| t.clocks())
    }

    const HEADER: &str = "scan,time,sensor_id,track_id,x,vx,y,vy,P00,P01,P02,P03,P10,P11,P12,P13,P20,P21,P22,P23,P30,P31,P32,P33";

    fn row(scan: u32, time: f64, sensor: i64, track: i64) -> String {
        format!("{scan},{time},{sensor},{track},1,2,3,4,1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1")
    }

    /// Two sensors at 2 s and 3 s periods with phases, a track each.
    fn file(eol: &str) -> String {
        let mut s = format!("{HEADER}{eol}");
        for k in 0..20u32 {
            s += &row(k, 0.5 + 2.0 * f64::from(k), 1, 7);
            s += eol;
            s += &row(k, 1.25 + 3.0 * f64::from(k), 2, 9);
            s += eol;
        }
        s
    }

    #[test]
    fn quick_pass_gives_the_validating_streams_clocks() {
        for eol in ["\n", "\r\n"] {
            let text = file(eol);
            let q = quick(&text).expect("read by the quick pass");
            assert_eq!(Some(q.clone()), full(&text));
            assert_eq!(q.len(), 2);
            assert_eq!(q[&1].period, 2.0);
            assert_eq!(q[&2].period, 3.0);
            // no final line end, blank lines, padded cells, a BOM
            let padded = format!(
                "\n\u{feff}{}",
                text.trim_end()
                    .replace(",1,7,", " , 1 ,7,")
                    .replace(eol, &format!("{eol}{eol}"))
            );
            assert_eq!(quick(&padded), full(&padded), "{padded}");
            assert!(quick(&padded).is_some());
        }
    }

    #[test]
    fn what_it_does_not_read_exactly_goes_to_the_validating_stream() {
        let text = file("\n");
        // a quote anywhere, a lone CR, a short row, a cell the fast parsers refuse, no header
        let quoted = text.replacen(",1,7,", ",\"1\",7,", 1);
        let lone_cr = text.replacen('\n', "\r", 3);
        let short = text.replacen(",1,7,1,2,", ",1,7,1,", 1);
        let long = text.replacen(",1,7,1,2,", ",1,7,1,2,5,", 1);
        let trailing_comma = text.replacen(",0,0,1\n", ",0,0,1,\n", 2);
        let plus = text.replacen(",1,7,", ",+1,7,", 1);
        let nan = text.replacen("0.5,1,7", "NaN,1,7", 1);
        for t in [
            quoted,
            lone_cr,
            short,
            long,
            trailing_comma,
            plus,
            nan,
            String::new(),
            "x,y\n1,2\n".into(),
        ] {
            assert_eq!(quick(&t), None, "{t}");
        }
    }

    #[test]
    fn the_two_cells_are_found_wherever_the_header_puts_them() {
        // the sensor and time columns last, first, and apart; cells counted after them
        let text = file("\n");
        let mut rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
        let n = rows[0].len();
        for order in [
            (0..n).rev().collect::<Vec<_>>(),
            [2, 1]
                .into_iter()
                .chain((0..n).filter(|&i| i != 1 && i != 2))
                .collect(),
            (3..n).chain([1, 0, 2]).collect(),
        ] {
            let moved: String = rows
                .iter_mut()
                .map(|r| order.iter().map(|&i| r[i]).collect::<Vec<_>>().join(",") + "\n")
                .collect();
            let q = quick(&moved).expect("read by the quick pass");
            assert_eq!(Some(q.clone()), full(&moved), "{moved}");
            assert_eq!(q[&1].period, 2.0);
            assert_eq!(q[&2].period, 3.0);
        }
    }
}
