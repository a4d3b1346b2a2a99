//! Multiplicative extended Kalman filter (Crassidis & Junkins, *Optimal Estimation of Dynamic
//! Systems*, ch. 7; docs/algorithms.md §3). The baseline every other filter is compared against.
//!
//! Error state `x = [δα; Δβ]` (rad, rad/s), `δq = q ⊗ q̂⁻¹ ≈ [δα/2; 1]`.

use super::{
    check_commit, is_spd, symmetrize, Diagnostics, Driver, Estimate, FilterConfig, FilterCore,
    FilterError, FilterSpec, FilterState, GyroErrors, InitialState, MekfState,
};
use crate::attitude::{skew, Quaternion};
use crate::sensors::{imu, Aspect, GyroNoise, VectorObservation};
use nalgebra::{Matrix3, Matrix3x6, Matrix6, Matrix6x3, Vector3, Vector6};

/// Rotation angle below which `Φ` uses Taylor series (no division by `‖ω̂‖`).
const SMALL_ROTATION_RAD: f64 = 1e-5;

/// The discrete error-state transition `Φ = expm(F Δt)`, `F = [[−[ω̂×], −I], [0, 0]]`:
/// `Φ₁₁ = I − [ω̂×] sin θ/‖ω̂‖ + [ω̂×]² (1 − cos θ)/‖ω̂‖²`,
/// `Φ₁₂ = [ω̂×] (1 − cos θ)/‖ω̂‖² − I Δt − [ω̂×]² (θ − sin θ)/‖ω̂‖³`, `Φ₂₁ = 0`, `Φ₂₂ = I`, `θ = ‖ω̂‖Δt`.
pub fn transition_matrix(omega_hat_rad_s: &Vector3<f64>, dt_s: f64) -> Matrix6<f64> {
    let w = omega_hat_rad_s.norm();
    let theta = w * dt_s;
    let wx = skew(omega_hat_rad_s);
    let wx2 = wx * wx;
    // c1 = sin θ/‖ω‖, c2 = (1 − cos θ)/‖ω‖², c3 = (θ − sin θ)/‖ω‖³, each with a series near θ = 0.
    let (c1, c2, c3) = if theta < SMALL_ROTATION_RAD {
        let t2 = dt_s * dt_s;
        (
            dt_s * (1.0 - theta * theta / 6.0),
            t2 / 2.0 * (1.0 - theta * theta / 12.0),
            t2 * dt_s / 6.0 * (1.0 - theta * theta / 20.0),
        )
    } else {
        (
            theta.sin() / w,
            (1.0 - theta.cos()) / (w * w),
            (theta - theta.sin()) / (w * w * w),
        )
    };
    let phi11 = Matrix3::identity() - wx * c1 + wx2 * c2;
    let phi12 = wx * c2 - Matrix3::identity() * dt_s - wx2 * c3;
    let mut phi = Matrix6::identity();
    phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&phi11);
    phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&phi12);
    phi
}

/// The discrete process noise of the Farrenkopf model over `Δt`:
/// `Q = [[(σ_v² Δt + σ_u² Δt³/3) I, −(σ_u² Δt²/2) I], [−(σ_u² Δt²/2) I, σ_u² Δt I]]`.
pub fn process_noise(gyro: &GyroNoise, dt_s: f64) -> Matrix6<f64> {
    let (sv2, su2) = (gyro.sigma_v * gyro.sigma_v, gyro.sigma_u * gyro.sigma_u);
    let q11 = sv2 * dt_s + su2 * dt_s.powi(3) / 3.0;
    let q12 = -su2 * dt_s * dt_s / 2.0;
    let q22 = su2 * dt_s;
    let mut q = Matrix6::zeros();
    for i in 0..3 {
        q[(i, i)] = q11;
        q[(i, i + 3)] = q12;
        q[(i + 3, i)] = q12;
        q[(i + 3, i + 3)] = q22;
    }
    q
}

/// The measurement Jacobian of one vector observation about the estimate: `H = [[A(q̂) r ×], 0₃]`,
/// from `b = A(δq) A(q̂) r ≈ A(q̂) r + [A(q̂) r ×] δα`.
pub fn measurement_jacobian(predicted_body: &Vector3<f64>) -> Matrix3x6<f64> {
    let mut h = Matrix3x6::zeros();
    h.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&skew(predicted_body));
    h
}

/// The result of one Joseph-form update with a single vector observation.
pub struct ScalarUpdate {
    pub gain: Matrix6x3<f64>,
    pub covariance: Matrix6<f64>,
    /// `νᵀ S⁻¹ ν` of the innovation given.
    pub nis: f64,
    pub correction: Vector6<f64>,
}

