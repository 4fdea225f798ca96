//! The deterministic core of the service: reports in (in the order the center task
//! takes them), fused instants out. No clock, no I/O but the journal: the live service
//! and `trackfuse replay` drive the same [`Engine`] with the same calls, so a replay of
//! the journal gives the live output byte for byte.
//!
//! # Time, not arrival order
//! Reports are held in *batches*, one per report time (a batch's scan index is the
//! largest scan of its reports). The oldest batch is handed to the center's
//! [`InstantBatcher`] (which fuses the center's update instants up to its time, exactly
//! as `trackfuse fuse` does batch after batch of a file) when every expected sensor is
//! *past* its time:
//! - the sensor has reported a later time, or
//! - its latest report is earlier and its next report (latest + its period, less
//!   [`CLOCK_TOLERANCE`] of a period) is due after the batch's time: it has nothing for it.
//!
//! A sensor whose latest report *is* the batch's time may still be sending that scan, so
//! the batch waits for its next report. A batch is also fused when the latency budget
//! after its first report runs out (the server's timer: [`Engine::release_through`],
//! journaled), when the reports held pass `max_pending_reports` (the oldest batches, at
//! once), and at shutdown ([`Engine::release_all`]). So a silent sensor delays an
//! instant by the budget at most and stalls nobody.
//!
//! # Fusing ahead
//! An instant is complete only when every sensor has reported past it, i.e. when the
//! next scan's first reports come; but its own reports are usually all in well before
//! that (a sensor sends a scan at once, then nothing until the next one). So when the
//! center has nothing else to do ([`Engine::fuse_ahead`], called by the server when
//! its input queue is empty), it fuses the oldest batch on a copy of the center and of
//! the instant batcher ([`FusionCenter::fork`]) and keeps the result aside. When the
//! batch is released, the copy *becomes* the center and its output is published if the
//! batch is the same one it fused (same time, no report added since: reports are only
//! ever added to a batch, and the batcher's result does not depend on their order);
//! otherwise the copy is dropped and the batch is fused as it is now. The output is the
//! same bytes either way (test `fusing_ahead_gives_the_same_output`); only when the
//! work is done moves. It is tried on a batch when every expected sensor has given it
//! at least as many reports as to the batch fused before (how the center guesses that
//! a scan is all in: a guess that only decides whether the work is done early, and at
//! most once per batch and count). A center whose method, rule or bias estimator
//! cannot be copied (a method plugged in from outside without `fork`) never fuses
//! ahead. `fuse_ahead = false` in center.toml turns it off.
//!
//! # Late reports
//! A report at or before the time of the last batch fused is *late*: its instant is
//! gone. It is counted (per sensor) and logged, and journaled, but neither fused nor
//! given to the bias estimator: the estimator pairs local tracks of one fused scan, and a
//! lone late report has no partner there (feeding it would also make the estimate depend
//! on how late it came). Its local track's time still advances, so its next report is
//! judged against it.
//!
//! # Choices where the issue is silent
//! - A report of a local track earlier than that track's previous one is rejected
//!   (`time_backwards`), a second one at the same time too (`duplicate`), as the CSV
//!   reader and the center refuse them.
//! - Reports of different times in one scan index are separate batches (a file's scan
//!   is one batch in `trackfuse fuse`); files whose scans each have one time (what this
//!   project's simulator and trackers write) give the same batches.

use crate::config::CenterSetup;
use crate::message::{encode_association, encode_fused, encode_report, Reason};
use anyhow::{Context, Result};
use rustc_hash::FxHashMap;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::time::{Duration, Instant};
use tokio_util::bytes::Bytes;
use trackfuse::center::instants::InstantBatcher;
use trackfuse::center::{FusionCenter, ScanOutput};
use trackfuse::clock::CLOCK_TOLERANCE;
use trackfuse::types::{Association, FusedTrack, Id, LocalTrack};

