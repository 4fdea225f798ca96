//! report.html of the built-in default run, opened in a real browser: headless Chromium
//! (Debian's `chromium`; `.ci/run` installs it when missing and runs this test with
//! `--ignored`). Chromium is driven by its own command-line switches: `--dump-dom` gives
//! the page after its load handler ran (the report's own check marks `<body>` with how
//! many plots decoded to a non-blank image), `--enable-logging=stderr` prints every
//! console message and uncaught error as a `:CONSOLE` line, `--screenshot` saves the
//! page. Set `TRACKFUSE_SCREENSHOT_TO=FILE` to keep a copy of the screenshot.

use assert_cmd::Command;
use std::path::Path;

fn chromium() -> String {
    std::env::var("CHROMIUM").unwrap_or_else(|_| "chromium".into())
}

/// Chromium with the switches this machine needs, a fresh profile under `profile`.
fn browser(profile: &Path) -> std::process::Command {
    let mut c = std::process::Command::new(chromium());
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    c
}

/// (the DOM after load, the console lines) of `page`.
fn load(page: &Path, profile: &Path) -> (String, Vec<String>) {
    let out = browser(profile)
        .args([
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=10000",
            "--dump-dom",
        ])
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs (install it: apt-get install -y chromium)");
    assert!(out.status.success(), "chromium failed: {out:?}");
    let dom = String::from_utf8_lossy(&out.stdout).into_owned();
    let console = String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(str::to_string)
        .collect();
    (dom, console)
}

/// The value of attribute `name` of the `<body>` tag of `dom`.
fn body_attr(dom: &str, name: &str) -> Option<String> {
    let start = dom.find("<body")?;
    let tag = &dom[start..start + dom[start..].find('>')?];
    let key = format!("{name}=\"");
    let i = tag.find(&key)? + key.len();
    Some(tag[i..i + tag[i..].find('"')?].to_string())
}

#[test]
#[ignore = "needs chromium; .ci/run runs it"]
fn the_default_run_report_loads_cleanly_and_every_plot_renders() {
    let dir = tempfile::tempdir().expect("tmp");
    let run = dir.path().join("run");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .arg("run")
        .arg("--out")
        .arg(&run)
        .assert()
        .success();
    let page = run.join("report.html");
    let html = std::fs::read_to_string(&page).expect("report.html");
    let images = html.matches("<img ").count();
    assert!(images >= 7, "only {images} plots in the report");
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "the report fetches something"
    );

    let (dom, console) = load(&page, &dir.path().join("profile1"));
    assert!(console.is_empty(), "console messages: {console:#?}");
    assert_eq!(
        body_attr(&dom, "data-images-ok").as_deref(),
        Some(images.to_string().as_str()),
        "not every plot rendered (or the check did not run)"
    );
    assert_eq!(body_attr(&dom, "data-images-bad").as_deref(), Some("0"));

    // the check sees a broken plot: the same page with one image's data spoilt
    let i = html.find("base64,").expect("an inline image") + "base64,".len();
    let broken = format!(
        "{}AAAA{}",
        &html[..i],
        &html[i + html[i..].find('"').expect("end")..]
    );
    let bad_page = dir.path().join("broken.html");
    std::fs::write(&bad_page, broken).expect("write");
    let (dom, console) = load(&bad_page, &dir.path().join("profile2"));
    assert_eq!(body_attr(&dom, "data-images-bad").as_deref(), Some("1"));
    assert!(
        console
            .iter()
            .any(|l| l.contains("plots that did not render")),
        "{console:#?}"
    );

    // a screenshot of the top of the report, not blank
    let shot = dir.path().join("report.png");
    let out = browser(&dir.path().join("profile3"))
        .arg("--window-size=1100,2200")
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs");
    assert!(out.status.success(), "chromium failed: {out:?}");
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&shot).expect("screenshot written"),
    ));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("decodes");
    assert_eq!((info.width, info.height), (1100, 2200));
    let px = info.color_type.samples();
    let inked = buf[..info.buffer_size()]
        .chunks(px)
        .filter(|p| p[..3].iter().any(|&c| c < 200))
        .count();
    let share = inked as f64 / (info.width as f64 * info.height as f64);
    assert!(
        share > 0.01,
        "the screenshot is nearly blank ({share:.4} inked)"
    );
    eprintln!(
        "screenshot: {} ({:.1} % inked)",
        shot.display(),
        100.0 * share
    );
    if let Ok(to) = std::env::var("TRACKFUSE_SCREENSHOT_TO") {
        std::fs::copy(&shot, &to).expect("copy the screenshot");
    }
}
