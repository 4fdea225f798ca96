//! `trackfuse plot` and the figures of the run report: PNG and SVG plots (plotters) of
//! any folder of FORMATS.md files, ours or another tool's, or of a run in memory.
//!
//! The figures (each drawn when its inputs are there):
//! - `scenario_map`: sensors, their coverage rings (`max_range`), the true trajectories;
//! - `local_tracks`: each sensor's local tracks in its own colour over the truth;
//! - `fused_tracks`: fused tracks over the truth (drawn on top, thin, so it stays
//!   visible), each labelled with its `fused_id`; `--ellipses` adds 2-sigma position
//!   ellipses;
//! - `position_error`: the fused position error of each target per time step;
//! - `error_by_method`: the RMS position error over targets per time step, fused and
//!   each sensor's local tracks;
//! - `gospa`: GOSPA per time step and its localisation / missed / false parts;
//! - `nees`: the mean NEES of the fused estimates per time step with its 95 % band;
//! - `bias`: the center's bias estimates against the true biases of sensors.csv;
//! - `bias_convergence`: each sensor's range and bearing bias estimate over time
//!   (bias_history.csv), with its true bias of sensors.csv as a dashed line of the same
//!   colour when sensors.csv is there;
//! - `rmse_per_scan`: the fused RMSE per scan of a summary.json that has it.
//!
//! Where the issue is silent: the per-time curves pair estimates with the truth at the
//! same time (the truth interpolated linearly between a target's rows when the estimate's
//! time is not a truth time, over gaps of at most twice the truth's median row interval)
//! and assign them by the same gated optimal assignment as the evaluation, within
//! `--gospa-c` for fused and `--label-gate` for local tracks; they are for looking and are
//! not the summary's numbers, which the evaluation computes. Distances on the maps are in
//! km, errors in m.

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use trackfuse::center::bias::{BiasEstimate, BiasSample};
use trackfuse::io::{read_fused_tracks, read_local_tracks, read_sensors, read_truth};
use trackfuse::metrics::{gated_assignment, gospa, EvaluationConfig, Gospa};
use trackfuse::types::{
    position_of, FusedTrack, Id, LocalTrack, Sensor, StateCov, StateVec, TruthState, Vec2,
};

use crate::output::Outputs;

#[derive(Args, Debug)]
pub struct PlotArgs {
    /// A folder of FORMATS.md files (ours or another tool's): any of truth.csv,
    /// sensors.csv, local_tracks.csv, fused_tracks.csv, bias_estimates.csv,
    /// bias_history.csv, summary.json.
    /// The options below name files elsewhere (e.g. the truth of another tool's output).
    pub dir: PathBuf,
    /// truth.csv (default: DIR/truth.csv when it exists).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// sensors.csv (default: DIR/sensors.csv when it exists).
    #[arg(long)]
    pub sensors: Option<PathBuf>,
    /// local_tracks.csv (default: DIR/local_tracks.csv when it exists).
    #[arg(long)]
    pub local_tracks: Option<PathBuf>,
    /// fused_tracks.csv (default: DIR/fused_tracks.csv when it exists).
    #[arg(long)]
    pub fused_tracks: Option<PathBuf>,
    /// bias_estimates.csv (default: DIR/bias_estimates.csv when it exists).
    #[arg(long)]
    pub bias: Option<PathBuf>,
    /// bias_history.csv (default: DIR/bias_history.csv when it exists).
    #[arg(long)]
    pub bias_history: Option<PathBuf>,
    /// Draw 2-sigma position ellipses of the fused tracks (every tenth row of a track).
    #[arg(long)]
    pub ellipses: bool,
    /// GOSPA cut-off c (m), also the gate assigning fused tracks to targets.
    #[arg(long, default_value_t = 1000.0)]
    pub gospa_c: f64,
    /// GOSPA order p.
    #[arg(long, default_value_t = 2.0)]
    pub gospa_p: f64,
    /// Gate (m) assigning local tracks to targets.
    #[arg(long, default_value_t = 2000.0)]
    pub label_gate: f64,
    /// Where to write the PNG and SVG files (never into DIR unless this says so).
    #[arg(long, default_value = "out/plot")]
    pub out: PathBuf,
}

/// Everything a set of figures is drawn from (any part may be empty).
#[derive(Debug, Clone, Default)]
pub struct PlotData {
    pub truth: Vec<TruthState>,
    pub sensors: Vec<Sensor>,
    pub local: Vec<LocalTrack>,
    pub fused: Vec<FusedTrack>,
    pub bias: Vec<BiasEstimate>,
    /// Every sensor's estimate after each fused instant (bias_history.csv).
    pub bias_history: Vec<BiasSample>,
    /// A summary's `fused_rmse_per_scan`.
    pub rmse_per_scan: Vec<(u32, f64)>,
    pub evaluation: EvaluationConfig,
    /// Draw covariance ellipses on the fused-track map.
    pub ellipses: bool,
}

/// One figure, drawn twice: SVG text and PNG bytes.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File stem (`NAME.svg`, `NAME.png`).
    pub name: &'static str,
    pub title: String,
    /// One sentence on what it shows.
    pub caption: String,
    pub svg: String,
    pub png: Vec<u8>,
}

/// Every figure `trackfuse plot` can write, in drawing order.
pub const FIGURE_NAMES: &[&str] = &[
    "scenario_map",
    "local_tracks",
    "fused_tracks",
    "position_error",
    "error_by_method",
    "gospa",
    "nees",
    "bias",
    "bias_convergence",
    "rmse_per_scan",
];

/// `trackfuse plot`'s output set: every figure as SVG and PNG.
pub fn plot_outputs() -> Vec<String> {
    FIGURE_NAMES
        .iter()
        .flat_map(|n| [format!("{n}.svg"), format!("{n}.png")])
        .collect()
}

fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("plotting: {e}")
}

/// Register the font plotters draws text with (DejaVu Sans, embedded, so a PNG looks the
/// same on every machine), once.
fn register_font() -> Result<()> {
    static DONE: std::sync::OnceLock<std::result::Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .map_err(|_| "the embedded font does not load".to_string())
    })
    .clone()
    .map_err(|e| anyhow!("plotting: {e}"))
}

type Area<DB> = DrawingArea<DB, Shift>;

/// Draw with `svg` into an SVG and with `png` into a PNG of `size` pixels.
fn render(
    size: (u32, u32),
    svg: impl FnOnce(&Area<SVGBackend>) -> Result<()>,
    png: impl FnOnce(&Area<BitMapBackend>) -> Result<()>,
) -> Result<(String, Vec<u8>)> {
    register_font()?;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        svg(&root)?;
        root.present().map_err(plot_err)?;
    }
    let (w, h) = size;
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        png(&root)?;
        root.present().map_err(plot_err)?;
    }
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header().map_err(plot_err)?;
        wr.write_image_data(&buf).map_err(plot_err)?;
        wr.finish().map_err(plot_err)?;
    }
    Ok((text, bytes))
}

