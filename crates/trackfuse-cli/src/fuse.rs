//! `trackfuse fuse`: the fusion center over local_tracks.csv (from this project or any
//! other tool) -> fused_tracks.csv + associations.csv.
//!
//! It streams: local_tracks.csv (and truth.csv, with `--truth`) is read one scan (or,
//! without a scan column, one time) at a time, and the center fuses at its own update
//! instants (`--period`, default the shortest of the sensors' median report intervals,
//! learned in a quick pass over each row's sensor and time first,
//! `trackfuse::io::quick_report_times`; `trackfuse::center::instants`), each
//! instant's fused tracks and associations written before the next batch is read, so
//! memory does not grow with the number of scans (with more than one thread the next
//! batch is read on a second thread while the current one is fused, and the previous
//! instant's rows are formatted and written on a third: `common::for_each_scan`,
//! `common::write_behind`, the same bytes at any thread count). Synchronous sensors are fused batch
//! by batch exactly as scan by scan. `--two-pass` streams
//! twice: pass 1 estimates the biases, pass 2 reads the files again and fuses every scan
//! corrected with pass 1's final estimates. Errors found while
//! streaming name the file and line of the row (a local track whose sensor is not in
//! sensors.csv, a center error about one local track) or of the scan's first row. On an
//! error while streaming the partial outputs are removed and the output folder is left
//! as it was (nothing has been renamed into place yet).

use crate::common::{
    for_each_scan, load_scenario, scenario_input, stages_on_threads, write_behind,
};
use crate::config::FusionFlags;
use crate::output::{Outputs, FUSE_OUTPUTS};
use anyhow::{Context, Result};
use clap::Args;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use trackfuse::center::bias::{BiasEstimate, BiasSample};
use trackfuse::center::instants::{default_period, InstantBatcher};
use trackfuse::center::t2ta::truth::{self, TruthSource};
use trackfuse::center::{
    registry, CenterError, FusedRun, FusionCenter, FusionConfig, Missing, ScanOutput,
};
use trackfuse::clock::{ReportClock, ReportTimes};
use trackfuse::io::{
    no_truth_rows, read_sensors, AssociationWriter, FusedTrackWriter, InputError, LocalTrackStream,
    TruthStream,
};
use trackfuse::metrics::label_local_tracks;
use trackfuse::{Id, LocalTrack, Sensor, TruthState};

#[derive(Args, Debug)]
pub struct FuseArgs {
    /// local_tracks.csv
    #[arg(long)]
    pub local_tracks: PathBuf,
    /// sensors.csv: what the center may know of the sensors (positions, noise; never the
    /// true biases). Needed by bias estimation and by methods that use sensor resolutions.
    #[arg(long)]
    pub sensors: Option<PathBuf>,
    /// truth.csv: only for the `mmse` reference rule (optimal fusion given the true
    /// association).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Gate (m) for labelling local tracks with the target they follow (with --truth).
    #[arg(long, default_value_t = 2000.0)]
    pub label_gate: f64,
    /// Scenario whose `[fusion]` section is the base config.
    #[arg(long)]
    pub scenario: Option<String>,
    #[command(flatten)]
    pub fusion: FusionFlags,
    /// Offline, with a bias estimator: fuse the whole file once to estimate the biases,
    /// then fuse again from the first scan with the local tracks corrected by the final
    /// estimates (not what a streaming center can do).
    #[arg(long)]
    pub two_pass: bool,
    /// Output directory (fused_tracks.csv, associations.csv).
    #[arg(long, default_value = "out/fuse")]
    pub out: PathBuf,
}

/// Write fused_tracks.csv, associations.csv and (with a bias estimator) bias_estimates.csv.
pub fn write_fused(outs: &mut Outputs, run: &FusedRun) -> Result<()> {
    let p = outs.path("fused_tracks.csv")?;
    let ctx = |p: &Path| format!("writing {}", p.display());
    let mut w = FusedTrackWriter::create(&p).with_context(|| ctx(&p))?;
    for f in &run.fused {
        w.write(f).with_context(|| ctx(&p))?;
    }
    w.finish().with_context(|| ctx(&p))?;
    let p = outs.path("associations.csv")?;
    let mut w = AssociationWriter::create(&p).with_context(|| ctx(&p))?;
    for a in &run.associations {
        w.write(a).with_context(|| ctx(&p))?;
    }
    w.finish().with_context(|| ctx(&p))?;
    if !run.bias.is_empty() {
        write_bias(outs, &run.bias)?;
    }
    if !run.bias_history.is_empty() {
        let p = outs.path(BIAS_HISTORY)?;
        let mut w = BiasHistoryWriter::create(&p)?;
        for b in &run.bias_history {
            w.write(b)?;
        }
        w.finish()?;
    }
    Ok(())
}

