//! CSV readers with validation. See the module docs of [`crate::io`].

use crate::io::{InputError, COV_COLUMNS};
use crate::models::wrap_angle;
use crate::types::{
    Association, FusedTrack, Id, LocalTrack, Measurement, Sensor, SensorKind, StateCov, StateVec,
    TruthState, Vec2,
};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Every column name a FORMATS.md reader looks up, besides the covariance cells.
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

/// File name and header of a table, for error reports.
struct Meta {
    path: std::path::PathBuf,
    headers: Vec<String>,
}

/// A CSV file opened for reading with its header resolved.
struct Table {
    meta: Meta,
    reader: csv::Reader<std::fs::File>,
}

/// One row being parsed, with enough context to report errors.
struct Row<'a> {
    table: &'a Meta,
    rec: &'a csv::ByteRecord,
    line: u64,
}

impl Table {
    fn open(path: &Path) -> Result<Table, InputError> {
        let file = std::fs::File::open(path)
            .map_err(|e| InputError::file(path, format!("cannot open: {e}")))?;
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(false)
            .trim(csv::Trim::All)
            .from_reader(file);
        let headers = reader
            .headers()
            .map_err(|e| csv_error(path, e))?
            .iter()
            .map(|h| h.trim_start_matches('\u{feff}').to_string())
            .collect::<Vec<_>>();
        if headers.iter().all(|h| h.is_empty()) {
            return Err(InputError::line(path, 1, "empty file or empty header row"));
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
                    line: Some(1),
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
        Ok(Table {
            meta: Meta {
                path: path.to_path_buf(),
                headers,
            },
            reader,
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
                line: Some(1),
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

    /// Visit every data row.
    fn for_each_row(
        &mut self,
        mut f: impl FnMut(&Row<'_>) -> Result<(), InputError>,
    ) -> Result<(), InputError> {
        let mut rec = csv::ByteRecord::new();
        let Table { meta, reader } = self;
        loop {
            match reader.read_byte_record(&mut rec) {
                Ok(false) => break,
                Ok(true) => {
                    let line = rec.position().map(|p| p.line()).unwrap_or(0);
                    f(&Row {
                        table: meta,
                        rec: &rec,
                        line,
                    })?;
                }
                Err(e) => return Err(csv_error(&meta.path, e)),
            }
        }
        Ok(())
    }
}

fn csv_error(path: &Path, e: csv::Error) -> InputError {
    let line = e.position().map(|p| p.line());
    let reason = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("row has {len} fields, header has {expected_len}")
        }
        csv::ErrorKind::Utf8 { .. } => "invalid UTF-8".to_string(),
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

impl Row<'_> {
    fn raw(&self, col: usize) -> &str {
        self.rec
            .get(col)
            .and_then(|b| std::str::from_utf8(b).ok())
            .unwrap_or("")
            .trim()
    }

    fn err(&self, col: usize, reason: impl Into<String>) -> InputError {
        InputError::cell(
            &self.table.path,
            self.line,
            col + 1,
            &self.table.headers[col],
            reason,
        )
    }

    fn is_empty(&self, col: usize) -> bool {
        self.raw(col).is_empty()
    }

    /// A finite float.
    fn f64(&self, col: usize) -> Result<f64, InputError> {
        let s = self.raw(col);
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

    fn int(&self, col: usize) -> Result<i64, InputError> {
        let s = self.raw(col);
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
}

/// Why a covariance read from a file is not one (FORMATS.md).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CovarianceError {
    /// `P[row][col]` and `P[col][row]` differ by more than `1e-9` relative.
    #[error("covariance is not symmetric: P{row}{col} = {upper} but P{col}{row} = {lower}")]
    NotSymmetric {
        row: usize,
        col: usize,
        upper: f64,
        lower: f64,
    },
    /// The smallest eigenvalue is below `-1e-9` relative.
    #[error("covariance is not positive semi-definite (smallest eigenvalue {min_eigenvalue})")]
    NotPositiveSemidefinite { min_eigenvalue: f64 },
}

/// Check that a covariance is symmetric positive semi-definite within `1e-9` relative
/// (FORMATS.md).
pub fn check_covariance(p: &StateCov) -> Result<(), CovarianceError> {
    let scale = p
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    for r in 0..4 {
        for c in (r + 1)..4 {
            if (p[(r, c)] - p[(c, r)]).abs() > 1e-9 * scale {
                return Err(CovarianceError::NotSymmetric {
                    row: r,
                    col: c,
                    upper: p[(r, c)],
                    lower: p[(c, r)],
                });
            }
        }
    }
    let eig = nalgebra::SymmetricEigen::new(crate::types::symmetrize(p));
    let min = eig.eigenvalues.iter().fold(f64::INFINITY, |m, v| m.min(*v));
    if min < -1e-9 * scale {
        return Err(CovarianceError::NotPositiveSemidefinite {
            min_eigenvalue: min,
        });
    }
    Ok(())
}

struct StateCols {
    state: [usize; 4],
    cov: [usize; 16],
}

impl StateCols {
    fn find(t: &Table) -> Result<StateCols, InputError> {
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
            p[(i / 4, i % 4)] = row.f64(self.cov[i])?;
        }
        check_covariance(&p)
            .map_err(|e| InputError::line(&row.table.path, row.line, e.to_string()))?;
        Ok((s, p))
    }
}

/// Read `sensors.csv`.
pub fn read_sensors(path: &Path) -> Result<Vec<Sensor>, InputError> {
    let mut t = Table::open(path)?;
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
    let mut seen = HashMap::new();
    t.for_each_row(|row| {
        let id = row.int(c_id)?;
        if let Some(prev) = seen.insert(id, row.line) {
            return Err(row.err(
                c_id,
                format!("duplicate sensor_id {id} (first on line {prev})"),
            ));
        }
        let kind = match c_kind {
            Some(c) if !row.is_empty(c) => match row.raw(c) {
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
                Some(c) => row.nonneg(c),
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
        out.push(Sensor {
            id,
            kind,
            x: row.f64(c_x)?,
            y: row.f64(c_y)?,
            sigma_a: sa,
            sigma_b: sb,
            pd,
            bias_r: row.opt_f64(c_br)?.unwrap_or(0.0),
            bias_theta: row.opt_f64(c_bt)?.unwrap_or(0.0),
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

/// Read `truth.csv`. Rows must not repeat `(scan, target_id)`; time must not go backwards
/// within a target.
pub fn read_truth(path: &Path) -> Result<Vec<TruthState>, InputError> {
    let mut t = Table::open(path)?;
    let c_scan = t.col("scan")?;
    let c_time = t.col("time")?;
    let c_tid = t.col("target_id")?;
    let cs = [t.col("x")?, t.col("vx")?, t.col("y")?, t.col("vy")?];
    let mut out = Vec::new();
    let mut seen: HashSet<(u32, Id)> = HashSet::new();
    let mut last: HashMap<Id, (f64, u32)> = HashMap::new();
    t.for_each_row(|row| {
        let scan = row.scan(c_scan)?;
        let time = row.f64(c_time)?;
        let target_id = row.int(c_tid)?;
        if !seen.insert((scan, target_id)) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!("duplicate row for scan {scan}, target_id {target_id}"),
            ));
        }
        check_time(row, c_time, &mut last, target_id, time, scan)?;
        let mut state = StateVec::zeros();
        for i in 0..4 {
            state[i] = row.f64(cs[i])?;
        }
        out.push(TruthState {
            scan,
            time,
            target_id,
            state,
        });
        Ok(())
    })?;
    Ok(out)
}

fn check_time<K: std::hash::Hash + Eq + std::fmt::Debug>(
    row: &Row<'_>,
    c_time: usize,
    last: &mut HashMap<K, (f64, u32)>,
    key: K,
    time: f64,
    scan: u32,
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
    let _ = scan;
    last.insert(key, (time, row.line as u32));
    Ok(())
}

/// Read `measurements.csv`. When `sensors` is given, every `sensor_id` must be one of them
/// and each row must carry the cells of its sensor's kind. Rows are returned sorted by
/// `(scan, sensor_id)` (stable, so the file's order within a scan and sensor is kept).
/// The `target_id` column is read for evaluation; trackers must not use it.
pub fn read_measurements(
    path: &Path,
    sensors: Option<&[Sensor]>,
) -> Result<Vec<Measurement>, InputError> {
    let mut t = Table::open(path)?;
    let c_scan = t.col("scan")?;
    let c_time = t.col("time")?;
    let c_sid = t.col("sensor_id")?;
    let c_r = t.opt("range");
    let c_b = t.opt("bearing");
    let c_x = t.opt("x");
    let c_y = t.opt("y");
    let c_tid = t.opt("target_id");
    let rb_cols = c_r.zip(c_b);
    let pos_cols = c_x.zip(c_y);
    if rb_cols.is_none() && pos_cols.is_none() {
        return Err(InputError {
            file: path.to_path_buf(),
            line: Some(1),
            column: None,
            column_name: Some("range,bearing / x,y".into()),
            reason: "missing measurement columns: need range and bearing, or x and y".into(),
        });
    }
    let kinds: Option<HashMap<Id, SensorKind>> =
        sensors.map(|s| s.iter().map(|s| (s.id, s.kind)).collect());
    let mut out: Vec<(Measurement, u64)> = Vec::new();
    let mut seen: HashSet<(u32, Id, u64, u64)> = HashSet::new();
    let mut scan_time: HashMap<(Id, u32), f64> = HashMap::new();
    t.for_each_row(|row| {
        let scan = row.scan(c_scan)?;
        let time = row.f64(c_time)?;
        let sensor_id = row.int(c_sid)?;
        let has_rb = rb_cols.is_some_and(|(r, b)| !row.is_empty(r) || !row.is_empty(b));
        let has_pos = pos_cols.is_some_and(|(x, y)| !row.is_empty(x) || !row.is_empty(y));
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
        if let Some(k) = &kinds {
            match k.get(&sensor_id) {
                None => {
                    return Err(row.err(
                        c_sid,
                        format!("sensor_id {sensor_id} is not in sensors.csv"),
                    ))
                }
                Some(&sk) if sk != kind => {
                    return Err(row.err(
                        c_sid,
                        format!(
                            "sensor {sensor_id} is a {} sensor but this row has {} cells",
                            sk.as_str(),
                            kind.as_str()
                        ),
                    ))
                }
                _ => {}
            }
        }
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
        match scan_time.get(&(sensor_id, scan)) {
            Some(&t0) if t0 != time => {
                return Err(row.err(
                    c_time,
                    format!("scan {scan} of sensor {sensor_id} has two times: {t0} and {time}"),
                ))
            }
            _ => {
                scan_time.insert((sensor_id, scan), time);
            }
        }
        if !seen.insert((scan, sensor_id, value[0].to_bits(), value[1].to_bits())) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                "duplicate row (same scan, sensor and measurement as an earlier row)",
            ));
        }
        out.push((
            Measurement {
                scan,
                time,
                sensor_id,
                kind,
                value,
                target_id,
            },
            row.line,
        ));
        Ok(())
    })?;
    out.sort_by_key(|(m, _)| (m.scan, m.sensor_id));
    // time must not go backwards as the scan index grows, per sensor
    let mut last: HashMap<Id, (f64, u64)> = HashMap::new();
    for (m, line) in &out {
        if let Some(&(t_prev, l_prev)) = last.get(&m.sensor_id) {
            if m.time < t_prev {
                let c = t.col("time")?;
                return Err(InputError::cell(
                    path,
                    *line,
                    c + 1,
                    "time",
                    format!("time goes backwards for sensor {}: scan {} at {} but an earlier scan (line {l_prev}) at {t_prev}", m.sensor_id, m.scan, m.time),
                ));
            }
        }
        last.insert(m.sensor_id, (m.time, *line));
    }
    Ok(out.into_iter().map(|(m, _)| m).collect())
}

/// Read `local_tracks.csv`. Rows are returned sorted by `(scan, sensor_id, track_id)`.
pub fn read_local_tracks(path: &Path) -> Result<Vec<LocalTrack>, InputError> {
    let mut t = Table::open(path)?;
    let c_scan = t.col("scan")?;
    let c_time = t.col("time")?;
    let c_sid = t.col("sensor_id")?;
    let c_tid = t.col("track_id")?;
    let sc = StateCols::find(&t)?;
    let mut out = Vec::new();
    let mut seen: HashMap<(u32, Id, Id), u64> = HashMap::new();
    let mut last: HashMap<(Id, Id), (f64, u32)> = HashMap::new();
    t.for_each_row(|row| {
        let scan = row.scan(c_scan)?;
        let time = row.f64(c_time)?;
        let sensor_id = row.int(c_sid)?;
        let track_id = row.int(c_tid)?;
        if let Some(prev) = seen.insert((scan, sensor_id, track_id), row.line) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!("duplicate row: scan {scan}, sensor {sensor_id}, track {track_id} already on line {prev}"),
            ));
        }
        check_time(row, c_time, &mut last, (sensor_id, track_id), time, scan)?;
        let (state, cov) = sc.read(row)?;
        out.push(LocalTrack { scan, time, sensor_id, track_id, state, cov });
        Ok(())
    })?;
    out.sort_by_key(|l| (l.scan, l.sensor_id, l.track_id));
    Ok(out)
}

/// Read `fused_tracks.csv`. Rows are returned sorted by `(scan, fused_id)`.
pub fn read_fused_tracks(path: &Path) -> Result<Vec<FusedTrack>, InputError> {
    let mut t = Table::open(path)?;
    let c_scan = t.col("scan")?;
    let c_time = t.col("time")?;
    let c_fid = t.col("fused_id")?;
    let c_n = t.col("n_sources")?;
    let c_src = t.opt("sources");
    let sc = StateCols::find(&t)?;
    let mut out = Vec::new();
    let mut seen: HashMap<(u32, Id), u64> = HashMap::new();
    let mut last: HashMap<Id, (f64, u32)> = HashMap::new();
    t.for_each_row(|row| {
        let scan = row.scan(c_scan)?;
        let time = row.f64(c_time)?;
        let fused_id = row.int(c_fid)?;
        if let Some(prev) = seen.insert((scan, fused_id), row.line) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!("duplicate row: scan {scan}, fused_id {fused_id} already on line {prev}"),
            ));
        }
        check_time(row, c_time, &mut last, fused_id, time, scan)?;
        let (state, cov) = sc.read(row)?;
        let n = row.int(c_n)?;
        if n < 0 {
            return Err(row.err(c_n, "n_sources must not be negative"));
        }
        let mut sources = Vec::new();
        if let Some(c) = c_src {
            let s = row.raw(c);
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
        out.push(FusedTrack {
            scan,
            time,
            fused_id,
            state,
            cov,
            sources,
        });
        Ok(())
    })?;
    out.sort_by_key(|f| (f.scan, f.fused_id));
    Ok(out)
}

