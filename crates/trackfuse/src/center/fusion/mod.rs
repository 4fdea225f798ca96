//! Track-to-track fusion rules, one file per rule, named after it (ALGORITHMS.md
//! section 3). Each implements [`super::FusionRule`] and is listed in [`super::registry`].

pub mod sdf;
