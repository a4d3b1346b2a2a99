//! The pipeline's state as plain data: what a checkpoint saves and restores (the file format is the
//! service's `persist` module's; a field added here is a compile error there).

use super::repeats::{Interpolation, MagHold};
use super::rest::RestDetector;
use super::sheet::{NoiseMeter, SensorSheet};
use super::{Ahrs, AhrsCounts};
use crate::attitude::Quaternion;
use crate::sensors::field::FieldChannel;
use crate::sensors::gravity::GravityChannel;
use crate::sensors::gyro::GyroChannel;
use nalgebra::{Matrix3, Vector3};

/// Where the pipeline is: aligning (collecting the first samples) or running.
#[derive(Clone, Debug, PartialEq)]
pub enum Phase {
    /// Collecting the alignment: sums since `t0_s`.
    Aligning {
        t0_s: f64,
        acc: Vector3<f64>,
        mag: Vector3<f64>,
        n_acc: u32,
        n_mag: u32,
    },
    Running,
}

/// Every field of an [`Ahrs`].
#[derive(Clone, Debug, PartialEq)]
pub struct AhrsState {
    pub phase: Phase,
    pub t_s: Option<f64>,
    pub q_gyro: Quaternion,
    pub sheet: SensorSheet,
    pub noise: NoiseMeter,
    pub gyro: GyroChannel,
    pub rest: RestDetector,
    pub gravity: GravityChannel,
    pub field: Option<FieldChannel>,
    pub since_bias_s: f64,
    pub published: Matrix3<f64>,
    pub north_var: f64,
    pub tilt_inconsistent_s: f64,
    pub heading_inconsistent_s: f64,
    pub counts: AhrsCounts,
    pub line: Interpolation,
    pub mag_hold: MagHold,
}

impl Ahrs {
    /// The pipeline's state, for a checkpoint.
    pub fn state(&self) -> AhrsState {
        AhrsState {
            phase: self.phase.clone(),
            t_s: self.t_s,
            q_gyro: self.q_gyro,
            sheet: self.sheet.clone(),
            noise: self.noise.clone(),
            gyro: self.gyro.clone(),
            rest: self.rest.clone(),
            gravity: self.gravity.clone(),
            field: self.field.clone(),
            since_bias_s: self.since_bias_s,
            published: self.published,
            north_var: self.north_var,
            tilt_inconsistent_s: self.tilt_inconsistent_s,
            heading_inconsistent_s: self.heading_inconsistent_s,
            counts: self.counts.clone(),
            line: self.line.clone(),
            mag_hold: self.mag_hold.clone(),
        }
    }

    /// The pipeline of a saved state; `Err` names what is not usable (a non-finite time or
    /// attitude).
    pub fn from_state(s: AhrsState) -> Result<Ahrs, String> {
        let q = [s.q_gyro.x, s.q_gyro.y, s.q_gyro.z, s.q_gyro.w];
        let n2: f64 = q.iter().map(|v| v * v).sum();
        if !q.iter().all(|v| v.is_finite()) || (n2 - 1.0).abs() > 1e-6 {
            return Err("the IMU pipeline's gyro frame is not a unit quaternion".into());
        }
        if !s.t_s.unwrap_or(0.0).is_finite()
            || !s.published.iter().all(|v| v.is_finite())
            || !(s.north_var >= 0.0 && s.north_var.is_finite())
        {
            return Err("the IMU pipeline's time or covariance is not finite".into());
        }
        Ok(Ahrs {
            phase: s.phase,
            t_s: s.t_s,
            q_gyro: s.q_gyro,
            sheet: s.sheet,
            noise: s.noise,
            gyro: s.gyro,
            rest: s.rest,
            gravity: s.gravity,
            field: s.field,
            since_bias_s: s.since_bias_s,
            published: s.published,
            north_var: s.north_var,
            tilt_inconsistent_s: s.tilt_inconsistent_s,
            heading_inconsistent_s: s.heading_inconsistent_s,
            last_gap: None,
            line: s.line,
            mag_hold: s.mag_hold,
            counts: s.counts,
            gains: Default::default(),
        })
    }
}