/// A report time as a map key (times are finite: checked on parsing).
#[derive(Debug, Clone, Copy, PartialEq)]
struct TimeKey(f64);
impl Eq for TimeKey {}
impl PartialOrd for TimeKey {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for TimeKey {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// The reports of one time not yet fused.
#[derive(Debug)]
struct Batch {
    scan: u32,
    /// The reports by sensor, in sensor-id order, each sensor's in arrival order. At
    /// release they are handed over sensor after sensor: a sensor that sends its tracks
    /// in track-id order (as this project's trackers and `loadgen` do) then gives the
    /// instant batcher rows already in its `(sensor_id, track_id)` order, so it appends
    /// them instead of sorting 200-byte rows on the way to the fusion (measured: about
    /// 0.15 ms of the mean latency of a 4 000-report instant, BENCHMARKS.md). The
    /// batcher's result does not
    /// depend on the order of a batch's rows (their keys are distinct: a second report
    /// of a track at one time is refused), so neither does the output.
    by_sensor: Vec<(Id, Vec<LocalTrack>)>,
    len: usize,
    /// When its first report arrived (for the latency budget and the latency metric).
    first_arrival: Instant,
}

impl Batch {
    /// How many reports sensor `id` gave this batch.
    fn count(&self, id: Id) -> usize {
        self.by_sensor
            .binary_search_by_key(&id, |(s, _)| *s)
            .map_or(0, |i| self.by_sensor[i].1.len())
    }

    /// The batch's reports into `rows` (emptied first), sensor after sensor.
    fn rows_into(&self, rows: &mut Vec<LocalTrack>) {
        rows.clear();
        for (_, r) in &self.by_sensor {
            rows.extend_from_slice(r);
        }
    }
}

/// A new file for what the service records (the journal, `--output`), behind a 1 MiB
/// buffer: with 8 KiB, recording at 300 000 reports/s made the service fall behind
/// (README, "Record and replay"); a crash loses at most the buffer.
pub(crate) fn create_buffered(
    path: &std::path::Path,
) -> std::io::Result<std::io::BufWriter<std::fs::File>> {
    std::fs::File::create(path).map(|f| std::io::BufWriter::with_capacity(1 << 20, f))
}

/// One fused instant's output: its fused tracks (sorted by `fused_id`), then one
/// association per local track (sorted by sensor and track), as the center gave them.
/// Encoding is left to whoever publishes it ([`InstantOutput::chunks`]), so that
/// the TCP service encodes off the center's task while the next reports come in; an
/// instant fused ahead (module docs) is encoded then, while the center waits, so that
/// publishing it is only handing its bytes over.
#[derive(Debug, Clone, Default)]
pub struct InstantOutput {
    pub fused: Vec<FusedTrack>,
    pub associations: Vec<Association>,
    /// The lines of `fused` and `associations`, when encoded ahead ([`Self::encode`]);
    /// else empty.
    encoded: Bytes,
}

impl InstantOutput {
    /// Encode the lines now ([`Self::chunks`] then hands out slices of them).
    pub fn encode(&mut self) {
        let mut v = Vec::with_capacity(256 * (self.fused.len() + self.associations.len()));
        for f in &self.fused {
            encode_fused(f, &mut v);
        }
        for a in &self.associations {
            encode_association(a, &mut v);
        }
        self.encoded = Bytes::from(v);
    }

    /// The instant's NDJSON lines (FORMATS.md "Streaming"), fused tracks first, in
    /// chunks of whole lines, each at least `min_chunk` bytes (at least one line) but
    /// the last (`usize::MAX`: one chunk), each encoded when it is asked for unless
    /// [`Self::encode`] did it before. The chunks joined are the same bytes whatever
    /// `min_chunk` is, and so are the chunks whether encoded before or not.
    pub fn chunks(&self, min_chunk: usize) -> Box<dyn Iterator<Item = Bytes> + Send + '_> {
        let min_chunk = min_chunk.max(1);
        if !self.encoded.is_empty() {
            let bytes = &self.encoded;
            let mut pos = 0;
            return Box::new(std::iter::from_fn(move || {
                if pos >= bytes.len() {
                    return None;
                }
                // the end of the first line that makes the chunk `min_chunk` long
                let from = pos.saturating_add(min_chunk - 1);
                let end = if from >= bytes.len() {
                    bytes.len()
                } else {
                    memchr::memchr(b'\n', &bytes[from..]).map_or(bytes.len(), |i| from + i + 1)
                };
                let chunk = bytes.slice(pos..end);
                pos = end;
                Some(chunk)
            }));
        }
        let cap = min_chunk.min(256 * (self.fused.len() + self.associations.len())) + 512;
        let mut fused = self.fused.iter();
        let mut associations = self.associations.iter();
        Box::new(std::iter::from_fn(move || {
            let mut chunk = Vec::with_capacity(cap);
            while chunk.len() < min_chunk {
                if let Some(f) = fused.next() {
                    encode_fused(f, &mut chunk);
                } else if let Some(a) = associations.next() {
                    encode_association(a, &mut chunk);
                } else {
                    break;
                }
            }
            (!chunk.is_empty()).then(|| Bytes::from(chunk))
        }))
    }
}

/// What [`Engine::accept`] did with a report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Held for its instant.
    Accepted,
    /// Its instant is already fused (module docs): counted, not fused.
    Late,
    /// Refused, with the reason.
    Rejected(Reason),
}

