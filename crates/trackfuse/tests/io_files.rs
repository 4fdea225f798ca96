//! Readers and writers against FORMATS.md: exact headers, exact round trip, and every
//! malformed-file case giving an error that names file, line, column and reason.

use std::path::{Path, PathBuf};
use trackfuse::io::{
    read_associations, read_fused_tracks, read_local_tracks, read_measurements, read_sensors,
    read_truth, write_sensors, InputError, LocalTrackWriter, MeasurementWriter, TruthWriter,
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