/// Read `associations.csv`. A `(scan, sensor_id, track_id)` may appear once.
pub fn read_associations(path: &Path) -> Result<Vec<Association>, InputError> {
    let mut t = Table::open(path)?;
    let c_scan = t.col("scan")?;
    let c_sid = t.col("sensor_id")?;
    let c_tid = t.col("track_id")?;
    let c_fid = t.col("fused_id")?;
    let mut out = Vec::new();
    let mut seen: HashMap<(u32, Id, Id), u64> = HashMap::new();
    t.for_each_row(|row| {
        let a = Association {
            scan: row.scan(c_scan)?,
            sensor_id: row.int(c_sid)?,
            track_id: row.int(c_tid)?,
            fused_id: row.int(c_fid)?,
        };
        if let Some(prev) = seen.insert((a.scan, a.sensor_id, a.track_id), row.line) {
            return Err(InputError::line(
                &row.table.path,
                row.line,
                format!(
                    "duplicate row: scan {}, sensor {}, track {} already on line {prev}",
                    a.scan, a.sensor_id, a.track_id
                ),
            ));
        }
        out.push(a);
        Ok(())
    })?;
    out.sort();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covariance_errors_say_which_entry_or_eigenvalue() {
        let mut p = StateCov::identity();
        p[(0, 1)] = 0.5;
        assert_eq!(
            check_covariance(&p),
            Err(CovarianceError::NotSymmetric {
                row: 0,
                col: 1,
                upper: 0.5,
                lower: 0.0
            })
        );
        let p = -StateCov::identity();
        assert!(matches!(
            check_covariance(&p),
            Err(CovarianceError::NotPositiveSemidefinite { min_eigenvalue }) if min_eigenvalue == -1.0
        ));
        assert_eq!(check_covariance(&StateCov::identity()), Ok(()));
    }
}
