//! Streaming CSV writers. Floats use `ryu` (shortest round-trip form, reads back exactly),
//! integers `itoa`-style via `std`; one reusable line buffer, no per-row allocation.
//!
//! # Output files are atomic
//! Every `create(path)` writes to a temporary file in `path`'s directory
//! (`.<name>.<random>.tmp`, made with `tempfile`) and renames it to `path` in `finish()`,
//! when every row is written and flushed ([`AtomicFile`]). A writer that fails or is
//! dropped before `finish()` removes its temporary file, so an error (a full disk, a bad
//! value) never leaves a truncated or empty file under the real name, and the file an
//! earlier run wrote there stays as it was until the new one is complete.
//!
//! # Only finite numbers
//! A non-finite float cell (NaN, inf) is an error of `end_row` naming the line (the header
//! is line 1), the column number and the column's header name; the row is not written, and
//! the file is not committed. Nothing downstream ever reads a NaN this crate wrote.

use crate::io::COV_COLUMNS;
use crate::models::wrap_angle;
use crate::types::{
    Association, FusedTrack, LocalTrack, Measurement, Sensor, SensorKind, StateCov, StateVec,
    TruthState,
};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// An output file that appears under its name only when complete: the bytes go to a
/// temporary file in the same directory (so the final rename stays on one file system and
/// is atomic), [`AtomicFile::commit`] flushes it and renames it over `path`; dropped
/// without a commit (an error, a panic) the temporary file is removed and `path` is left
/// as it was. Buffered (1 MiB), like the writers it backs.
///
/// The file is created with mode `0o666` minus the umask, as `File::create` would (a
/// plain temporary file would be `0o600`). Replacing a symlink replaces the link, not its
/// target.
pub struct AtomicFile {
    out: BufWriter<File>,
    /// Removes the temporary file when dropped; renamed by `commit`.
    tmp: tempfile::TempPath,
    path: PathBuf,
}

