//! `trackfuse bench`: end-to-end throughput figures for BENCHMARKS.md.

use crate::common::{load_scenario, scenario_input};
use crate::config::{FusionFlags, TrackerFlags};
use crate::output::{Outputs, SIMULATE_OUTPUTS};
use crate::simulate::simulate_to_dir;
use anyhow::Result;
use clap::{Args, Subcommand};
use std::path::PathBuf;
use std::time::Instant;
use trackfuse::center::FusionCenter;
use trackfuse::clock::ReportTimes;
use trackfuse::local::{track_sensors, MultiSensorTracker};
use trackfuse::pipeline::known_targets;
use trackfuse::sim::synthetic_local_tracks;
use trackfuse::types::LocalTrack;

#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchWhat,
}

#[derive(Subcommand, Debug)]
pub enum BenchWhat {
    /// Simulation throughput: generate and write a scenario (default: the built-in
    /// grid-bench, 1 000 targets x 4 radars x 1 000 scans with clutter).
    Simulate {
        /// Scenario file or built-in name.
        #[arg(default_value = "grid-bench")]
        scenario: String,
        /// Output directory (files are written for real, then left there).
        #[arg(long, default_value = "out/bench-sim")]
        out: PathBuf,
    },
    /// Local-tracking throughput: simulate in memory, then time one tracker per sensor
    /// (default: the built-in track-bench, 100 targets x 4 radars with 169 false alarms
    /// per sensor-scan, EKF + GNN with M-of-N initiation).
    Track {
        /// Scenario file or built-in name.
        #[arg(default_value = "track-bench")]
        scenario: String,
        #[command(flatten)]
        tracker: TrackerFlags,
        /// Repetitions (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: u32,
        /// Also time each step of the trackers' scans in as many more runs, with the
        /// step clocks on (not the timed runs), and print those of the fastest in ns per
        /// measurement, then what the steps worked on in that run, per measurement (as
        /// `track-sweep --steps` does).
        #[arg(long)]
        steps: bool,
    },
    /// Local tracking's cost per measurement against the number of targets at a fixed
    /// clutter density (BENCHMARKS.md, issue 13 point 2): the built-in grid-bench with
    /// each count of --targets on its 1 km grid (side L = ceil(sqrt N) km), clutter of
    /// 0.08 per km^2 per scan over the grid plus L/2 on each side, the four sensors
    /// 10 km beyond the grid's corners; per size the tracks kept per measurement, the
    /// time per measurement and per track kept (one thread, after an untimed run, best
    /// of --repeat runs, or of as many as fill about 0.5 s for a size that takes under
    /// 0.2 s), and the cost per measurement relative to the first size; with --steps,
    /// tables of where that time goes and of what the steps worked on.
    TrackSweep {
        #[command(flatten)]
        tracker: TrackerFlags,
        /// Target counts (comma-separated), the first the reference.
        #[arg(long, value_delimiter = ',', default_value = "100,1000,10000,30000")]
        targets: Vec<usize>,
        /// The sensors: `radar` (grid-bench's range-bearing radars, 20 m and 0.002 rad:
        /// the cross-range error grows with the distance, which grows with the grid) or
        /// `position` (x-y sensors of 50 m on each axis: an accuracy that does not).
        #[arg(long, default_value = "radar", value_parser = ["radar", "position"])]
        sensors: String,
        /// Scans simulated and tracked per size.
        #[arg(long, default_value_t = 30)]
        scans: u32,
        /// Repetitions per size at least (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: u32,
        /// Also time each step of the trackers' scans (predict, convert, gate,
        /// associate, update, tentative, delete, initiate, report) in as many more runs
        /// per size, with the step clocks on (not the timed runs), and print those of the
        /// fastest in ns per measurement after the table, then what the steps worked on
        /// in that run, per measurement (gated pairs, tentative tracks and their gated
        /// pairs, measurements left for initiation, accepted pairs, tracks started).
        #[arg(long)]
        steps: bool,
    },
    /// Fusion-center throughput on synthetic local tracks: targets on a 1 km grid, each
    /// seen by every sensor with 20 m / 5 m/s noise; local tracks per second per core at
    /// TARGETS x SENSORS, and the time per scan for each size of --sweep.
    Fuse {
        #[command(flatten)]
        fusion: FusionFlags,
        /// Targets for the throughput figure.
        #[arg(long, default_value_t = 1000)]
        targets: usize,
        /// Sensors (each reports every target).
        #[arg(long, default_value_t = 4)]
        sensors: usize,
        /// Scans timed for the throughput figure.
        #[arg(long, default_value_t = 50)]
        scans: u32,
        /// Local tracks per scan of the scaling sweep (comma-separated).
        #[arg(long, value_delimiter = ',', default_value = "100,1000,10000,100000")]
        sweep: Vec<usize>,
    },
    /// What a user gets on a folder of radar files with no flags: runs `track` and
    /// `fuse` with their defaults, then prints fused GOSPA (c = 500 m, p = 1), missed and
    /// false tracks per scan, fused RMSE, each radar's local GOSPA and RMSE, and the
    /// fused RMSE against the best radar's (`--reference` scores another tool's output
    /// folder beside it).
    Real(crate::bench_real::RealArgs),
    /// Bias-estimator throughput: simulate and track the scenario (default: the built-in
    /// bias-bench, 500 targets and 3 biased radars) in memory, then time the whole fusion
    /// center over the run with the scenario's bias estimator and with none, on one
    /// thread, in the thread's CPU time (best of --repeat); the difference is the
    /// estimator's cost, printed as local tracks per second per core for the estimator
    /// and for the whole center.
    Bias {
        /// Scenario file or built-in name.
        #[arg(default_value = "bias-bench")]
        scenario: String,
        /// Repetitions of each timing (the best is reported).
        #[arg(long, default_value_t = 5)]
        repeat: u32,
    },
    /// CSV throughput: read DATA/measurements.csv (with DATA/sensors.csv) and
    /// LOCAL_TRACKS with the validating streams, then write the rows read with the
    /// writers into a sink that counts the bytes; MB/s of this thread's CPU time (best of
    /// --repeat).
    Io {
        /// Directory holding sensors.csv and measurements.csv.
        #[arg(long, default_value = "out/sim")]
        data: PathBuf,
        /// local_tracks.csv (default: none).
        #[arg(long)]
        local_tracks: Option<PathBuf>,
        /// Repetitions (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: u32,
    },
}

