//! `trackfuse fuse` publishes confirmed global tracks only unless `--publish all`, which
//! writes the tentative ones too with their status; `--no-management` is the papers'
//! center.

use assert_cmd::Command;
use std::path::Path;

const COV: &str = "P00,P01,P02,P03,P10,P11,P12,P13,P20,P21,P22,P23,P30,P31,P32,P33";
const COV_CELLS: &str = "100,0,0,0,0,4,0,0,0,0,100,0,0,0,0,4";

/// A target seen by sensors 0 and 1 for 6 scans, and a lone track of sensor 1 for one
/// scan 40 km away (a clutter-born local track; the default `confirm_scans` is 2).
fn local_tracks() -> String {
    let mut s = format!("scan,time,sensor_id,track_id,x,vx,y,vy,{COV}\n");
    for scan in 0..6u32 {
        let t = 5.0 * scan as f64;
        let x = 100.0 * t;
        s.push_str(&format!("{scan},{t},0,1,{x},100,0,0,{COV_CELLS}\n"));
        s.push_str(&format!("{scan},{t},1,4,{},100,5,0,{COV_CELLS}\n", x + 5.0));
        if scan < 1 {
            s.push_str(&format!("{scan},{t},1,9,40000,0,40000,0,{COV_CELLS}\n"));
        }
    }
    s
}

fn fuse(dir: &Path, name: &str, extra: &[&str]) -> Vec<Vec<String>> {
    let out = dir.join(name);
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["fuse", "--local-tracks"])
        .arg(dir.join("local_tracks.csv"))
        .arg("--out")
        .arg(&out)
        .args(extra)
        .assert()
        .success();
    let text = std::fs::read_to_string(out.join("fused_tracks.csv")).expect("fused");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(header.last(), Some(&"status"));
    let assoc = std::fs::read_to_string(out.join("associations.csv")).expect("associations");
    // one association row per local track per scan, whatever is published
    assert_eq!(assoc.lines().count() - 1, 6 * 2 + 1);
    lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn publish_all_writes_tentative_rows_and_the_default_does_not() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(dir.path().join("local_tracks.csv"), local_tracks()).expect("write");
    let status = |rows: &[Vec<String>], s: &str| {
        rows.iter()
            .filter(|r| r.last().map(String::as_str) == Some(s))
            .count()
    };
    let default = fuse(dir.path(), "default", &[]);
    assert_eq!(default.len(), 6, "the two-sensor target only");
    assert_eq!(status(&default, "confirmed"), 6);
    let all = fuse(dir.path(), "all", &["--publish", "all"]);
    assert_eq!(all.len(), 7);
    assert_eq!(status(&all, "tentative"), 1);
    let tentative: Vec<&Vec<String>> = all
        .iter()
        .filter(|r| r.last().map(String::as_str) == Some("tentative"))
        .collect();
    assert!(tentative.iter().all(|r| r[r.len() - 2] == "1:9"));
    // the papers' center publishes it at once, as confirmed
    let off = fuse(dir.path(), "off", &["--no-management"]);
    assert_eq!(off.len(), 7);
    assert_eq!(status(&off, "confirmed"), 7);
    let e = Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["fuse", "--local-tracks"])
        .arg(dir.path().join("local_tracks.csv"))
        .arg("--out")
        .arg(dir.path().join("bad"))
        .args(["--publish", "some"])
        .output()
        .expect("run");
    assert!(!e.status.success());
    assert!(String::from_utf8_lossy(&e.stderr).contains("--publish some"));
}
