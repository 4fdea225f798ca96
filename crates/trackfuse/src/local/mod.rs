//! Local tracking: one tracker per sensor (ALGORITHMS.md section 2).
//!
//! A tracker is a composition: a [`filter::Filter`] (KF, EKF, CMKF, IMM, ...), a
//! [`association::DataAssociator`] (NN, GNN, PDA, JPDA, FNN, MEF-JPDA, FDB-DAF, Fuzzy-GA),
//! gating ([`gating`]) and track management ([`tracker`]: known initial states or M-of-N
//! initiation, deletion after misses). Methods are chosen by name through [`registry`].

pub mod association;
pub mod filter;
pub mod gating;
pub mod registry;

use crate::params::ParamTables;
use serde::{Deserialize, Serialize};

/// Configuration of the local trackers (`[tracker]` in a scenario).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerConfig {
    /// Per-method parameter tables, `[tracker.params.<method name>]`.
    #[serde(default)]
    pub params: ParamTables,
}

impl TrackerConfig {
    /// Range-check the values; `Err((key, reason))`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        Ok(())
    }
}
