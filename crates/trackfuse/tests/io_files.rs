//! Readers and writers against docs/formats.md: exact headers, exact round trip, and every
//! malformed-file case giving an error that names file, line, column and reason.

use std::path::{Path, PathBuf};
use trackfuse::io::{
    read_associations, read_associations_from, read_fused_tracks, read_fused_tracks_from,
    read_local_tracks, read_local_tracks_from, read_measurements, read_measurements_from,
    read_sensors, read_sensors_from, read_truth, read_truth_from, write_sensors, AssociationStream,
    FusedTrackStream, InputError, LocalTrackStream, LocalTrackWriter, MeasurementStream,
    MeasurementWriter, TruthStream, TruthWriter,
};
use trackfuse::sim::simulate;
use trackfuse::RunConfig;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write fixture");
    p
}

const COV: &str = "P00,P01,P02,P03,P10,P11,P12,P13,P20,P21,P22,P23,P30,P31,P32,P33";
const ID16: &str = "1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1";

fn local_header() -> String {
    format!("scan,time,sensor_id,track_id,x,vx,y,vy,{COV}")
}

fn expect_err(
    r: Result<impl std::fmt::Debug, InputError>,
    line: Option<u64>,
    column: Option<&str>,
    reason: &str,
) -> InputError {
    let e = r.expect_err("must be rejected");
    let msg = e.to_string();
    assert_eq!(e.line, line, "{msg}");
    assert_eq!(e.column_name.as_deref(), column, "{msg}");
    assert!(msg.contains(reason), "'{msg}' should contain '{reason}'");
    assert!(
        msg.contains(e.file.file_name().and_then(|f| f.to_str()).unwrap_or("?")),
        "{msg}"
    );
    e
}

#[test]
fn simulated_files_have_exact_headers_and_round_trip_exactly() {
    let dir = tempfile::tempdir().expect("tmp");
    let sc = RunConfig::default_builtin().scenario;
    let out = simulate(&sc, 3);
    let sp = dir.path().join("sensors.csv");
    write_sensors(&sp, &out.sensors).expect("sensors");
    let tp = dir.path().join("truth.csv");
    let mut tw = TruthWriter::create(&tp).expect("truth");
    for t in &out.truth {
        tw.write(t).expect("row");
    }
    tw.finish().expect("flush");
    let mp = dir.path().join("measurements.csv");
    let mut mw = MeasurementWriter::create(&mp, &out.sensors).expect("meas");
    for m in &out.measurements {
        mw.write(m).expect("row");
    }
    mw.finish().expect("flush");

    let first = |p: &Path| {
        std::fs::read_to_string(p)
            .expect("read")
            .lines()
            .next()
            .unwrap_or("")
            .to_string()
    };
    assert_eq!(first(&tp), "scan,time,target_id,x,vx,y,vy");
    assert_eq!(first(&mp), "scan,time,sensor_id,range,bearing,target_id");
    assert!(first(&sp).starts_with("sensor_id,x,y,sigma_r,sigma_theta,pd"));

    assert_eq!(read_sensors(&sp).expect("sensors"), out.sensors);
    assert_eq!(read_truth(&tp).expect("truth"), out.truth);
    let back = read_measurements(&mp, Some(&out.sensors)).expect("meas");
    assert_eq!(back.len(), out.measurements.len());
    for (a, b) in back.iter().zip(&out.measurements) {
        assert_eq!(a.value[0].to_bits(), b.value[0].to_bits());
        assert_eq!(a.value[1].to_bits(), b.value[1].to_bits());
        assert_eq!(
            (a.scan, a.sensor_id, a.target_id),
            (b.scan, b.sensor_id, b.target_id)
        );
    }
}

