//! Multiplicative extended Kalman filter (Crassidis & Junkins, *Optimal Estimation of Dynamic
//! Systems*, ch. 7; docs/algorithms.md §3). The baseline every other filter is compared against.
//!
//! Error state `x = [δα; Δβ]` (rad, rad/s), `δq = q ⊗ q̂⁻¹ ≈ [δα/2; 1]`.

use super::{
    is_spd, symmetrize, Diagnostics, Driver, Estimate, FilterConfig, FilterCore, FilterError,
    FilterSpec, FilterState, GyroErrors, InitialState, MekfState,
};
use crate::attitude::{skew, Quaternion};
use crate::sensors::{heading, Aspect, GyroNoise, VectorObservation};
use nalgebra::{ArrayStorage, Matrix3, Matrix3x6, Matrix6, Vector3, Vector6};

mod kernels;
#[cfg(test)]
mod tests;

use kernels::{Cov, Noise};

/// The discrete error-state transition `Φ = expm(F Δt)`, `F = [[−[ω̂×], −I], [0, 0]]`:
/// `Φ₁₁ = I − [ω̂×] sin θ/‖ω̂‖ + [ω̂×]² (1 − cos θ)/‖ω̂‖²`,
/// `Φ₁₂ = [ω̂×] (1 − cos θ)/‖ω̂‖² − I Δt − [ω̂×]² (θ − sin θ)/‖ω̂‖³`, `Φ₂₁ = 0`, `Φ₂₂ = I`, `θ = ‖ω̂‖Δt`
/// (series for small θ). The filter uses its two blocks only.
pub fn transition_matrix(omega_hat_rad_s: &Vector3<f64>, dt_s: f64) -> Matrix6<f64> {
    let (a, b) = kernels::phi_blocks(&(*omega_hat_rad_s).into(), dt_s);
    let mut phi = Matrix6::identity();
    for i in 0..3 {
        for j in 0..3 {
            phi[(i, j)] = a[i][j];
            phi[(i, j + 3)] = b[i][j];
        }
    }
    phi
}

/// The per-axis entries of the Farrenkopf model's process noise over `Δt`.
fn noise(gyro: &GyroNoise, dt_s: f64) -> Noise {
    let (sv2, su2) = (gyro.sigma_v * gyro.sigma_v, gyro.sigma_u * gyro.sigma_u);
    Noise {
        q11: sv2 * dt_s + su2 * dt_s.powi(3) / 3.0,
        q12: -su2 * dt_s * dt_s / 2.0,
        q22: su2 * dt_s,
    }
}

