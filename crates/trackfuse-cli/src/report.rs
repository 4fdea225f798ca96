//! The run report: `report.html` (one self-contained file: styles inline, every plot a
//! PNG data URI, no script or font fetched, so it opens offline) and `report.md` (the same
//! text, the plots left out, since Markdown cannot inline them portably and the PNG/SVG
//! files are one `trackfuse plot` away), written by `run`, `mc` and `evaluate`: the metric
//! tables, the scenario, the methods with every parameter in force, the version and the
//! command line.
//!
//! The HTML carries one small inline script that checks, once the page has loaded, that
//! every plot decoded and is not blank (it draws each into a canvas and looks for a
//! non-white pixel), marks the page with the result (`data-images-ok` / `data-images-bad`
//! on `<body>`) and reports a broken plot as a console error and a visible note: what the
//! headless-Chromium test reads, and what tells a reader a plot is missing.

use crate::common::summary_tables;
use crate::describe::{command_line_text, Provenance, VERSION};
use crate::output::Outputs;
use crate::plot::Figure;
use anyhow::Result;
use base64::Engine;
use trackfuse::metrics::Summary;

/// What a report is made of.
pub struct ReportInput<'a> {
    pub summary: &'a Summary,
    pub provenance: &'a Provenance,
    /// The scenario as run (run, mc).
    pub scenario_text: Option<&'a str>,
    pub figures: Vec<Figure>,
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn md_cell(s: &str) -> String {
    s.trim_start().replace('|', "\\|")
}

/// The facts of the header: (label, value).
fn facts(r: &ReportInput<'_>) -> Vec<(String, String)> {
    let p = r.provenance;
    let mut v = vec![
        ("trackfuse version".to_string(), VERSION.to_string()),
        ("command".to_string(), p.command.to_string()),
        (
            "command line".to_string(),
            command_line_text(&p.command_line),
        ),
    ];
    if let Some(s) = &p.scenario {
        v.push((
            "scenario".into(),
            if s.is_empty() { "-".into() } else { s.clone() },
        ));
    }
    if let Some(s) = p.seed {
        v.push(("master seed".into(), s.to_string()));
    }
    if let Some(s) = p.run_index {
        v.push(("Monte Carlo run index".into(), s.to_string()));
    }
    if let Some(n) = p.monte_carlo_runs {
        v.push(("Monte Carlo runs".into(), n.to_string()));
    }
    if let Some(m) = &p.methods {
        v.push((
            "local tracker".into(),
            format!("{} + {}", m.tracker.associator, m.tracker.filter),
        ));
        v.push((
            "fusion center".into(),
            format!("{} + {}", m.fusion.method, m.fusion.rule),
        ));
        v.push(("bias estimation".into(), m.bias_resolved.clone()));
        if let Some([qx, qy]) = m.tracker_process_noise_resolved {
            v.push((
                "local process noise".into(),
                format!("{qx}, {qy} m/s^2 (x, y)"),
            ));
        }
    }
    v.push((
        "evaluation".into(),
        format!(
            "GOSPA c = {} m, p = {}, alpha = 2; local-track label gate {} m",
            p.evaluation.gospa_c, p.evaluation.gospa_p, p.evaluation.label_gate
        ),
    ));
    v
}

/// The parameters in force, as TOML (the `[tracker]`, `[fusion]`, `[evaluation]` tables
/// the run used).
fn parameters_toml(p: &Provenance) -> Option<String> {
    let m = p.methods.as_ref()?;
    #[derive(serde::Serialize)]
    struct InForce<'a> {
        tracker: &'a trackfuse::local::TrackerConfig,
        fusion: &'a trackfuse::center::FusionConfig,
        evaluation: &'a trackfuse::metrics::EvaluationConfig,
    }
    toml::to_string(&InForce {
        tracker: &m.tracker,
        fusion: &m.fusion,
        evaluation: &p.evaluation,
    })
    .ok()
}

fn title(r: &ReportInput<'_>) -> String {
    let p = r.provenance;
    match (&p.scenario, p.command) {
        (Some(s), "mc") if !s.is_empty() => format!("trackfuse Monte Carlo report: {s}"),
        (Some(s), _) if !s.is_empty() => format!("trackfuse run report: {s}"),
        (_, "evaluate") => "trackfuse evaluation report".into(),
        _ => "trackfuse run report".into(),
    }
}

