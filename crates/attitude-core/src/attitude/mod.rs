//! Attitude mathematics: the quaternion and its kinematics, Rodrigues parameters, the weighted
//! quaternion average and the single-epoch (Wahba) solution. Numeric core: no I/O, no panics on input.

pub mod average;
pub mod quaternion;
pub mod rodrigues;
pub mod wahba;

pub use average::{
    signed_average, weighted_average, AverageAccumulator, AverageError, QuaternionAverage,
};
pub use quaternion::{skew, Quaternion};
pub use rodrigues::Grp;
pub use wahba::{q_method, WahbaError, WahbaSolution};