/// One Kalman update with `H = [[b̂×], 0]`, `R = σ² I`, solved by Cholesky (no inverse), Joseph form
/// `P⁺ = (I − KH) P (I − KH)ᵀ + K R Kᵀ`. `innovation` may be `None` when only the covariance is
/// wanted (the Cramér–Rao recursion).
pub fn joseph_update(
    p: &Matrix6<f64>,
    predicted_body: &Vector3<f64>,
    sigma: f64,
    innovation: Option<&Vector3<f64>>,
) -> Option<ScalarUpdate> {
    vector_update(p, predicted_body, sigma, innovation, None)
}

/// [`joseph_update`] for a tilt-only observation ([`crate::sensors::Aspect::Tilt`]): the gain's
/// attitude rows are projected on the plane perpendicular to the body-frame vertical `v_body` (the
/// estimate is tilted, never turned about the vertical) and its bias rows likewise (the tilt never
/// drives the bias about the vertical, which only a heading observation can tell). The covariance
/// follows in Joseph form with the full `H`, which holds for any gain.
pub fn tilt_update(
    p: &Matrix6<f64>,
    predicted_body: &Vector3<f64>,
    v_body: &Vector3<f64>,
    sigma: f64,
    innovation: &Vector3<f64>,
) -> Option<ScalarUpdate> {
    vector_update(p, predicted_body, sigma, Some(innovation), Some(v_body))
}

fn vector_update(
    p: &Matrix6<f64>,
    predicted_body: &Vector3<f64>,
    sigma: f64,
    innovation: Option<&Vector3<f64>>,
    horizontal_about: Option<&Vector3<f64>>,
) -> Option<ScalarUpdate> {
    let h = measurement_jacobian(predicted_body);
    let r = sigma * sigma;
    let pht = p * h.transpose();
    let s = h * pht + Matrix3::identity() * r;
    let chol = s.cholesky()?;
    // K = P Hᵀ S⁻¹  ⇔  S Kᵀ = H P.
    let mut gain = chol.solve(&pht.transpose()).transpose();
    if let Some(v) = horizontal_about {
        let proj = Matrix3::identity() - v * v.transpose();
        let ka = proj * gain.fixed_view::<3, 3>(0, 0);
        let kb = proj * gain.fixed_view::<3, 3>(3, 0);
        gain.fixed_view_mut::<3, 3>(0, 0).copy_from(&ka);
        gain.fixed_view_mut::<3, 3>(3, 0).copy_from(&kb);
    }
    let ikh = Matrix6::identity() - gain * h;
    let mut covariance = ikh * p * ikh.transpose() + gain * gain.transpose() * r;
    symmetrize(&mut covariance);
    let (nis, correction) = match innovation {
        Some(nu) => (nu.dot(&chol.solve(nu)), gain * nu),
        None => (0.0, Vector6::zeros()),
    };
    Some(ScalarUpdate {
        gain,
        covariance,
        nis,
        correction,
    })
}

/// One update with a direct observation of the gyro bias, `z = β + n`, `n ~ N(0, σ² I₃)`
/// (`H = [0₃, I₃]`; e.g. the mean gyro rate while the vehicle is at rest), Joseph form.
pub fn bias_update(
    p: &Matrix6<f64>,
    sigma: f64,
    innovation: &Vector3<f64>,
) -> Option<ScalarUpdate> {
    let mut h = Matrix3x6::zeros();
    h.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&Matrix3::identity());
    let r = sigma * sigma;
    let pht = p * h.transpose();
    let s = h * pht + Matrix3::identity() * r;
    let chol = s.cholesky()?;
    let gain = chol.solve(&pht.transpose()).transpose();
    let ikh = Matrix6::identity() - gain * h;
    let mut covariance = ikh * p * ikh.transpose() + gain * gain.transpose() * r;
    symmetrize(&mut covariance);
    Some(ScalarUpdate {
        gain,
        covariance,
        nis: innovation.dot(&chol.solve(innovation)),
        correction: gain * innovation,
    })
}

/// The result of one heading-only update ([`heading_update`]).
pub struct HeadingUpdate {
    pub covariance: Matrix6<f64>,
    pub nis: f64,
    pub correction: Vector6<f64>,
}

