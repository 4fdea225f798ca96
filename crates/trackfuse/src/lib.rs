//! # trackfuse
//!
//! Distributed multi-sensor, multi-target tracking: each sensor runs its own tracker
//! ([`local`]), a fusion center ([`center`]) associates the local tracks that follow the
//! same target (track-to-track association) and fuses them (track-to-track fusion).
//!
//! Every stage reads and writes the files of `docs/formats.md` ([`io`]) and is one library call,
//! so the CLI, the Monte Carlo engine ([`montecarlo`]) and a service share one code path.
//! The library holds no global state and prints nothing.

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