/// The file of every sensor's bias estimate after each fused instant.
const BIAS_HISTORY: &str = "bias_history.csv";

/// Writes bias_history.csv (docs/formats.md): `scan,time,sensor_id,bias_r,bias_theta`,
/// one row per sensor per fused instant, as the center goes (streamed, atomically: an
/// unfinished writer leaves no file). Non-finite estimates are an error naming the row.
struct BiasHistoryWriter {
    path: PathBuf,
    file: Option<trackfuse::io::AtomicFile>,
    line: u64,
}

impl BiasHistoryWriter {
    fn create(path: &Path) -> Result<BiasHistoryWriter> {
        use std::io::Write;
        let mut w = trackfuse::io::AtomicFile::create(path)
            .with_context(|| format!("writing {}", path.display()))?;
        w.write_all(b"scan,time,sensor_id,bias_r,bias_theta\n")
            .with_context(|| format!("writing {}", path.display()))?;
        Ok(BiasHistoryWriter {
            path: path.to_path_buf(),
            file: Some(w),
            line: 1,
        })
    }

    fn write(&mut self, b: &BiasSample) -> Result<()> {
        use std::io::Write;
        self.line += 1;
        crate::output::finite_cells(
            &self.path.display().to_string(),
            self.line,
            &[
                (4, "bias_r", b.estimate.range),
                (5, "bias_theta", b.estimate.bearing),
            ],
        )?;
        if let Some(w) = self.file.as_mut() {
            writeln!(
                w,
                "{},{},{},{},{}",
                b.scan, b.time, b.estimate.sensor_id, b.estimate.range, b.estimate.bearing
            )
            .with_context(|| format!("writing {}", self.path.display()))?;
        }
        Ok(())
    }

    fn finish(mut self) -> Result<()> {
        let ctx = || format!("writing {}", self.path.display());
        if let Some(w) = self.file.take() {
            w.commit().with_context(ctx)?;
        }
        Ok(())
    }
}

/// Write bias_estimates.csv (finite cells only, atomically).
fn write_bias(outs: &mut Outputs, bias: &[BiasEstimate]) -> Result<()> {
    let mut s = String::from("sensor_id,bias_r,bias_theta\n");
    for (i, b) in bias.iter().enumerate() {
        crate::output::finite_cells(
            &outs.dir().join("bias_estimates.csv").display().to_string(),
            i as u64 + 2,
            &[(2, "bias_r", b.range), (3, "bias_theta", b.bearing)],
        )?;
        s.push_str(&format!("{},{},{}\n", b.sensor_id, b.range, b.bearing));
    }
    outs.write("bias_estimates.csv", s.as_bytes())?;
    Ok(())
}

