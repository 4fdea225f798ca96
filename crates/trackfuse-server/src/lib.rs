//! The trackfuse fusion center as a service (issue 15): sensors stream local tracks in
//! as NDJSON over TCP (or through NATS JetStream, [`nats`]), subscribers receive fused tracks and associations, an HTTP
//! endpoint serves health and Prometheus metrics; `--record` journals the input and
//! `replay` reproduces the output byte for byte. The fusion is the library's
//! `FusionCenter` at its update instants (`InstantBatcher`), as `trackfuse fuse` runs it.

pub mod cli;
pub mod config;
pub mod engine;
pub mod http;
pub mod loadgen;
pub mod message;
pub mod metrics;
pub mod nats;
pub mod server;

/// The NATS client the service uses (for tests and tools that talk to its streams).
pub use async_nats;
pub use config::ServiceConfig;
pub use engine::{replay, Engine};
pub use nats::{start_nats, NatsService};
pub use server::{start, Outputs, Service};