/// Peak resident set size of this process (kB), from /proc on Linux.
fn peak_rss_kb() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

pub fn run(args: &BenchArgs) -> Result<()> {
    match &args.what {
        BenchWhat::Simulate { scenario, out } => {
            let sc = load_scenario(Some(scenario))?.0.scenario;
            let input = scenario_input(Some(scenario));
            let inputs: Vec<&std::path::Path> = input.iter().map(|p| p.as_path()).collect();
            // the simulated files, without the scenario copy
            let mut outs = Outputs::new(out, &SIMULATE_OUTPUTS[1..], &inputs)?;
            let t0 = Instant::now();
            let stats = simulate_to_dir(&sc, 0, &mut outs)?;
            outs.finish();
            let secs = t0.elapsed().as_secs_f64();
            let rows = stats.measurement_rows + stats.truth_rows;
            say!("scenario            {}", sc.name);
            say!("scans x targets     {} x {}", sc.scans, sc.target_count());
            say!("measurement rows    {}", stats.measurement_rows);
            say!("truth rows          {}", stats.truth_rows);
            say!("wall time           {secs:.3} s");
            say!(
                "measurement rows/s  {:.0}",
                stats.measurement_rows as f64 / secs
            );
            say!("all rows/s          {:.0}", rows as f64 / secs);
            if let Some(kb) = peak_rss_kb() {
                say!("peak RSS            {:.1} MiB", kb as f64 / 1024.0);
            }
        }
        BenchWhat::Track {
            scenario,
            tracker,
            repeat,
            steps,
        } => bench_track(scenario, tracker, *repeat, *steps)?,
        BenchWhat::TrackSweep {
            tracker,
            targets,
            sensors,
            scans,
            repeat,
            steps,
        } => bench_track_sweep(
            tracker,
            targets,
            sensors == "position",
            *scans,
            *repeat,
            *steps,
        )?,
        BenchWhat::Fuse {
            fusion,
            targets,
            sensors,
            scans,
            sweep,
        } => bench_fuse(fusion, *targets, *sensors, *scans, sweep)?,
        BenchWhat::Real(a) => crate::bench_real::run(a)?,
        BenchWhat::Bias { scenario, repeat } => bench_bias(scenario, *repeat)?,
        BenchWhat::Io {
            data,
            local_tracks,
            repeat,
        } => bench_io(data, local_tracks.as_deref(), *repeat)?,
    }
    Ok(())
}

