//! Track-to-track fusion rules, one file per rule, named after it (ALGORITHMS.md
//! section 3). Each implements [`super::FusionRule`] and is listed in [`super::registry`].

pub mod bar_shalom_campo;
pub(crate) mod blue;
mod ci_det;
pub mod convex_combination;
pub mod covariance_intersection;
pub mod fuzzy;
pub mod information_matrix;
pub mod mmse;
#[cfg(test)]
mod properties;
pub mod sdf;
pub mod simple;
pub mod superior;
#[cfg(test)]
mod valid_covariances;