/// A figure from a drawing function generic over the backend.
macro_rules! figure {
    ($name:expr, $title:expr, $caption:expr, $size:expr, $f:ident ( $($arg:expr),* )) => {{
        let (svg, png) = render($size, |r| $f(r, $($arg),*), |r| $f(r, $($arg),*))?;
        Figure {
            name: $name,
            title: $title.into(),
            caption: $caption.into(),
            svg,
            png,
        }
    }};
}

/// Ten well-separated colours (the usual categorical palette of plotting tools).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

fn km(p: Vec2) -> (f64, f64) {
    (p[0] / 1000.0, p[1] / 1000.0)
}

/// Equal-aspect bounds (km) around the points, padded by 5 %.
fn map_bounds(points: &[(f64, f64)], size: (u32, u32)) -> Option<(f64, f64, f64, f64)> {
    let mut it = points.iter().filter(|p| p.0.is_finite() && p.1.is_finite());
    let first = it.next()?;
    let (mut x0, mut x1, mut y0, mut y1) = (first.0, first.0, first.1, first.1);
    for &(x, y) in it {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let pad = 0.05 * (x1 - x0).max(y1 - y0).max(0.1);
    let (mut x0, mut x1, mut y0, mut y1) = (x0 - pad, x1 + pad, y0 - pad, y1 + pad);
    // same scale on both axes (plot area about size minus the label areas)
    let aspect = (size.0 as f64 - LEGEND_W as f64 - 80.0) / (size.1 as f64 - 90.0);
    let (w, h) = (x1 - x0, y1 - y0);
    if w / h < aspect {
        let extra = (h * aspect - w) / 2.0;
        x0 -= extra;
        x1 += extra;
    } else {
        let extra = (w / aspect - h) / 2.0;
        y0 -= extra;
        y1 += extra;
    }
    Some((x0, x1, y0, y1))
}

/// A tick label: at most 5 significant digits, a power of ten past 1e5.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a >= 1e5 {
        let e = a.log10().floor() as i32;
        let m = v / 10f64.powi(e);
        format!("{m:.1}e{e}")
    } else if a >= 100.0 || a == 0.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        let s = format!("{v:.2}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

type Tracks = BTreeMap<(Id, Id), Vec<(f64, f64)>>;

fn truth_series(truth: &[TruthState]) -> BTreeMap<Id, Vec<(f64, f64)>> {
    let mut m: BTreeMap<Id, Vec<(f64, f64)>> = BTreeMap::new();
    for t in truth {
        m.entry(t.target_id)
            .or_default()
            .push(km(position_of(&t.state)));
    }
    m
}

/// Points within one track that are further apart than this (km) are not joined (a track
/// that coasts off and comes back, or two tracks sharing an id).
fn split_jumps(pts: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for &p in pts {
        if let Some(&q) = cur.last() {
            let d = ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt();
            if d > 20.0 {
                out.push(std::mem::take(&mut cur));
            }
        }
        cur.push(p);
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

struct MapCtx<'a> {
    d: &'a PlotData,
    bounds: (f64, f64, f64, f64),
}

/// The map's chart: axes in km, equal scale.
fn map_chart<'a, DB: DrawingBackend>(
    root: &'a Area<DB>,
    title: &str,
    b: (f64, f64, f64, f64),
) -> Result<
    ChartContext<
        'a,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
> {
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(b.0..b.1, b.2..b.3)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(246, 246, 246))
        .x_desc("x east (km)")
        .y_desc("y north (km)")
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(plot_err)?;
    Ok(chart)
}

/// Width (px) of the legend panel right of every chart: legends never cover data.
const LEGEND_W: u32 = 190;

/// What a legend entry shows.
#[derive(Debug, Clone, Copy)]
enum Mark {
    Line(RGBAColor, u32),
    Triangle,
    Dot(RGBAColor),
    Band(RGBAColor),
    /// A continuation line of the entry above.
    Blank,
}

type Legend = Vec<(String, Mark)>;

/// The chart area and the legend panel right of it.
fn split_legend<DB: DrawingBackend>(root: &Area<DB>) -> (Area<DB>, Area<DB>) {
    let w = root.dim_in_pixel().0;
    root.split_horizontally(w.saturating_sub(LEGEND_W))
}

/// Draw the legend `entries` into the panel `area`, from the top (below the caption).
fn side_legend<DB: DrawingBackend>(area: &Area<DB>, entries: &[(String, Mark)]) -> Result<()> {
    let font = ("sans-serif", 13).into_font();
    for (i, (label, mark)) in entries.iter().enumerate() {
        let y = 48 + i as i32 * 20;
        let (x0, x1) = (6, 28);
        match *mark {
            Mark::Line(c, w) => area.draw(&PathElement::new(
                vec![(x0, y), (x1, y)],
                c.stroke_width(w.max(2)),
            )),
            Mark::Triangle => area.draw(&TriangleMarker::new((17, y), 5, BLACK.filled())),
            Mark::Dot(c) => area.draw(&Circle::new((17, y), 5, c.filled())),
            Mark::Band(c) => area.draw(&Rectangle::new([(x0, y - 5), (x1, y + 5)], c.filled())),
            Mark::Blank => Ok(()),
        }
        .map_err(plot_err)?;
        area.draw(&Text::new(label.clone(), (34, y - 8), font.clone()))
            .map_err(plot_err)?;
    }
    Ok(())
}

type MapChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn draw_truth<DB: DrawingBackend>(
    chart: &mut MapChart<'_, DB>,
    truth: &[TruthState],
    style: ShapeStyle,
    legend: &mut Legend,
) -> Result<()> {
    for pts in truth_series(truth).values() {
        for seg in split_jumps(pts) {
            chart
                .draw_series(LineSeries::new(seg, style))
                .map_err(plot_err)?;
        }
    }
    if !truth.is_empty() {
        legend.push(("truth".into(), Mark::Line(style.color, style.stroke_width)));
    }
    Ok(())
}