#[test]
fn local_tracks_round_trip_and_crlf() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = dir.path().join("local_tracks.csv");
    let mut w = LocalTrackWriter::create(&p).expect("create");
    let mut cov = trackfuse::StateCov::identity() * 2.5;
    cov[(0, 1)] = 0.1 + 0.2;
    cov[(1, 0)] = 0.1 + 0.2;
    let t = trackfuse::LocalTrack {
        scan: 2,
        time: 2.0,
        sensor_id: 1,
        track_id: 4,
        state: trackfuse::StateVec::new(1.0 / 3.0, -2.0, 1e-300, 7e22),
        cov,
    };
    w.write(&t).expect("row");
    w.finish().expect("flush");
    let text = std::fs::read_to_string(&p).expect("read");
    assert_eq!(text.lines().next(), Some(local_header().as_str()));
    assert_eq!(read_local_tracks(&p).expect("read"), vec![t]);
    // the same file with CRLF line endings (as Python's csv module writes)
    let crlf = write(dir.path(), "crlf.csv", &text.replace('\n', "\r\n"));
    assert_eq!(read_local_tracks(&crlf).expect("crlf"), vec![t]);
}

#[test]
fn missing_column() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = write(
        dir.path(),
        "truth.csv",
        "scan,time,target_id,x,vx,y\n0,0,1,0,0,0\n",
    );
    expect_err(
        read_truth(&p),
        Some(1),
        Some("vy"),
        "missing required column",
    );
    let p = write(
        dir.path(),
        "sensors.csv",
        "sensor_id,x,y,sigma_r,pd\n0,0,0,5,1\n",
    );
    expect_err(
        read_sensors(&p),
        Some(1),
        Some("sigma_theta"),
        "missing required column",
    );
    let p = write(
        dir.path(),
        "measurements.csv",
        "scan,time,sensor_id,range\n0,0,0,5\n",
    );
    expect_err(
        read_measurements(&p, None),
        Some(1),
        Some("range,bearing / x,y"),
        "missing measurement columns",
    );
}

#[test]
fn text_in_a_number() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = write(
        dir.path(),
        "truth.csv",
        "scan,time,target_id,x,vx,y,vy\n0,0,1,0,0,0,0\n1,1,1,12a,0,0,0\n",
    );
    let e = expect_err(read_truth(&p), Some(3), Some("x"), "'12a' is not a number");
    assert_eq!(e.column, Some(4));
    let p = write(
        dir.path(),
        "assoc.csv",
        "scan,sensor_id,track_id,fused_id\n0,0,1.5,2\n",
    );
    expect_err(
        read_associations(&p),
        Some(2),
        Some("track_id"),
        "not an integer",
    );
}

#[test]
fn nan_and_infinity() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = write(
        dir.path(),
        "truth.csv",
        "scan,time,target_id,x,vx,y,vy\n0,0,1,0,NaN,0,0\n",
    );
    expect_err(read_truth(&p), Some(2), Some("vx"), "not finite");
    let p = write(
        dir.path(),
        "m.csv",
        "scan,time,sensor_id,x,y\n0,0,0,inf,1\n",
    );
    expect_err(
        read_measurements(&p, None),
        Some(2),
        Some("x"),
        "not finite",
    );
}

#[test]
fn mirrored_covariance_cells_read_alike_whatever_their_spelling() {
    // the reader takes a cell below the diagonal from its mirror when the two have the
    // same bytes; spelled differently it parses it: the same matrix either way, and a
    // bad cell below the diagonal is still reported at its own column
    let dir = tempfile::tempdir().expect("tmp");
    let same = "4,0.5,0.25,0,0.5,9,0,0,0.25,0,16,1e-3,0,0,1e-3,25";
    let spelled = "4,0.5,0.25,0,5e-1,9,0,0,0.250,0,16,0.001,-0,0.0,1E-3,25";
    let rows: Vec<_> = [same, spelled]
        .iter()
        .enumerate()
        .map(|(i, cov)| {
            let p = write(
                dir.path(),
                &format!("lt{i}.csv"),
                &format!("{}\n0,0,0,1,10,1,20,2,{cov}\n", local_header()),
            );
            read_local_tracks(&p).expect("valid").remove(0)
        })
        .collect();
    assert_eq!(rows[0].cov, rows[1].cov);
    assert_eq!(rows[0].cov[(1, 0)], 0.5);
    assert_eq!(rows[0].cov[(3, 2)], 1e-3);
    let bad = "4,0.5,0.25,0,0.5,9,0,0,0.25,0,16,1e-3,0,0,x,25";
    let p = write(
        dir.path(),
        "bad.csv",
        &format!("{}\n0,0,0,1,10,1,20,2,{bad}\n", local_header()),
    );
    expect_err(read_local_tracks(&p), Some(2), Some("P32"), "not a number");
}