/// Running totals (the server turns them into metrics).
#[derive(Debug, Default, Clone)]
pub struct EngineStats {
    pub accepted: u64,
    pub late: u64,
    pub instants_fused: u64,
    pub batches_released: u64,
    /// Batches fused early because `max_pending_reports` was reached.
    pub forced_by_limit: u64,
    /// Instants the center refused (an error it reported; logged, the service goes on).
    pub center_errors: u64,
    /// Batches fused ahead of their release (module docs, "Fusing ahead").
    pub fused_ahead: u64,
    /// Of those, the ones kept (no report of the batch came after).
    pub ahead_kept: u64,
}

/// A journal line that is not a report: a release the server's timer made (over NATS
/// also the message a center publishes on the input stream's control subject, so that
/// every center reading the stream applies it at the same place).
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct ReleaseLine {
    pub release_through: f64,
}

/// The journal's first line: everything that decides the output.
#[derive(Debug, Serialize, Deserialize)]
pub struct JournalHeader {
    pub trackfuse_journal: u32,
    pub setup: CenterSetup,
}

/// An instant fused ahead of time (module docs, "Fusing ahead"): the center and the
/// instant batcher after the batch `key` of `len` reports, and what fusing it gave.
struct Ahead {
    key: TimeKey,
    len: usize,
    center: FusionCenter,
    batcher: InstantBatcher,
    fused: Fused,
}

/// What handing one batch to the instant batcher gave.
#[derive(Default)]
struct Fused {
    output: Vec<InstantOutput>,
    times: Vec<Duration>,
    instants: u64,
    error: Option<String>,
}

/// Hand one batch (`scan`, `time`, its `rows`) to `batcher` and fuse on `center` what
/// it gives (the one path of a batch, fused ahead or not).
fn fuse_batch(
    center: &mut FusionCenter,
    batcher: &mut InstantBatcher,
    out: &mut ScanOutput,
    scan: u32,
    time: f64,
    rows: &[LocalTrack],
) -> Fused {
    let mut fused = Fused::default();
    let result = batcher.push(scan, time, rows, |s, t, tracks| {
        let t0 = Instant::now();
        center.process_at_into(s, t, tracks, out)?;
        fused.times.push(t0.elapsed());
        fused.instants += 1;
        if !out.fused.is_empty() || !out.associations.is_empty() {
            // taken, not copied: the center refills the emptied buffers
            fused.output.push(InstantOutput {
                fused: std::mem::take(&mut out.fused),
                associations: std::mem::take(&mut out.associations),
                encoded: Bytes::new(),
            });
        }
        Ok::<(), trackfuse::center::CenterError>(())
    });
    if let Err(e) = result {
        fused.error = Some(format!("instant at time {time}: center error: {e}"));
    }
    fused
}

/// The fusion center with its batches (module docs).
pub struct Engine {
    center: FusionCenter,
    batcher: InstantBatcher,
    pending: BTreeMap<TimeKey, Batch>,
    pending_reports: usize,
    max_pending: usize,
    /// Each expected sensor's period and latest report time.
    sensors: BTreeMap<Id, (f64, Option<f64>)>,
    /// Each local track's latest report time (one lookup per report: `FxHashMap`, the
    /// standard library's SipHash was about 3 % of the service's CPU).
    track_time: FxHashMap<(Id, Id), f64>,
    /// The rows of the batch being released, sensor after sensor (reused).
    release_rows: Vec<LocalTrack>,
    /// The time of the last batch fused.
    released_through: Option<f64>,
    journal: Option<std::io::BufWriter<std::fs::File>>,
    scan_out: ScanOutput,
    line: Vec<u8>,
    /// The fused instants not yet taken ([`Engine::take_output`]).
    output: Vec<InstantOutput>,
    /// Each fused instant's time in the center, not yet taken.
    pub fusion_times: Vec<Duration>,
    /// The first-arrival time of each batch released, not yet taken.
    pub released_arrivals: Vec<Instant>,
    pub stats: EngineStats,
    /// Center errors not yet logged.
    pub errors: Vec<String>,
    /// Whether to fuse ahead (module docs); off for good once the center cannot be
    /// copied.
    ahead_on: bool,
    /// The instant fused ahead, if any.
    ahead: Option<Box<Ahead>>,
    /// The batch (time, count) last fused ahead: not tried twice.
    ahead_tried: Option<(TimeKey, usize)>,
    /// Each expected sensor's report count in the batch fused last (sensor-id order).
    last_counts: Vec<(Id, usize)>,
    /// The center and batcher a kept instant fused ahead replaced, freed at the next
    /// fusing ahead (off the moment the instant is published).
    retired: Option<Box<(FusionCenter, InstantBatcher)>>,
}