/// Every local track's sensor must be in the given sensors.csv: a method or bias
/// estimator that reads the sensors would otherwise skip or misread that sensor's tracks.
/// The error names the row (file, line, column `sensor_id`).
fn check_sensors_cover(
    scan_rows: &[LocalTrack],
    lines: &[u64],
    (local_path, column): (&Path, usize),
    known: &BTreeSet<Id>,
    sensors_path: &Path,
) -> Result<()> {
    if let Some((t, &line)) = scan_rows
        .iter()
        .zip(lines)
        .find(|(t, _)| !known.contains(&t.sensor_id))
    {
        let reason = format!(
            "sensor_id {} (track {}, scan {}) is not in {} (its sensors: {})",
            t.sensor_id,
            t.track_id,
            t.scan,
            sensors_path.display(),
            known
                .iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        return Err(InputError::cell(local_path, line, column, "sensor_id", reason).into());
    }
    Ok(())
}

/// The center's error with the flag that gives what it is missing (the library names the
/// file, e.g. "the sensors (sensors.csv)"; the flag is the CLI's).
fn with_flag_hint(e: CenterError) -> anyhow::Error {
    let bias = registry::BIAS_ESTIMATORS.first().map_or("NAME", |b| b.name);
    let flag = match &e {
        CenterError::Needs {
            what: Missing::Sensors(_),
            ..
        }
        | CenterError::UnknownSensor { .. } => "--sensors sensors.csv".to_string(),
        CenterError::Needs {
            what: Missing::Truth,
            ..
        } => "--truth truth.csv".to_string(),
        CenterError::Needs {
            what: Missing::BiasEstimator,
            ..
        } => format!("--bias {bias}, with --sensors sensors.csv"),
        _ => return e.into(),
    };
    anyhow::anyhow!("{e} (give {flag})")
}

pub fn run(args: &FuseArgs) -> Result<()> {
    let base = match args.scenario.as_deref() {
        Some(s) => load_scenario(Some(s))?.0.fusion,
        None => FusionConfig::default(),
    };
    let cfg = args.fusion.apply(&base)?;
    let sensors = args.sensors.as_deref().map(read_sensors).transpose()?;
    // the default `auto` that resolves to no estimator says why, once
    if cfg.bias.as_deref() == Some(trackfuse::center::bias::AUTO) {
        if let trackfuse::center::bias::BiasChoice::Off(why) = cfg.bias_choice(sensors.as_deref()) {
            eprintln!("note: {why}");
        }
    }
    // the labels of the scan being fused, replaced scan by scan
    let labels = Arc::new(ScanLabels::default());
    let mut center = new_center(args, &cfg, sensors.as_deref(), &labels)?;
    if args.two_pass && !center.has_bias_estimator() {
        return Err(with_flag_hint(CenterError::Needs {
            method: "two-pass fusion",
            what: Missing::BiasEstimator,
        }));
    }
    // the headers are read and checked before the output folder is touched
    let mut first = StreamFusion::open(args, &labels, sensors.as_deref())?;
    // pass over the file for each sensor's report clock: its interval is the staleness
    // limit of its reports, and the shortest is the default update period
    let clocks = report_clocks(&args.local_tracks)?;
    let period = cfg
        .period
        .or_else(|| default_period(&clocks))
        .unwrap_or(1.0);
    first.schedule = (period, clocks.clone());
    let scenario_path = scenario_input(args.scenario.as_deref());
    let mut inputs = vec![args.local_tracks.as_path()];
    inputs.extend(args.sensors.as_deref());
    inputs.extend(args.truth.as_deref());
    inputs.extend(scenario_path.as_deref());
    let mut outs = Outputs::new(&args.out, FUSE_OUTPUTS, &inputs)?;
    let fused_path = outs.path("fused_tracks.csv")?;
    let assoc_path = outs.path("associations.csv")?;
    let ctx = |p: &Path| format!("writing {}", p.display());
    // atomic: on an error (a bad row late in the file) the writers are dropped unfinished
    // and leave no partial file, and `outs` dropped unfinished removes the output set
    let mut fw = FusedTrackWriter::create(&fused_path).with_context(|| ctx(&fused_path))?;
    let mut aw = AssociationWriter::create(&assoc_path).with_context(|| ctx(&assoc_path))?;
    let mut history = match center.has_bias_estimator() {
        true => Some(BiasHistoryWriter::create(&outs.path(BIAS_HISTORY)?)?),
        false => None,
    };
    let mut samples = Vec::new();
    let mut record = |center: &FusionCenter, s: u32, t: f64| -> Result<()> {
        if let Some(h) = history.as_mut() {
            samples.clear();
            center.record_bias(s, t, &mut samples);
            for b in &samples {
                h.write(b)?;
            }
        }
        Ok(())
    };
    let write = |out: &ScanOutput| -> Result<()> {
        for f in &out.fused {
            fw.write(f).with_context(|| ctx(&fused_path))?;
        }
        for a in &out.associations {
            aw.write(a).with_context(|| ctx(&assoc_path))?;
        }
        Ok(())
    };
    // with more than one thread the fused tracks and associations are formatted and
    // written on a thread of their own, an instant behind the center (the same bytes)
    let behind = stages_on_threads();
    let streamed = write_behind(behind, write, |emit| -> Result<_> {
        // the instant's output goes to the writer; the center fills a batch the writer
        // is done with (cleared) next
        let mut hand = |out: &mut ScanOutput| -> Result<()> {
            let mut spare = emit.buffer();
            spare.fused.clear();
            spare.associations.clear();
            std::mem::swap(out, &mut spare);
            emit.send(spare)
        };
        Ok(if args.two_pass {
            // pass 1 estimates the biases and writes nothing; pass 2 reads the files again,
            // corrects every scan with pass 1's final estimates and fuses without estimator
            // (what `fuse_all_two_pass` does on a whole file in memory)
            let first_stats = first.run(&mut center, None, |_, c, s, t| record(c, s, t))?;
            let second_cfg = FusionConfig {
                bias: None,
                ..cfg.clone()
            };
            let mut second = new_center(args, &second_cfg, sensors.as_deref(), &labels)?;
            let mut again = StreamFusion::open(args, &labels, sensors.as_deref())?;
            again.schedule = (period, clocks);
            let mut stats = again.run(&mut second, Some(&center), |out, _, _, _| hand(out))?;
            stats.elapsed += first_stats.elapsed;
            (stats, center.bias_estimates())
        } else {
            let stats = first.run(&mut center, None, |out, c, s, t| {
                hand(out)?;
                record(c, s, t)
            })?;
            (stats, center.bias_estimates())
        })
    });
    let (stats, bias) = match streamed {
        Ok(v) => v,
        Err(e) => {
            // the atomic writers, dropped unfinished, leave nothing under the real names
            drop((fw, aw, history));
            outs.failed_before_commit();
            return Err(e);
        }
    };
    fw.finish().with_context(|| ctx(&fused_path))?;
    aw.finish().with_context(|| ctx(&assoc_path))?;
    if let Some(h) = history {
        h.finish()?;
    }
    if !bias.is_empty() {
        write_bias(&mut outs, &bias)?;
    }
    let dir = outs.dir().to_path_buf();
    outs.finish();
    eprintln!(
        "fused {} local-track rows ({} + {}): {} global tracks, {} rows in {:.3} s -> {}",
        stats.local_rows,
        cfg.method,
        cfg.rule,
        stats.ids.len(),
        stats.fused_rows,
        stats.elapsed.as_secs_f64(),
        dir.display()
    );
    print_bias(&bias);
    Ok(())
}

/// Each sensor's report clock, from the distinct times of its rows in local_tracks.csv.
fn report_clocks(path: &Path) -> Result<BTreeMap<Id, ReportClock>> {
    // two cells a row; a file the quick pass does not read exactly goes through the
    // validating stream (which also names the first bad row, if any)
    if let Some((times, _)) = trackfuse::io::quick_report_times(path)? {
        return Ok(times.clocks());
    }
    let mut times = ReportTimes::default();
    let mut stream = LocalTrackStream::open(path)?;
    let mut buf = Vec::new();
    while stream.next_scan(&mut buf)?.is_some() {
        for t in &buf {
            times.add(t.sensor_id, t.time);
        }
    }
    Ok(times.clocks())
}

/// The center of `cfg`, fed the per-scan `labels` when `--truth` is given; a config that
/// asks for the true association without `--truth` is an error up front.
fn new_center(
    args: &FuseArgs,
    cfg: &FusionConfig,
    sensors: Option<&[Sensor]>,
    labels: &Arc<ScanLabels>,
) -> Result<FusionCenter> {
    let center = match args.truth {
        Some(_) => FusionCenter::with_truth(cfg, sensors, labels.clone()),
        None => FusionCenter::new(cfg, sensors),
    };
    let center = center.map_err(with_flag_hint)?;
    if center.lacks_truth() {
        let method = if cfg.method == truth::NAME {
            truth::NAME
        } else {
            registry::make_rule(&cfg.rule, &cfg.params)?.name()
        };
        return Err(with_flag_hint(CenterError::Needs {
            method,
            what: Missing::Truth,
        }));
    }
    Ok(center)
}

fn print_bias(bias: &[BiasEstimate]) {
    for b in bias {
        eprintln!(
            "  bias estimate sensor {}: range {:.1} m, bearing {:.5} rad",
            b.sensor_id, b.range, b.bearing
        );
    }
}

/// The truth labels of one scan's local tracks, for the `truth` associator (rule
/// `mmse`): [`StreamFusion`] replaces them before each scan it fuses.
#[derive(Default)]
struct ScanLabels(Mutex<HashMap<(u32, Id, Id), Id>>);

impl TruthSource for ScanLabels {
    fn target_of(&self, scan: u32, sensor_id: Id, track_id: Id) -> Option<Id> {
        // a poisoned lock means a panic elsewhere; its labels are still whole maps
        let map = self.0.lock().unwrap_or_else(|e| e.into_inner());
        map.get(&(scan, sensor_id, track_id)).copied()
    }
}

/// truth.csv read in step with local_tracks.csv: the truth of one scan at a time.
struct TruthCursor {
    stream: TruthStream,
    buf: Vec<TruthState>,
    /// The scan `buf` holds (`None`: not read yet, or the end).
    scan: Option<u32>,
    done: bool,
}

impl TruthCursor {
    /// Open the file and read its first scan: a file without rows is an error at once.
    fn open(path: &Path) -> Result<TruthCursor> {
        let mut c = TruthCursor {
            stream: TruthStream::open(path)?,
            buf: Vec::new(),
            scan: None,
            done: false,
        };
        c.rows_of(0)?;
        if c.done {
            return Err(no_truth_rows(path).into());
        }
        Ok(c)
    }

    /// The truth rows of `scan` (none when the file has no rows of it). Scans must be
    /// asked in increasing order; truth scans in between are skipped (read and checked).
    fn rows_of(&mut self, scan: u32) -> Result<&[TruthState]> {
        while !self.done && self.scan.is_none_or(|s| s < scan) {
            self.scan = self.stream.next_scan(&mut self.buf)?;
            self.done = self.scan.is_none();
        }
        Ok(if self.scan == Some(scan) {
            &self.buf
        } else {
            &[]
        })
    }

    /// Read (and so check) the rest of the file.
    fn finish(&mut self) -> Result<()> {
        while self.stream.next_scan(&mut self.buf)?.is_some() {}
        Ok(())
    }
}

/// What [`StreamFusion::run`] did.
#[derive(Default)]
struct FuseStats {
    local_rows: usize,
    fused_rows: usize,
    ids: BTreeSet<Id>,
    /// Time spent in the center (not reading or writing).
    elapsed: std::time::Duration,
}

/// The center driven scan by scan from local_tracks.csv: each scan is read, checked,
/// fused and written before the next is read, so memory does not grow with the number
/// of scans.
struct StreamFusion<'a> {
    local: LocalTrackStream,
    truth: Option<TruthCursor>,
    labels: &'a ScanLabels,
    label_gate: f64,
    /// The sensors and their file, to check every local track's sensor is known.
    sensors: Option<(BTreeSet<Id>, &'a Path)>,
    /// The center's update period and the sensors' report clocks.
    schedule: (f64, BTreeMap<Id, ReportClock>),
}

impl<'a> StreamFusion<'a> {
    /// Open local_tracks.csv (and truth.csv) and check their headers.
    fn open(
        args: &'a FuseArgs,
        labels: &'a ScanLabels,
        sensors: Option<&[Sensor]>,
    ) -> Result<StreamFusion<'a>> {
        Ok(StreamFusion {
            local: LocalTrackStream::open(&args.local_tracks)?,
            truth: args.truth.as_deref().map(TruthCursor::open).transpose()?,
            labels,
            label_gate: args.label_gate,
            sensors: sensors
                .zip(args.sensors.as_deref())
                .map(|(s, p)| (s.iter().map(|s| s.id).collect(), p)),
            schedule: (1.0, BTreeMap::new()),
        })
    }

    /// Fuse the whole file with `center` at the center's update instants
    /// ([`InstantBatcher`]: batch after batch of rows sharing one time, each instant's
    /// fresh latest reports predicted to it), handing each instant's output to `write`
    /// (which may take its rows: the center clears the output before filling it).
    /// With `corrector` (pass 2 of `--two-pass`), each batch's local tracks are first
    /// corrected with that center's bias estimates; the truth labels are those of the
    /// rows as read, as in `fuse_all_two_pass`.
    fn run(
        &mut self,
        center: &mut FusionCenter,
        corrector: Option<&FusionCenter>,
        mut write: impl FnMut(&mut ScanOutput, &FusionCenter, u32, f64) -> Result<()>,
    ) -> Result<FuseStats> {
        let mut stats = FuseStats::default();
        let mut out = ScanOutput::default();
        let mut batcher = InstantBatcher::new(self.schedule.0, &self.schedule.1);
        // the file line and the truth label of each local track's latest report
        let mut lines_of: HashMap<(Id, Id), u64> = HashMap::new();
        let mut labels_of: HashMap<(Id, Id), Id> = HashMap::new();
        let path = self.local.path().to_path_buf();
        let sid_column = self.local.column("sensor_id").unwrap_or(0);
        let StreamFusion {
            local,
            truth: truth_cursor,
            labels: scan_labels,
            label_gate,
            sensors,
            ..
        } = self;
        // reading on a second thread when more than one is asked for (`--threads`)
        let prefetch = stages_on_threads();
        let next = |rows: &mut Vec<LocalTrack>, lines: &mut Vec<u64>| {
            let scan = local.next_scan(rows)?;
            lines.clear();
            lines.extend_from_slice(local.lines());
            Ok::<_, InputError>(scan)
        };
        for_each_scan(prefetch, next, |scan, rows, read_lines| {
            if let Some((known, sensors_path)) = &sensors {
                check_sensors_cover(rows, read_lines, (&path, sid_column), known, sensors_path)?;
            }
            if let Some(truth) = truth_cursor.as_mut() {
                let labels = label_local_tracks(truth.rows_of(scan)?, rows, *label_gate);
                for r in rows.iter() {
                    let key = (r.sensor_id, r.track_id);
                    match labels.get(&(scan, key.0, key.1)) {
                        Some(&l) => labels_of.insert(key, l),
                        None => labels_of.remove(&key),
                    };
                }
            }
            if let Some(c) = corrector {
                c.correct_with_bias(rows);
            }
            for (r, &l) in rows.iter().zip(read_lines) {
                lines_of.insert((r.sensor_id, r.track_id), l);
            }
            stats.local_rows += rows.len();
            let time = rows
                .iter()
                .map(|r| r.time)
                .fold(f64::NEG_INFINITY, f64::max);
            let has_truth = truth_cursor.is_some();
            batcher.push(scan, time, rows, |s, t, tracks| {
                if has_truth {
                    let map = tracks
                        .iter()
                        .filter_map(|r| {
                            let key = (r.sensor_id, r.track_id);
                            labels_of.get(&key).map(|&l| ((s, key.0, key.1), l))
                        })
                        .collect();
                    *scan_labels.0.lock().unwrap_or_else(|e| e.into_inner()) = map;
                }
                let t0 = std::time::Instant::now();
                center
                    .process_at_into(s, t, tracks, &mut out)
                    .map_err(|e| located(&path, &lines_of, s, tracks, e))?;
                stats.elapsed += t0.elapsed();
                stats.fused_rows += out.fused.len();
                stats.ids.extend(out.fused.iter().map(|f| f.fused_id));
                write(&mut out, center, s, t)
            })?;
            Ok(())
        })?;
        if let Some(truth) = truth_cursor.as_mut() {
            truth.finish()?;
        }
        Ok(stats)
    }
}