/// One heading-only update (`crate::sensors::imu`): the scalar measurement `y = H δx + v` with
/// `H = [hᵀ, 0₃]` ([`crate::sensors::imu::heading_jacobian`]; `h·v = 1` for the body-frame vertical `v`,
/// and `h` also holds the leak of a tilt error into the heading, `∝ tan dip`), `R = σ_ψ²`, innovation
/// `nu`. The attitude part of the Kalman gain is projected on `v` (`K_α ← v vᵀ K_α`) so that the update
/// turns the estimate about the vertical only, never tilts it, and so is its bias part (`K_β ← v vᵀ K_β`:
/// a field error never drives the horizontal bias, which gravity observes); the covariance follows in Joseph form
/// `P⁺ = (I − KH) P (I − KH)ᵀ + K R Kᵀ` with the full `H`, which holds for any gain. `None` when
/// `S ≤ 0`.
pub fn heading_update(
    p: &Matrix6<f64>,
    h_att: &Vector3<f64>,
    v_body: &Vector3<f64>,
    sigma_psi: f64,
    nu: f64,
) -> Option<HeadingUpdate> {
    let h = Vector6::new(h_att[0], h_att[1], h_att[2], 0.0, 0.0, 0.0);
    let r = sigma_psi * sigma_psi;
    let ph = p * h;
    let s = h.dot(&ph) + r;
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let mut gain = ph / s;
    let ka = Vector3::new(gain[0], gain[1], gain[2]);
    let kb = Vector3::new(gain[3], gain[4], gain[5]);
    let ka = v_body * v_body.dot(&ka);
    let kb = v_body * v_body.dot(&kb);
    for i in 0..3 {
        gain[i] = ka[i];
        gain[i + 3] = kb[i];
    }
    let ikh = Matrix6::identity() - gain * h.transpose();
    let mut covariance = ikh * p * ikh.transpose() + gain * gain.transpose() * r;
    symmetrize(&mut covariance);
    Some(HeadingUpdate {
        covariance,
        nis: nu * nu / s,
        correction: gain * nu,
    })
}

/// The MEKF state.
#[derive(Clone, Debug)]
pub struct Mekf {
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    q: Quaternion,
    bias: Vector3<f64>,
    p: Matrix6<f64>,
    diagnostics: Diagnostics,
}

impl Mekf {
    /// The MEKF of a saved state (checked by [`FilterState::restore`]).
    pub(super) fn from_state(s: MekfState) -> Self {
        Mekf {
            gyro: s.gyro,
            gyro_errors: s.gyro_errors,
            q: s.q,
            bias: s.bias,
            p: s.p,
            diagnostics: s.diagnostics,
        }
    }

    pub fn new(config: &FilterConfig, initial: &InitialState) -> Result<Self, FilterError> {
        let q = initial.q.normalized().ok_or_else(|| {
            FilterError::InvalidConfig("initial quaternion has no direction".into())
        })?;
        let p = initial.covariance_matrix();
        if !is_spd(&p) || !initial.bias_rad_s.iter().all(|b| b.is_finite()) {
            return Err(FilterError::InvalidConfig(
                "initial sigmas must be positive and finite".into(),
            ));
        }
        config.gyro_errors.validate()?;
        Ok(Mekf {
            gyro: config.gyro,
            gyro_errors: config.gyro_errors,
            q,
            bias: initial.bias_rad_s,
            p,
            diagnostics: Diagnostics::default(),
        })
    }

    pub fn covariance(&self) -> &Matrix6<f64> {
        &self.p
    }
}

impl FilterCore for Mekf {
    fn spec(&self) -> FilterSpec {
        FilterSpec {
            kind: super::FilterKind::Mekf,
            fiducial: None,
        }
    }

    fn propagate(&mut self, omega_meas_rad_s: &Vector3<f64>, dt_s: f64) -> Result<(), FilterError> {
        let omega_hat = omega_meas_rad_s - self.bias;
        let phi = transition_matrix(&omega_hat, dt_s);
        let mut p = phi * self.p * phi.transpose() + process_noise(&self.gyro, dt_s);
        let extra = self.gyro_errors.rate_variance(&omega_hat, dt_s);
        for i in 0..3 {
            p[(i, i)] += extra;
        }
        // A bounded (Gauss–Markov) bias reverts to zero: x_β ← φ x_β.
        let phi_b = self.gyro_errors.bias_reversion(&self.gyro, dt_s);
        let mut bias = self.bias;
        if phi_b < 1.0 {
            bias *= phi_b;
            for i in 0..6 {
                for j in 3..6 {
                    p[(i, j)] *= phi_b;
                    p[(j, i)] *= phi_b;
                }
            }
        }
        symmetrize(&mut p);
        let q = self.q.propagate(&omega_hat, dt_s);
        if !q.is_finite() || !p.iter().all(|x| x.is_finite()) {
            return Err(FilterError::NonFinite {
                step: "propagation",
            });
        }
        self.q = q;
        self.bias = bias;
        self.p = p;
        self.diagnostics.propagations += 1;
        Ok(())
    }