#[test]
fn covariance_not_symmetric_psd() {
    let dir = tempfile::tempdir().expect("tmp");
    let asym = "1,0.5,0,0,0,1,0,0,0,0,1,0,0,0,0,1";
    let p = write(
        dir.path(),
        "lt.csv",
        &format!("{}\n0,0,0,1,0,0,0,0,{asym}\n", local_header()),
    );
    expect_err(read_local_tracks(&p), Some(2), None, "not symmetric");
    let neg = "1,0,0,0,0,-1,0,0,0,0,1,0,0,0,0,1";
    let p = write(
        dir.path(),
        "lt2.csv",
        &format!(
            "{}\n0,0,0,1,0,0,0,0,{ID16}\n1,1,0,1,0,0,0,0,{neg}\n",
            local_header()
        ),
    );
    expect_err(
        read_local_tracks(&p),
        Some(3),
        None,
        "not positive semi-definite",
    );
}

#[test]
fn time_going_backwards_within_a_track() {
    let dir = tempfile::tempdir().expect("tmp");
    let text = format!(
        "{}\n0,5,0,1,0,0,0,0,{ID16}\n0,5,1,1,0,0,0,0,{ID16}\n1,4,0,1,0,0,0,0,{ID16}\n",
        local_header()
    );
    let p = write(dir.path(), "lt.csv", &text);
    expect_err(
        read_local_tracks(&p),
        Some(4),
        Some("time"),
        "time goes backwards",
    );
    // another track's earlier time is fine
    let ok = format!(
        "{}\n0,5,0,1,0,0,0,0,{ID16}\n1,4,0,2,0,0,0,0,{ID16}\n",
        local_header()
    );
    assert!(read_local_tracks(&write(dir.path(), "ok.csv", &ok)).is_ok());
}

#[test]
fn duplicate_rows() {
    let dir = tempfile::tempdir().expect("tmp");
    let text = format!(
        "{}\n0,0,0,1,0,0,0,0,{ID16}\n0,0,0,1,1,0,0,0,{ID16}\n",
        local_header()
    );
    expect_err(
        read_local_tracks(&write(dir.path(), "lt.csv", &text)),
        Some(3),
        None,
        "duplicate row",
    );
    let t = "scan,time,target_id,x,vx,y,vy\n0,0,1,0,0,0,0\n0,0,1,0,0,0,0\n";
    expect_err(
        read_truth(&write(dir.path(), "t.csv", t)),
        Some(3),
        None,
        "duplicate row",
    );
    let s = "sensor_id,x,y,sigma_r,sigma_theta,pd\n0,0,0,5,0.001,1\n0,1,1,5,0.001,1\n";
    expect_err(
        read_sensors(&write(dir.path(), "s.csv", s)),
        Some(3),
        Some("sensor_id"),
        "duplicate sensor_id",
    );
    let m = "scan,time,sensor_id,range,bearing\n0,0,0,100,0.5\n0,0,0,100,0.5\n";
    expect_err(
        read_measurements(&write(dir.path(), "m.csv", m), None),
        Some(3),
        None,
        "duplicate row",
    );
}

#[test]
fn ragged_row_and_bad_values() {
    let dir = tempfile::tempdir().expect("tmp");
    let t = "scan,time,target_id,x,vx,y,vy\n0,0,1,0,0,0\n";
    expect_err(
        read_truth(&write(dir.path(), "t.csv", t)),
        Some(2),
        None,
        "row has 6 fields, header has 7",
    );
    let s = "sensor_id,x,y,sigma_r,sigma_theta,pd\n0,0,0,5,0.001,1.5\n";
    expect_err(
        read_sensors(&write(dir.path(), "s.csv", s)),
        Some(2),
        Some("pd"),
        "must be in [0, 1]",
    );
    let s = "sensor_id,x,y,sigma_r,sigma_theta,pd,kind\n0,0,0,5,0.001,1,sonar\n";
    expect_err(
        read_sensors(&write(dir.path(), "s.csv", s)),
        Some(2),
        Some("kind"),
        "unknown kind",
    );
    let sensors = read_sensors(&write(
        dir.path(),
        "s2.csv",
        "sensor_id,x,y,sigma_r,sigma_theta,pd\n0,0,0,5,0.001,1\n",
    ))
    .expect("ok");
    let m = "scan,time,sensor_id,range,bearing\n0,0,3,100,0.5\n";
    expect_err(
        read_measurements(&write(dir.path(), "m.csv", m), Some(&sensors)),
        Some(2),
        Some("sensor_id"),
        "not in sensors.csv",
    );
    let m = "scan,time,sensor_id,range,bearing\n0,0,0,-100,0.5\n";
    expect_err(
        read_measurements(&write(dir.path(), "m2.csv", m), None),
        Some(2),
        Some("range"),
        "must not be negative",
    );
}

