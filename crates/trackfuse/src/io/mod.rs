//! Readers and writers for every file of `docs/formats.md`.
//!
//! Readers find columns by header name (any order, extra columns ignored), accept LF and
//! CRLF, and reject — never repair — missing columns, unparsable or non-finite numbers,
//! cells that are not UTF-8, covariances that are not symmetric positive semi-definite,
//! rows out of scan order, time going backwards within one key and duplicate rows. Every
//! error names file, line, column and reason ([`InputError`]); lines are counted from the
//! bytes, so a CRLF file and its LF twin name the same line. Writers write LF and floats
//! in shortest round-trip form, only finite ones, and each file atomically
//! ([`AtomicFile`]).
//!
//! # The ordering rule
//! Every file with a `scan` column (truth.csv, measurements.csv, local_tracks.csv,
//! fused_tracks.csv, associations.csv) has its rows in non-decreasing `scan` order, in
//! any order within a scan — the order every simulator, tracker and center of this
//! project writes. A row whose scan is smaller than the previous row's is an error
//! naming its line, the column `scan` and the previous row's line, with a hint to sort
//! the data rows by the scan column. Within one key (a target, a `(sensor_id, track_id)`,
//! a `fused_id`, a sensor's scans in measurements.csv) time must not go backwards
//! either. Readers never sort a file into shape; within a scan they return rows in a
//! fixed order (below), so results do not depend on the order of a scan's rows.
//!
//! `scan` is optional in local_tracks.csv and measurements.csv (sensors reporting at
//! their own rates and phases): a file without it has its rows in non-decreasing `time`
//! order, any order within one time; a smaller time after a larger one is an error
//! naming both lines, with a hint to sort by the time column. Its rows sharing one time
//! are one batch ("scan"), numbered 0, 1, 2, ... in time order, and `next_scan` returns
//! one batch at a time.
//!
//! # Reading scan by scan
//! Each file kind with a `scan` column has a stream that reads one scan at a time, so a
//! caller's memory does not grow with the number of scans: [`TruthStream`],
//! [`MeasurementStream`], [`LocalTrackStream`], [`FusedTrackStream`] and
//! [`AssociationStream`].
//!
//! - `XStream::open(path)` (measurements: `open(path, sensors)`) opens a file, and
//!   `XStream::from_reader(reader, name)` reads any [`std::io::Read`] (bytes in memory,
//!   a pipe, a fuzz input), naming it `name` in messages. Both read and check the header.
//! - `next_scan(&mut buf) -> Result<Option<u32>, InputError>` clears `buf`, fills it with
//!   the next scan's rows (its capacity is reused) and returns the scan index, or `None`
//!   at the end of the file. After an error every later call returns the same error.
//! - `lines()` gives the 1-based file line of each row of the last scan, parallel to
//!   `buf`, so a caller can name the line of a row in an error found later (a sensor not
//!   in sensors.csv, a fusion error).
//! - `rows_read()` counts the data rows read so far; `collect_rows()` reads the rest.
//!
//! Within a scan the rows come as the whole-file readers return them: truth in file
//! order; measurements stable-sorted by `sensor_id`; local tracks by
//! `(sensor_id, track_id)`; fused tracks by `fused_id`; associations by
//! `(sensor_id, track_id)`. The whole-file readers (`read_truth`, ...) are these streams
//! collected, and each has a `*_from(reader, name)` twin over any [`std::io::Read`].
//! `read_truth` refuses a file with a header and no rows ([`no_truth_rows`]): every
//! metric against it would be undefined.
//!
//! Memory: a stream holds one scan's rows plus, per key, the latest time (the rule
//! above); duplicate sets and per-scan maps are cleared at every scan.

mod checks;
mod error;
mod lines;
mod quick;
mod reader;
mod records;
mod writer;

pub use checks::{
    check_associations, check_fused_tracks, check_local_track_keys, check_local_tracks,
    check_measurements, check_sensors, check_truth, RecordError,
};
pub use error::InputError;
pub use quick::{quick_report_times, quick_report_times_from};
pub use reader::{
    check_covariance, no_truth_rows, read_associations, read_associations_from, read_fused_tracks,
    read_fused_tracks_from, read_local_tracks, read_local_tracks_from, read_measurements,
    read_measurements_from, read_sensors, read_sensors_from, read_truth, read_truth_from,
    AssociationStream, CovarianceError, FusedTrackStream, LocalTrackStream, MeasurementStream,
    TruthStream,
};
pub use writer::{
    write_sensors, AssociationWriter, AtomicFile, CsvRowWriter, FusedTrackWriter, LocalTrackWriter,
    MeasurementWriter, Sink, TruthWriter,
};

/// Header names of the covariance columns, `P00 … P33`, row-major.
pub const COV_COLUMNS: [&str; 16] = [
    "P00", "P01", "P02", "P03", "P10", "P11", "P12", "P13", "P20", "P21", "P22", "P23", "P30",
    "P31", "P32", "P33",
];
