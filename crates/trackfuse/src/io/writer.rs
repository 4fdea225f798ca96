//! Streaming CSV writers. Floats use `ryu` (shortest round-trip form, reads back exactly),
//! integers `itoa`-style via `std`; one reusable line buffer, no per-row allocation.

use crate::io::COV_COLUMNS;
use crate::models::wrap_angle;
use crate::types::{
    Association, FusedTrack, LocalTrack, Measurement, Sensor, SensorKind, StateCov, StateVec,
    TruthState,
};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// A minimal fast CSV row writer over any `Write`.
pub struct CsvRowWriter<W: Write> {
    out: W,
    line: Vec<u8>,
    float: ryu::Buffer,
    first: bool,
}

impl CsvRowWriter<BufWriter<File>> {
    /// Create (truncate) `path` and write `header`.
    pub fn create(path: &Path, header: &str) -> io::Result<Self> {
        let f = File::create(path)?;
        Self::new(BufWriter::with_capacity(1 << 20, f), header)
    }
}

impl<W: Write> CsvRowWriter<W> {
    /// Wrap `out` and write the `header` line.
    pub fn new(mut out: W, header: &str) -> io::Result<Self> {
        out.write_all(header.as_bytes())?;
        out.write_all(b"\n")?;
        Ok(CsvRowWriter {
            out,
            line: Vec::with_capacity(512),
            float: ryu::Buffer::new(),
            first: true,
        })
    }

    #[inline]
    fn sep(&mut self) {
        if !self.first {
            self.line.push(b',');
        }
        self.first = false;
    }

    /// Append a float cell (shortest round-trip; `-0` written as `0`).
    #[inline]
    pub fn float(&mut self, v: f64) -> &mut Self {
        self.sep();
        let v = if v == 0.0 { 0.0 } else { v };
        let s = self.float.format(v);
        // ryu writes "1.0"; keep it, it reads back exactly.
        self.line.extend_from_slice(s.as_bytes());
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

    /// Finish the current row.
    #[inline]
    pub fn end_row(&mut self) -> io::Result<()> {
        self.line.push(b'\n');
        self.out.write_all(&self.line)?;
        self.line.clear();
        self.first = true;
        Ok(())
    }

    /// Flush and return the inner writer.
    pub fn finish(mut self) -> io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
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

impl TruthWriter<BufWriter<File>> {
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(BufWriter::with_capacity(1 << 20, File::create(path)?))
    }
}

impl<W: Write> TruthWriter<W> {
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
    pub fn finish(self) -> io::Result<W> {
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

impl MeasurementWriter<BufWriter<File>> {
    /// Create the file with the columns the given sensors need.
    pub fn create(path: &Path, sensors: &[Sensor]) -> io::Result<Self> {
        Self::new(
            BufWriter::with_capacity(1 << 20, File::create(path)?),
            sensors,
        )
    }
}

impl<W: Write> MeasurementWriter<W> {
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
        w.int(m.scan as i64).float(m.time).int(m.sensor_id);
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
    pub fn finish(self) -> io::Result<W> {
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

impl LocalTrackWriter<BufWriter<File>> {
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(BufWriter::with_capacity(1 << 20, File::create(path)?))
    }
}

impl<W: Write> LocalTrackWriter<W> {
    pub fn header() -> String {
        header_with_cov("scan,time,sensor_id,track_id,x,vx,y,vy", "")
    }
    pub fn new(out: W) -> io::Result<Self> {
        Ok(LocalTrackWriter(CsvRowWriter::new(out, &Self::header())?))
    }
    pub fn write(&mut self, t: &LocalTrack) -> io::Result<()> {
        let w = &mut self.0;
        w.int(t.scan as i64)
            .float(t.time)
            .int(t.sensor_id)
            .int(t.track_id);
        w.state_cov(&t.state, &t.cov);
        w.end_row()
    }
    pub fn finish(self) -> io::Result<W> {
        self.0.finish()
    }
}

/// Streaming writer of `fused_tracks.csv` (with the optional `sources` column).
pub struct FusedTrackWriter<W: Write>(CsvRowWriter<W>);

impl FusedTrackWriter<BufWriter<File>> {
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(BufWriter::with_capacity(1 << 20, File::create(path)?))
    }
}

impl<W: Write> FusedTrackWriter<W> {
    pub fn header() -> String {
        header_with_cov("scan,time,fused_id,x,vx,y,vy", ",n_sources,sources")
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
        w.end_row()
    }
    pub fn finish(self) -> io::Result<W> {
        self.0.finish()
    }
}

/// Streaming writer of `associations.csv`.
pub struct AssociationWriter<W: Write>(CsvRowWriter<W>);

impl AssociationWriter<BufWriter<File>> {
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(BufWriter::with_capacity(1 << 20, File::create(path)?))
    }
}

impl<W: Write> AssociationWriter<W> {
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
    pub fn finish(self) -> io::Result<W> {
        self.0.finish()
    }
}