#[test]
fn foreign_files_with_optional_columns_and_any_order() {
    let dir = tempfile::tempdir().expect("tmp");
    // position sensors with empty radar cells, columns reordered, extra column ignored
    let s = "pd,sensor_id,kind,x,y,sigma_r,sigma_theta,sigma_x,sigma_y,comment\n0.9,4,position,10,20,,,3,4,hello\n";
    let sensors = read_sensors(&write(dir.path(), "s.csv", s)).expect("ok");
    assert_eq!(sensors[0].kind, trackfuse::SensorKind::Position);
    assert_eq!((sensors[0].sigma_a, sensors[0].sigma_b), (3.0, 4.0));
    // bearing outside (-pi, pi] is wrapped; no target_id column
    let m = "time,scan,sensor_id,range,bearing\n0,0,0,100,7.0\n";
    let ms = read_measurements(&write(dir.path(), "m.csv", m), None).expect("ok");
    assert!((ms[0].value[1] - (7.0 - std::f64::consts::TAU)).abs() < 1e-12);
    assert_eq!(ms[0].target_id, -1);
    // fused tracks without the sources column
    let f = format!("scan,time,fused_id,x,vx,y,vy,{COV},n_sources\n0,0,3,1,2,3,4,{ID16},2\n");
    let fs = read_fused_tracks(&write(dir.path(), "f.csv", &f)).expect("ok");
    assert_eq!(fs[0].fused_id, 3);
}

#[test]
fn a_duplicated_column_is_rejected_and_unknown_duplicates_ignored() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = write(
        dir.path(),
        "truth.csv",
        "scan,time,target_id,x,vx,y,x,vy\n0,0,1,5,0,0,6,0\n",
    );
    let e = expect_err(read_truth(&p), Some(1), Some("x"), "appears twice");
    assert_eq!(e.column, Some(7));
    let cov_dup = format!("{},P00\n", local_header());
    let p = write(dir.path(), "local_tracks.csv", &cov_dup);
    expect_err(read_local_tracks(&p), Some(1), Some("P00"), "appears twice");
    // extra columns are ignored, even when repeated
    let p = write(
        dir.path(),
        "truth2.csv",
        "scan,time,target_id,x,vx,y,vy,note,note\n0,0,1,5,0,0,0,a,b\n",
    );
    assert_eq!(read_truth(&p).expect("extra columns ignored").len(), 1);
}

// ------------------------------------------------------------------ issue 11: readers

/// One valid file of each kind with scan column, with rows for scans 0, 0, 1, 2, 2, 3
/// (lines 2..=7), and a function to read it from bytes.
type Reader = fn(&[u8], &str) -> Result<usize, InputError>;