impl Engine {
    /// A center for `setup`; with `journal`, every accepted line and timer release is
    /// written there (after a header with `setup`) before it is processed.
    pub fn new(setup: &CenterSetup, journal: Option<&std::path::Path>) -> Result<Engine> {
        let center = FusionCenter::new(&setup.fusion, setup.sensors.as_deref())?;
        if center.lacks_truth() {
            anyhow::bail!(
                "fusion: the method or rule needs the true association, which a live service does not have"
            );
        }
        let batcher = InstantBatcher::new(setup.period(), &setup.clocks());
        let journal = match journal {
            Some(p) => {
                let mut w = create_buffered(p)
                    .with_context(|| format!("creating journal {}", p.display()))?;
                let header = JournalHeader {
                    trackfuse_journal: 1,
                    setup: setup.clone(),
                };
                serde_json::to_writer(&mut w, &header)?;
                w.write_all(b"\n")?;
                Some(w)
            }
            None => None,
        };
        Ok(Engine {
            center,
            batcher,
            pending: BTreeMap::new(),
            pending_reports: 0,
            max_pending: setup.max_pending_reports,
            sensors: setup
                .expected
                .iter()
                .map(|s| (s.id, (s.period, None)))
                .collect(),
            track_time: FxHashMap::default(),
            release_rows: Vec::new(),
            released_through: None,
            journal,
            scan_out: ScanOutput::default(),
            line: Vec::new(),
            output: Vec::new(),
            fusion_times: Vec::new(),
            released_arrivals: Vec::new(),
            stats: EngineStats::default(),
            errors: Vec::new(),
            ahead_on: true,
            ahead: None,
            ahead_tried: None,
            last_counts: Vec::new(),
            retired: None,
        })
    }

    /// Turn fusing ahead (module docs) on or off (on by default).
    pub fn set_fuse_ahead(&mut self, on: bool) {
        self.ahead_on = on;
        if !on {
            self.ahead = None;
        }
    }

    /// Whether [`Engine::fuse_ahead`] would fuse now: on, the oldest batch looks all
    /// in (every expected sensor has given it at least as many reports as the batch
    /// fused before) and was not fused ahead with its present count. Cheap.
    pub fn wants_fuse_ahead(&self) -> bool {
        if !self.ahead_on || self.last_counts.is_empty() {
            return false;
        }
        let Some((&key, batch)) = self.pending.first_key_value() else {
            return false;
        };
        if self.ahead_tried == Some((key, batch.len)) {
            return false;
        }
        self.last_counts
            .iter()
            .all(|&(id, before)| batch.count(id) >= before)
    }

    /// If the oldest batch looks all in (module docs, "Fusing ahead") and was not
    /// fused ahead as it is, fuse it on a copy of the center. Returns whether it did.
    pub fn fuse_ahead(&mut self) -> bool {
        if !self.wants_fuse_ahead() {
            return false;
        }
        let Some((&key, batch)) = self.pending.first_key_value() else {
            return false;
        };
        self.ahead_tried = Some((key, batch.len));
        // freed here, not when it was replaced (that is when the instant is published)
        self.retired = None;
        let Some(mut center) = self.center.fork() else {
            self.ahead_on = false;
            return false;
        };
        let mut batcher = self.batcher.clone();
        batch.rows_into(&mut self.release_rows);
        let mut fused = fuse_batch(
            &mut center,
            &mut batcher,
            &mut self.scan_out,
            batch.scan,
            key.0,
            &self.release_rows,
        );
        for o in &mut fused.output {
            o.encode();
        }
        self.stats.fused_ahead += 1;
        self.ahead = Some(Box::new(Ahead {
            key,
            len: batch.len,
            center,
            batcher,
            fused,
        }));
        true
    }

    /// Whether `sensor_id` is expected.
    pub fn knows(&self, sensor_id: Id) -> bool {
        self.sensors.contains_key(&sensor_id)
    }