fn draw_sensors<DB: DrawingBackend>(
    chart: &mut MapChart<'_, DB>,
    all: &[Sensor],
    rings: bool,
    b: (f64, f64, f64, f64),
    legend: &mut Legend,
) -> Result<()> {
    // only the sensors in view (a marker out of view would be drawn on the border)
    let sensors: Vec<Sensor> = all
        .iter()
        .filter(|s| {
            let (x, y) = (s.x / 1000.0, s.y / 1000.0);
            x >= b.0 && x <= b.1 && y >= b.2 && y <= b.3
        })
        .cloned()
        .collect();
    let sensors = sensors.as_slice();
    if sensors.is_empty() {
        return Ok(());
    }
    for (i, s) in sensors.iter().enumerate() {
        if rings && s.max_range > 0.0 {
            let c = colour(i);
            let ring: Vec<(f64, f64)> = (0..=120)
                .map(|k| {
                    let a = k as f64 / 120.0 * std::f64::consts::TAU;
                    (
                        (s.x + s.max_range * a.cos()) / 1000.0,
                        (s.y + s.max_range * a.sin()) / 1000.0,
                    )
                })
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(ring.clone(), c.mix(0.05))))
                .map_err(plot_err)?;
            chart
                .draw_series(LineSeries::new(ring, c.mix(0.6).stroke_width(1)))
                .map_err(plot_err)?;
        }
    }
    let style = ShapeStyle {
        color: BLACK.to_rgba(),
        filled: true,
        stroke_width: 1,
    };
    chart
        .draw_series(sensors.iter().map(|s| {
            EmptyElement::at((s.x / 1000.0, s.y / 1000.0))
                + TriangleMarker::new((0, 0), 7, style)
                + Text::new(format!("S{}", s.id), (8, -14), ("sans-serif", 13))
        }))
        .map_err(plot_err)?;
    legend.push(("sensors".into(), Mark::Triangle));
    if rings && sensors.iter().any(|s| s.max_range > 0.0) {
        legend.push((
            "coverage (max_range)".into(),
            Mark::Band(colour(0).mix(0.25)),
        ));
    }
    Ok(())
}

fn draw_map<DB: DrawingBackend>(root: &Area<DB>, m: &MapCtx<'_>) -> Result<()> {
    let (plot, side) = split_legend(root);
    let mut lg = Legend::new();
    let mut chart = map_chart(
        &plot,
        "Scenario: sensors, coverage and true trajectories",
        m.bounds,
    )?;
    draw_sensors(&mut chart, &m.d.sensors, true, m.bounds, &mut lg)?;
    let style = BLACK.stroke_width(2);
    draw_truth(&mut chart, &m.d.truth, style, &mut lg)?;
    // target ids at the start of each trajectory
    chart
        .draw_series(truth_series(&m.d.truth).iter().filter_map(|(id, pts)| {
            pts.first().map(|&p| {
                EmptyElement::at(p)
                    + Circle::new((0, 0), 3, BLACK.filled())
                    + Text::new(format!("T{id}"), (-6, 5), ("sans-serif", 12))
            })
        }))
        .map_err(plot_err)?;
    lg.push(("start of target T<id>".into(), Mark::Dot(BLACK.to_rgba())));
    side_legend(&side, &lg)
}

fn draw_local<DB: DrawingBackend>(root: &Area<DB>, m: &MapCtx<'_>) -> Result<()> {
    let (plot, side) = split_legend(root);
    let mut lg = Legend::new();
    let mut chart = map_chart(&plot, "Local tracks by sensor, over the truth", m.bounds)?;
    draw_sensors(&mut chart, &m.d.sensors, false, m.bounds, &mut lg)?;
    let mut tracks: Tracks = BTreeMap::new();
    for l in &m.d.local {
        tracks
            .entry((l.sensor_id, l.track_id))
            .or_default()
            .push(km(position_of(&l.state)));
    }
    let sensor_ids: Vec<Id> = {
        let mut v: Vec<Id> = tracks.keys().map(|k| k.0).collect();
        v.dedup();
        v
    };
    let mut labelled = std::collections::BTreeSet::new();
    for ((sid, _), pts) in &tracks {
        let i = sensor_ids.iter().position(|s| s == sid).unwrap_or(0);
        let style = colour(i).mix(0.75).stroke_width(1);
        for seg in split_jumps(pts) {
            chart
                .draw_series(LineSeries::new(seg, style))
                .map_err(plot_err)?;
        }
        if labelled.insert(*sid) {
            lg.push((format!("sensor {sid}"), Mark::Line(style.color, 3)));
        }
    }
    draw_truth(
        &mut chart,
        &m.d.truth,
        BLACK.mix(0.5).stroke_width(1),
        &mut lg,
    )?;
    side_legend(&side, &lg)
}

/// Points of the 2-sigma ellipse of the position part of `cov` around `c` (km).
fn ellipse(state: &StateVec, cov: &StateCov) -> Option<Vec<(f64, f64)>> {
    let p = nalgebra::Matrix2::new(cov[(0, 0)], cov[(0, 2)], cov[(2, 0)], cov[(2, 2)]);
    let eig = nalgebra::SymmetricEigen::new(p);
    if eig.eigenvalues.iter().any(|v| !v.is_finite() || *v < 0.0) {
        return None;
    }
    let (a, b) = (
        2.0 * eig.eigenvalues[0].sqrt(),
        2.0 * eig.eigenvalues[1].sqrt(),
    );
    let (u, v) = (eig.eigenvectors.column(0), eig.eigenvectors.column(1));
    Some(
        (0..=36)
            .map(|k| {
                let t = k as f64 / 36.0 * std::f64::consts::TAU;
                let x = state[0] + a * t.cos() * u[0] + b * t.sin() * v[0];
                let y = state[2] + a * t.cos() * u[1] + b * t.sin() * v[1];
                (x / 1000.0, y / 1000.0)
            })
            .collect(),
    )
}

fn draw_fused<DB: DrawingBackend>(root: &Area<DB>, m: &MapCtx<'_>) -> Result<()> {
    let (plot, side) = split_legend(root);
    let mut lg = Legend::new();
    let mut chart = map_chart(&plot, "Fused tracks (with ids) and the truth", m.bounds)?;
    draw_sensors(&mut chart, &m.d.sensors, false, m.bounds, &mut lg)?;
    let mut tracks: BTreeMap<Id, Vec<&FusedTrack>> = BTreeMap::new();
    for f in &m.d.fused {
        tracks.entry(f.fused_id).or_default().push(f);
    }
    for (i, (id, rows)) in tracks.iter().enumerate() {
        let c = colour(i);
        let style = c.stroke_width(2);
        let pts: Vec<(f64, f64)> = rows.iter().map(|f| km(position_of(&f.state))).collect();
        for seg in split_jumps(&pts) {
            chart
                .draw_series(LineSeries::new(seg, style))
                .map_err(plot_err)?;
        }
        if m.d.ellipses {
            for f in rows.iter().step_by(10) {
                if let Some(e) = ellipse(&f.state, &f.cov) {
                    chart
                        .draw_series(LineSeries::new(e, c.mix(0.7).stroke_width(1)))
                        .map_err(plot_err)?;
                }
            }
        }
        if let Some(&last) = pts.last() {
            chart
                .draw_series(std::iter::once(
                    EmptyElement::at(last)
                        + Circle::new((0, 0), 2, c.filled())
                        + Text::new(
                            format!("{id}"),
                            (4, -12),
                            ("sans-serif", 12).into_font().color(&c),
                        ),
                ))
                .map_err(plot_err)?;
        }
    }
    if !tracks.is_empty() {
        lg.push((
            "fused track, id at".into(),
            Mark::Line(colour(0).to_rgba(), 2),
        ));
        lg.push(("  its last point".into(), Mark::Blank));
        if m.d.ellipses {
            lg.push(("2-sigma ellipse".into(), Mark::Line(colour(0).mix(0.7), 1)));
        }
    }
    draw_truth(&mut chart, &m.d.truth, BLACK.stroke_width(1), &mut lg)?;
    side_legend(&side, &lg)
}