fn kinds() -> Vec<(&'static str, String, Vec<String>, Reader)> {
    let local = |scan: u32, sensor: i64| format!("{scan},{scan},{sensor},1,0,0,0,0,{ID16}");
    let fused = |scan: u32, id: i64| format!("{scan},{scan},{id},0,0,0,0,{ID16},1,0:1");
    let scans = [(0, 0), (0, 1), (1, 0), (2, 0), (2, 1), (3, 0)];
    vec![
        (
            "truth.csv",
            "scan,time,target_id,x,vx,y,vy".to_string(),
            scans
                .iter()
                .map(|&(s, k)| format!("{s},{s},{k},0,0,0,0"))
                .collect(),
            |b, p| read_truth_from(b, p).map(|v| v.len()),
        ),
        (
            "measurements.csv",
            "scan,time,sensor_id,x,y".to_string(),
            scans
                .iter()
                .map(|&(s, k)| format!("{s},{s},{k},1,2"))
                .collect(),
            |b, p| read_measurements_from(b, p, None).map(|v| v.len()),
        ),
        (
            "local_tracks.csv",
            local_header(),
            scans.iter().map(|&(s, k)| local(s, k)).collect(),
            |b, p| read_local_tracks_from(b, p).map(|v| v.len()),
        ),
        (
            "fused_tracks.csv",
            format!("scan,time,fused_id,x,vx,y,vy,{COV},n_sources,sources"),
            scans.iter().map(|&(s, k)| fused(s, k)).collect(),
            |b, p| read_fused_tracks_from(b, p).map(|v| v.len()),
        ),
        (
            "associations.csv",
            "scan,sensor_id,track_id,fused_id".to_string(),
            scans.iter().map(|&(s, k)| format!("{s},{k},1,0")).collect(),
            |b, p| read_associations_from(b, p).map(|v| v.len()),
        ),
    ]
}

fn join(header: &str, rows: &[String], eol: &str) -> Vec<u8> {
    let mut s = String::from(header);
    s.push_str(eol);
    for r in rows {
        s.push_str(r);
        s.push_str(eol);
    }
    s.into_bytes()
}

/// Replace the cell of column `col` in `row` with `cell`.
fn set_cell(row: &str, col: usize, cell: &str) -> String {
    let mut cells: Vec<&str> = row.split(',').collect();
    cells[col] = cell;
    cells.join(",")
}

#[test]
fn crlf_and_lf_twins_name_the_same_line_in_every_reader() {
    for (name, header, rows, read) in kinds() {
        for eol in ["\n", "\r\n"] {
            assert_eq!(read(&join(&header, &rows, eol), name), Ok(6), "{name}");
        }
        // a bad number in column 2 (time, or sensor_id of associations) of each data line
        let col_name = header.split(',').nth(1).expect("two columns").to_string();
        for k in 0..rows.len() {
            let mut bad = rows.clone();
            bad[k] = set_cell(&bad[k], 1, "12a");
            for eol in ["\n", "\r\n"] {
                let e = read(&join(&header, &bad, eol), name).expect_err("bad cell");
                assert_eq!(e.file, Path::new(name));
                assert_eq!(e.line, Some(k as u64 + 2), "{name} {eol:?}: {e}");
                assert_eq!(e.column, Some(2), "{e}");
                assert_eq!(e.column_name.as_deref(), Some(col_name.as_str()), "{e}");
                assert!(e.to_string().contains("'12a' is not"), "{e}");
            }
        }
        // a ragged row (the csv crate's own error) on line 5
        let mut ragged = rows.clone();
        ragged[3].push_str(",9");
        for eol in ["\n", "\r\n"] {
            let e = read(&join(&header, &ragged, eol), name).expect_err("ragged");
            assert_eq!(e.line, Some(5), "{name} {eol:?}: {e}");
            assert!(e.reason.contains("fields, header has"), "{e}");
        }
    }
    // blank lines and a quoted cell holding a line break count as lines
    let text = "scan,time,target_id,x,vx,y,vy,note\r\n\r\n0,0,1,0,0,0,0,\"a\r\nb\"\r\n1,1,1,0,0,0,0,c\r\n2,2,1,0,NaN,0,0,d\r\n";
    let e = read_truth_from(text.as_bytes(), "truth.csv").expect_err("NaN");
    assert_eq!((e.line, e.column), (Some(6), Some(5)), "{e}");
}

#[test]
fn crlf_line_numbers_of_sensors_csv() {
    let rows = ["0,0,0,5,0.001,1", "1,0,0,5,0.001,1", "2,0,0,5,0.001,oops"];
    for eol in ["\n", "\r\n"] {
        let mut text = format!("sensor_id,x,y,sigma_r,sigma_theta,pd{eol}");
        for r in rows {
            text.push_str(r);
            text.push_str(eol);
        }
        let e = read_sensors_from(text.as_bytes(), "sensors.csv").expect_err("bad pd");
        assert_eq!(
            (e.line, e.column, e.column_name.as_deref()),
            (Some(4), Some(6), Some("pd")),
            "{e}"
        );
    }
}