const SPREAD_NOTE: &str = "The spread columns are over the per-run values: their sample standard deviation and the Student-t 95 % confidence interval of their mean (the value column pools every sample of every run).";

/// report.md.
pub fn markdown(r: &ReportInput<'_>) -> String {
    let mut s = format!("# {}\n\n", title(r));
    for (k, v) in facts(r) {
        if k == "command line" {
            s.push_str(&format!("- {k}: `{v}`\n"));
        } else {
            s.push_str(&format!("- {k}: {v}\n"));
        }
    }
    s.push_str("\n## Metrics\n\n");
    s.push_str(&format!("runs: {}\n\n", r.summary.runs));
    for t in summary_tables(r.summary, &r.provenance.spread) {
        if !t.title.is_empty() {
            s.push_str(&format!("### {}\n\n", t.title));
        }
        s.push_str(&format!(
            "| {} |\n|{}\n",
            t.header.join(" | "),
            t.header
                .iter()
                .enumerate()
                .map(|(i, _)| if i == 0 { "---|" } else { "---:|" })
                .collect::<String>()
        ));
        for row in &t.rows {
            let cells: Vec<String> = row.iter().map(|c| md_cell(c)).collect();
            s.push_str(&format!("| {} |\n", cells.join(" | ")));
        }
        s.push('\n');
    }
    if !r.provenance.spread.is_empty() {
        s.push_str(SPREAD_NOTE);
        s.push_str("\n\n");
    }
    if !r.figures.is_empty() {
        s.push_str(
            "## Plots\n\nIn report.html (inline); as PNG and SVG files with `trackfuse plot`.\n\n",
        );
        for f in &r.figures {
            s.push_str(&format!("- {}: {}\n", f.title, f.caption));
        }
        s.push('\n');
    }
    if let Some(p) = parameters_toml(r.provenance) {
        s.push_str("## Methods and every parameter in force\n\n```toml\n");
        s.push_str(&p);
        s.push_str("```\n\n");
    }
    if let Some(t) = r.scenario_text {
        s.push_str("## Scenario (as run)\n\n```toml\n");
        s.push_str(t);
        if !t.ends_with('\n') {
            s.push('\n');
        }
        s.push_str("```\n");
    }
    s
}