/// Time key of a row (ns, so that equal times compare equal).
fn tkey(t: f64) -> i64 {
    (t * 1e9).round() as i64
}

/// The truth at given times: rows at that time, or interpolated (see the module doc).
struct TruthAt {
    by_time: BTreeMap<i64, Vec<TruthState>>,
    by_target: BTreeMap<Id, Vec<TruthState>>,
    max_gap: f64,
}

impl TruthAt {
    fn new(truth: &[TruthState]) -> TruthAt {
        let mut by_time: BTreeMap<i64, Vec<TruthState>> = BTreeMap::new();
        let mut by_target: BTreeMap<Id, Vec<TruthState>> = BTreeMap::new();
        for t in truth {
            by_time.entry(tkey(t.time)).or_default().push(*t);
            by_target.entry(t.target_id).or_default().push(*t);
        }
        for v in by_target.values_mut() {
            v.sort_by(|a, b| a.time.total_cmp(&b.time));
        }
        let mut gaps: Vec<f64> = by_target
            .values()
            .flat_map(|v| v.windows(2).map(|w| w[1].time - w[0].time))
            .filter(|g| *g > 0.0)
            .collect();
        gaps.sort_by(f64::total_cmp);
        let max_gap = gaps.get(gaps.len() / 2).map_or(0.0, |m| 2.0 * m);
        TruthAt {
            by_time,
            by_target,
            max_gap,
        }
    }

    fn at(&self, time: f64) -> Vec<TruthState> {
        if let Some(v) = self.by_time.get(&tkey(time)) {
            return v.clone();
        }
        let mut out = Vec::new();
        for rows in self.by_target.values() {
            let i = rows.partition_point(|r| r.time < time);
            if i == 0 || i >= rows.len() {
                continue;
            }
            let (a, b) = (&rows[i - 1], &rows[i]);
            if b.time - a.time > self.max_gap {
                continue;
            }
            let w = (time - a.time) / (b.time - a.time);
            let mut t = *a;
            t.time = time;
            t.state = a.state * (1.0 - w) + b.state * w;
            out.push(t);
        }
        out
    }
}

/// Per-time-step values of the fused tracks against the truth.
struct Step {
    time: f64,
    gospa: Gospa,
    /// (target, position error m)
    errors: Vec<(Id, f64)>,
    /// NEES of each assigned estimate
    nees: Vec<f64>,
}

fn nees(e: &StateVec, p: &StateCov) -> Option<f64> {
    let inv = p.try_inverse()?;
    let v = (e.transpose() * inv * e)[(0, 0)];
    v.is_finite().then_some(v)
}

fn fused_steps(d: &PlotData, truth: &TruthAt) -> Vec<Step> {
    let mut by_time: BTreeMap<i64, Vec<&FusedTrack>> = BTreeMap::new();
    for f in &d.fused {
        by_time.entry(tkey(f.time)).or_default().push(f);
    }
    let synchronous = by_time.keys().all(|k| truth.by_time.contains_key(k));
    if synchronous {
        for k in truth.by_time.keys() {
            by_time.entry(*k).or_default();
        }
    }
    let (c, p) = (d.evaluation.gospa_c, d.evaluation.gospa_p);
    by_time
        .iter()
        .map(|(k, fs)| {
            let time = *k as f64 / 1e9;
            let ts = truth.at(time);
            let tpos: Vec<Vec2> = ts.iter().map(|t| position_of(&t.state)).collect();
            let fpos: Vec<Vec2> = fs.iter().map(|f| position_of(&f.state)).collect();
            let g = gospa(&tpos, &fpos, c, p);
            let mut errors = Vec::new();
            let mut ns = Vec::new();
            for (fi, ti) in gated_assignment(&fpos, &tpos, c).into_iter().enumerate() {
                if let Some(ti) = ti {
                    errors.push((ts[ti].target_id, (fpos[fi] - tpos[ti]).norm()));
                    if let Some(v) = nees(&(fs[fi].state - ts[ti].state), &fs[fi].cov) {
                        ns.push(v);
                    }
                }
            }
            Step {
                time,
                gospa: g,
                errors,
                nees: ns,
            }
        })
        .collect()
}

/// RMS local position error over targets per time, per sensor.
fn local_rms(d: &PlotData, truth: &TruthAt) -> BTreeMap<Id, Vec<(f64, f64)>> {
    let mut by: BTreeMap<(Id, i64), Vec<Vec2>> = BTreeMap::new();
    for l in &d.local {
        by.entry((l.sensor_id, tkey(l.time)))
            .or_default()
            .push(position_of(&l.state));
    }
    let mut out: BTreeMap<Id, Vec<(f64, f64)>> = BTreeMap::new();
    for ((sid, k), lpos) in by {
        let time = k as f64 / 1e9;
        let tpos: Vec<Vec2> = truth
            .at(time)
            .iter()
            .map(|t| position_of(&t.state))
            .collect();
        let e2: Vec<f64> = gated_assignment(&lpos, &tpos, d.evaluation.label_gate)
            .into_iter()
            .enumerate()
            .filter_map(|(li, ti)| ti.map(|ti| (lpos[li] - tpos[ti]).norm_squared()))
            .collect();
        if !e2.is_empty() {
            let rms = (e2.iter().sum::<f64>() / e2.len() as f64).sqrt();
            out.entry(sid).or_default().push((time, rms));
        }
    }
    out
}

type XY =
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>;

fn xy_chart<'a, DB: DrawingBackend>(
    root: &'a Area<DB>,
    title: &str,
    x: (f64, f64),
    y: (f64, f64),
    xdesc: &str,
    ydesc: &str,
) -> Result<ChartContext<'a, DB, XY>> {
    let x1 = if x.1 > x.0 { x.1 } else { x.0 + 1.0 };
    let y1 = if y.1 > y.0 { y.1 } else { y.0 + 1.0 };
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(65)
        .build_cartesian_2d(x.0..x1, y.0..y1)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(246, 246, 246))
        .x_desc(xdesc)
        .y_desc(ydesc)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(plot_err)?;
    Ok(chart)
}

