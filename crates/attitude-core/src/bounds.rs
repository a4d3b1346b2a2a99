//! Accuracy limits: the yardstick for every filter (docs/algorithms.md §5).

use crate::attitude::Quaternion;
use crate::filters::mekf::{joseph_update, process_noise, transition_matrix};
use crate::filters::{is_spd, symmetrize};
use crate::sensors::GyroNoise;
use nalgebra::{Matrix6, Vector3};

/// Steady-state 1σ of a single-axis attitude/bias filter with an attitude sensor of noise `σ_n` (rad)
/// every `Δt`, and the gyro noise `σ_v`, `σ_u` (Crassidis & Junkins; verified against a Riccati solution):
/// `S_u = σ_u Δt^{3/2}/σ_n`, `S_v = σ_v Δt^{½}/σ_n`, `γ = ¼ [S_u + √(S_u²/3 + 4 S_v² + 16)]`,
/// `ξ = γ + √(γ² − 1)`, `σ_θ⁺ = σ_n √(1 − ξ⁻²)`, `σ_β⁺ = (σ_n/Δt) √(S_u(ξ − ξ⁻¹) − S_u²/2)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SteadyState {
    /// Attitude 1σ after an update, rad.
    pub sigma_att_rad: f64,
    /// Bias 1σ after an update, rad/s.
    pub sigma_bias_rad_s: f64,
}

pub fn steady_state(gyro: &GyroNoise, sigma_n_rad: f64, dt_s: f64) -> SteadyState {
    let su = gyro.sigma_u * dt_s.powf(1.5) / sigma_n_rad;
    let sv = gyro.sigma_v * dt_s.sqrt() / sigma_n_rad;
    let gamma = 0.25 * (su + (su * su / 3.0 + 4.0 * sv * sv + 16.0).sqrt());
    let xi = gamma + (gamma * gamma - 1.0).sqrt();
    SteadyState {
        sigma_att_rad: sigma_n_rad * (1.0 - xi.powi(-2)).sqrt(),
        sigma_bias_rad_s: sigma_n_rad / dt_s * (su * (xi - 1.0 / xi) - su * su / 2.0).sqrt(),
    }
}

/// Posterior Cramér–Rao bound along a true trajectory: the MEKF covariance recursion with every
/// Jacobian at the true attitude, rate and bias, and no data:
/// `J_{k+1} = (Q + F J_k⁻¹ Fᵀ)⁻¹ + Σⱼ Hⱼᵀ Rⱼ⁻¹ Hⱼ`, kept here in covariance form `P = J⁻¹` (the Joseph
/// update with a linear `H` is the same recursion and better conditioned than inverting `J`).
#[derive(Clone, Debug)]
pub struct Pcrb {
    gyro: GyroNoise,
    p: Matrix6<f64>,
}

impl Pcrb {
    /// Starts from the prior covariance `P₀ = J₀⁻¹`. With a uniform attitude prior, pass the MEKF's
    /// initial covariance (it does not affect the steady-state window).
    pub fn new(gyro: GyroNoise, p0: Matrix6<f64>) -> Self {
        Pcrb { gyro, p: p0 }
    }

    /// From per-axis initial 1σ of attitude (rad) and bias (rad/s).
    pub fn from_sigmas(
        gyro: GyroNoise,
        sigma_att_rad: &Vector3<f64>,
        sigma_bias_rad_s: &Vector3<f64>,
    ) -> Self {
        let mut p0 = Matrix6::zeros();
        for i in 0..3 {
            p0[(i, i)] = sigma_att_rad[i].powi(2);
            p0[(i + 3, i + 3)] = sigma_bias_rad_s[i].powi(2);
        }
        Pcrb::new(gyro, p0)
    }

    /// Propagates over `dt_s` with the true body rate.
    pub fn propagate(&mut self, omega_true_rad_s: &Vector3<f64>, dt_s: f64) {
        if dt_s <= 0.0 {
            return;
        }
        let phi = transition_matrix(omega_true_rad_s, dt_s);
        self.p = phi * self.p * phi.transpose() + process_noise(&self.gyro, dt_s);
        symmetrize(&mut self.p);
    }

    /// Adds the information of one vector observation of reference `r` with noise `σ`, taken at the
    /// true attitude.
    pub fn observe(&mut self, q_true: &Quaternion, reference: &Vector3<f64>, sigma: f64) {
        let b = q_true.attitude_matrix() * reference;
        if let Some(u) = joseph_update(&self.p, &b, sigma, None) {
            if is_spd(&u.covariance) {
                self.p = u.covariance;
            }
        }
    }

    /// The bound on the covariance of `[δα; δβ]`.
    pub fn covariance(&self) -> &Matrix6<f64> {
        &self.p
    }

    /// √diag of the attitude block, rad.
    pub fn sigma_att_rad(&self) -> Vector3<f64> {
        Vector3::new(
            self.p[(0, 0)].sqrt(),
            self.p[(1, 1)].sqrt(),
            self.p[(2, 2)].sqrt(),
        )
    }
}