#[test]
fn a_non_utf8_byte_is_reported_as_such_in_its_cell() {
    let mut text = b"scan,time,target_id,x,vx,y,vy\n0,0,1,0,0,0,0\n1,1,1,0,".to_vec();
    text.extend_from_slice(&[b'1', 0xff, b'2']);
    text.extend_from_slice(b",0,0\n");
    let e = read_truth_from(&text[..], "truth.csv").expect_err("not UTF-8");
    assert_eq!(
        (e.line, e.column, e.column_name.as_deref()),
        (Some(3), Some(5), Some("vx")),
        "{e}"
    );
    assert_eq!(
        e.to_string(),
        "truth.csv:3:5: column 'vx': invalid UTF-8 (byte 0xff at byte 2 of the cell); \
         the file must be UTF-8 text"
    );
    // in a text cell (kind) and in the header
    let s = b"sensor_id,x,y,sigma_r,sigma_theta,pd,kind\n0,0,0,5,0.001,1,rad\xe9\n";
    let e = read_sensors_from(&s[..], "sensors.csv").expect_err("not UTF-8");
    assert_eq!((e.line, e.column_name.as_deref()), (Some(2), Some("kind")));
    assert!(e.reason.starts_with("invalid UTF-8"), "{e}");
    let h = b"scan,ti\xffme,target_id,x,vx,y,vy\n0,0,1,0,0,0,0\n";
    let e = read_truth_from(&h[..], "truth.csv").expect_err("not UTF-8");
    assert_eq!((e.line, e.column), (Some(1), Some(2)), "{e}");
    assert!(e.reason.starts_with("invalid UTF-8"), "{e}");
}

#[test]
fn every_scan_file_must_be_in_scan_order() {
    for (name, header, rows, read) in kinds() {
        // any order within a scan is fine
        let mut within = rows.clone();
        within.swap(0, 1);
        within.swap(3, 4);
        assert_eq!(read(&join(&header, &within, "\n"), name), Ok(6), "{name}");
        // scan 1 (line 5) after scan 2 (line 4)
        let mut back = rows.clone();
        back.swap(2, 3);
        let e = read(&join(&header, &back, "\n"), name).expect_err("unsorted");
        let scan_col = header.split(',').position(|h| h == "scan").expect("scan") + 1;
        assert_eq!(
            (e.line, e.column, e.column_name.as_deref()),
            (Some(5), Some(scan_col), Some("scan")),
            "{name}: {e}"
        );
        assert!(
            e.reason.starts_with("scan 1 comes after scan 2 (line 4): rows must be in non-decreasing scan order (any order within a scan); sort the data rows by the scan column"),
            "{name}: {e}"
        );
    }
}

#[test]
fn measurements_within_a_scan_come_back_stable_sorted_by_sensor() {
    let m = "scan,time,sensor_id,x,y\n0,0,1,1,1\n0,0,0,2,2\n0,0,1,3,3\n1,1,0,4,4\n";
    let ms = read_measurements_from(m.as_bytes(), "m.csv", None).expect("ok");
    let got: Vec<(u32, i64, f64)> = ms
        .iter()
        .map(|m| (m.scan, m.sensor_id, m.value[0]))
        .collect();
    assert_eq!(got, [(0, 0, 2.0), (0, 1, 1.0), (0, 1, 3.0), (1, 0, 4.0)]);
    // a sensor's time going backwards from scan to scan names the later row
    let m = "scan,time,sensor_id,x,y\n0,5,0,1,1\n1,4,0,2,2\n";
    let e = read_measurements_from(m.as_bytes(), "m.csv", None).expect_err("backwards");
    assert_eq!((e.line, e.column_name.as_deref()), (Some(3), Some("time")));
    assert!(e.reason.contains("time goes backwards for sensor 0"), "{e}");
}

