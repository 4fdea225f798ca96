//! The fusion center: track-to-track association and fusion (ALGORITHMS.md section 3).

use serde::{Deserialize, Serialize};

/// Configuration of the fusion center (`[fusion]` in a scenario).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FusionConfig {}

impl FusionConfig {
    /// Range-check the values; `Err((key, reason))`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        Ok(())
    }
}
