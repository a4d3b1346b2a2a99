//! `P/V/reset`: the request and its reply.

use super::{EstimateMsg, QuaternionMsg};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// A sigma given as one number for every axis or three.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum PerAxis {
    One(f64),
    Three([f64; 3]),
}

impl PerAxis {
    pub fn to_vector(&self) -> Vector3<f64> {
        match self {
            PerAxis::One(v) => Vector3::repeat(*v),
            PerAxis::Three(v) => Vector3::new(v[0], v[1], v[2]),
        }
    }
}

/// `P/V/reset` request payload; every field optional.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetMsg {
    /// `mekf`, `usque` or `qpf` (default: the vehicle's configured filter).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filter: Option<String>,
    /// `propagated` or `average` (sampling filters).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fiducial: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<usize>,
    /// The attitude; absent means initialise from the next vector-observation set.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q: Option<QuaternionMsg>,
    /// Attitude 1σ, deg (one value or three).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_deg: Option<PerAxis>,
    /// Gyro bias, rad/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias: Option<[f64; 3]>,
    /// Bias 1σ, rad/s (one value or three).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_sigma: Option<PerAxis>,
    /// Start time, s (default: the time of the next measurement).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t: Option<f64>,
}

/// `P/V/reset` reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetReplyMsg {
    pub vehicle: String,
    /// `initializing` or `tracking`.
    pub state: String,
    pub filter: String,
    pub fiducial: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<usize>,
    /// The new estimate when the reset gave an attitude; null while initialising.
    pub estimate: Option<EstimateMsg>,
}
