//! Motion and measurement models (ALGORITHMS.md section 1).

pub mod measurement;
pub mod motion;
pub mod polar;

pub use measurement::{
    range_bearing, range_bearing_jacobian, range_bearing_to_position, wrap_angle, POSITION_H,
};
pub use motion::{cv_transition, noise_gain, process_noise, AccelerationSegment};