    /// Take one valid report (parsed by [`crate::message::parse_report`], of an
    /// expected sensor) that arrived at `arrival`, then fuse every batch that is
    /// complete.
    pub fn accept(&mut self, track: LocalTrack, arrival: Instant) -> Result<Verdict> {
        let key = (track.sensor_id, track.track_id);
        if let Some(&prev) = self.track_time.get(&key) {
            if track.time < prev {
                return Ok(Verdict::Rejected(Reason::TimeBackwards));
            }
            if track.time == prev {
                return Ok(Verdict::Rejected(Reason::Duplicate));
            }
        }
        if let Some(j) = self.journal.as_mut() {
            self.line.clear();
            encode_report(&track, &mut self.line);
            self.line.push(b'\n');
            j.write_all(&self.line).context("writing the journal")?;
        }
        self.track_time.insert(key, track.time);
        if let Some((_, last)) = self.sensors.get_mut(&track.sensor_id) {
            *last = Some(last.map_or(track.time, |l: f64| l.max(track.time)));
        }
        if self.released_through.is_some_and(|r| track.time <= r) {
            self.stats.late += 1;
            self.release_ready();
            return Ok(Verdict::Late);
        }
        self.stats.accepted += 1;
        let batch = self.pending.entry(TimeKey(track.time)).or_insert(Batch {
            scan: track.scan,
            by_sensor: Vec::new(),
            len: 0,
            first_arrival: arrival,
        });
        batch.scan = batch.scan.max(track.scan);
        let s = match batch
            .by_sensor
            .binary_search_by_key(&track.sensor_id, |(s, _)| *s)
        {
            Ok(s) => s,
            Err(s) => {
                batch.by_sensor.insert(s, (track.sensor_id, Vec::new()));
                s
            }
        };
        batch.by_sensor[s].1.push(track);
        batch.len += 1;
        self.pending_reports += 1;
        while self.pending_reports > self.max_pending {
            self.stats.forced_by_limit += 1;
            self.release_first();
        }
        self.release_ready();
        Ok(Verdict::Accepted)
    }

    /// Whether every expected sensor is past `time` (module docs).
    fn complete(&self, time: f64) -> bool {
        self.sensors.values().all(|&(period, last)| match last {
            None => false,
            Some(l) => l > time || (l < time && time < l + period * (1.0 - CLOCK_TOLERANCE)),
        })
    }

    /// Fuse the complete batches, oldest first, up to the first incomplete one.
    fn release_ready(&mut self) {
        while let Some((k, _)) = self.pending.first_key_value() {
            if !self.complete(k.0) {
                break;
            }
            self.release_first();
        }
    }

    /// The first-arrival time of the oldest batch not yet fused (the server's budget
    /// timer runs from it) and its time.
    pub fn oldest_pending(&self) -> Option<(f64, Instant)> {
        self.pending
            .first_key_value()
            .map(|(k, b)| (k.0, b.first_arrival))
    }

    /// The time of the newest batch not yet fused.
    pub fn newest_pending(&self) -> Option<f64> {
        self.pending.last_key_value().map(|(k, _)| k.0)
    }

    /// The earliest first-arrival among the batches not yet fused.
    pub fn earliest_arrival(&self) -> Option<(f64, Instant)> {
        self.pending
            .iter()
            .min_by_key(|(_, b)| b.first_arrival)
            .map(|(k, b)| (k.0, b.first_arrival))
    }

    /// Fuse every batch up to and including `time` (the latency budget ran out for it);
    /// journaled.
    pub fn release_through(&mut self, time: f64) -> Result<()> {
        if let Some(j) = self.journal.as_mut() {
            serde_json::to_writer(
                &mut *j,
                &ReleaseLine {
                    release_through: time,
                },
            )?;
            j.write_all(b"\n").context("writing the journal")?;
        }
        while self
            .pending
            .first_key_value()
            .is_some_and(|(k, _)| k.0 <= time)
        {
            self.release_first();
        }
        self.release_ready();
        Ok(())
    }

    /// Fuse every batch held (shutdown, end of a replay) and flush the journal.
    pub fn release_all(&mut self) -> Result<()> {
        while !self.pending.is_empty() {
            self.release_first();
        }
        self.flush_journal()
    }

    /// Flush the journal to the file.
    pub fn flush_journal(&mut self) -> Result<()> {
        if let Some(j) = self.journal.as_mut() {
            j.flush().context("flushing the journal")?;
        }
        Ok(())
    }

