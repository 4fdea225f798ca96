//! Where a command writes, and the rules that make its output folder trustworthy.
//!
//! - **Never over an input.** Every command lists its input files; an output path that is
//!   the same file as an input (same device and inode, so also through a symlink or a hard
//!   link: `same-file`) is an error naming both, raised before anything is written. An
//!   output that does not exist yet cannot be an input.
//! - **Only where asked.** Outputs go to `--out DIR` (each command's default is
//!   `out/<command>`, relative to the working directory), never next to an input unasked.
//! - **Atomic files.** Each file is written to a temporary file in its directory and
//!   renamed into place when complete ([`trackfuse::io::AtomicFile`]); an error leaves no
//!   truncated file under the real name.
//! - **One run per folder.** Each command has a fixed output set (its `*_OUTPUTS`
//!   constant). When it succeeds, the files of that set it did not write this time (e.g.
//!   `bias_estimates.csv` after a run without a bias estimator) are removed, with one line
//!   on stderr each. When it fails after it began writing, every file of its set is removed
//!   (one line on stderr each), so the folder never mixes two runs; when it fails before
//!   writing anything, or before renaming any file into place (`track` and `fuse` on a bad
//!   row found while streaming: [`Outputs::failed_before_commit`]), the folder is left as
//!   it was. Files outside the set are never
//!   touched, nor is any file of the set that is one of the command's inputs.

use anyhow::{bail, Context, Result};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use trackfuse::io::AtomicFile;

/// `trackfuse simulate`'s outputs.
pub const SIMULATE_OUTPUTS: &[&str] = &[
    "scenario.toml",
    "sensors.csv",
    "truth.csv",
    "measurements.csv",
];
/// `trackfuse track`'s outputs.
pub const TRACK_OUTPUTS: &[&str] = &["local_tracks.csv"];
/// `trackfuse fuse`'s outputs (`bias_estimates.csv` with a bias estimator only).
pub const FUSE_OUTPUTS: &[&str] = &[
    "fused_tracks.csv",
    "associations.csv",
    "bias_estimates.csv",
    "bias_history.csv",
];
/// `trackfuse run`'s outputs: simulate's, track's, fuse's and `summary.json`.
pub const RUN_OUTPUTS: &[&str] = &[
    "scenario.toml",
    "sensors.csv",
    "truth.csv",
    "measurements.csv",
    "local_tracks.csv",
    "fused_tracks.csv",
    "associations.csv",
    "bias_estimates.csv",
    "bias_history.csv",
    "summary.json",
    "report.html",
    "report.md",
];
/// `trackfuse mc`'s and `trackfuse evaluate`'s outputs.
pub const MC_OUTPUTS: &[&str] = &["summary.json", "report.html", "report.md"];
/// `trackfuse evaluate`'s outputs (as `mc`'s).
pub const SUMMARY_OUTPUTS: &[&str] = MC_OUTPUTS;

/// A command's output folder: its output set, its inputs, and what this run wrote.
pub struct Outputs {
    dir: PathBuf,
    set: Vec<PathBuf>,
    inputs: Vec<PathBuf>,
    written: BTreeSet<PathBuf>,
    finished: bool,
}

/// Whether `a` and `b` are the same existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    same_file::is_same_file(a, b).unwrap_or(false)
}