impl AtomicFile {
    /// Start writing `path` (nothing appears under that name until [`AtomicFile::commit`]).
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the path names no file"))?;
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let (file, tmp) = builder.tempfile_in(dir)?.into_parts();
        Ok(AtomicFile {
            out: BufWriter::with_capacity(1 << 20, file),
            tmp,
            path: path.to_path_buf(),
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flush and rename the temporary file to the final path; on an error the temporary
    /// file is removed.
    pub fn commit(self) -> io::Result<PathBuf> {
        let AtomicFile { out, tmp, path } = self;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        drop(file);
        tmp.persist(&path).map_err(|e| e.error)?;
        Ok(path)
    }

    /// Write all of `bytes` to `path` atomically (a whole small file: summary.json, a
    /// scenario copy, a report).
    pub fn write_all_to(path: &Path, bytes: &[u8]) -> io::Result<PathBuf> {
        let mut f = AtomicFile::create(path)?;
        f.write_all(bytes)?;
        f.commit()
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.out.write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.out.write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

/// Where a writer's rows go, and what `finish()` does with it once every row is written:
/// an [`AtomicFile`] is committed (renamed into place, `Done` = the final path); an
/// in-memory or borrowed sink is flushed and handed back.
pub trait Sink: Write {
    type Done;
    /// Flush and complete the sink.
    fn done(self) -> io::Result<Self::Done>;
}

impl Sink for AtomicFile {
    type Done = PathBuf;
    fn done(self) -> io::Result<PathBuf> {
        self.commit()
    }
}

impl Sink for Vec<u8> {
    type Done = Vec<u8>;
    fn done(self) -> io::Result<Vec<u8>> {
        Ok(self)
    }
}

impl Sink for File {
    type Done = File;
    fn done(mut self) -> io::Result<File> {
        self.flush()?;
        Ok(self)
    }
}

impl<W: Write> Sink for BufWriter<W> {
    type Done = BufWriter<W>;
    fn done(mut self) -> io::Result<BufWriter<W>> {
        self.flush()?;
        Ok(self)
    }
}

impl<W: Write + ?Sized> Sink for &mut W {
    type Done = ();
    fn done(self) -> io::Result<()> {
        self.flush()
    }
}

/// A minimal fast CSV row writer over any [`Sink`].
pub struct CsvRowWriter<W: Write> {
    out: W,
    line: Vec<u8>,
    float: ryu::Buffer,
    first: bool,
    /// The header's column names, for the error of a non-finite cell.
    columns: Vec<String>,
    /// Column index of the next cell.
    col: usize,
    /// Data rows written so far.
    rows: u64,
    /// The first non-finite cell of the current row: (column index, value).
    bad: Option<(usize, f64)>,
    /// The bits and text of the last value written by [`CsvRowWriter::float_repeated`].
    repeated: Option<u64>,
    repeated_text: Vec<u8>,
}

impl CsvRowWriter<AtomicFile> {
    /// Start writing `path` atomically ([`AtomicFile`]) and write `header`.
    pub fn create(path: &Path, header: &str) -> io::Result<Self> {
        Self::new(AtomicFile::create(path)?, header)
    }
}

impl<W: Sink> CsvRowWriter<W> {
    /// Wrap `out` and write the `header` line.
    pub fn new(mut out: W, header: &str) -> io::Result<Self> {
        out.write_all(header.as_bytes())?;
        out.write_all(b"\n")?;
        Ok(CsvRowWriter {
            out,
            line: Vec::with_capacity(512),
            float: ryu::Buffer::new(),
            first: true,
            columns: header.split(',').map(str::to_string).collect(),
            col: 0,
            rows: 0,
            bad: None,
            repeated: None,
            repeated_text: Vec::new(),
        })
    }

    #[inline]
    fn sep(&mut self) {
        if !self.first {
            self.line.push(b',');
            self.col += 1;
        }
        self.first = false;
    }

    /// Append a float cell (shortest round-trip; `-0` written as `0`). A non-finite value
    /// makes [`CsvRowWriter::end_row`] fail.
    #[inline]
    pub fn float(&mut self, v: f64) -> &mut Self {
        self.sep();
        if !v.is_finite() && self.bad.is_none() {
            self.bad = Some((self.col, v));
        }
        let v = if v == 0.0 { 0.0 } else { v };
        let s = self.float.format(v);
        // ryu writes "1.0"; keep it, it reads back exactly.
        self.line.extend_from_slice(s.as_bytes());
        self
    }

    /// [`CsvRowWriter::float`] for a column whose value repeats from row to row (a
    /// scan's time): the text of the last value is kept and copied when the bits are
    /// the same, one comparison instead of formatting the number again. The same bytes
    /// as `float`.
    #[inline]
    pub fn float_repeated(&mut self, v: f64) -> &mut Self {
        if self.repeated == Some(v.to_bits()) {
            self.sep();
            self.line.extend_from_slice(&self.repeated_text);
        } else {
            let start = self.line.len() + usize::from(!self.first);
            self.float(v);
            // only finite values are kept: a non-finite one must go through `float`
            // every time, which marks the row bad
            if v.is_finite() {
                self.repeated_text.clear();
                self.repeated_text.extend_from_slice(&self.line[start..]);
                self.repeated = Some(v.to_bits());
            }
        }
        self
    }

    /// Append an integer cell.
    #[inline]
    pub fn int(&mut self, v: i64) -> &mut Self {
        self.sep();
        let mut buf = [0u8; 24];
        let mut n = v.unsigned_abs();
        let mut i = buf.len();
        loop {
            i -= 1;
            buf[i] = b'0' + (n % 10) as u8;
            n /= 10;
            if n == 0 {
                break;
            }
        }
        if v < 0 {
            i -= 1;
            buf[i] = b'-';
        }
        self.line.extend_from_slice(&buf[i..]);
        self
    }

    /// Append a text cell (must not contain `,`, `"` or newlines).
    #[inline]
    pub fn text(&mut self, v: &str) -> &mut Self {
        self.sep();
        self.line.extend_from_slice(v.as_bytes());
        self
    }

    /// Append an empty cell.
    #[inline]
    pub fn empty(&mut self) -> &mut Self {
        self.sep();
        self
    }

    /// Finish the current row. A non-finite float cell in it is an
    /// [`io::ErrorKind::InvalidData`] error naming the line, column number and column
    /// name; the row is not written.
    #[inline]
    pub fn end_row(&mut self) -> io::Result<()> {
        let line = self.rows + 2;
        if let Some((col, v)) = self.bad.take() {
            self.line.clear();
            self.first = true;
            self.col = 0;
            let name = self.columns.get(col).map_or("?", |s| s.as_str());
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "line {line}, column {} ({name}): {v} is not a finite number (outputs hold finite numbers only)",
                    col + 1
                ),
            ));
        }
        self.line.push(b'\n');
        self.out.write_all(&self.line)?;
        self.line.clear();
        self.first = true;
        self.col = 0;
        self.rows += 1;
        Ok(())
    }

    /// Flush and complete the sink (an [`AtomicFile`] is renamed into place).
    pub fn finish(mut self) -> io::Result<W::Done> {
        self.out.flush()?;
        self.out.done()
    }

    fn state_cov(&mut self, state: &StateVec, cov: &StateCov) {
        for v in state.iter() {
            self.float(*v);
        }
        for r in 0..4 {
            for c in 0..4 {
                self.float(cov[(r, c)]);
            }
        }
    }
}

/// Write `sensors.csv`: required columns, then every optional one.
pub fn write_sensors(path: &Path, sensors: &[Sensor]) -> io::Result<()> {
    let mut w = CsvRowWriter::create(
        path,
        "sensor_id,x,y,sigma_r,sigma_theta,pd,kind,sigma_x,sigma_y,bias_r,bias_theta,max_range,clutter_density",
    )?;
    for s in sensors {
        w.int(s.id).float(s.x).float(s.y);
        match s.kind {
            SensorKind::RangeBearing => {
                w.float(s.sigma_a).float(s.sigma_b);
            }
            SensorKind::Position => {
                w.empty().empty();
            }
        }
        w.float(s.pd).text(s.kind.as_str());
        match s.kind {
            SensorKind::RangeBearing => {
                w.empty().empty();
            }
            SensorKind::Position => {
                w.float(s.sigma_a).float(s.sigma_b);
            }
        }
        w.float(s.bias_r).float(s.bias_theta).float(s.max_range);
        match s.clutter_density {
            Some(d) => w.float(d),
            None => w.empty(),
        };
        w.end_row()?;
    }
    w.finish()?;
    Ok(())
}

/// Streaming writer of `truth.csv`.
pub struct TruthWriter<W: Write>(CsvRowWriter<W>);

impl TruthWriter<AtomicFile> {
    /// Start writing `path` atomically ([`AtomicFile`]).
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(AtomicFile::create(path)?)
    }
}