    /// Hand the oldest batch to the instant batcher and fuse what it gives.
    fn release_first(&mut self) {
        let Some((key, batch)) = self.pending.pop_first() else {
            return;
        };
        self.pending_reports -= batch.len;
        self.released_through = Some(key.0);
        self.stats.batches_released += 1;
        self.released_arrivals.push(batch.first_arrival);
        self.last_counts.clear();
        self.last_counts
            .extend(self.sensors.keys().map(|&id| (id, batch.count(id))));
        let fused = match self.ahead.take() {
            // the same batch: nothing was added to it since (module docs)
            Some(a) if a.key == key && a.len == batch.len => {
                let a = *a;
                let center = std::mem::replace(&mut self.center, a.center);
                let batcher = std::mem::replace(&mut self.batcher, a.batcher);
                self.retired = Some(Box::new((center, batcher)));
                self.stats.ahead_kept += 1;
                a.fused
            }
            _ => {
                batch.rows_into(&mut self.release_rows);
                fuse_batch(
                    &mut self.center,
                    &mut self.batcher,
                    &mut self.scan_out,
                    batch.scan,
                    key.0,
                    &self.release_rows,
                )
            }
        };
        self.stats.instants_fused += fused.instants;
        self.output.extend(fused.output);
        self.fusion_times.extend(fused.times);
        if let Some(e) = fused.error {
            self.stats.center_errors += 1;
            self.errors.push(e);
        }
    }

    /// The instants fused since the last call (those with output lines), oldest first.
    pub fn take_output(&mut self) -> Vec<InstantOutput> {
        std::mem::take(&mut self.output)
    }

    /// Whether fused instants wait to be taken.
    pub fn has_output(&self) -> bool {
        !self.output.is_empty()
    }

    /// [`Engine::take_output`] encoded, one chunk of lines per instant.
    pub fn take_output_lines(&mut self) -> Vec<Vec<u8>> {
        self.take_output()
            .iter()
            .map(|o| {
                o.chunks(usize::MAX)
                    .next()
                    .map_or_else(Vec::new, |b| b.to_vec())
            })
            .collect()
    }

    /// Global tracks the center holds.
    pub fn live_global_tracks(&self) -> usize {
        self.center.globals().len()
    }

    /// Reports held in batches not yet fused.
    pub fn pending_reports(&self) -> usize {
        self.pending_reports
    }
}