#[test]
fn sensors_follow_the_scenario_value_rule() {
    let head = "sensor_id,x,y,sigma_r,sigma_theta,pd,kind,sigma_x,sigma_y,bias_r\n";
    let cases = [
        (
            "0,0,0,0,0.001,1,,,,",
            "sigma_r",
            4,
            "0 must be a positive number",
        ),
        (
            "0,0,0,5,-0.001,1,,,,",
            "sigma_theta",
            5,
            "-0.001 must be a positive number",
        ),
        (
            "0,0,0,,,1,position,3,0,",
            "sigma_y",
            9,
            "0 must be a positive number",
        ),
        (
            "-2,0,0,5,0.001,1,,,,",
            "sensor_id",
            1,
            "-2 must not be negative",
        ),
        (
            "0,0,0,,,1,position,3,3,10",
            "bias_r",
            10,
            "range/bearing biases apply to range_bearing sensors only",
        ),
    ];
    for (row, col, n, reason) in cases {
        let text = format!("{head}1,0,0,5,0.001,1,,,,\n{row}\n");
        let e = read_sensors_from(text.as_bytes(), "sensors.csv").expect_err(row);
        assert_eq!(e.line, Some(3), "{e}");
        assert_eq!(e.column, Some(n), "{e}");
        assert_eq!(e.column_name.as_deref(), Some(col), "{e}");
        assert_eq!(e.reason, reason, "{e}");
    }
    // pd 0 (a sensor that never detects) is a valid value, in the scenario as here
    let ok = format!("{head}0,0,0,5,0.001,0,,,,\n");
    assert_eq!(
        read_sensors_from(ok.as_bytes(), "s.csv").expect("pd 0")[0].pd,
        0.0
    );
}

#[test]
fn a_header_only_truth_file_is_an_error() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = write(dir.path(), "truth.csv", "scan,time,target_id,x,vx,y,vy\n");
    let e = read_truth(&p).expect_err("no rows");
    assert_eq!((e.line, e.column), (None, None));
    assert_eq!(e.file, p);
    assert_eq!(
        e.reason,
        "no truth rows (the file has a header but no rows)"
    );
}

#[test]
fn streams_give_one_scan_at_a_time_with_lines() {
    let text = format!(
        "{}\n0,0,1,2,0,0,0,0,{ID16}\n0,0,0,5,0,0,0,0,{ID16}\n2,2,0,5,0,0,0,0,{ID16}\n",
        local_header()
    );
    let mut s = LocalTrackStream::from_reader(text.as_bytes(), "lt.csv").expect("open");
    let mut buf = Vec::new();
    assert_eq!(s.next_scan(&mut buf), Ok(Some(0)));
    let keys: Vec<(i64, i64)> = buf.iter().map(|t| (t.sensor_id, t.track_id)).collect();
    assert_eq!(keys, [(0, 5), (1, 2)]);
    assert_eq!(s.lines(), [3, 2]);
    assert_eq!(s.next_scan(&mut buf), Ok(Some(2)));
    assert_eq!((buf.len(), s.lines()), (1, &[4u64][..]));
    assert_eq!(s.next_scan(&mut buf), Ok(None));
    assert!(buf.is_empty());
    assert_eq!(s.path(), Path::new("lt.csv"));
    // an error is returned again, not skipped
    let bad = format!(
        "{}\n1,1,0,5,0,0,0,0,{ID16}\n0,0,0,5,0,0,0,0,{ID16}\n",
        local_header()
    );
    let mut s = LocalTrackStream::from_reader(bad.as_bytes(), "lt.csv").expect("open");
    let e = s.next_scan(&mut buf).expect_err("unsorted");
    assert_eq!(s.next_scan(&mut buf), Err(e));
    // the whole-file readers are the streams collected
    let mut t = TruthStream::from_reader(
        "scan,time,target_id,x,vx,y,vy\n0,0,1,0,0,0,0\n0,0,2,0,0,0,0\n1,1,1,0,0,0,0\n".as_bytes(),
        "truth.csv",
    )
    .expect("open");
    let mut truth = Vec::new();
    assert_eq!(t.next_scan(&mut truth), Ok(Some(0)));
    assert_eq!(truth.len(), 2);
    assert_eq!(t.lines(), [2, 3]);
    let m = MeasurementStream::from_reader(
        "scan,time,sensor_id,x,y\n3,1,0,1,1\n".as_bytes(),
        "m.csv",
        None,
    )
    .expect("open");
    assert_eq!(m.collect_rows().expect("rows")[0].scan, 3);
    let fused = format!("scan,time,fused_id,x,vx,y,vy,{COV},n_sources\n0,0,3,1,2,3,4,{ID16},2\n");
    let f = FusedTrackStream::from_reader(fused.as_bytes(), "f.csv").expect("open");
    assert_eq!(f.collect_rows().expect("rows").len(), 1);
    let mut a = AssociationStream::from_reader(
        "scan,sensor_id,track_id,fused_id\n4,1,1,0\n4,0,1,0\n".as_bytes(),
        "a.csv",
    )
    .expect("open");
    let mut rows = Vec::new();
    assert_eq!(a.next_scan(&mut rows), Ok(Some(4)));
    assert_eq!(rows[0].sensor_id, 0);
    assert_eq!(a.lines(), [3, 2]);
}