/// A sink that counts the bytes written and keeps none (the writers' formatting cost
/// without the disk's).
#[derive(Default)]
struct CountingSink(u64);

impl std::io::Write for CountingSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0 += buf.len() as u64;
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl trackfuse::io::Sink for CountingSink {
    type Done = u64;
    fn done(self) -> std::io::Result<u64> {
        Ok(self.0)
    }
}

/// The best of `repeat` runs of `f` in this thread's CPU seconds, and `f`'s last value.
fn best_cpu<T>(repeat: u32, mut f: impl FnMut() -> Result<T>) -> Result<(f64, T)> {
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..repeat.max(1) {
        let t0 = cpu_time::ThreadTime::now();
        let v = f()?;
        best = best.min(t0.elapsed().as_secs_f64());
        last = Some(v);
    }
    let v = last.ok_or_else(|| anyhow::anyhow!("no run"))?;
    Ok((best, v))
}

fn print_io(what: &str, bytes: u64, rows: usize, secs: f64) -> Result<()> {
    say!(
        "{what:<28} {:>8.1} MB  {rows:>9} rows  {:>7.3} s  {:>7.0} MB/s  {:>6.2} M rows/s",
        bytes as f64 / 1e6,
        secs,
        bytes as f64 / 1e6 / secs,
        rows as f64 / 1e6 / secs
    );
    Ok(())
}

fn bench_io(
    data: &std::path::Path,
    local_tracks: Option<&std::path::Path>,
    repeat: u32,
) -> Result<()> {
    use trackfuse::io::{
        read_sensors, LocalTrackStream, LocalTrackWriter, MeasurementStream, MeasurementWriter,
    };
    let sensors = read_sensors(&data.join("sensors.csv"))?;
    bench_file(
        repeat,
        &data.join("measurements.csv"),
        |p| MeasurementStream::open(p, Some(&sensors)),
        |s, buf| s.next_scan(buf),
        |rows| {
            let mut w = MeasurementWriter::new(CountingSink::default(), &sensors)?;
            for m in rows {
                w.write(m)?;
            }
            Ok(w.finish()?)
        },
    )?;
    if let Some(path) = local_tracks {
        bench_file(
            repeat,
            path,
            LocalTrackStream::open,
            |s, buf| s.next_scan(buf),
            |rows| {
                let mut w = LocalTrackWriter::new(CountingSink::default())?;
                for t in rows {
                    w.write(t)?;
                }
                Ok(w.finish()?)
            },
        )?;
    }
    Ok(())
}

/// One file of `bench io`: read it with the validating stream scan by scan into one
/// reused buffer (as `track` and `fuse` read), the quick pass, then write the rows read
/// into a counting sink; best of `repeat` in this thread's CPU time, one line each.
fn bench_file<S, T>(
    repeat: u32,
    path: &std::path::Path,
    open: impl Fn(&std::path::Path) -> Result<S, trackfuse::io::InputError>,
    next: impl Fn(&mut S, &mut Vec<T>) -> Result<Option<u32>, trackfuse::io::InputError>,
    write: impl Fn(&[T]) -> Result<u64>,
) -> Result<()> {
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let bytes = std::fs::metadata(path)?.len();
    let (secs, n) = best_cpu(repeat, || {
        let mut s = open(path)?;
        let mut buf = Vec::new();
        let mut n = 0;
        while next(&mut s, &mut buf)?.is_some() {
            n += buf.len();
        }
        Ok(n)
    })?;
    print_io(&format!("read {name}"), bytes, n, secs)?;
    let (secs, n) = best_cpu(repeat, || quick_rows(path))?;
    print_io(&format!("quick pass {name}"), bytes, n, secs)?;
    let mut rows = Vec::new();
    let mut s = open(path)?;
    let mut buf = Vec::new();
    while next(&mut s, &mut buf)?.is_some() {
        rows.append(&mut buf);
    }
    let (secs, written) = best_cpu(repeat, || write(&rows))?;
    print_io(&format!("write {name}"), written, rows.len(), secs)?;
    Ok(())
}