/// Replay a journal: the same engine fed the same lines, every batch fused at the end
/// (as at shutdown); the output lines written to `out`. Returns the engine's totals.
pub fn replay(journal: &std::path::Path, out: &mut dyn Write) -> Result<EngineStats> {
    use std::io::BufRead;
    let f = std::fs::File::open(journal)
        .with_context(|| format!("opening journal {}", journal.display()))?;
    let mut lines = std::io::BufReader::new(f).lines();
    let first = lines
        .next()
        .with_context(|| format!("{}: empty journal", journal.display()))??;
    let header: JournalHeader = serde_json::from_str(&first)
        .with_context(|| format!("{}:1: not a trackfuse journal header", journal.display()))?;
    let mut engine = Engine::new(&header.setup, None)?;
    let now = Instant::now();
    for (i, line) in lines.enumerate() {
        let line = line?;
        let at = || format!("{}:{}", journal.display(), i + 2);
        // a release line is the only one that starts with its key (reports start with
        // `scan`, as `encode_report` writes them)
        let release = line
            .starts_with("{\"release_through\"")
            .then(|| serde_json::from_str::<ReleaseLine>(&line).ok())
            .flatten();
        if let Some(r) = release {
            engine.release_through(r.release_through)?;
        } else {
            let t = crate::message::parse_report(line.as_bytes())
                .map_err(|r| anyhow::anyhow!("{}: {}: {}", at(), r.reason, r.detail))?;
            engine.accept(t, now)?;
        }
        for chunk in engine.take_output_lines() {
            out.write_all(&chunk)?;
        }
    }
    engine.release_all()?;
    for chunk in engine.take_output_lines() {
        out.write_all(&chunk)?;
    }
    for e in &engine.errors {
        eprintln!("warning: {e}");
    }
    Ok(engine.stats.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ServiceConfig;
    use trackfuse::types::{StateCov, StateVec};

    fn engine() -> Engine {
        let cfg = ServiceConfig::from_toml(
            "[[sensors]]\nid = 0\nperiod = 1.0\n[[sensors]]\nid = 1\nperiod = 2.0\n\
             [fusion]\nmethod = \"chi2-gnn\"\nrule = \"bc\"\nbias = \"none\"\n",
        )
        .expect("config");
        Engine::new(&cfg.center_setup().expect("setup"), None).expect("engine")
    }

    /// Three sensors of period 1 s, the default fusion without bias estimation.
    fn three_sensors() -> CenterSetup {
        ServiceConfig::from_toml(
            "[[sensors]]\nid = 0\nperiod = 1.0\n[[sensors]]\nid = 1\nperiod = 1.0\n\
             [[sensors]]\nid = 2\nperiod = 1.0\n[fusion]\nbias = \"none\"\n",
        )
        .expect("config")
        .center_setup()
        .expect("setup")
    }

    fn report(sensor: Id, k: u32) -> LocalTrack {
        LocalTrack {
            scan: k,
            time: f64::from(k),
            sensor_id: sensor,
            track_id: 1,
            state: StateVec::new(10.0 * f64::from(k), 10.0, 0.0, 0.0),
            cov: StateCov::identity() * 25.0,
        }
    }

    #[test]
    fn a_sensor_never_heard_from_holds_every_instant_until_the_budget_runs_out() {
        let mut e = engine();
        let now = Instant::now();
        for k in 0..6 {
            assert_eq!(
                e.accept(report(0, k), now).expect("accept"),
                Verdict::Accepted
            );
        }
        // sensor 1 has not reported: not past any time, whatever its period says
        assert_eq!(e.stats.instants_fused, 0);
        assert_eq!(e.pending_reports(), 6);
        // the budget ran out for time 2: those batches are fused, the rest still wait
        e.release_through(2.0).expect("release");
        assert_eq!(e.stats.batches_released, 3);
        assert_eq!(e.pending_reports(), 3);
    }

    #[test]
    fn after_a_budget_release_a_sensor_is_past_the_times_before_its_next_report() {
        let mut e = engine();
        let now = Instant::now();
        let at = |sensor, k, time| LocalTrack {
            time,
            ..report(sensor, k)
        };
        // sensor 1 (period 2) at 0.5, sensor 0 (period 1) at 0, 1, 2
        e.accept(at(1, 0, 0.5), now).expect("accept");
        for k in 0..3 {
            e.accept(report(0, k), now).expect("accept");
        }
        // time 0 is past for both; 0.5 is sensor 1's latest: it may still be sending it
        assert_eq!(e.stats.batches_released, 1);
        // the budget runs out for 0.5; then 1 is past for sensor 1 too (its next report
        // is due at 2.5), 2 waits for sensor 0's next report
        e.release_through(0.5).expect("release");
        assert_eq!(e.stats.batches_released, 3);
        e.accept(report(0, 3), now).expect("accept");
        assert_eq!(e.stats.batches_released, 4);
        // time 3 is after sensor 1's due report (2.5): it waits for it
        e.accept(report(0, 4), now).expect("accept");
        assert_eq!(e.stats.batches_released, 4);
        e.accept(at(1, 2, 2.5), now).expect("accept");
        assert_eq!(e.stats.batches_released, 4, "2.5 is sensor 1's latest");
        e.accept(at(1, 4, 4.5), now).expect("accept");
        // 2.5 and 3 are past; 4 is sensor 0's latest
        assert_eq!(e.stats.batches_released, 6);
        assert_eq!(e.stats.late, 0);
    }

    /// A batch's reports go to the center sensor after sensor, each sensor's in arrival
    /// order ([`Batch`]): the output must not depend on how the sensors' reports
    /// interleave or in which track order they come.
    #[test]
    fn the_output_does_not_depend_on_the_arrival_order_within_a_time() {
        let setup = three_sensors();
        let reports = |k: u32| -> Vec<LocalTrack> {
            let mut v = Vec::new();
            for sensor in 0..3i64 {
                for target in 0..5i64 {
                    let off = sensor as f64 * 3.0 - (target % 2) as f64;
                    v.push(LocalTrack {
                        scan: k,
                        time: f64::from(k),
                        sensor_id: sensor,
                        track_id: 10 + target * 7 % 5 + sensor,
                        state: StateVec::new(
                            1000.0 * target as f64 + 20.0 * f64::from(k) + off,
                            20.0,
                            -500.0 * target as f64 + off,
                            0.0,
                        ),
                        cov: StateCov::identity() * (25.0 + sensor as f64),
                    });
                }
            }
            v
        };
        let run = |order: &dyn Fn(&mut Vec<LocalTrack>)| -> Vec<Vec<u8>> {
            let mut e = Engine::new(&setup, None).expect("engine");
            let now = Instant::now();
            let mut lines = Vec::new();
            for k in 0..6 {
                let mut r = reports(k);
                order(&mut r);
                for t in r {
                    assert_eq!(e.accept(t, now).expect("accept"), Verdict::Accepted);
                }
                lines.extend(e.take_output_lines());
            }
            e.release_all().expect("release");
            lines.extend(e.take_output_lines());
            lines
        };
        let by_sensor = run(&|_| {});
        // the sensors interleaved, the last sensor first, each one's tracks backwards
        let shuffled = run(&|r| {
            r.sort_by_key(|t| {
                (
                    std::cmp::Reverse(t.track_id),
                    std::cmp::Reverse(t.sensor_id),
                )
            })
        });
        assert!(by_sensor.len() >= 5, "{} instants", by_sensor.len());
        assert!(by_sensor.iter().all(|l| !l.is_empty()));
        assert_eq!(by_sensor, shuffled);
    }

    /// Fusing ahead (module docs) changes when the work is done, never the output:
    /// with a batch fused ahead after every report (as often as the engine allows),
    /// including one whose last report comes after it was fused ahead (a target seen
    /// first by sensor 2 at time 3, its report sent after sensor 0's next scan began),
    /// the output is the same bytes as with fusing ahead off.
    #[test]
    fn fusing_ahead_gives_the_same_output() {
        let setup = three_sensors();
        let report = |k: u32, sensor: i64, target: i64| {
            let off = sensor as f64 * 3.0 - (target % 2) as f64 + f64::from(k % 3);
            LocalTrack {
                scan: k,
                time: f64::from(k),
                sensor_id: sensor,
                track_id: 10 * sensor + target,
                state: StateVec::new(
                    1000.0 * target as f64 + 20.0 * f64::from(k) + off,
                    20.0,
                    -500.0 * target as f64 + off,
                    0.0,
                ),
                cov: StateCov::identity() * (25.0 + sensor as f64),
            }
        };
        // (report, deliver after it the held-back straggler)
        let mut stream = Vec::new();
        for k in 0..9u32 {
            for sensor in 0..3i64 {
                for target in 0..5i64 {
                    stream.push(report(k, sensor, target));
                    if k == 4 && sensor == 0 && target == 0 {
                        // the straggler of time 3
                        stream.push(report(3, 2, 5));
                    }
                }
            }
        }
        let run = |ahead: bool| -> (Vec<Vec<u8>>, EngineStats) {
            let mut e = Engine::new(&setup, None).expect("engine");
            e.set_fuse_ahead(ahead);
            let now = Instant::now();
            let mut lines = Vec::new();
            for t in &stream {
                assert_eq!(e.accept(*t, now).expect("accept"), Verdict::Accepted);
                e.fuse_ahead();
                lines.extend(e.take_output_lines());
            }
            e.release_all().expect("release");
            lines.extend(e.take_output_lines());
            (lines, e.stats.clone())
        };
        let (off, off_stats) = run(false);
        let (on, on_stats) = run(true);
        assert_eq!(off_stats.fused_ahead, 0);
        assert!(off.len() >= 8, "{} instants", off.len());
        assert_eq!(on, off);
        assert_eq!(on_stats.instants_fused, off_stats.instants_fused);
        // fused ahead: the batches of times 1 to 8 but 0 (no batch before it to
        // compare with) and 4 (sensor 2 gave it 5 reports, 6 to the batch before: not
        // all in by the guess), the one of time 3 twice (5 reports of sensor 2, then
        // the straggler's 6th), its first result dropped
        assert_eq!(on_stats.fused_ahead, 8, "{on_stats:?}");
        assert_eq!(on_stats.ahead_kept, 7, "{on_stats:?}");
    }

    /// An instant encoded ahead ([`InstantOutput::encode`]) gives the same chunks, at
    /// every chunk size, as one encoded chunk by chunk.
    #[test]
    fn an_instant_encoded_ahead_gives_the_same_chunks() {
        let mut e = engine();
        let now = Instant::now();
        for k in 0..4 {
            for sensor in 0..2 {
                let mut r = report(sensor, k);
                r.track_id = 3 + sensor;
                e.accept(r, now).expect("accept");
            }
        }
        e.release_all().expect("release");
        let outputs = e.take_output();
        assert!(outputs.len() >= 3);
        for o in outputs {
            let whole: Vec<u8> = o.chunks(usize::MAX).flat_map(|b| b.to_vec()).collect();
            assert!(whole.ends_with(b"\n") && whole.len() > 200);
            let mut ahead = o.clone();
            ahead.encode();
            for size in [
                0,
                1,
                7,
                100,
                150,
                301,
                whole.len() - 1,
                whole.len(),
                32 * 1024,
                usize::MAX,
            ] {
                let a: Vec<Bytes> = o.chunks(size).collect();
                let b: Vec<Bytes> = ahead.chunks(size).collect();
                assert_eq!(a, b, "chunk size {size}");
                assert_eq!(a.concat(), whole, "chunk size {size}");
                assert!(a.iter().all(|c| c.ends_with(b"\n")));
            }
        }
    }
}