/// The discrete process noise of the Farrenkopf model over `Δt`:
/// `Q = [[(σ_v² Δt + σ_u² Δt³/3) I, −(σ_u² Δt²/2) I], [−(σ_u² Δt²/2) I, σ_u² Δt I]]`.
pub fn process_noise(gyro: &GyroNoise, dt_s: f64) -> Matrix6<f64> {
    let n = noise(gyro, dt_s);
    let mut q = Matrix6::zeros();
    for i in 0..3 {
        q[(i, i)] = n.q11;
        q[(i, i + 3)] = n.q12;
        q[(i + 3, i)] = n.q12;
        q[(i + 3, i + 3)] = n.q22;
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

/// The result of one update: the covariance after it, `νᵀ S⁻¹ ν` of the innovation given and the
/// error-state correction.
pub struct ScalarUpdate {
    pub covariance: Matrix6<f64>,
    pub nis: f64,
    pub correction: Vector6<f64>,
}

fn cov(p: &Matrix6<f64>) -> Cov {
    p.data.0
}

fn matrix(p: Cov) -> Matrix6<f64> {
    Matrix6::from_data(ArrayStorage(p))
}

fn finish(p: Cov, c: kernels::Correction) -> ScalarUpdate {
    ScalarUpdate {
        covariance: matrix(p),
        nis: c.nis,
        correction: Vector6::from(c.dx),
    }
}

/// One Kalman update with `H = [[b̂×], 0]`, `R = σ² I`, equal to the Joseph form
/// `P⁺ = (I − KH) P (I − KH)ᵀ + K R Kᵀ` (computed as two scalar updates, `kernels`). `innovation`
/// may be `None` when only the covariance is wanted (the Cramér–Rao recursion).
pub fn joseph_update(
    p: &Matrix6<f64>,
    predicted_body: &Vector3<f64>,
    sigma: f64,
    innovation: Option<&Vector3<f64>>,
) -> Option<ScalarUpdate> {
    let mut p = cov(p);
    let nu = innovation.map_or([0.0; 3], |n| (*n).into());
    let c = kernels::vector(&mut p, &(*predicted_body).into(), sigma, &nu, None)?;
    let mut u = finish(p, c);
    if innovation.is_none() {
        (u.nis, u.correction) = (0.0, Vector6::zeros());
    }
    Some(u)
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
    let mut p = cov(p);
    let v = (*v_body).into();
    let c = kernels::vector(
        &mut p,
        &(*predicted_body).into(),
        sigma,
        &(*innovation).into(),
        Some(&v),
    )?;
    Some(finish(p, c))
}

/// One update with a direct observation of the gyro bias, `z = β + n`, `n ~ N(0, σ² I₃)`
/// (`H = [0₃, I₃]`; e.g. the mean gyro rate while the vehicle is at rest), Joseph form.
pub fn bias_update(
    p: &Matrix6<f64>,
    sigma: f64,
    innovation: &Vector3<f64>,
) -> Option<ScalarUpdate> {
    let mut p = cov(p);
    let c = kernels::bias(&mut p, sigma, &(*innovation).into())?;
    Some(finish(p, c))
}

/// One heading-only update (`crate::sensors::heading`): the scalar measurement `y = H δx + v` with
/// `H = [hᵀ, 0₃]` ([`crate::sensors::heading::heading_jacobian`]; `h·v = 1` for the body-frame vertical `v`,
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
) -> Option<ScalarUpdate> {
    let mut p = cov(p);
    let c = kernels::heading(&mut p, &(*h_att).into(), &(*v_body).into(), sigma_psi, nu)?;
    Some(finish(p, c))
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
        // (The kernels keep the covariance exactly symmetric; a given one may be so to rounding.)
        let mut p = p;
        symmetrize(&mut p);
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

/// `eˣ` for the bias reversion, whose exponent `−Δt/τ` is tiny at an IMU's rates (`τ` of hours or
/// days): below |x| = 1e-5 the series to x³ is exact to rounding (the next term is below 5e-22), and
/// there is no libm call per sample.
fn exp_small(x: f64) -> f64 {
    if x.abs() < 1e-5 {
        1.0 + x * (1.0 + x * 0.5 * (1.0 + x * (1.0 / 3.0)))
    } else {
        x.exp()
    }
}

/// True when every entry is finite: `0·x` is 0 for a finite `x` and NaN otherwise, summed in six
/// independent lanes (no early exit, no serial chain: it vectorises).
fn all_finite(p: &Cov) -> bool {
    let mut lanes = [0.0; 6];
    for row in p {
        for j in 0..6 {
            lanes[j] += row[j] * 0.0;
        }
    }
    lanes.iter().sum::<f64>() == 0.0
}

/// The check before an update commits: finite values and a positive-definite covariance, by the full
/// Cholesky. (Updates are a tenth of an IMU's samples or fewer, so this costs little; the cheap
/// conditions of [`super::plausibly_spd`] let through what rounding makes of an update that removes nearly all
/// of a huge variance, an indefinite covariance that a later propagation turns into a negative
/// variance: the property tests of `tests/it/parsers_prop.rs` find such inputs. The per-sample health
/// check of a published estimate is the cheap one.)
fn check(step: &'static str, finite: bool, p: &Matrix6<f64>) -> Result<(), FilterError> {
    if !finite {
        return Err(FilterError::NonFinite { step });
    }
    if !is_spd(p) {
        return Err(FilterError::NotPositiveDefinite { step });
    }
    Ok(())
}

impl FilterCore for Mekf {
    fn spec(&self) -> FilterSpec {
        FilterSpec {
            kind: super::FilterKind::Mekf,
            fiducial: None,
        }
    }

    fn propagate_with(
        &mut self,
        omega_meas_rad_s: &Vector3<f64>,
        dt_s: f64,
        extra_rad2: f64,
    ) -> Result<(), FilterError> {
        let omega_hat = omega_meas_rad_s - self.bias;
        let (a, b) = kernels::phi_blocks(&omega_hat.into(), dt_s);
        let extra = self.gyro_errors.rate_variance(&omega_hat, dt_s) + extra_rad2;
        // A bounded (Gauss–Markov) bias reverts to zero: x_β ← φ x_β.
        let rate = self.gyro_errors.bias_reversion_rate(&self.gyro);
        let phi_b = if rate > 0.0 {
            exp_small(-dt_s * rate)
        } else {
            1.0
        };
        let p = kernels::propagate(
            &self.p.data.0,
            &a,
            &b,
            &noise(&self.gyro, dt_s),
            extra,
            phi_b,
        );
        let bias = if phi_b < 1.0 {
            self.bias * phi_b
        } else {
            self.bias
        };
        let q = self.q.propagate(&omega_hat, dt_s);
        if !q.is_finite() || !all_finite(&p) {
            return Err(FilterError::NonFinite {
                step: "propagation",
            });
        }
        self.q = q;
        self.bias = bias;
        self.p = matrix(p);
        self.diagnostics.propagations += 1;
        Ok(())
    }

    /// Processes the observations one at a time about the same linearisation point `q̂⁻` with the
    /// accumulated correction, which is algebraically the batch update of the stacked observations;
    /// each one is two scalar updates (one for a heading), on the covariance the previous left.
    fn update(&mut self, observations: &[VectorObservation]) -> Result<(), FilterError> {
        let a = self.q.attitude_matrix();
        let mut p = cov(&self.p);
        let mut dx = [0.0; 6];
        let mut nis = 0.0;
        let mut dof = 0;
        for (index, o) in observations.iter().enumerate() {
            let singular = FilterError::SingularInnovation { index };
            let dalpha = Vector3::new(dx[0], dx[1], dx[2]);
            let c = match &o.aspect {
                Aspect::Heading(up) => {
                    // A heading-only observation (crate::sensors::heading): y = −ψ(Â⁻), H = [hᵀ, 0].
                    let Some((e1, e2, horizontal)) = heading::heading_basis(&o.reference, up)
                    else {
                        continue;
                    };
                    let v = a * (up / up.norm());
                    let h = heading::heading_jacobian(&a, &o.reference, &e2, horizontal);
                    let y = -heading::heading_residual(&a, &o.body, &e1, &e2);
                    let nu = y - h.dot(&dalpha);
                    let sigma = heading::heading_sigma_rad(o.sigma, horizontal);
                    dof += 1;
                    kernels::heading(&mut p, &h.into(), &v.into(), sigma, nu).ok_or(singular)?
                }
                aspect => {
                    // ν = b − b̂ − H dx, H dx = b̂ × δα.
                    let predicted = a * o.reference;
                    let nu = o.body - predicted - predicted.cross(&dalpha);
                    let vertical = match aspect {
                        Aspect::Tilt(up) => Some((a * (up / up.norm())).into()),
                        _ => None,
                    };
                    dof += if vertical.is_some() { 2 } else { 3 };
                    kernels::vector(
                        &mut p,
                        &predicted.into(),
                        o.sigma,
                        &nu.into(),
                        vertical.as_ref(),
                    )
                    .ok_or(singular)?
                }
            };
            for (d, c) in dx.iter_mut().zip(c.dx) {
                *d += c;
            }
            nis += c.nis;
        }
        let dalpha = Vector3::new(dx[0], dx[1], dx[2]);
        let q = Quaternion::from_rotation_vector(&dalpha)
            .compose(&self.q)
            .normalized()
            .ok_or(FilterError::NonFinite { step: "update" })?;
        let bias = self.bias + Vector3::new(dx[3], dx[4], dx[5]);
        let finite = q.is_finite() && bias.iter().all(|b| b.is_finite()) && all_finite(&p);
        let p = matrix(p);
        check("update", finite, &p)?;
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
        let mut p = cov(&self.p);
        let c = kernels::bias(&mut p, sigma_rad_s, &nu.into())
            .ok_or(FilterError::SingularInnovation { index: 0 })?;
        let dalpha = Vector3::new(c.dx[0], c.dx[1], c.dx[2]);
        let q = Quaternion::from_rotation_vector(&dalpha)
            .compose(&self.q)
            .normalized()
            .ok_or(FilterError::NonFinite {
                step: "bias update",
            })?;
        let bias = self.bias + Vector3::new(c.dx[3], c.dx[4], c.dx[5]);
        let finite = q.is_finite() && bias.iter().all(|b| b.is_finite()) && all_finite(&p);
        let p = matrix(p);
        check("bias update", finite, &p)?;
        self.q = q;
        self.bias = bias;
        self.p = p;
        Ok(())
    }

    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) {
        // (Symmetric to rounding as the driver checks it: the upper triangle is added and mirrored.)
        for i in 0..3 {
            for j in i..3 {
                let v = self.p[(i, j)] + cov_rad2[(i, j)];
                self.p[(i, j)] = v;
                self.p[(j, i)] = v;
            }
        }
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

    /// In place when `into` already holds an MEKF's state (a vehicle's history keeps one every
    /// quarter second of samples into the same slots): the variant's 650 bytes are written, not a
    /// whole `FilterState` built and moved, which is sized for the largest filter's.
    fn state_into(driver: &Driver<Self>, into: &mut FilterState) {
        let FilterState::Mekf(d, s) = into else {
            *into = Self::state(driver);
            return;
        };
        let m = driver.core();
        *d = driver.driver_state();
        // (Every field named: one added to the state does not compile until it is copied here.)
        let MekfState {
            gyro,
            gyro_errors,
            q,
            bias,
            p,
            diagnostics,
        } = s;
        *gyro = m.gyro;
        *gyro_errors = m.gyro_errors;
        *q = m.q;
        *bias = m.bias;
        *p = m.p;
        diagnostics.clone_from(&m.diagnostics);
    }

    fn bias_rad_s(&self) -> Vector3<f64> {
        self.bias
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