/// The quick pass of `track` and `fuse` over `path` (`trackfuse::io::quick_report_times`):
/// the number of data rows it read; an error if it sends the file to the
/// validating stream instead (then it measures nothing).
fn quick_rows(path: &std::path::Path) -> Result<usize> {
    let times = trackfuse::io::quick_report_times(path)?.ok_or_else(|| {
        anyhow::anyhow!(
            "{}: the quick pass does not read this file (the validating stream does)",
            path.display()
        )
    })?;
    Ok(times.1 as usize)
}

/// `bench bias`: see [`BenchWhat::Bias`].
fn bench_bias(scenario: &str, repeat: u32) -> Result<()> {
    let (config, _) = load_scenario(Some(scenario))?;
    let sc = &config.scenario;
    let sim = trackfuse::sim::simulate(sc, 0);
    let known = known_targets(&sim.truth);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let local = pool.install(|| {
        track_sensors(
            &sim.sensors,
            &sim.measurements,
            &config.tracker,
            Some(sc.process_noise),
            &known,
            sc.seed,
            0,
        )
    })?;
    let with = config.fusion.clone();
    let estimator = match with.bias_choice(Some(&sim.sensors)) {
        trackfuse::center::bias::BiasChoice::Estimator(name) => name.to_string(),
        trackfuse::center::bias::BiasChoice::Off(why) => {
            anyhow::bail!("scenario {}: no bias estimator runs ({why:?})", sc.name)
        }
    };
    let mut without = with.clone();
    without.bias = None;
    let time = |cfg: &trackfuse::center::FusionConfig| -> Result<(f64, usize)> {
        let mut best = f64::INFINITY;
        let mut fused = 0;
        for _ in 0..repeat.max(1) {
            // the pool thread's CPU time: on a shared machine wall time counts other work
            let (run, secs) = pool.install(|| {
                let t0 = cpu_time::ThreadTime::now();
                let run = trackfuse::center::fuse_all(&local, cfg, Some(&sim.sensors), None);
                (run, t0.elapsed().as_secs_f64())
            });
            best = best.min(secs);
            fused = run?.fused.len();
        }
        Ok((best, fused))
    };
    let (t_with, fused) = time(&with)?;
    let (t_without, _) = time(&without)?;
    let n = local.len() as f64;
    let est = (t_with - t_without).max(f64::MIN_POSITIVE);
    say!("scenario                        {}", sc.name);
    say!(
        "fusion center                   {} + {}, bias {estimator}",
        with.method,
        with.rule
    );
    say!("local-track rows                {}", local.len());
    say!("fused rows                      {fused}");
    say!("center without estimator        {t_without:.4} s (CPU, 1 thread, best of {repeat})");
    say!("center with estimator           {t_with:.4} s");
    say!("estimator alone                 {est:.4} s");
    say!("estimator local tracks/s        {:.0}", n / est);
    say!("whole center local tracks/s     {:.0}", n / t_with);
    Ok(())
}

/// What [`time_tracking`] measured.
struct TrackTiming {
    /// Measurements of the run.
    measurements: usize,
    /// Local-track rows the trackers reported.
    rows: usize,
    /// Tracks kept (confirmed and tentative) after each sensor-scan, summed.
    track_scans: usize,
    /// Sensors x scans.
    sensor_scans: f64,
    /// Best wall time of the tracking (s).
    best: f64,
    /// The step times of the last run, when its step clocks were on.
    steps: Option<trackfuse::local::StepTimes>,
}