impl<W: Sink> TruthWriter<W> {
    pub const HEADER: &'static str = "scan,time,target_id,x,vx,y,vy";
    pub fn new(out: W) -> io::Result<Self> {
        Ok(TruthWriter(CsvRowWriter::new(out, Self::HEADER)?))
    }
    pub fn write(&mut self, t: &TruthState) -> io::Result<()> {
        let w = &mut self.0;
        w.int(t.scan as i64).float(t.time).int(t.target_id);
        for v in t.state.iter() {
            w.float(*v);
        }
        w.end_row()
    }
    pub fn finish(self) -> io::Result<W::Done> {
        self.0.finish()
    }
}

/// Which measurement columns a `measurements.csv` carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeasurementColumns {
    RangeBearing,
    Position,
    Mixed,
}

/// Streaming writer of `measurements.csv` (with the `target_id` truth column).
pub struct MeasurementWriter<W: Write> {
    w: CsvRowWriter<W>,
    cols: MeasurementColumns,
}

impl MeasurementWriter<AtomicFile> {
    /// Start writing `path` atomically ([`AtomicFile`]) with the columns the given sensors
    /// need.
    pub fn create(path: &Path, sensors: &[Sensor]) -> io::Result<Self> {
        Self::new(AtomicFile::create(path)?, sensors)
    }
}