/// An error if `output` is one of `inputs` (naming both).
pub fn refuse_input(output: &Path, inputs: &[&Path]) -> Result<()> {
    for input in inputs {
        if same_file(output, input) {
            bail!(
                "{}: this output is the input {}; refusing to write over an input (choose another --out or file name)",
                output.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// An error if a cell of line `line` of output `file` is not finite (the check the
/// library's CSV writers make, for a file written by hand): `(column number, name, value)`.
pub fn finite_cells(file: &str, line: u64, cells: &[(usize, &str, f64)]) -> Result<()> {
    if let Some((col, name, v)) = cells.iter().find(|c| !c.2.is_finite()) {
        bail!(
            "writing {file}: line {line}, column {col} ({name}): {v} is not a finite number (outputs hold finite numbers only)"
        );
    }
    Ok(())
}

impl Outputs {
    /// Check that no file of the output set `names` in `dir` is one of `inputs`. Nothing
    /// is created, written or removed yet (the folder is created by the first
    /// [`Outputs::path`]).
    pub fn new(dir: &Path, names: &[&str], inputs: &[&Path]) -> Result<Outputs> {
        let set: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
        Outputs::with_files(dir, set, inputs)
    }

    /// As [`Outputs::new`] with explicit file paths (e.g. `evaluate --summary FILE`).
    pub fn with_files(dir: &Path, set: Vec<PathBuf>, inputs: &[&Path]) -> Result<Outputs> {
        for f in &set {
            refuse_input(f, inputs)?;
        }
        Ok(Outputs {
            dir: dir.to_path_buf(),
            set,
            inputs: inputs.iter().map(|p| p.to_path_buf()).collect(),
            written: BTreeSet::new(),
            finished: false,
        })
    }

    /// The output folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The path of output `name` (in the folder, created if need be), recorded as written
    /// by this run: call it just before writing the file.
    pub fn path(&mut self, name: &str) -> Result<PathBuf> {
        let p = self.dir.join(name);
        self.mark(&p)?;
        Ok(p)
    }

    /// Record an output about to be written at `path` (one of the set given by path), and
    /// create its folder.
    fn mark(&mut self, path: &Path) -> Result<()> {
        if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
        }
        self.written.insert(path.to_path_buf());
        Ok(())
    }

    /// Write the output file `path` (one of the set given by path) whole, atomically.
    pub fn write_file(&mut self, path: &Path, bytes: &[u8]) -> Result<PathBuf> {
        self.mark(path)?;
        AtomicFile::write_all_to(path, bytes).with_context(|| format!("writing {}", path.display()))
    }

    /// Write output `name` whole, atomically.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<PathBuf> {
        let p = self.path(name)?;
        AtomicFile::write_all_to(&p, bytes).with_context(|| format!("writing {}", p.display()))
    }

    fn is_input(&self, p: &Path) -> bool {
        self.inputs.iter().any(|i| same_file(p, i))
    }

    fn remove(&self, p: &Path, why: &str) {
        if p.is_file() && !self.is_input(p) {
            match std::fs::remove_file(p) {
                Ok(()) => eprintln!("removed {} ({why})", p.display()),
                Err(e) => eprintln!("could not remove {} ({why}): {e}", p.display()),
            }
        }
    }

    /// The run failed before it renamed any file into place (its atomic writers dropped
    /// unfinished leave nothing under the real names: a bad row found while streaming):
    /// leave the folder as it was, an earlier run's outputs included.
    pub fn failed_before_commit(mut self) {
        self.finished = true;
    }

    /// The run succeeded: remove the files of the set this run did not write.
    pub fn finish(mut self) {
        self.finished = true;
        for p in &self.set {
            if !self.written.contains(p) {
                self.remove(p, "an earlier run's output that this run does not write");
            }
        }
    }
}

impl Drop for Outputs {
    /// The run failed: if it had begun writing, remove its whole output set.
    fn drop(&mut self) {
        if self.finished || self.written.is_empty() {
            return;
        }
        for p in &self.set {
            self.remove(p, "the run failed while writing its outputs");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let input = dir.path().join("fused_tracks.csv");
        std::fs::write(&input, "x\n").expect("write");
        let e = Outputs::new(dir.path(), FUSE_OUTPUTS, &[&input])
            .err()
            .expect("refused");
        assert!(e.to_string().contains("this output is the input"), "{e}");
        // a not-yet-existing output is never an input
        let other = dir.path().join("elsewhere");
        assert!(Outputs::new(&other, FUSE_OUTPUTS, &[&input]).is_ok());
        // and nothing was created
        assert!(!other.exists());
    }

    #[test]
    fn a_hand_written_output_refuses_non_finite_cells() {
        assert!(finite_cells("b.csv", 2, &[(2, "bias_r", 1.0)]).is_ok());
        let e = finite_cells(
            "b.csv",
            3,
            &[(2, "bias_r", 1.0), (3, "bias_theta", f64::NAN)],
        )
        .expect_err("NaN");
        assert_eq!(
            e.to_string(),
            "writing b.csv: line 3, column 3 (bias_theta): NaN is not a finite number (outputs hold finite numbers only)"
        );
    }

    #[test]
    fn stale_files_of_the_set_go_others_stay() {
        let dir = tempfile::tempdir().expect("tempdir");
        for f in ["bias_estimates.csv", "notes.txt", "fused_tracks.csv"] {
            std::fs::write(dir.path().join(f), "old\n").expect("write");
        }
        let mut o = Outputs::new(dir.path(), FUSE_OUTPUTS, &[]).expect("outputs");
        o.write("fused_tracks.csv", b"new\n").expect("write");
        o.write("associations.csv", b"new\n").expect("write");
        o.finish();
        assert!(!dir.path().join("bias_estimates.csv").exists());
        assert!(dir.path().join("notes.txt").exists());
        assert_eq!(
            std::fs::read_to_string(dir.path().join("fused_tracks.csv")).expect("read"),
            "new\n"
        );
    }

    #[test]
    fn a_failed_run_leaves_none_of_its_set() {
        let dir = tempfile::tempdir().expect("tempdir");
        std::fs::write(dir.path().join("associations.csv"), "old\n").expect("write");
        std::fs::write(dir.path().join("notes.txt"), "keep\n").expect("write");
        {
            let mut o = Outputs::new(dir.path(), FUSE_OUTPUTS, &[]).expect("outputs");
            o.write("fused_tracks.csv", b"new\n").expect("write");
            // an error here drops `o` unfinished
        }
        assert!(!dir.path().join("fused_tracks.csv").exists());
        assert!(!dir.path().join("associations.csv").exists());
        assert!(dir.path().join("notes.txt").exists());
        // failing before writing anything leaves the folder as it was
        std::fs::write(dir.path().join("associations.csv"), "old\n").expect("write");
        drop(Outputs::new(dir.path(), FUSE_OUTPUTS, &[]).expect("outputs"));
        assert!(dir.path().join("associations.csv").exists());
    }
}
