//! `trackfuse fuse`: the fusion center over local_tracks.csv (from this project or any
//! other tool) -> fused_tracks.csv + associations.csv.

use crate::common::{load_scenario, scenario_input};
use crate::config::FusionFlags;
use crate::output::{Outputs, FUSE_OUTPUTS};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use trackfuse::center::{
    fuse_all, fuse_all_two_pass, registry, CenterError, FusedRun, FusionConfig, Missing,
};
use trackfuse::io::{
    read_local_tracks, read_sensors, read_truth, AssociationWriter, FusedTrackWriter,
};
use trackfuse::metrics::label_local_tracks;
use trackfuse::{Id, LocalTrack, Sensor};

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
    /// Scenario whose [fusion] section is the base config.
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
        let mut s = String::from("sensor_id,bias_r,bias_theta\n");
        for (i, b) in run.bias.iter().enumerate() {
            crate::output::finite_cells(
                &outs.dir().join("bias_estimates.csv").display().to_string(),
                i as u64 + 2,
                &[(2, "bias_r", b.range), (3, "bias_theta", b.bearing)],
            )?;
            s.push_str(&format!("{},{},{}\n", b.sensor_id, b.range, b.bearing));
        }
        outs.write("bias_estimates.csv", s.as_bytes())?;
    }
    Ok(())
}

/// Every local track's sensor must be in the given sensors.csv: a method or bias
/// estimator that reads the sensors would otherwise skip or misread that sensor's tracks.
fn check_sensors_cover(
    local: &[LocalTrack],
    sensors: &[Sensor],
    local_path: &Path,
    sensors_path: &Path,
) -> Result<()> {
    let known: BTreeSet<Id> = sensors.iter().map(|s| s.id).collect();
    if let Some(t) = local.iter().find(|t| !known.contains(&t.sensor_id)) {
        bail!(
            "{}: sensor_id {} (track {}, scan {}) is not in {} (its sensors: {})",
            local_path.display(),
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
    let local = read_local_tracks(&args.local_tracks)?;
    let sensors = args.sensors.as_deref().map(read_sensors).transpose()?;
    if let (Some(sensors), Some(path)) = (&sensors, &args.sensors) {
        check_sensors_cover(&local, sensors, &args.local_tracks, path)?;
    }
    let labels = match &args.truth {
        Some(t) => Some(label_local_tracks(&read_truth(t)?, &local, args.label_gate)),
        None => None,
    };
    let t0 = std::time::Instant::now();
    let run = if args.two_pass {
        fuse_all_two_pass(&local, &cfg, sensors.as_deref(), labels.as_ref())
    } else {
        fuse_all(&local, &cfg, sensors.as_deref(), labels.as_ref())
    }
    .map_err(with_flag_hint)?;
    let elapsed = t0.elapsed();
    let scenario_path = scenario_input(args.scenario.as_deref());
    let mut inputs = vec![args.local_tracks.as_path()];
    inputs.extend(args.sensors.as_deref());
    inputs.extend(args.truth.as_deref());
    inputs.extend(scenario_path.as_deref());
    let mut outs = Outputs::new(&args.out, FUSE_OUTPUTS, &inputs)?;
    write_fused(&mut outs, &run)?;
    let dir = outs.dir().to_path_buf();
    outs.finish();
    let ids: std::collections::BTreeSet<i64> = run.fused.iter().map(|f| f.fused_id).collect();
    eprintln!(
        "fused {} local-track rows ({} + {}): {} global tracks, {} rows in {:.3} s -> {}",
        local.len(),
        cfg.method,
        cfg.rule,
        ids.len(),
        run.fused.len(),
        elapsed.as_secs_f64(),
        dir.display()
    );
    for b in &run.bias {
        eprintln!(
            "  bias estimate sensor {}: range {:.1} m, bearing {:.5} rad",
            b.sensor_id, b.range, b.bearing
        );
    }
    Ok(())
}