impl<W: Sink> MeasurementWriter<W> {
    pub fn new(out: W, sensors: &[Sensor]) -> io::Result<Self> {
        let rb = sensors.iter().any(|s| s.kind == SensorKind::RangeBearing);
        let pos = sensors.iter().any(|s| s.kind == SensorKind::Position);
        let (cols, header) = match (rb, pos) {
            (true, true) => (
                MeasurementColumns::Mixed,
                "scan,time,sensor_id,range,bearing,x,y,target_id",
            ),
            (false, true) => (
                MeasurementColumns::Position,
                "scan,time,sensor_id,x,y,target_id",
            ),
            _ => (
                MeasurementColumns::RangeBearing,
                "scan,time,sensor_id,range,bearing,target_id",
            ),
        };
        Ok(MeasurementWriter {
            w: CsvRowWriter::new(out, header)?,
            cols,
        })
    }

    pub fn write(&mut self, m: &Measurement) -> io::Result<()> {
        let w = &mut self.w;
        w.int(m.scan as i64).float_repeated(m.time).int(m.sensor_id);
        match (self.cols, m.kind) {
            (MeasurementColumns::Mixed, SensorKind::RangeBearing) => {
                w.float(m.value[0])
                    .float(wrap_angle(m.value[1]))
                    .empty()
                    .empty();
            }
            (MeasurementColumns::Mixed, SensorKind::Position) => {
                w.empty().empty().float(m.value[0]).float(m.value[1]);
            }
            (_, SensorKind::RangeBearing) => {
                w.float(m.value[0]).float(wrap_angle(m.value[1]));
            }
            (_, SensorKind::Position) => {
                w.float(m.value[0]).float(m.value[1]);
            }
        }
        w.int(m.target_id);
        w.end_row()
    }
    pub fn finish(self) -> io::Result<W::Done> {
        self.w.finish()
    }
}

fn header_with_cov(prefix: &str, suffix: &str) -> String {
    let mut h = String::from(prefix);
    for c in COV_COLUMNS {
        h.push(',');
        h.push_str(c);
    }
    h.push_str(suffix);
    h
}

/// Streaming writer of `local_tracks.csv`.
pub struct LocalTrackWriter<W: Write>(CsvRowWriter<W>);

impl LocalTrackWriter<AtomicFile> {
    /// Start writing `path` atomically ([`AtomicFile`]).
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(AtomicFile::create(path)?)
    }
}

impl<W: Sink> LocalTrackWriter<W> {
    pub fn header() -> String {
        header_with_cov("scan,time,sensor_id,track_id,x,vx,y,vy", "")
    }
    pub fn new(out: W) -> io::Result<Self> {
        Ok(LocalTrackWriter(CsvRowWriter::new(out, &Self::header())?))
    }
    pub fn write(&mut self, t: &LocalTrack) -> io::Result<()> {
        let w = &mut self.0;
        w.int(t.scan as i64)
            .float_repeated(t.time)
            .int(t.sensor_id)
            .int(t.track_id);
        w.state_cov(&t.state, &t.cov);
        w.end_row()
    }
    pub fn finish(self) -> io::Result<W::Done> {
        self.0.finish()
    }
}

/// Streaming writer of `fused_tracks.csv` (with the optional `sources` and `status`
/// columns: `status` is always written).
pub struct FusedTrackWriter<W: Write>(CsvRowWriter<W>);

impl FusedTrackWriter<AtomicFile> {
    /// Start writing `path` atomically ([`AtomicFile`]).
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(AtomicFile::create(path)?)
    }
}

impl<W: Sink> FusedTrackWriter<W> {
    pub fn header() -> String {
        header_with_cov("scan,time,fused_id,x,vx,y,vy", ",n_sources,sources,status")
    }
    pub fn new(out: W) -> io::Result<Self> {
        Ok(FusedTrackWriter(CsvRowWriter::new(out, &Self::header())?))
    }
    pub fn write(&mut self, t: &FusedTrack) -> io::Result<()> {
        let w = &mut self.0;
        w.int(t.scan as i64).float(t.time).int(t.fused_id);
        w.state_cov(&t.state, &t.cov);
        w.int(t.sources.len() as i64);
        let mut s = String::new();
        for (i, (sensor, track)) in t.sources.iter().enumerate() {
            if i > 0 {
                s.push('|');
            }
            s.push_str(&format!("{sensor}:{track}"));
        }
        w.text(&s);
        w.text(t.status.as_str());
        w.end_row()
    }
    pub fn finish(self) -> io::Result<W::Done> {
        self.0.finish()
    }
}