fn range_of(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for x in v.filter(|x| x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if lo > hi {
        (0.0, 1.0)
    } else {
        (lo, hi)
    }
}

/// Lines of `(x, y)` series, one colour each, in a chart from y = 0.
fn draw_lines<DB: DrawingBackend>(
    root: &Area<DB>,
    title: &str,
    xdesc: &str,
    ydesc: &str,
    series: &[(String, Vec<(f64, f64)>)],
    legend_max: usize,
) -> Result<()> {
    let (plot, side) = split_legend(root);
    let x = range_of(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)));
    let y = range_of(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)));
    let mut chart = xy_chart(&plot, title, x, (0.0, y.1 * 1.08), xdesc, ydesc)?;
    let mut lg = Legend::new();
    for (i, (name, pts)) in series.iter().enumerate() {
        let style = colour(i).stroke_width(if series.len() > 5 { 1 } else { 2 });
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), style))
            .map_err(plot_err)?;
        if i < legend_max {
            lg.push((name.clone(), Mark::Line(style.color, 3)));
        }
    }
    if series.len() > legend_max {
        lg.push((
            format!("{} series, colours repeat", series.len()),
            Mark::Line(colour(0).to_rgba(), 1),
        ));
    }
    side_legend(&side, &lg)
}

/// A line figure: title, x axis, y axis, named series, legend entries at most.
type LineFig<'a> = (
    &'a str,
    &'a str,
    &'a str,
    Vec<(String, Vec<(f64, f64)>)>,
    usize,
);

fn draw_series_fig<DB: DrawingBackend>(root: &Area<DB>, a: &LineFig<'_>) -> Result<()> {
    draw_lines(root, a.0, a.1, a.2, &a.3, a.4)
}

fn draw_gospa<DB: DrawingBackend>(root: &Area<DB>, a: &(&[Step], f64, f64)) -> Result<()> {
    let (steps, c, p) = *a;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let dist = vec![(
        "GOSPA".to_string(),
        steps.iter().map(|s| (s.time, s.gospa.distance)).collect(),
    )];
    let title = format!("GOSPA per time step (c = {c} m, p = {p}, alpha = 2)");
    draw_lines(&top, &title, "time (s)", "GOSPA (m)", &dist, 1)?;
    let parts = vec![
        (
            "localisation".to_string(),
            steps
                .iter()
                .map(|s| (s.time, s.gospa.localisation))
                .collect(),
        ),
        (
            "missed targets".to_string(),
            steps.iter().map(|s| (s.time, s.gospa.missed)).collect(),
        ),
        (
            "false tracks".to_string(),
            steps.iter().map(|s| (s.time, s.gospa.false_)).collect(),
        ),
    ];
    let unit = if p == 1.0 {
        "part (m)".to_string()
    } else {
        format!("part (m^{p})")
    };
    draw_lines(&bottom, "GOSPA parts", "time (s)", &unit, &parts, 3)
}

fn draw_nees<DB: DrawingBackend>(root: &Area<DB>, steps: &[Step]) -> Result<()> {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    // mean NEES of n 4-dim errors: n * mean ~ chi2(4n) if consistent
    let rows: Vec<(f64, f64, f64, f64)> = steps
        .iter()
        .filter(|s| !s.nees.is_empty())
        .filter_map(|s| {
            let n = s.nees.len() as f64;
            let mean = s.nees.iter().sum::<f64>() / n;
            let chi = ChiSquared::new(4.0 * n).ok()?;
            Some((
                s.time,
                mean,
                chi.inverse_cdf(0.025) / n,
                chi.inverse_cdf(0.975) / n,
            ))
        })
        .collect();
    let x = range_of(rows.iter().map(|r| r.0));
    let ymax = rows
        .iter()
        .map(|r| r.1.max(r.3))
        .fold(8.0f64, f64::max)
        .min(rows.iter().map(|r| r.3).fold(8.0, f64::max) * 6.0);
    let (plot, side) = split_legend(root);
    let mut chart = xy_chart(
        &plot,
        "NEES of the fused tracks per time step (4-dim state)",
        x,
        (0.0, ymax * 1.05),
        "time (s)",
        "mean NEES (dimensionless)",
    )?;
    let band: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.0, r.3))
        .chain(rows.iter().rev().map(|r| (r.0, r.2)))
        .collect();
    let band_style = RGBColor(44, 160, 44).mix(0.2);
    chart
        .draw_series(std::iter::once(Polygon::new(band, band_style)))
        .map_err(plot_err)?;
    let ideal = BLACK.mix(0.6).stroke_width(1);
    chart
        .draw_series(LineSeries::new([(x.0, 4.0), (x.1, 4.0)], ideal))
        .map_err(plot_err)?;
    let style = colour(0).stroke_width(2);
    chart
        .draw_series(LineSeries::new(
            rows.iter().map(|r| (r.0, r.1.min(ymax * 1.05))),
            style,
        ))
        .map_err(plot_err)?;
    side_legend(
        &side,
        &[
            ("mean NEES".into(), Mark::Line(style.color, 2)),
            ("  (clipped at the top)".into(), Mark::Blank),
            ("ideal: 4".into(), Mark::Line(ideal.color, 1)),
            ("95 % band of the".into(), Mark::Band(band_style)),
            ("  mean if consistent".into(), Mark::Blank),
        ],
    )
}

fn draw_bias<DB: DrawingBackend>(root: &Area<DB>, d: &PlotData) -> Result<()> {
    let (charts, side) = split_legend(root);
    let (left, right) = charts.split_horizontally(charts.dim_in_pixel().0 / 2);
    let ids: Vec<Id> = d.bias.iter().map(|b| b.sensor_id).collect();
    let n = ids.len() as f64;
    for (area, title, unit, scale, est, tru) in [
        (
            &left,
            "Range bias per sensor",
            "range bias (m)",
            1.0,
            (|b: &BiasEstimate| b.range) as fn(&BiasEstimate) -> f64,
            (|s: &Sensor| s.bias_r) as fn(&Sensor) -> f64,
        ),
        (
            &right,
            "Bearing bias per sensor",
            "bearing bias (mrad)",
            1000.0,
            |b: &BiasEstimate| b.bearing,
            |s: &Sensor| s.bias_theta,
        ),
    ] {
        let pts: Vec<(f64, f64, Option<f64>)> = d
            .bias
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let t = d.sensors.iter().find(|s| s.id == b.sensor_id).map(tru);
                (i as f64, est(b) * scale, t.map(|t| t * scale))
            })
            .collect();
        let y = range_of(
            pts.iter()
                .flat_map(|p| [Some(p.1), p.2, Some(0.0)])
                .flatten(),
        );
        let span = (y.1 - y.0).max(1e-3);
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(
                -0.5..(n - 0.5).max(0.5),
                (y.0 - 0.1 * span)..(y.1 + 0.45 * span),
            )
            .map_err(plot_err)?;
        let idc = ids.clone();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(ids.len().max(1))
            .x_label_formatter(&move |x| {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 {
                    idc.get(i as usize)
                        .map_or(String::new(), |s| format!("S{s}"))
                } else {
                    String::new()
                }
            })
            .x_desc("sensor")
            .y_desc(unit)
            .y_label_formatter(&|v| tick(*v))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(plot_err)?;
        let est_style = colour(0).filled();
        chart
            .draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 6, est_style)))
            .map_err(plot_err)?;
        let true_style = BLACK.stroke_width(3);
        chart
            .draw_series(pts.iter().filter_map(|p| {
                p.2.map(|t| PathElement::new(vec![(p.0 - 0.3, t), (p.0 + 0.3, t)], true_style))
            }))
            .map_err(plot_err)?;
    }
    side_legend(
        &side,
        &[
            ("estimate (center)".into(), Mark::Dot(colour(0).to_rgba())),
            ("true (sensors.csv)".into(), Mark::Line(BLACK.to_rgba(), 3)),
        ],
    )
}

