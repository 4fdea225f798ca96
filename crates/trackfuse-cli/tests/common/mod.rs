//! Reading computed numbers out of a reproduction's Markdown, for the smoke tests that
//! assert them inside a band.
#![allow(dead_code)] // each test file uses a part of it

pub mod service;

/// Run `trackfuse args` with a standard output whose reader has already gone (the
/// pipe's read end closed before the command starts, as `| head` after its lines) and
/// assert that it ends quietly: status 0, nothing on standard error.
pub fn assert_quiet_on_closed_stdout(args: &[&str]) {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let out = std::process::Command::new(assert_cmd::cargo::cargo_bin("trackfuse"))
        .args(args)
        .stdout(writer)
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {:?}: {err}", out.status);
    assert!(err.is_empty(), "{args:?}: {err}");
}

/// The cells of the first table row of `md` that starts with `lead` (a row's opening,
/// `| FDBSC-TA |` or `| FDBSC-TA | \`track-pair-ls\` | sensor 2 |`), every cell of the
/// row trimmed, the lead's own included (cell 0 is the row label).
pub fn row<'a>(md: &'a str, lead: &str) -> Vec<&'a str> {
    let line = md
        .lines()
        .find(|l| l.starts_with(lead))
        .unwrap_or_else(|| panic!("no row starting {lead:?} in\n{md}"));
    let inner = line.trim().trim_start_matches('|').trim_end_matches('|');
    inner.split('|').map(str::trim).collect()
}

/// Cell `col` of [`row`] as a number: its first word (`0.4005 ± 0.0002` gives 0.4005,
/// `98.3 %` 98.3, `+2 %` 2).
pub fn cell(md: &str, lead: &str, col: usize) -> f64 {
    let cells = row(md, lead);
    let c = cells
        .get(col)
        .unwrap_or_else(|| panic!("row {lead:?} has no cell {col}: {cells:?}"));
    let word = c.split_whitespace().next().unwrap_or("");
    word.trim_start_matches('+')
        .parse()
        .unwrap_or_else(|_| panic!("cell {col} of row {lead:?} is not a number: {c:?}"))
}

/// Assert `lo <= cell(md, lead, col) <= hi`; `what` names the number in the message.
pub fn assert_cell(md: &str, lead: &str, col: usize, (lo, hi): (f64, f64), what: &str) {
    let v = cell(md, lead, col);
    assert!(
        (lo..=hi).contains(&v),
        "{what} (row {lead:?}, cell {col}) = {v}, outside [{lo}, {hi}]"
    );
}

/// The part of `md` from the heading line `heading` (e.g. `## Table 6`, matched at the
/// start of a line) to the next heading of the same or a higher level.
pub fn section<'a>(md: &'a str, heading: &str) -> &'a str {
    let start = md
        .match_indices(heading)
        .map(|(i, _)| i)
        .find(|&i| i == 0 || md.as_bytes()[i - 1] == b'\n')
        .unwrap_or_else(|| panic!("no heading {heading:?}"));
    let level = heading.chars().take_while(|&c| c == '#').count();
    let rest = &md[start + heading.len()..];
    let mut end = rest.len();
    let mut offset = 0;
    for line in rest.split_inclusive('\n') {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if offset > 0 && hashes > 0 && hashes <= level && line[hashes..].starts_with(' ') {
            end = offset;
            break;
        }
        offset += line.len();
    }
    &rest[..end]
}