#[test]
fn files_without_a_scan_column_are_batched_by_time() {
    // local tracks of two sensors at their own times, no scan column
    let h = format!("time,sensor_id,track_id,x,vx,y,vy,{COV}");
    let row = |t: &str, s: i64, id: i64| format!("{t},{s},{id},0,0,0,0,{ID16}");
    let text = [
        h.clone(),
        row("0", 0, 1),
        row("1.5", 1, 4),
        row("1.5", 1, 2),
        row("4", 0, 1),
        row("6.5", 1, 4),
    ]
    .join("\n");
    let mut s = LocalTrackStream::from_reader(text.as_bytes(), "l.csv").expect("header");
    let mut buf = Vec::new();
    let mut got = Vec::new();
    while let Some(scan) = s.next_scan(&mut buf).expect("ok") {
        got.push((
            scan,
            buf.iter()
                .map(|t| (t.time, t.sensor_id, t.track_id))
                .collect::<Vec<_>>(),
            s.lines().to_vec(),
        ));
    }
    assert_eq!(
        got,
        vec![
            (0, vec![(0.0, 0, 1)], vec![2]),
            (1, vec![(1.5, 1, 2), (1.5, 1, 4)], vec![4, 3]),
            (2, vec![(4.0, 0, 1)], vec![5]),
            (3, vec![(6.5, 1, 4)], vec![6]),
        ]
    );
    // a smaller time after a larger one names both lines and the column
    let back = [h.clone(), row("4", 0, 1), row("1.5", 1, 4)].join("\n");
    let e = read_local_tracks_from(back.as_bytes(), "l.csv").expect_err("unsorted");
    assert_eq!((e.line, e.column), (Some(3), Some(1)), "{e}");
    assert!(
        e.reason.starts_with("time 1.5 comes after time 4 (line 2): a file without a scan column must have its rows in non-decreasing time order"),
        "{e}"
    );
    // one track twice at one time is a duplicate
    let dup = [h.clone(), row("4", 0, 1), row("4", 0, 1)].join("\n");
    let e = read_local_tracks_from(dup.as_bytes(), "l.csv").expect_err("duplicate");
    assert!(e.reason.contains("duplicate row"), "{e}");
    // measurements likewise
    let m = "time,sensor_id,x,y\n0,0,1,1\n0.5,1,2,2\n0.5,1,3,3\n1,0,4,4\n";
    let ms = read_measurements_from(m.as_bytes(), "m.csv", None).expect("ok");
    let got: Vec<(u32, f64, i64)> = ms.iter().map(|m| (m.scan, m.time, m.sensor_id)).collect();
    assert_eq!(got, [(0, 0.0, 0), (1, 0.5, 1), (1, 0.5, 1), (2, 1.0, 0)]);
    let m = "time,sensor_id,x,y\n1,0,1,1\n0.5,1,2,2\n";
    let e = read_measurements_from(m.as_bytes(), "m.csv", None).expect_err("unsorted");
    assert_eq!(
        (e.line, e.column_name.as_deref()),
        (Some(3), Some("time")),
        "{e}"
    );
    // truth keeps its scan column
    let t = "time,target_id,x,vx,y,vy\n0,1,0,0,0,0\n";
    let e = read_truth_from(t.as_bytes(), "t.csv").expect_err("scan required");
    assert_eq!(e.column_name.as_deref(), Some("scan"), "{e}");
}