/// The fused RMSE per scan figure of a summary's `fused_rmse_per_scan` (none when empty).
pub fn rmse_figure(per_scan: &[(u32, f64)], title: &str) -> Result<Option<Figure>> {
    if per_scan.is_empty() {
        return Ok(None);
    }
    let a = (
        title,
        "scan",
        "RMSE (m)",
        vec![(
            "fused".to_string(),
            per_scan
                .iter()
                .map(|&(s, v)| (s as f64, v))
                .collect::<Vec<_>>(),
        )],
        1usize,
    );
    Ok(Some(figure!(
        "rmse_per_scan",
        title,
        "Fused position RMSE per scan, over every target (and every run) assigned at that scan.",
        (900, 450),
        draw_series_fig(&a)
    )))
}

/// One named `(x, y)` series of a line figure.
pub type Series = (String, Vec<(f64, f64)>);

/// Lines with a dot at every point (the sweeps of the reproductions: few points, each
/// a Monte Carlo result), the y axis from 0 to `y_max` (or 8 % above the largest value).
fn draw_points<DB: DrawingBackend>(
    root: &Area<DB>,
    a: &(&str, &str, &str, &[Series], Option<f64>),
) -> Result<()> {
    let (title, xdesc, ydesc, series, y_max) = *a;
    let (plot, side) = split_legend(root);
    let x = range_of(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)));
    let y = range_of(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)));
    let top = y_max.unwrap_or(y.1 * 1.08);
    let mut chart = xy_chart(&plot, title, x, (0.0, top), xdesc, ydesc)?;
    let mut lg = Legend::new();
    let n = series.len() as u32;
    for (i, (name, pts)) in series.iter().enumerate() {
        let c = colour(i);
        // earlier series wider and with larger dots, so that a later one drawn over an
        // equal curve leaves it visible at its edges
        let (base, step) = if pts.len() <= 60 { (2, 2) } else { (1, 1) };
        let w = base + step * (n - 1 - i as u32).min(2);
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(w)))
            .map_err(plot_err)?;
        if pts.len() <= 60 {
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, w + 1, c.filled())))
                .map_err(plot_err)?;
        }
        lg.push((name.clone(), Mark::Line(c.to_rgba(), w)));
    }
    if n > 1 {
        lg.push(("(equal curves overlap:".into(), Mark::Blank));
        lg.push((" the first drawn widest)".into(), Mark::Blank));
    }
    side_legend(&side, &lg)
}

/// A line figure of named series (for the reproductions' figures): `xdesc` / `ydesc`
/// are the axis labels with their units; `y_max` fixes the top of the y axis (the
/// bottom is 0). Series of at most 60 points get a dot at every point.
pub fn line_figure(
    name: &'static str,
    title: &str,
    caption: &str,
    (xdesc, ydesc): (&str, &str),
    series: &[Series],
    y_max: Option<f64>,
) -> Result<Figure> {
    let a = (title, xdesc, ydesc, series, y_max);
    Ok(figure!(name, title, caption, (900, 480), draw_points(&a)))
}

/// Every figure the data allow, in [`FIGURE_NAMES`] order.
pub fn figures(d: &PlotData) -> Result<Vec<Figure>> {
    let mut out = Vec::new();
    let size = (900, 820);
    let mut pts: Vec<(f64, f64)> = d.truth.iter().map(|t| km(position_of(&t.state))).collect();
    pts.extend(d.sensors.iter().map(|s| (s.x / 1000.0, s.y / 1000.0)));
    if pts.is_empty() {
        pts.extend(d.fused.iter().map(|f| km(position_of(&f.state))));
        pts.extend(d.local.iter().map(|l| km(position_of(&l.state))));
    }
    let mut map_pts = pts.clone();
    for s in d.sensors.iter().filter(|s| s.max_range > 0.0) {
        map_pts.push(((s.x - s.max_range) / 1000.0, (s.y - s.max_range) / 1000.0));
        map_pts.push(((s.x + s.max_range) / 1000.0, (s.y + s.max_range) / 1000.0));
    }
    if let Some(bounds) = map_bounds(&map_pts, size) {
        if !d.truth.is_empty() || !d.sensors.is_empty() {
            let m = MapCtx { d, bounds };
            out.push(figure!(
                "scenario_map",
                "Scenario",
                "Sensors (triangles) with their coverage rings where max_range is known, and the true trajectories (T = target id at its start).",
                size,
                draw_map(&m)
            ));
        }
    }
    // the track maps zoom on the truth (on the tracks without a truth); sensors outside
    // are left out of view
    let mut zoom: Vec<(f64, f64)> = d.truth.iter().map(|t| km(position_of(&t.state))).collect();
    if zoom.is_empty() {
        zoom.extend(d.fused.iter().map(|f| km(position_of(&f.state))));
        zoom.extend(d.local.iter().map(|l| km(position_of(&l.state))));
    }
    let Some(bounds) = map_bounds(&zoom, size) else {
        return Ok(out);
    };
    let m = MapCtx { d, bounds };
    if !d.local.is_empty() {
        out.push(figure!(
            "local_tracks",
            "Local tracks",
            "Each sensor's local tracks in its own colour; the truth in grey.",
            size,
            draw_local(&m)
        ));
    }
    if !d.fused.is_empty() {
        out.push(figure!(
            "fused_tracks",
            "Fused tracks",
            if d.ellipses {
                "Fused tracks, one colour per fused_id with the id at its last point and 2-sigma position ellipses; the truth drawn over them in black."
            } else {
                "Fused tracks, one colour per fused_id with the id at its last point; the truth drawn over them in black."
            },
            size,
            draw_fused(&m)
        ));
    }
    if !d.truth.is_empty() && (!d.fused.is_empty() || !d.local.is_empty()) {
        let truth = TruthAt::new(&d.truth);
        let steps = fused_steps(d, &truth);
        if !d.fused.is_empty() {
            let mut per: BTreeMap<Id, Vec<(f64, f64)>> = BTreeMap::new();
            for s in &steps {
                for &(t, e) in &s.errors {
                    per.entry(t).or_default().push((s.time, e));
                }
            }
            let series: Vec<(String, Vec<(f64, f64)>)> = per
                .into_iter()
                .map(|(t, v)| (format!("target {t}"), v))
                .collect();
            let legend_max = if series.len() <= 10 { series.len() } else { 0 };
            let a = (
                "Fused position error per target",
                "time (s)",
                "position error (m)",
                series,
                legend_max,
            );
            out.push(figure!(
                "position_error",
                "Position error per target",
                "Distance between each target and the fused track assigned to it, per time step (one colour per target).",
                (900, 450),
                draw_series_fig(&a)
            ));
        }
        let mut methods: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
        if !d.fused.is_empty() {
            methods.push((
                "fused".into(),
                steps
                    .iter()
                    .filter(|s| !s.errors.is_empty())
                    .map(|s| {
                        let e2: f64 = s.errors.iter().map(|e| e.1 * e.1).sum();
                        (s.time, (e2 / s.errors.len() as f64).sqrt())
                    })
                    .collect(),
            ));
        }
        for (sid, v) in local_rms(d, &truth) {
            methods.push((format!("local, sensor {sid}"), v));
        }
        if !methods.is_empty() {
            let n = methods.len();
            let a = (
                "Position error per time step: fused and local",
                "time (s)",
                "RMS position error over targets (m)",
                methods,
                n,
            );
            out.push(figure!(
                "error_by_method",
                "Position error by method",
                "RMS over the targets of the position error per time step, of the fused tracks and of each sensor's local tracks.",
                (900, 450),
                draw_series_fig(&a)
            ));
        }
        if !d.fused.is_empty() {
            let a = (steps.as_slice(), d.evaluation.gospa_c, d.evaluation.gospa_p);
            out.push(figure!(
                "gospa",
                "GOSPA over time",
                "GOSPA of the fused tracks per time step (top) and its parts: localisation, missed targets, false tracks (bottom).",
                (900, 700),
                draw_gospa(&a)
            ));
            if steps.iter().any(|s| !s.nees.is_empty()) {
                out.push(figure!(
                    "nees",
                    "NEES over time",
                    "Mean NEES of the fused estimates assigned to a target, per time step, with the 95 % chi-square band of the mean for a consistent filter.",
                    (900, 450),
                    draw_nees(&steps)
                ));
            }
        }
    }
    if !d.bias.is_empty() {
        out.push(figure!(
            "bias",
            "Bias estimates",
            "The fusion center's final sensor-bias estimates against the true biases of sensors.csv (range in m, bearing in mrad).",
            (900, 420),
            draw_bias(d)
        ));
    }
    if !d.bias_history.is_empty() {
        out.push(figure!(
            "bias_convergence",
            "Bias estimates over time",
            "Each sensor's range (left, m) and bearing (right, mrad) bias estimate after every fused instant, one colour per sensor; its true bias from sensors.csv dashed in the same colour.",
            (1000, 450),
            draw_bias_convergence(d)
        ));
    }
    if let Some(f) = rmse_figure(&d.rmse_per_scan, "Fused position RMSE per scan")? {
        out.push(f);
    }
    Ok(out)
}