/// Streaming writer of `associations.csv`.
pub struct AssociationWriter<W: Write>(CsvRowWriter<W>);

impl AssociationWriter<AtomicFile> {
    /// Start writing `path` atomically ([`AtomicFile`]).
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(AtomicFile::create(path)?)
    }
}

impl<W: Sink> AssociationWriter<W> {
    pub const HEADER: &'static str = "scan,sensor_id,track_id,fused_id";
    pub fn new(out: W) -> io::Result<Self> {
        Ok(AssociationWriter(CsvRowWriter::new(out, Self::HEADER)?))
    }
    pub fn write(&mut self, a: &Association) -> io::Result<()> {
        let w = &mut self.0;
        w.int(a.scan as i64)
            .int(a.sensor_id)
            .int(a.track_id)
            .int(a.fused_id);
        w.end_row()
    }
    pub fn finish(self) -> io::Result<W::Done> {
        self.0.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sink that accepts `left` bytes, then fails like a full disk.
    struct FailsAfter {
        left: usize,
        got: Vec<u8>,
    }

    impl Write for FailsAfter {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if self.left == 0 {
                return Err(io::Error::other("no space left on device"));
            }
            let n = buf.len().min(self.left);
            self.left -= n;
            self.got.extend_from_slice(&buf[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    fn truth(scan: u32, x: f64) -> TruthState {
        TruthState {
            scan,
            time: scan as f64,
            target_id: 1,
            state: StateVec::new(x, 1.0, 2.0, 3.0),
        }
    }

    fn files_in(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .expect("dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_failing_sink_is_an_error() {
        let mut sink = FailsAfter {
            left: 40,
            got: Vec::new(),
        };
        let mut w = TruthWriter::new(&mut sink).expect("header fits");
        let err = (0..10).try_for_each(|k| w.write(&truth(k, 1.0)));
        assert_eq!(
            err.expect_err("the sink fails").to_string(),
            "no space left on device"
        );
    }

    #[test]
    fn an_unfinished_file_never_appears_under_its_name() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("truth.csv");
        std::fs::write(&path, "an earlier run\n").expect("write");
        {
            let mut w = TruthWriter::create(&path).expect("create");
            w.write(&truth(0, 1.0)).expect("row");
            // dropped unfinished, as on any error
        }
        assert_eq!(files_in(dir.path()), vec!["truth.csv"]);
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            "an earlier run\n"
        );
        let mut w = TruthWriter::create(&path).expect("create");
        w.write(&truth(0, 1.0)).expect("row");
        assert_eq!(w.finish().expect("commit"), path);
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            "scan,time,target_id,x,vx,y,vy\n0,0.0,1,1.0,1.0,2.0,3.0\n"
        );
        assert_eq!(files_in(dir.path()), vec!["truth.csv"]);
    }

    #[test]
    fn a_non_finite_value_is_refused_with_line_and_column() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("truth.csv");
        let mut w = TruthWriter::create(&path).expect("create");
        w.write(&truth(0, 1.0)).expect("row");
        let e = w.write(&truth(1, f64::INFINITY)).expect_err("inf refused");
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert_eq!(
            e.to_string(),
            "line 3, column 4 (x): inf is not a finite number (outputs hold finite numbers only)"
        );
        drop(w);
        assert!(files_in(dir.path()).is_empty());
        let mut buf = Vec::new();
        let mut w = LocalTrackWriter::new(&mut buf).expect("header");
        let mut t = LocalTrack {
            scan: 0,
            time: 0.0,
            sensor_id: 0,
            track_id: 0,
            state: StateVec::zeros(),
            cov: StateCov::identity(),
        };
        t.cov[(3, 3)] = f64::NAN;
        let e = w.write(&t).expect_err("NaN refused");
        assert!(
            e.to_string().starts_with("line 2, column 24 (P33): NaN"),
            "{e}"
        );
    }
}
