//! Track-to-track association methods, one file per method, named after it
//! (ALGORITHMS.md section 3). Each implements [`super::TrackAssociator`] and is listed in
//! [`super::registry`].

pub mod chi2_gnn;
pub mod fdbsc;
pub mod fdtta;
pub mod fta;
pub mod ftta;
pub(crate) mod grouping;
pub mod ht_t2gt;
pub mod truth;
pub mod wfc;