/// A center error at instant `scan`, at the line of the local track it names (its
/// latest report's line, in `lines`), else at the line of the instant's first track.
fn located(
    path: &Path,
    lines: &HashMap<(Id, Id), u64>,
    scan: u32,
    tracks: &[LocalTrack],
    e: CenterError,
) -> anyhow::Error {
    let members: Vec<(Id, Id)> = match &e {
        CenterError::UnknownSensor {
            sensor_id,
            track_id,
            ..
        }
        | CenterError::DuplicateTrack {
            sensor_id,
            track_id,
            ..
        }
        | CenterError::NonFiniteTrack {
            sensor_id,
            track_id,
            ..
        }
        | CenterError::InvalidCovariance {
            sensor_id,
            track_id,
            ..
        } => vec![(*sensor_id, *track_id)],
        CenterError::NonFiniteFusion { tracks, .. }
        | CenterError::NumericalFailure { tracks, .. } => tracks.clone(),
        _ => Vec::new(),
    };
    let member_lines: Vec<u64> = members
        .iter()
        .filter(|m| tracks.iter().any(|t| (t.sensor_id, t.track_id) == **m))
        .filter_map(|m| lines.get(m).copied())
        .collect();
    let first = tracks
        .first()
        .and_then(|t| lines.get(&(t.sensor_id, t.track_id)).copied());
    let line = member_lines.first().copied().or(first).unwrap_or(0);
    let path = path.display().to_string();
    let others = if member_lines.len() > 1 {
        let l: Vec<String> = member_lines.iter().map(|l| l.to_string()).collect();
        format!(" (the local tracks on lines {})", l.join(", "))
    } else {
        String::new()
    };
    anyhow::anyhow!(
        "{path}:{line}: scan {scan}{others}: {:#}",
        with_flag_hint(e)
    )
}
