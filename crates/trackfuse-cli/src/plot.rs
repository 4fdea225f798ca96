//! `trackfuse plot`: SVG plots of a run directory — trajectories (truth, local tracks,
//! fused tracks, sensors) and the fused position error per scan.

use anyhow::{bail, Context, Result};
use clap::Args;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use trackfuse::io::{read_fused_tracks, read_local_tracks, read_sensors, read_truth};
use trackfuse::Id;

use crate::output::{Outputs, PLOT_OUTPUTS};

#[derive(Args, Debug)]
pub struct PlotArgs {
    /// A run directory (as written by `simulate`, `track`, `fuse`, `run`): truth.csv and any
    /// of sensors.csv, local_tracks.csv, fused_tracks.csv, summary.json.
    pub dir: PathBuf,
    /// Where to write the SVG files (never into the run directory unless this says so).
    #[arg(long, default_value = "out/plot")]
    pub out: PathBuf,
}

type Series = BTreeMap<Id, Vec<(f64, f64)>>;

fn bounds<'a>(all: impl Iterator<Item = &'a (f64, f64)>) -> Option<(f64, f64, f64, f64)> {
    let mut b: Option<(f64, f64, f64, f64)> = None;
    for &(x, y) in all {
        b = Some(match b {
            None => (x, x, y, y),
            Some((a, c, d, e)) => (a.min(x), c.max(x), d.min(y), e.max(y)),
        });
    }
    b.map(|(x0, x1, y0, y1)| {
        let pad = 0.05 * (x1 - x0).max(y1 - y0).max(1.0);
        (x0 - pad, x1 + pad, y0 - pad, y1 + pad)
    })
}

fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("plotting: {e}")
}

fn trajectories(dir: &Path, outs: &mut Outputs) -> Result<PathBuf> {
    let truth = read_truth(&dir.join("truth.csv"))?;
    let mut t_series: Series = BTreeMap::new();
    for t in &truth {
        t_series
            .entry(t.target_id)
            .or_default()
            .push((t.state[0], t.state[2]));
    }
    let mut l_series: BTreeMap<(Id, Id), Vec<(f64, f64)>> = BTreeMap::new();
    if dir.join("local_tracks.csv").exists() {
        for l in read_local_tracks(&dir.join("local_tracks.csv"))? {
            l_series
                .entry((l.sensor_id, l.track_id))
                .or_default()
                .push((l.state[0], l.state[2]));
        }
    }
    let mut f_series: Series = BTreeMap::new();
    if dir.join("fused_tracks.csv").exists() {
        for f in read_fused_tracks(&dir.join("fused_tracks.csv"))? {
            f_series
                .entry(f.fused_id)
                .or_default()
                .push((f.state[0], f.state[2]));
        }
    }
    let sensors = if dir.join("sensors.csv").exists() {
        read_sensors(&dir.join("sensors.csv"))?
    } else {
        Vec::new()
    };
    let s_points: Vec<(f64, f64)> = sensors.iter().map(|s| (s.x, s.y)).collect();
    let Some((x0, x1, y0, y1)) = bounds(
        t_series
            .values()
            .flatten()
            .chain(f_series.values().flatten())
            .chain(s_points.iter()),
    ) else {
        bail!("{}: no truth rows to plot", dir.join("truth.csv").display());
    };
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, (900, 800)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Trajectories", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("x east (m)")
        .y_desc("y north (m)")
        .draw()
        .map_err(plot_err)?;
    let local_style = ShapeStyle {
        color: RGBAColor(120, 120, 220, 0.45),
        filled: false,
        stroke_width: 1,
    };
    for (i, pts) in l_series.values().enumerate() {
        let s = chart
            .draw_series(LineSeries::new(pts.iter().copied(), local_style))
            .map_err(plot_err)?;
        if i == 0 {
            s.label("local tracks")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], local_style));
        }
    }
    let truth_style = ShapeStyle {
        color: BLACK.to_rgba(),
        filled: false,
        stroke_width: 2,
    };
    for (i, pts) in t_series.values().enumerate() {
        let s = chart
            .draw_series(LineSeries::new(pts.iter().copied(), truth_style))
            .map_err(plot_err)?;
        if i == 0 {
            s.label("truth")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], truth_style));
        }
    }
    let fused_style = ShapeStyle {
        color: RED.to_rgba(),
        filled: false,
        stroke_width: 1,
    };
    for (i, pts) in f_series.values().enumerate() {
        let s = chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 2, fused_style)))
            .map_err(plot_err)?;
        if i == 0 {
            s.label("fused tracks")
                .legend(move |(x, y)| Circle::new((x + 10, y), 3, fused_style));
        }
    }
    if !s_points.is_empty() {
        let sensor_style = ShapeStyle {
            color: GREEN.mix(0.9),
            filled: true,
            stroke_width: 1,
        };
        chart
            .draw_series(
                s_points
                    .iter()
                    .map(|&p| TriangleMarker::new(p, 8, sensor_style)),
            )
            .map_err(plot_err)?
            .label("sensors")
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 6, sensor_style));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err)?;
    root.present().map_err(plot_err)?;
    drop(chart);
    drop(root);
    outs.write("trajectories.svg", svg.as_bytes())
}

fn rmse_curve(dir: &Path, outs: &mut Outputs) -> Result<Option<PathBuf>> {
    let p = dir.join("summary.json");
    if !p.exists() {
        return Ok(None);
    }
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p)?)
        .with_context(|| format!("{}", p.display()))?;
    let pts: Vec<(f64, f64)> = v["fused_rmse_per_scan"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|e| Some((e[0].as_f64()?, e[1].as_f64()?)))
                .collect()
        })
        .unwrap_or_default();
    if pts.is_empty() {
        return Ok(None);
    }
    let xmax = pts.iter().map(|p| p.0).fold(1.0f64, f64::max);
    let ymax = pts.iter().map(|p| p.1).fold(1e-9f64, f64::max) * 1.1;
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, (900, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Fused position RMSE per scan", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..xmax, 0f64..ymax)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("scan")
        .y_desc("RMSE (m)")
        .draw()
        .map_err(plot_err)?;
    chart
        .draw_series(LineSeries::new(pts, &BLUE))
        .map_err(plot_err)?;
    root.present().map_err(plot_err)?;
    drop(chart);
    drop(root);
    outs.write("rmse_per_scan.svg", svg.as_bytes()).map(Some)
}

pub fn run(args: &PlotArgs) -> Result<()> {
    let inputs: Vec<PathBuf> = [
        "truth.csv",
        "sensors.csv",
        "local_tracks.csv",
        "fused_tracks.csv",
        "summary.json",
    ]
    .iter()
    .map(|f| args.dir.join(f))
    .collect();
    let inputs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    let mut outs = Outputs::new(&args.out, PLOT_OUTPUTS, &inputs)?;
    let t = trajectories(&args.dir, &mut outs)?;
    eprintln!("wrote {}", t.display());
    if let Some(r) = rmse_curve(&args.dir, &mut outs)? {
        eprintln!("wrote {}", r.display());
    }
    outs.finish();
    Ok(())
}
