//! Local tracking: one tracker per sensor (ALGORITHMS.md section 2).

use serde::{Deserialize, Serialize};

/// Configuration of the local trackers (`[tracker]` in a scenario).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerConfig {}

impl TrackerConfig {
    /// Range-check the values; `Err((key, reason))`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        Ok(())
    }
}