/// The rows of a small CSV file of named numeric columns: each row's cells of `names`
/// (in that order) parsed as finite numbers, errors naming file, line and column. The
/// bias files are a few rows per instant, so this reads them with the `csv` crate
/// rather than the streaming readers of the large files.
fn read_numeric_columns(path: &Path, names: &[&str]) -> Result<Vec<Vec<f64>>> {
    let mut r = csv::ReaderBuilder::new()
        .from_path(path)
        .with_context(|| format!("reading {}", path.display()))?;
    let headers = r
        .headers()
        .with_context(|| format!("reading {}", path.display()))?
        .clone();
    let cols: Vec<usize> = names
        .iter()
        .map(|name| {
            headers
                .iter()
                .position(|h| h.trim() == *name)
                .ok_or_else(|| anyhow!("{}: line 1: no column `{name}`", path.display()))
        })
        .collect::<Result<_>>()?;
    let mut out = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let line = i + 2;
        let rec = rec.with_context(|| format!("{}: line {line}", path.display()))?;
        let mut row = Vec::with_capacity(cols.len());
        for (&c, name) in cols.iter().zip(names) {
            let s = rec.get(c).map(str::trim).ok_or_else(|| {
                anyhow!(
                    "{}: line {line}, column {}: `{name}` missing",
                    path.display(),
                    c + 1
                )
            })?;
            let v: f64 = s.parse().map_err(|_| {
                anyhow!(
                    "{}: line {line}, column {} ({name}): `{s}` is not a number",
                    path.display(),
                    c + 1
                )
            })?;
            if !v.is_finite() {
                bail!(
                    "{}: line {line}, column {} ({name}): {v} is not finite",
                    path.display(),
                    c + 1
                );
            }
            // ids and scans must be whole numbers in range
            if (name.ends_with("_id") || *name == "scan")
                && (v.fract() != 0.0
                    || v.abs() > (1u64 << 53) as f64
                    || (*name == "scan" && !(0.0..=u32::MAX as f64).contains(&v)))
            {
                bail!(
                    "{}: line {line}, column {} ({name}): `{s}` is not an integer in range",
                    path.display(),
                    c + 1
                );
            }
            row.push(v);
        }
        out.push(row);
    }
    Ok(out)
}

/// bias_estimates.csv (`sensor_id,bias_r,bias_theta`), errors naming file, line, column.
pub fn read_bias(path: &Path) -> Result<Vec<BiasEstimate>> {
    Ok(
        read_numeric_columns(path, &["sensor_id", "bias_r", "bias_theta"])?
            .into_iter()
            .map(|r| BiasEstimate {
                sensor_id: r[0] as Id,
                range: r[1],
                bearing: r[2],
            })
            .collect(),
    )
}

/// bias_history.csv (`scan,time,sensor_id,bias_r,bias_theta`), errors naming file, line,
/// column.
pub fn read_bias_history(path: &Path) -> Result<Vec<BiasSample>> {
    Ok(
        read_numeric_columns(path, &["scan", "time", "sensor_id", "bias_r", "bias_theta"])?
            .into_iter()
            .map(|r| BiasSample {
                scan: r[0] as u32,
                time: r[1],
                estimate: BiasEstimate {
                    sensor_id: r[2] as Id,
                    range: r[3],
                    bearing: r[4],
                },
            })
            .collect(),
    )
}

