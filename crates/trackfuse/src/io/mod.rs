//! Readers and writers for every file of `FORMATS.md`.
//!
//! Readers find columns by header name (any order, extra columns ignored), accept LF and
//! CRLF, and reject — never repair — missing columns, unparsable or non-finite numbers,
//! covariances that are not symmetric positive semi-definite, time going backwards within
//! one `(sensor_id, track_id)` and duplicate rows. Every error names file, line, column and
//! reason ([`InputError`]). Writers write LF and floats in shortest round-trip form.

mod error;
mod lines;
mod reader;
mod writer;

pub use error::InputError;
pub use reader::{
    check_covariance, no_truth_rows, read_associations, read_associations_from, read_fused_tracks,
    read_fused_tracks_from, read_local_tracks, read_local_tracks_from, read_measurements,
    read_measurements_from, read_sensors, read_sensors_from, read_truth, read_truth_from,
    AssociationStream, CovarianceError, FusedTrackStream, LocalTrackStream, MeasurementStream,
    TruthStream,
};
pub use writer::{
    write_sensors, AssociationWriter, CsvRowWriter, FusedTrackWriter, LocalTrackWriter,
    MeasurementWriter, TruthWriter,
};

/// Header names of the covariance columns, `P00 … P33`, row-major.
pub const COV_COLUMNS: [&str; 16] = [
    "P00", "P01", "P02", "P03", "P10", "P11", "P12", "P13", "P20", "P21", "P22", "P23", "P30",
    "P31", "P32", "P33",
];