const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0 auto;max-width:1000px;padding:1em 2em;color:#222}\
h1{font-size:1.6em;border-bottom:2px solid #1f77b4;padding-bottom:.2em}h2{font-size:1.3em;margin-top:1.6em}\
table{border-collapse:collapse;margin:.5em 0 1em}td,th{border:1px solid #ccc;padding:.2em .6em;text-align:right}\
td:first-child,th:first-child{text-align:left;white-space:pre}th{background:#f0f4f8}\
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1em}dt{font-weight:600}dd{margin:0}\
code,pre{font-family:ui-monospace,'DejaVu Sans Mono',monospace;font-size:.9em}pre{background:#f6f8fa;padding:.8em;overflow:auto;max-height:30em}\
figure{margin:1em 0}figure img{max-width:min(100%,900px);height:auto;border:1px solid #ddd}figcaption{font-size:.9em;color:#555}\
details{margin:.5em 0}.bad{color:#b00;font-weight:600}.note{font-size:.9em;color:#555}\
nav a{margin-right:1em}";

/// Checks every plot once loaded (see the module doc).
const CHECK_SCRIPT: &str = r#"window.addEventListener('load',function(){
var imgs=document.querySelectorAll('figure img'),ok=0,bad=[];
imgs.forEach(function(im){
 var good=im.complete&&im.naturalWidth>0;
 if(good){var c=document.createElement('canvas');c.width=im.naturalWidth;c.height=im.naturalHeight;
  var x=c.getContext('2d');x.drawImage(im,0,0);var d=x.getImageData(0,0,c.width,c.height).data,ink=0;
  for(var i=0;i<d.length;i+=4){if(d[i]<200||d[i+1]<200||d[i+2]<200){ink++;}}
  good=ink>100;}
 if(good){ok++;}else{bad.push(im.alt);var p=document.createElement('p');p.className='bad';
  p.textContent='This plot did not render: '+im.alt;im.parentNode.appendChild(p);}
});
document.body.setAttribute('data-images-ok',String(ok));
document.body.setAttribute('data-images-bad',String(bad.length));
if(bad.length){console.error('plots that did not render: '+bad.join(', '));}
});"#;

/// One metric table, folded away when it is long.
fn html_table(s: &mut String, tb: &crate::common::MetricTable) {
    let many = tb.rows.len() > 25;
    if many {
        s.push_str(&format!(
            "<details><summary>{} ({} rows)</summary>\n",
            esc(&tb.title),
            tb.rows.len()
        ));
    } else if !tb.title.is_empty() {
        s.push_str(&format!("<h3>{}</h3>\n", esc(&tb.title)));
    }
    s.push_str("<table>\n<tr>");
    for h in &tb.header {
        s.push_str(&format!("<th>{}</th>", esc(h)));
    }
    s.push_str("</tr>\n");
    for row in &tb.rows {
        s.push_str("<tr>");
        for c in row {
            s.push_str(&format!("<td>{}</td>", esc(c)));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    if many {
        s.push_str("</details>\n");
    }
}

/// report.html.
pub fn html(r: &ReportInput<'_>) -> String {
    let t = esc(&title(r));
    let mut s = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>{t}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{t}</h1>\n<nav><a href=\"#metrics\">Metrics</a>"
    );
    if !r.figures.is_empty() {
        s.push_str("<a href=\"#plots\">Plots</a>");
    }
    s.push_str("<a href=\"#methods\">Methods and parameters</a>");
    if r.scenario_text.is_some() {
        s.push_str("<a href=\"#scenario\">Scenario</a>");
    }
    s.push_str("</nav>\n<dl>\n");
    for (k, v) in facts(r) {
        if k == "command line" {
            s.push_str(&format!(
                "<dt>{}</dt><dd><code>{}</code></dd>\n",
                esc(&k),
                esc(&v)
            ));
        } else {
            s.push_str(&format!("<dt>{}</dt><dd>{}</dd>\n", esc(&k), esc(&v)));
        }
    }
    s.push_str("</dl>\n<h2 id=\"metrics\">Metrics</h2>\n");
    s.push_str(&format!("<p>runs: {}</p>\n", r.summary.runs));
    // the scalar metrics first, then the plots, then the per-target tables
    let mut tables = summary_tables(r.summary, &r.provenance.spread);
    let main = tables.pop();
    if let Some(t) = &main {
        html_table(&mut s, t);
    }
    if !r.provenance.spread.is_empty() {
        s.push_str(&format!("<p class=\"note\">{}</p>\n", esc(SPREAD_NOTE)));
    }
    if !r.figures.is_empty() {
        s.push_str("<h2 id=\"plots\">Plots</h2>\n");
        let b64 = base64::engine::general_purpose::STANDARD;
        for f in &r.figures {
            s.push_str(&format!(
                "<figure id=\"fig-{}\"><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption><b>{}</b>. {}</figcaption></figure>\n",
                f.name,
                esc(&f.title),
                b64.encode(&f.png),
                esc(&f.title),
                esc(&f.caption)
            ));
        }
    }
    if !tables.is_empty() {
        s.push_str("<h2 id=\"per-target\">Per target and sensor</h2>\n");
    }
    for tb in &tables {
        html_table(&mut s, tb);
    }
    s.push_str("<h2 id=\"methods\">Methods and every parameter in force</h2>\n");
    match parameters_toml(r.provenance) {
        Some(p) => s.push_str(&format!("<pre>{}</pre>\n", esc(&p))),
        None => s.push_str(
            "<p>Evaluated from files: the methods that made them are not known to trackfuse.</p>\n",
        ),
    }
    if let Some(t) = r.scenario_text {
        s.push_str("<h2 id=\"scenario\">Scenario (as run)</h2>\n");
        s.push_str(&format!("<pre>{}</pre>\n", esc(t)));
    }
    s.push_str(&format!(
        "<script>{CHECK_SCRIPT}</script>\n</body>\n</html>\n"
    ));
    s
}

/// Write report.html and report.md into the output folder.
pub fn write_reports(outs: &mut Outputs, r: &ReportInput<'_>) -> Result<()> {
    outs.write("report.html", html(r).as_bytes())?;
    outs.write("report.md", markdown(r).as_bytes())?;
    Ok(())
}

/// [`write_reports`] into `dir` for an output set given by paths (`evaluate --summary`).
pub fn write_reports_in(
    outs: &mut Outputs,
    dir: &std::path::Path,
    r: &ReportInput<'_>,
) -> Result<()> {
    outs.write_file(&dir.join("report.html"), html(r).as_bytes())?;
    outs.write_file(&dir.join("report.md"), markdown(r).as_bytes())?;
    Ok(())
}
