//! # trackfuse
//!
//! Distributed multi-sensor, multi-target tracking: each sensor runs its own tracker
//! ([`local`]), a fusion center ([`center`]) associates the local tracks that follow the
//! same target (track-to-track association) and fuses them (track-to-track fusion).
//!
//! Every stage reads and writes the files of `docs/formats.md` ([`io`]) and is one library call,
//! so the CLI, the Monte Carlo engine ([`montecarlo`]) and a service share one code path.
//! The library holds no global state and prints nothing.
//!
//! ## Where to start
//!
//! - One whole run in memory (simulate, track, fuse, evaluate) from a scenario:
//!   [`pipeline::run_once`] with a [`RunConfig`] ([`RunConfig::builtin`] for the
//!   repository's scenarios).
//! - One sensor's tracker, scan by scan: [`local::SensorTracker`], configured by
//!   [`local::TrackerConfig`]; several sensors at once: [`local::MultiSensorTracker`].
//! - The fusion center, scan by scan: [`center::FusionCenter`], configured by
//!   [`center::FusionConfig`] (association method, fusion rule, bias estimation, global
//!   track management), each method selected by name (`trackfuse methods` lists them).
//! - Methods of your own, registered by name: [`center::registry::CenterRegistry`] and
//!   [`local::registry::LocalRegistry`] (runnable examples in `examples/`).
//! - The files of the contract, streamed: [`io`]; scores (GOSPA, OSPA, RMSE, NEES, the
//!   correct-association rate): [`metrics`].
//!
//! `FusionCenter`, `SensorTracker` and `pipeline::run_once` carry runnable examples.

// the library reports through its return values; printing is the CLI's
#![deny(clippy::print_stdout, clippy::print_stderr, clippy::dbg_macro)]

pub mod center;
pub mod clock;
pub mod config;
pub mod covariance;
pub mod experiments;
pub mod io;
pub mod local;
pub mod max_entropy;
pub mod metrics;
pub mod models;
pub mod montecarlo;
pub mod params;
pub mod pipeline;
pub mod rng;
pub mod scenario;
pub mod sim;
pub mod spatial;
pub mod stats;
pub mod types;
pub mod union_find;

pub use config::RunConfig;
pub use scenario::Scenario;
pub use types::*;
