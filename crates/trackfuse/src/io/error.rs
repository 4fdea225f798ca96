//! The input error every reader returns: file, line, column and reason.

use std::fmt;
use std::path::{Path, PathBuf};

/// A problem with an input file, located as precisely as possible.
///
/// `line` is 1-based (the header is line 1); `column` is the 1-based field number and
/// `column_name` the header name of that field, when the problem is in one cell.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    pub file: PathBuf,
    pub line: Option<u64>,
    pub column: Option<usize>,
    pub column_name: Option<String>,
    pub reason: String,
}

impl InputError {
    /// An error about the whole file (cannot open, empty, ...).
    pub fn file(file: &Path, reason: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            line: None,
            column: None,
            column_name: None,
            reason: reason.into(),
        }
    }

    /// An error about one line.
    pub fn line(file: &Path, line: u64, reason: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            line: Some(line),
            column: None,
            column_name: None,
            reason: reason.into(),
        }
    }

    /// An error about one cell.
    pub fn cell(
        file: &Path,
        line: u64,
        column: usize,
        name: &str,
        reason: impl Into<String>,
    ) -> Self {
        InputError {
            file: file.to_path_buf(),
            line: Some(line),
            column: Some(column),
            column_name: Some(name.to_string()),
            reason: reason.into(),
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
            if let Some(c) = self.column {
                write!(f, ":{c}")?;
            }
        }
        write!(f, ": ")?;
        if let Some(name) = &self.column_name {
            write!(f, "column '{name}': ")?;
        }
        write!(f, "{}", self.reason)
    }
}

impl std::error::Error for InputError {}