    /// Processes the observations one at a time about the same linearisation point `q̂⁻` with the
    /// accumulated correction, which is algebraically the batch update of the stacked observations
    /// but needs only 3×3 solves and no allocation.
    fn update(&mut self, observations: &[VectorObservation]) -> Result<(), FilterError> {
        let a = self.q.attitude_matrix();
        let mut p = self.p;
        let mut dx = Vector6::zeros();
        let mut nis = 0.0;
        let mut dof = 0;
        for (index, o) in observations.iter().enumerate() {
            if let Aspect::Tilt(up) = &o.aspect {
                let predicted = a * o.reference;
                let nu = o.body - predicted - measurement_jacobian(&predicted) * dx;
                let v = a * (up / up.norm());
                let u = tilt_update(&p, &predicted, &v, o.sigma, &nu)
                    .ok_or(FilterError::SingularInnovation { index })?;
                dx += u.correction;
                p = u.covariance;
                nis += u.nis;
                dof += 2;
                continue;
            }
            if let Aspect::Heading(up) = &o.aspect {
                // A heading-only observation (crate::sensors::imu): y = −ψ(Â⁻), H = [hᵀ, 0].
                let Some((e1, e2, horizontal)) = imu::heading_basis(&o.reference, up) else {
                    continue;
                };
                let v = a * (up / up.norm());
                let h = imu::heading_jacobian(&a, &o.reference, &e2, horizontal);
                let y = -imu::heading_residual(&a, &o.body, &e1, &e2);
                let nu = y - (h[0] * dx[0] + h[1] * dx[1] + h[2] * dx[2]);
                let u = heading_update(&p, &h, &v, imu::heading_sigma_rad(o.sigma, horizontal), nu)
                    .ok_or(FilterError::SingularInnovation { index })?;
                dx += u.correction;
                p = u.covariance;
                nis += u.nis;
                dof += 1;
                continue;
            }
            let predicted = a * o.reference;
            let h = measurement_jacobian(&predicted);
            let nu = o.body - predicted - h * dx;
            let u = joseph_update(&p, &predicted, o.sigma, Some(&nu))
                .ok_or(FilterError::SingularInnovation { index })?;
            dx += u.correction;
            p = u.covariance;
            nis += u.nis;
            dof += 3;
        }
        let dalpha = Vector3::new(dx[0], dx[1], dx[2]);
        let q = Quaternion::from_rotation_vector(&dalpha)
            .compose(&self.q)
            .normalized()
            .ok_or(FilterError::NonFinite { step: "update" })?;
        let bias = self.bias + Vector3::new(dx[3], dx[4], dx[5]);
        check_commit(
            "update",
            q.is_finite() && bias.iter().all(|b| b.is_finite()),
            &p,
        )?;
        self.q = q;
        self.bias = bias;
        self.p = p;
        self.diagnostics.updates += 1;
        self.diagnostics.nis = Some(nis);
        self.diagnostics.nis_dof = Some(dof);
        Ok(())
    }

    fn update_bias(&mut self, z_rad_s: &Vector3<f64>, sigma_rad_s: f64) -> Result<(), FilterError> {
        let nu = z_rad_s - self.bias;
        let u = bias_update(&self.p, sigma_rad_s, &nu)
            .ok_or(FilterError::SingularInnovation { index: 0 })?;
        let dalpha = Vector3::new(u.correction[0], u.correction[1], u.correction[2]);
        let q = Quaternion::from_rotation_vector(&dalpha)
            .compose(&self.q)
            .normalized()
            .ok_or(FilterError::NonFinite {
                step: "bias update",
            })?;
        let bias = self.bias + Vector3::new(u.correction[3], u.correction[4], u.correction[5]);
        let finite = q.is_finite() && bias.iter().all(|b| b.is_finite());
        check_commit("bias update", finite, &u.covariance)?;
        self.q = q;
        self.bias = bias;
        self.p = u.covariance;
        Ok(())
    }

    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) {
        let mut block = self.p.fixed_view_mut::<3, 3>(0, 0);
        block += cov_rad2;
    }

    fn state(driver: &Driver<Self>) -> FilterState {
        let m = driver.core();
        FilterState::Mekf(
            driver.driver_state(),
            MekfState {
                gyro: m.gyro,
                gyro_errors: m.gyro_errors,
                q: m.q,
                bias: m.bias,
                p: m.p,
                diagnostics: m.diagnostics.clone(),
            },
        )
    }

    fn estimate(&self) -> Estimate {
        Estimate {
            t_s: 0.0,
            q: self.q.canonical(),
            bias_rad_s: self.bias,
            covariance: self.p,
            diagnostics: self.diagnostics.clone(),
        }
    }
}