/// Each sensor's range and bearing bias estimates over time, its true bias dashed.
fn draw_bias_convergence<DB: DrawingBackend>(root: &Area<DB>, d: &PlotData) -> Result<()> {
    let (charts, side) = split_legend(root);
    let (left, right) = charts.split_horizontally(charts.dim_in_pixel().0 / 2);
    let mut by_sensor: BTreeMap<Id, Vec<&BiasSample>> = BTreeMap::new();
    for b in &d.bias_history {
        by_sensor.entry(b.estimate.sensor_id).or_default().push(b);
    }
    let x = range_of(d.bias_history.iter().map(|b| b.time));
    type Get = fn(&BiasSample) -> f64;
    type True = fn(&Sensor) -> f64;
    let panels: [(&Area<DB>, &str, &str, Get, True); 2] = [
        (
            &left,
            "Range bias estimate",
            "range bias (m)",
            |b| b.estimate.range,
            |s| s.bias_r,
        ),
        (
            &right,
            "Bearing bias estimate",
            "bearing bias (mrad)",
            |b| b.estimate.bearing * 1000.0,
            |s| s.bias_theta * 1000.0,
        ),
    ];
    for (area, title, unit, get, tru) in panels {
        let truths: BTreeMap<Id, f64> = by_sensor
            .keys()
            .filter_map(|id| {
                d.sensors
                    .iter()
                    .find(|s| s.id == *id)
                    .map(|s| (*id, tru(s)))
            })
            .collect();
        let y = range_of(
            d.bias_history
                .iter()
                .map(get)
                .chain(truths.values().copied())
                .chain([0.0]),
        );
        let pad = 0.08 * (y.1 - y.0).max(1e-3);
        let mut chart = xy_chart(area, title, x, (y.0 - pad, y.1 + pad), "time (s)", unit)?;
        for (i, (id, rows)) in by_sensor.iter().enumerate() {
            let c = colour(i);
            chart
                .draw_series(LineSeries::new(
                    rows.iter().map(|b| (b.time, get(b))),
                    c.stroke_width(2),
                ))
                .map_err(plot_err)?;
            if let Some(&t) = truths.get(id) {
                chart
                    .draw_series(DashedLineSeries::new(
                        [(x.0, t), (x.1.max(x.0 + 1.0), t)],
                        8,
                        5,
                        c.stroke_width(1),
                    ))
                    .map_err(plot_err)?;
            }
        }
    }
    let mut lg = Legend::new();
    for (i, id) in by_sensor.keys().enumerate() {
        lg.push((
            format!("sensor {id} estimate"),
            Mark::Line(colour(i).to_rgba(), 3),
        ));
    }
    if !d.sensors.is_empty() {
        lg.push(("true bias: dashed".into(), Mark::Line(BLACK.mix(0.6), 1)));
    }
    side_legend(&side, &lg)
}

/// The file `given`, or `dir/name` when it exists.
fn input(dir: &Path, given: &Option<PathBuf>, name: &str) -> Option<PathBuf> {
    given
        .clone()
        .or_else(|| Some(dir.join(name)).filter(|p| p.is_file()))
}

pub fn run(args: &PlotArgs) -> Result<()> {
    let cfg = EvaluationConfig {
        gospa_c: args.gospa_c,
        gospa_p: args.gospa_p,
        label_gate: args.label_gate,
    };
    cfg.validate()
        .map_err(|e| anyhow!("--{}: {}", e.key.replace('_', "-"), e.reason))?;
    if !args.dir.is_dir() {
        bail!("{}: not a folder", args.dir.display());
    }
    let truth_p = input(&args.dir, &args.truth, "truth.csv");
    let sensors_p = input(&args.dir, &args.sensors, "sensors.csv");
    let local_p = input(&args.dir, &args.local_tracks, "local_tracks.csv");
    let fused_p = input(&args.dir, &args.fused_tracks, "fused_tracks.csv");
    let bias_p = input(&args.dir, &args.bias, "bias_estimates.csv");
    let history_p = input(&args.dir, &args.bias_history, "bias_history.csv");
    let summary_p = Some(args.dir.join("summary.json")).filter(|p| p.is_file());
    let all: Vec<PathBuf> = [
        &truth_p, &sensors_p, &local_p, &fused_p, &bias_p, &history_p, &summary_p,
    ]
    .into_iter()
    .flatten()
    .cloned()
    .collect();
    if truth_p.is_none() && sensors_p.is_none() && local_p.is_none() && fused_p.is_none() {
        bail!(
            "{}: none of truth.csv, sensors.csv, local_tracks.csv, fused_tracks.csv there (or given with --truth, --sensors, --local-tracks, --fused-tracks)",
            args.dir.display()
        );
    }
    let inputs: Vec<&Path> = all.iter().map(|p| p.as_path()).collect();
    let names = plot_outputs();
    let name_refs: Vec<&str> = names.iter().map(|s| s.as_str()).collect();
    let mut outs = Outputs::new(&args.out, &name_refs, &inputs)?;
    let mut d = PlotData {
        evaluation: cfg,
        ellipses: args.ellipses,
        ..Default::default()
    };
    if let Some(p) = &truth_p {
        d.truth = read_truth(p)?;
    }
    if let Some(p) = &sensors_p {
        d.sensors = read_sensors(p)?;
    }
    if let Some(p) = &local_p {
        d.local = read_local_tracks(p)?;
    }
    if let Some(p) = &fused_p {
        d.fused = read_fused_tracks(p)?;
    }
    if let Some(p) = &bias_p {
        d.bias = read_bias(p)?;
    }
    if let Some(p) = &history_p {
        d.bias_history = read_bias_history(p)?;
    }
    if let Some(p) = &summary_p {
        let text =
            std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
        // another tool's summary.json may be anything (Stone Soup's holds NaN, which is
        // not JSON): said on stderr, and only the RMSE-per-scan plot is left out
        let v: Option<serde_json::Value> = match serde_json::from_str(&text) {
            Ok(v) => Some(v),
            Err(e) => {
                eprintln!(
                    "{}: not JSON trackfuse reads ({e}); its RMSE-per-scan plot is left out",
                    p.display()
                );
                None
            }
        };
        match v
            .as_ref()
            .map(|v| v.get("fused_rmse_per_scan").and_then(|a| a.as_array()))
        {
            None => {}
            Some(Some(a)) => {
                for (i, e) in a.iter().enumerate() {
                    let pair = e[0].as_u64().zip(e[1].as_f64()).ok_or_else(|| {
                        anyhow!(
                            "{}: fused_rmse_per_scan[{i}] is not a [scan, rmse] pair",
                            p.display()
                        )
                    })?;
                    let scan = u32::try_from(pair.0).map_err(|_| {
                        anyhow!("{}: fused_rmse_per_scan[{i}]: scan {} too large", p.display(), pair.0)
                    })?;
                    d.rmse_per_scan.push((scan, pair.1));
                }
            }
            Some(None) => eprintln!(
                "{}: no fused_rmse_per_scan (not a trackfuse summary); its RMSE-per-scan plot is left out",
                p.display()
            ),
        }
    }
    let figs = figures(&d)?;
    for f in &figs {
        let a = outs.write(&format!("{}.svg", f.name), f.svg.as_bytes())?;
        let b = outs.write(&format!("{}.png", f.name), &f.png)?;
        eprintln!("wrote {} and {}", a.display(), b.display());
    }
    outs.finish();
    Ok(())
}