impl TrackTiming {
    fn us_per_measurement(&self) -> f64 {
        self.best * 1e6 / self.measurements.max(1) as f64
    }
    fn us_per_track_kept(&self) -> f64 {
        self.best * 1e6 / self.track_scans.max(1) as f64
    }
    fn kept_per_measurement(&self) -> f64 {
        self.track_scans as f64 / self.measurements.max(1) as f64
    }
}

fn bench_track(scenario: &str, flags: &TrackerFlags, repeat: u32, steps: bool) -> Result<()> {
    let (config, _) = load_scenario(Some(scenario))?;
    let cfg = flags.apply(&config.tracker)?;
    let sc = config.scenario;
    let sim = trackfuse::sim::simulate(&sc, 0);
    let t = time_tracking(&sim, &sc, &cfg, repeat, false)?;
    let n = t.measurements;
    let per_sensor_scan = n as f64 / t.sensor_scans;
    say!("scenario                    {}", sc.name);
    say!(
        "tracker                     {} + {}",
        cfg.associator,
        cfg.filter
    );
    say!(
        "sensors x scans             {} x {}",
        sc.sensors.len(),
        sc.scans
    );
    say!("measurements                {n} ({per_sensor_scan:.0} per sensor-scan)");
    say!("local-track rows            {}", t.rows);
    say!(
        "tracks kept per sensor-scan {:.0} ({:.2} per measurement; confirmed and tentative)",
        t.track_scans as f64 / t.sensor_scans,
        t.kept_per_measurement()
    );
    say!("wall time (1 thread, best)  {:.4} s", t.best);
    say!(
        "per sensor-scan             {:.1} us",
        t.best * 1e6 / t.sensor_scans
    );
    say!(
        "per track kept, per scan    {:.3} us",
        t.us_per_track_kept()
    );
    say!("measurements/s per core     {:.0}", n as f64 / t.best);
    if steps {
        let timed = time_tracking(&sim, &sc, &cfg, repeat, true)?;
        if let Some(s) = timed.steps {
            print_step_table("scenario", &[(sc.name.clone(), s)])?;
        }
    }
    Ok(())
}

/// The scenario of one size of [`bench_track_sweep`]: the built-in grid-bench text with
/// the substitutions BENCHMARKS.md's sed recipe makes (series B; series C with
/// `position`), each checked to apply.
fn sweep_scenario(targets: usize, position: bool, scans: u32) -> Result<String> {
    let base = trackfuse::config::RunConfig::builtin_text("grid-bench")
        .ok_or_else(|| anyhow::anyhow!("the built-in grid-bench is missing"))?;
    let side = (targets as f64).sqrt().ceil() as i64 * 1000;
    let half = side / 2;
    let mut text = base.to_string();
    let mut swap = |from: &str, to: &str| -> Result<()> {
        anyhow::ensure!(
            text.contains(from),
            "the built-in grid-bench has no `{from}` to change for the sweep"
        );
        text = text.replace(from, to);
        Ok(())
    };
    swap("\nscans = 1000\n", &format!("\nscans = {scans}\n"))?;
    swap("\ncount = 1000\n", &format!("\ncount = {targets}\n"))?;
    swap("\ndensity = 0.01\n", "\ndensity = 0.08\n")?;
    // through placeholders, so that a new value never matches a later pattern
    swap("-50000.0", "@lo@")?;
    swap("80000.0", "@hi@")?;
    swap("40000.0", "@far@")?;
    swap("@lo@", &format!("-{half}.0"))?;
    swap("@hi@", &format!("{}.0", side + half))?;
    swap("@far@", &format!("{}.0", side + 10_000))?;
    if position {
        swap("\nsigma_r = 20.0\n", "\nkind = \"position\"\n")?;
        swap(
            "\nsigma_theta = 0.002\n",
            "\nsigma_x = 50.0\nsigma_y = 50.0\n",
        )?;
    }
    Ok(text)
}

/// `bench track-sweep`: [`time_tracking`] on [`sweep_scenario`] at each size; with
/// `steps`, one more run per size with the step clocks on, printed as a second table
/// (times) and a third (work counts).
fn bench_track_sweep(
    flags: &TrackerFlags,
    targets: &[usize],
    position: bool,
    scans: u32,
    repeat: u32,
    steps: bool,
) -> Result<()> {
    anyhow::ensure!(!targets.is_empty(), "--targets: give at least one count");
    anyhow::ensure!(
        targets.iter().all(|&n| n > 0),
        "--targets: a count must be at least 1"
    );
    anyhow::ensure!(scans > 0, "--scans: must be at least 1");
    say!(
        "grid-bench at a fixed clutter density (0.08 per km^2 per scan), {} sensors, {scans} scans, one thread, best of at least {repeat} runs",
        if position { "position (50 m)" } else { "radar (20 m, 0.002 rad)" }
    );
    say!("| targets | measurements per sensor-scan | tracks kept per measurement | us per measurement | us per track kept | per measurement / first |");
    say!("|---|---|---|---|---|---|");
    let mut first = None;
    let mut step_rows = Vec::new();
    for &n in targets {
        let text = sweep_scenario(n, position, scans)?;
        let config = trackfuse::config::RunConfig::from_toml(&text, &format!("grid-bench x {n}"))?;
        let cfg = flags.apply(&config.tracker)?;
        // one untimed run first (it also warms the caches and the allocator); a size
        // that runs in under 0.2 s is then repeated until about 0.5 s, at most 500
        // times: a few milliseconds' best is mostly the machine's noise
        let sim = trackfuse::sim::simulate(&config.scenario, 0);
        let probe = time_tracking(&sim, &config.scenario, &cfg, 1, false)?;
        let runs = if probe.best < 0.2 {
            ((0.5 / probe.best.max(1e-6)).ceil() as u32)
                .min(500)
                .max(repeat)
        } else {
            repeat
        };
        let t = time_tracking(&sim, &config.scenario, &cfg, runs, false)?;
        if steps {
            let timed = time_tracking(&sim, &config.scenario, &cfg, runs, true)?;
            if let Some(s) = timed.steps {
                step_rows.push((n.to_string(), s));
            }
        }
        let us = t.us_per_measurement();
        let reference = *first.get_or_insert(us);
        say!(
            "| {n} | {:.0} | {:.2} | {us:.3} | {:.3} | {:.2}x |",
            t.measurements as f64 / t.sensor_scans,
            t.kept_per_measurement(),
            t.us_per_track_kept(),
            us / reference
        );
    }
    if steps {
        print_step_table("targets", &step_rows)?;
    }
    Ok(())
}

/// The second table of `bench track-sweep --steps`: each step's time per measurement
/// (ns), its total, and the total relative to the first size; the third: what the steps
/// worked on, per measurement ([`trackfuse::local::WorkCounts`]).
fn print_step_table(label: &str, rows: &[(String, trackfuse::local::StepTimes)]) -> Result<()> {
    let Some((_, first)) = rows.first() else {
        return Ok(());
    };
    say!("");
    say!("where the time goes: ns per measurement of each step (as many more runs with the step clocks on, the fastest)");
    let names: Vec<&str> = first.steps().iter().map(|&(name, _)| name).collect();
    say!(
        "| {label} | {} | total | total / first |",
        names.join(" | ")
    );
    say!("|---|{}---|---|", "---|".repeat(names.len()));
    // per measurement the trackers processed in that run (counted with the work)
    let per = |d: std::time::Duration, s: &trackfuse::local::StepTimes| {
        d.as_secs_f64() * 1e9 / s.work.measurements.max(1) as f64
    };
    let reference = per(first.total(), first);
    for (n, s) in rows {
        let cells: Vec<String> = s
            .steps()
            .iter()
            .map(|&(_, d)| format!("{:.1}", per(d, s)))
            .collect();
        let total = per(s.total(), s);
        say!(
            "| {n} | {} | {total:.1} | {:.2}x |",
            cells.join(" | "),
            total / reference
        );
    }
    // the counts the tracker's definition fixes: a time that grows with them is work
    // that grows, not an index or a cache that got slower
    say!("");
    say!("what the steps worked on, per measurement (the same runs): (track, measurement) pairs in the gates, tentative tracks, (tentative track, measurement) pairs in their gates, measurements left for initiation, pairs the two-point gate accepts, tentative tracks started");
    say!("| {label} | gated | tentative | tentative gated | unused | pairs | started |");
    say!("|---|---|---|---|---|---|---|");
    for (n, s) in rows {
        let w = &s.work;
        let per = |c: u64| c as f64 / w.measurements.max(1) as f64;
        say!(
            "| {n} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            per(w.gated),
            per(w.tentative),
            per(w.tentative_gated),
            per(w.unused),
            per(w.pairs),
            per(w.started)
        );
    }
    Ok(())
}

/// Time the path `trackfuse track` runs on one thread on `sim` (run 0 of `sc`, in
/// memory), best of `repeat`.
fn time_tracking(
    sim: &trackfuse::sim::SimulationOutput,
    sc: &trackfuse::scenario::Scenario,
    cfg: &trackfuse::local::TrackerConfig,
    repeat: u32,
    steps: bool,
) -> Result<TrackTiming> {
    let known = known_targets(&sim.truth);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut best = f64::INFINITY;
    let mut rows = 0;
    // the path `trackfuse track` runs: the trackers fed scan by scan, each scan's local
    // tracks handed on (here counted) and the buffer reused, so that memory and its page
    // faults do not grow with the number of scans; the clocks as `track` learns them
    let mut times = ReportTimes::default();
    for m in &sim.measurements {
        times.add(m.sensor_id, m.time);
    }
    let clocks = times.clocks();
    // scans in ascending order (a simulation writes them so; sorted stably otherwise)
    let mut measurements = sim.measurements.clone();
    measurements.sort_by_key(|m| m.scan);
    let mut local = Vec::new();
    // tracks (confirmed and tentative) kept after each scan, summed over the scans: the
    // work per scan grows with them, and they need not grow as the measurements do
    let mut track_scans = 0;
    let mut step_times = None;
    for _ in 0..repeat.max(1) {
        let t0 = Instant::now();
        (rows, track_scans) = pool
            .install(|| {
                let mut tracker = MultiSensorTracker::new(
                    &sim.sensors,
                    cfg,
                    Some(sc.process_noise),
                    &known,
                    sc.seed,
                    0,
                )?;
                tracker.set_clocks(&clocks);
                tracker.set_step_timing(steps);
                let (mut rows, mut track_scans) = (0, 0);
                for ms in measurements.chunk_by(|a, b| a.scan == b.scan) {
                    local.clear();
                    tracker.process_scan(ms[0].scan, ms, &mut local)?;
                    rows += local.len();
                    track_scans += tracker.track_count();
                }
                Ok::<_, trackfuse::local::TrackerError>((rows, track_scans, tracker.step_times()))
            })
            .map(|(rows, kept, times)| {
                let elapsed = t0.elapsed().as_secs_f64();
                // the step times of the fastest run, as the best wall time is
                if steps && elapsed < best {
                    step_times = Some(times);
                }
                best = best.min(elapsed);
                (rows, kept)
            })?;
    }
    Ok(TrackTiming {
        measurements: sim.measurements.len(),
        rows,
        track_scans,
        sensor_scans: sc.scans as f64 * sim.sensors.len() as f64,
        best,
        steps: step_times,
    })
}

fn time_center(flags: &FusionFlags, scans: &[Vec<LocalTrack>]) -> Result<ScanTimes> {
    let cfg = flags.apply(&trackfuse::center::FusionConfig::default())?;
    let mut center = FusionCenter::new(&cfg, None)?;
    // first scan starts the global tracks; time the steady state after it
    // (as a service would: one output buffer reused from scan to scan)
    let mut out = trackfuse::center::ScanOutput::default();
    center.process_scan_into(&scans[0], &mut out)?;
    let mut tracks = 0;
    let mut times = Vec::with_capacity(scans.len());
    for s in &scans[1..] {
        // the thread's CPU time, not wall time: on a shared machine the wall time of a
        // 40 ms scan includes the time slices of other processes
        let t0 = cpu_time::ThreadTime::now();
        center.process_scan_into(s, &mut out)?;
        times.push(t0.elapsed().as_secs_f64());
        tracks += s.len();
    }
    Ok(ScanTimes { times, tracks })
}

/// CPU time of each timed scan (the thread's).
struct ScanTimes {
    times: Vec<f64>,
    tracks: usize,
}

impl ScanTimes {
    fn total(&self) -> f64 {
        self.times.iter().sum()
    }

    /// The median time per scan: on a shared machine a few scans are slowed by other
    /// work, and the median does not follow them.
    fn median(&self) -> f64 {
        let mut t = self.times.clone();
        t.sort_unstable_by(f64::total_cmp);
        t.get(t.len() / 2).copied().unwrap_or(0.0)
    }
}

fn bench_fuse(
    flags: &FusionFlags,
    targets: usize,
    sensors: usize,
    scans: u32,
    sweep: &[usize],
) -> Result<()> {
    let cfg = flags.apply(&trackfuse::center::FusionConfig::default())?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let data = synthetic_local_tracks(targets, sensors, scans.max(2) + 1);
    let timed = pool.install(|| time_center(flags, &data))?;
    let (secs, n) = (timed.total(), timed.tracks);
    say!("fusion center               {} + {}", cfg.method, cfg.rule);
    say!("targets x sensors           {targets} x {sensors}");
    say!("scans timed                 {}", data.len() - 1);
    say!("local tracks/s per core     {:.0}", n as f64 / secs);
    say!();
    say!("local tracks per scan   median time per scan (ms)   us per local track");
    for &m in sweep {
        let t = (m / sensors.max(1)).max(1);
        let reps = ((1_000_000 / m.max(1)) as u32).clamp(11, 200);
        let data = synthetic_local_tracks(t, sensors, reps + 1);
        let timed = pool.install(|| time_center(flags, &data))?;
        let per_scan = timed.median();
        say!(
            "{:>21}   {:>25.3}   {:>18.3}",
            t * sensors,
            per_scan * 1e3,
            per_scan * 1e6 / (t * sensors) as f64
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use trackfuse::types::SensorKind;

    /// The sweep's scenario is BENCHMARKS.md's series: N targets on the 1 km grid of side
    /// L = ceil(sqrt N) km, clutter 0.08 per km^2 over the grid plus L/2 on each side, the
    /// sensors 10 km beyond the corners; radars, or 50 m position sensors. 6 400 targets
    /// (L = 80 km, L/2 = 40 km) would have met a later pattern without the placeholders.
    #[test]
    fn sweep_scenarios_are_the_documented_series() {
        for (n, side) in [(100usize, 10_000.0), (6_400, 80_000.0), (30_000, 174_000.0)] {
            for position in [false, true] {
                let text = sweep_scenario(n, position, 7).expect("scenario");
                let sc = trackfuse::config::RunConfig::from_toml(&text, "sweep")
                    .expect("valid")
                    .scenario;
                let half = side / 2.0;
                assert_eq!(sc.scans, 7);
                assert_eq!(sc.target_count(), n);
                assert_eq!(sc.clutter.density, 0.08);
                assert_eq!(
                    sc.clutter.region,
                    Some([-half, side + half, -half, side + half])
                );
                let far = side + 10_000.0;
                let positions: Vec<[f64; 2]> = sc.sensors.iter().map(|s| s.position).collect();
                assert_eq!(
                    positions,
                    vec![
                        [-10_000.0, -10_000.0],
                        [far, -10_000.0],
                        [-10_000.0, far],
                        [far, far]
                    ]
                );
                for s in &sc.sensors {
                    if position {
                        assert_eq!(s.kind, SensorKind::Position);
                        assert_eq!((s.sigma_x, s.sigma_y), (Some(50.0), Some(50.0)));
                    } else {
                        assert_eq!(s.kind, SensorKind::RangeBearing);
                        assert_eq!((s.sigma_r, s.sigma_theta), (Some(20.0), Some(0.002)));
                    }
                }
            }
        }
    }
}
