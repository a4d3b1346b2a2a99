//! Quaternion particle filter with a minimal local-error (MRP) representation (Cheng & Crassidis 2010),
//! with the fiducial quaternion of Chang 2014: either the previous estimate propagated like an EKF
//! (its Eq. 1) or the MMSE weighted average of the particles (its Eqs. 3–6). docs/algorithms.md §3.
//!
//! Particle `i` is a global quaternion `qᵢ`, a bias `βᵢ` and a log-weight. Its local state is
//! `xᵢ = [δpᵢ; βᵢ] ∈ R⁶` with `δpᵢ = MRP(qᵢ ⊗ q_fid⁻¹)`: the unconstrained space in which the particle
//! covariance is computed and the cloud is regularised, so the quaternions never need normalising.
//!
//! One update:
//! 1. fiducial: the chart starts at the previous estimate propagated with `ω̃ − β̂` (for `average`
//!    the weighted average is first taken after the weights change, in step 3);
//! 2. log-likelihood of every particle; progressive correction applies it in stages `λ_s` with
//!    `λ_s (max − min) log L ≤ T` (Musso, Oudjane & Le Gland 2001), resampling and regularising between
//!    stages;
//! 3. after every weight change the fiducial is re-centred on the current weights (the weighted average
//!    for `average`, `MRP⁻¹(Σ wᵢ δpᵢ) ⊗ q_fid` for `propagated`): the literal reading (prior weights,
//!    chart fixed during the update) distorts ring-shaped and multimodal posteriors far from the
//!    fiducial and fails from large initial errors;
//! 4. the estimate (before the final resampling: less Monte-Carlo noise) `x̂ = Σ wᵢ xᵢ`,
//!    `q̂ = MRP⁻¹(δp̂) ⊗ q_fid`, `P = Σ wᵢ (xᵢ − x̂)(·)ᵀ`, reported in small-angle radians (`δα ≈ 4 δp`);
//! 5. systematic resampling when `N_eff = 1/Σwᵢ² < N_th`, then a covariance-preserving (Liu–West
//!    shrinkage) kernel in the local space with a small inflation.
//!
//! **Fallback when the average is ill-defined**: when the top eigenvalue of `M = Σ wᵢ qᵢ qᵢᵀ` is not
//! separated from the next to rounding (a perfectly diffuse cloud, or non-finite input), the filter keeps
//! the propagated fiducial for that step and counts it in `diagnostics.fiducial_fallbacks`. A small but
//! real gap is not a reason to fall back: for a ring-shaped posterior the average still lies on the ring,
//! and falling back there measured worse (docs/algorithms.md §3).

mod cloud;
mod kernels;
mod options;
mod par;
#[cfg(test)]
mod tests;
mod update;

pub use cloud::Cloud;
use cloud::*;
use options::*;
pub use options::{Kernel, QpfOptions};
pub use par::{auto_threads, set_max_threads};
use update::Evidence;

use super::{
    Diagnostics, Driver, Estimate, Fiducial, FilterConfig, FilterCore, FilterError, FilterKind,
    FilterSpec, FilterState, GyroErrors, InitialState, QpfState,
};
use crate::attitude::{AverageAccumulator, Grp, Quaternion};
use crate::rng::Xoshiro256PlusPlus;
use crate::sensors::gyro::normal3;
use crate::sensors::{heading, Aspect, GyroNoise, VectorObservation};
use crate::simd::Isa;
use kernels::{Average, Local, Moments};
use nalgebra::{Matrix3, Matrix4, Matrix6, Vector3, Vector6};
use rand::{Rng, RngCore, SeedableRng};
use rand_distr::{Beta, Distribution, StandardNormal};

/// The quaternion particle filter.
#[derive(Clone, Debug)]
pub struct Qpf {
    fiducial: Fiducial,
    options: QpfOptions,
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    cloud: Cloud,
    /// Preallocated: the cloud being built by resampling, and a backup for rolling a failed update
    /// back: its weights are saved at the start of every update, its particles are swapped in at the
    /// update's first resampling (until then only the weights change).
    /// (Working buffers are not part of a checkpoint: they are sized again on a restore.)
    scratch: Cloud,
    backup: Cloud,
    backup_has_particles: bool,
    log_lik: Vec<f64>,
    /// The heading-only observations of the current update (reused buffer).
    heading_terms: Vec<kernels::Heading>,
    resample_index: Vec<u32>,
    /// Threads of a pass (0: `par::auto_threads`) and the instruction set of the kernels (`None`:
    /// `Isa::active`). The results do not depend on either.
    threads: usize,
    isa: Option<Isa>,
    /// The previous estimate propagated with `ω̃ − β̂` (Chang 2014, Eq. 1): the `propagated`
    /// fiducial, the sign reference of the average, and the fallback when the average is undecidable.
    q_prop: Quaternion,
    q_hat: Quaternion,
    beta_hat: Vector3<f64>,
    /// Covariance of `[δα; δβ]` (rad, rad/s) at the last update.
    p_hat: Matrix6<f64>,
    /// True after a propagation: the estimate is recomputed from the cloud when asked.
    stale: bool,
    rng: Xoshiro256PlusPlus,
    diagnostics: Diagnostics,
}

impl Qpf {
    /// The QPF of a saved state (checked by [`FilterState::restore`]), working buffers sized for its
    /// cloud.
    pub(super) fn from_state(s: QpfState) -> Result<Self, FilterError> {
        let n = s.cloud.w.len();
        let rng = Xoshiro256PlusPlus::from_state(s.rng).ok_or_else(|| {
            FilterError::InvalidConfig("saved filter state: the generator's state is zero".into())
        })?;
        Ok(Qpf {
            fiducial: s.fiducial,
            options: s.options,
            gyro: s.gyro,
            gyro_errors: s.gyro_errors,
            scratch: s.cloud.clone(),
            backup: s.cloud.clone(),
            backup_has_particles: false,
            cloud: s.cloud,
            log_lik: vec![0.0; n],
            heading_terms: Vec::with_capacity(16),
            resample_index: vec![0; n],
            threads: 0,
            isa: None,
            q_prop: s.q_prop,
            q_hat: s.q_hat,
            beta_hat: s.beta_hat,
            p_hat: s.p_hat,
            stale: s.stale,
            rng,
            diagnostics: s.diagnostics,
        })
    }

    pub fn new(
        config: &FilterConfig,
        initial: &InitialState,
        options: QpfOptions,
        seed: u64,
    ) -> Result<Self, FilterError> {
        let n = config.particles;
        if n > u32::MAX as usize {
            return Err(FilterError::InvalidConfig(format!(
                "at most {} particles, got {n}",
                u32::MAX
            )));
        }
        if n < 2 {
            return Err(FilterError::InvalidConfig(format!(
                "particles must be at least 2, got {n}"
            )));
        }
        options.validate()?;
        let bad = |what: &str| Err(FilterError::InvalidConfig(what.to_string()));
        let q0 = initial.q.normalized().ok_or_else(|| {
            FilterError::InvalidConfig("initial quaternion has no direction".into())
        })?;
        let sig_ok = |v: &Vector3<f64>| v.iter().all(|s| s.is_finite() && *s >= 0.0);
        if !sig_ok(&initial.sigma_att_rad)
            || !sig_ok(&initial.bias_sigma_rad_s)
            || !initial.bias_rad_s.iter().all(|b| b.is_finite())
        {
            return bad("initial sigmas must be finite and non-negative, the bias finite");
        }
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut cloud = Cloud::with_len(n);
        // A full covariance (a start from a published estimate): particles drawn from it jointly.
        let factor = match &initial.covariance {
            Some(p) if !initial.uniform_attitude => Some(
                p.cholesky()
                    .ok_or_else(|| {
                        FilterError::InvalidConfig(
                            "the initial covariance must be positive definite".into(),
                        )
                    })?
                    .l(),
            ),
            _ => None,
        };
        for i in 0..n {
            if let Some(l) = &factor {
                let x = l * Vector6::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
                let dalpha = Vector3::new(x[0], x[1], x[2]);
                let q = Quaternion::from_rotation_vector(&dalpha).compose(&q0);
                let b = initial.bias_rad_s + Vector3::new(x[3], x[4], x[5]);
                cloud.set(i, &q, &b);
                continue;
            }
            let q = if initial.uniform_attitude {
                loop {
                    let v: [f64; 4] = [
                        rng.sample(StandardNormal),
                        rng.sample(StandardNormal),
                        rng.sample(StandardNormal),
                        rng.sample(StandardNormal),
                    ];
                    if let Some(q) = Quaternion::new(v[0], v[1], v[2], v[3]).normalized() {
                        break q;
                    }
                }
            } else {
                // An exact rotation by a Gaussian rotation vector: valid for any 1σ, even tens of degrees.
                let dalpha = normal3(&mut rng).component_mul(&initial.sigma_att_rad);
                Quaternion::from_rotation_vector(&dalpha).compose(&q0)
            };
            let b = initial.bias_rad_s + normal3(&mut rng).component_mul(&initial.bias_sigma_rad_s);
            cloud.set(i, &q, &b);
        }
        let p_hat = initial.covariance_matrix();
        let diagnostics = Diagnostics {
            resamples: Some(0),
            fiducial_fallbacks: Some(0),
            ess: Some(n as f64),
            ..Diagnostics::default()
        };
        Ok(Qpf {
            fiducial: config.spec.fiducial.unwrap_or(Fiducial::Average),
            options,
            gyro: config.gyro,
            gyro_errors: config.gyro_errors,
            scratch: cloud.clone(),
            backup: cloud.clone(),
            backup_has_particles: false,
            cloud,
            log_lik: vec![0.0; n],
            heading_terms: Vec::with_capacity(16),
            resample_index: vec![0; n],
            threads: 0,
            isa: None,
            q_prop: q0,
            q_hat: q0,
            beta_hat: initial.bias_rad_s,
            p_hat,
            stale: true,
            rng,
            diagnostics,
        })
    }

    /// A filter over given weighted particles `(q, β, w)` (weights need not be normalised): restoring a
    /// checkpoint, or seeding a cloud in tests. The estimate starts at their average.
    pub fn from_particles(
        config: &FilterConfig,
        options: QpfOptions,
        particles: &[(Quaternion, Vector3<f64>, f64)],
        seed: u64,
    ) -> Result<Self, FilterError> {
        let n = particles.len();
        let first = particles
            .first()
            .ok_or_else(|| FilterError::InvalidConfig("no particles".into()))?;
        let mut cfg = config.clone();
        cfg.particles = n;
        let init = InitialState {
            t_s: None,
            q: first.0,
            sigma_att_rad: Vector3::zeros(),
            bias_rad_s: first.1,
            bias_sigma_rad_s: Vector3::zeros(),
            uniform_attitude: false,
            covariance: None,
        };
        let mut f = Qpf::new(&cfg, &init, options, seed)?;
        let total: f64 = particles.iter().map(|p| p.2).sum();
        for (i, (q, b, w)) in particles.iter().enumerate() {
            let q = q.normalized().ok_or_else(|| {
                FilterError::InvalidConfig(format!("particle {i} has no direction"))
            })?;
            if !(w.is_finite() && *w >= 0.0 && b.iter().all(|x| x.is_finite())) {
                return Err(FilterError::InvalidConfig(format!(
                    "particle {i} is not finite"
                )));
            }
            f.cloud.set(i, &q, b);
            f.cloud.w[i] = w / total;
        }
        if !(total > 0.0 && total.is_finite()) {
            return Err(FilterError::InvalidConfig(
                "particle weights sum to zero".into(),
            ));
        }
        f.scratch = f.cloud.clone();
        f.backup = f.cloud.clone();
        Ok(f)
    }

    pub fn particles(&self) -> usize {
        self.cloud.len()
    }

    /// Runs every pass on `threads` threads (0: one per core from `par::PARALLEL_FROM` particles on,
    /// the default). The estimates are the same bits whatever it is.
    pub fn set_threads(&mut self, threads: usize) {
        self.threads = threads;
    }

    /// Runs the kernels with `isa` (`None`: the detected or forced one, `Isa::active`); an
    /// unsupported one runs the portable build. For tests and benchmarks: the bits are the same.
    pub fn set_isa(&mut self, isa: Option<Isa>) {
        self.isa = isa;
    }

    fn isa(&self) -> Isa {
        self.isa.unwrap_or_else(Isa::active)
    }

    fn threads(&self) -> usize {
        match self.threads {
            0 => par::auto_threads(self.cloud.len()),
            t => t,
        }
    }

    /// The average of `sums` (sign-continuous with `reference`), or `reference` itself when the
    /// average is undecidable. Returns whether it fell back, and the concentration and gap.
    fn average_or(
        avg: Result<crate::attitude::QuaternionAverage, crate::attitude::AverageError>,
        reference: &Quaternion,
    ) -> (Quaternion, bool, Option<(f64, f64)>) {
        match avg {
            Ok(avg) => (avg.q, false, Some((avg.concentration, avg.gap))),
            Err(_) => (*reference, true, None),
        }
    }

    /// Moves the chart centre onto the current weights (the key to large initial errors): the
    /// weighted average for `average` (from the sums of the weight update), `MRP⁻¹(Σ wᵢ δpᵢ) ⊗ fid`
    /// for `propagated` (a moments pass, which also normalises the weights: `scale` becomes 1).
    fn recenter(&mut self, fid: &Quaternion, sums: &Average, scale: &mut f64) -> Quaternion {
        match self.fiducial {
            Fiducial::Average => {
                let avg = cloud::average_of(sums, self.cloud.len(), fid);
                let (q, fell_back, conc) = Self::average_or(avg, fid);
                if fell_back {
                    *self.diagnostics.fiducial_fallbacks.get_or_insert(0) += 1;
                }
                if let Some((c, g)) = conc {
                    self.diagnostics.concentration = Some(c);
                    self.diagnostics.eigen_gap = Some(g);
                }
                q
            }
            Fiducial::Propagated => {
                let mean = self.moments(fid, scale).mean;
                Grp::MRP
                    .to_quaternion(&Vector3::new(mean[0], mean[1], mean[2]))
                    .compose(fid)
            }
        }
    }

    /// The moments of `[δp; β]` about `fid`, normalising the weights (`scale`, then 1) in the pass.
    fn moments(&mut self, fid: &Quaternion, scale: &mut f64) -> Stats {
        let (isa, threads) = (self.isa(), self.threads());
        let st = self
            .cloud
            .moments_scaling(fid, &self.beta_hat, *scale, isa, threads);
        *scale = 1.0;
        st
    }
}

impl FilterCore for Qpf {
    fn spec(&self) -> FilterSpec {
        FilterSpec {
            kind: FilterKind::Qpf,
            fiducial: Some(self.fiducial),
        }
    }

    /// Samples the discrete gyro model exactly for each particle: `βᵢ' = βᵢ + σ_u √Δt N`,
    /// `ω̂ᵢ = ω̃ − ½(βᵢ + βᵢ') − (σ_v²/Δt + σ_u²Δt/12)^{½} N`, `qᵢ ← Ω(ω̂ᵢ) qᵢ`.
    fn propagate_with(
        &mut self,
        omega_meas_rad_s: &Vector3<f64>,
        dt_s: f64,
        extra_rad2: f64,
    ) -> Result<(), FilterError> {
        // A Gauss–Markov bias (GyroErrors::bias_limit_rad_s) reverts by φ per step with the same
        // stationary spread; a random walk has φ = 1.
        let phi_b = self.gyro_errors.bias_reversion(&self.gyro, dt_s);
        let su = if phi_b < 1.0 {
            let sb = self.gyro_errors.bias_limit_rad_s;
            sb * (1.0 - phi_b * phi_b).sqrt()
        } else {
            self.gyro.sigma_u * dt_s.sqrt()
        };
        // The rate-proportional noise adds (k ‖ω̂‖)² Δt of attitude variance: (k ‖ω̂‖)²/Δt of rate.
        let extra = self
            .gyro_errors
            .rate_variance(&(omega_meas_rad_s - self.beta_hat), dt_s)
            + extra_rad2;
        let sw = (self.gyro.discrete_rate_sigma(dt_s).powi(2) + extra / (dt_s * dt_s)).sqrt();
        let p = kernels::Propagation {
            phi_b,
            su,
            sw,
            omega: [
                omega_meas_rad_s[0],
                omega_meas_rad_s[1],
                omega_meas_rad_s[2],
            ],
            dt: dt_s,
        };
        let (key, isa, threads) = (self.rng.next_u64(), self.isa(), self.threads());
        let c = &mut self.cloud;
        let n = c.len();
        let view = [
            &mut c.qx[..],
            &mut c.qy,
            &mut c.qz,
            &mut c.qw,
            &mut c.bx,
            &mut c.by,
            &mut c.bz,
        ];
        par::blocks(
            threads,
            n,
            view,
            |k, [qx, qy, qz, qw, bx, by, bz]| {
                kernels::propagate(isa, key, k, &p, qx, qy, qz, qw, bx, by, bz)
            },
            |()| {},
        );
        self.q_prop = self
            .q_prop
            .propagate(&(omega_meas_rad_s - self.beta_hat), dt_s);
        self.beta_hat *= phi_b;
        self.stale = true;
        self.diagnostics.propagations += 1;
        Ok(())
    }

    fn update(&mut self, observations: &[VectorObservation]) -> Result<(), FilterError> {
        self.update_with(&Evidence::Vectors(observations))
    }

    fn update_bias(&mut self, z_rad_s: &Vector3<f64>, sigma_rad_s: f64) -> Result<(), FilterError> {
        self.update_with(&Evidence::Bias(*z_rad_s, sigma_rad_s))
    }

    fn bias_rad_s(&self) -> Vector3<f64> {
        self.beta_hat
    }

    /// Jitters every particle's attitude by an independent `N(0, cov_rad2)` body-frame rotation vector.
    fn inflate_attitude(&mut self, cov_rad2: &Matrix3<f64>) {
        if cov_rad2.amax() <= 0.0 {
            return;
        }
        // A square root of a positive semi-definite matrix (Cholesky may fail on a singular one).
        let eig = cov_rad2.symmetric_eigen();
        let l =
            eig.eigenvectors * Matrix3::from_diagonal(&eig.eigenvalues.map(|v| v.max(0.0).sqrt()));
        for i in 0..self.cloud.len() {
            let (q, b) = (self.cloud.q(i), self.cloud.beta(i));
            let dalpha = l * normal3(&mut self.rng);
            self.cloud.set(
                i,
                &Quaternion::from_rotation_vector(&dalpha).compose(&q),
                &b,
            );
        }
        self.stale = true;
    }

    fn state(driver: &Driver<Self>) -> FilterState {
        let f = driver.core();
        FilterState::Qpf(
            driver.driver_state(),
            QpfState {
                fiducial: f.fiducial,
                options: f.options,
                gyro: f.gyro,
                gyro_errors: f.gyro_errors,
                cloud: f.cloud.clone(),
                q_prop: f.q_prop,
                q_hat: f.q_hat,
                beta_hat: f.beta_hat,
                p_hat: f.p_hat,
                stale: f.stale,
                rng: f.rng.state(),
                diagnostics: f.diagnostics.clone(),
            },
        )
    }

    fn state_into(driver: &Driver<Self>, into: &mut FilterState) {
        let FilterState::Qpf(d, s) = into else {
            *into = Self::state(driver);
            return;
        };
        let f = driver.core();
        *d = driver.driver_state();
        // (Every field named: one added to the state does not compile until it is copied here.)
        let QpfState {
            fiducial,
            options,
            gyro,
            gyro_errors,
            cloud,
            q_prop,
            q_hat,
            beta_hat,
            p_hat,
            stale,
            rng,
            diagnostics,
        } = s;
        *fiducial = f.fiducial;
        *options = f.options;
        *gyro = f.gyro;
        *gyro_errors = f.gyro_errors;
        cloud.clone_from(&f.cloud);
        *q_prop = f.q_prop;
        *q_hat = f.q_hat;
        *beta_hat = f.beta_hat;
        *p_hat = f.p_hat;
        *stale = f.stale;
        *rng = f.rng.state();
        diagnostics.clone_from(&f.diagnostics);
    }

    fn estimate(&self) -> Estimate {
        let (q, bias, cov) = if self.stale {
            // Between updates: the cloud's moments about its re-centred fiducial, computed without
            // storing anything (this method does not change the filter).
            let (isa, threads) = (self.isa(), self.threads());
            let fid = match self.fiducial {
                Fiducial::Average => {
                    let avg = self.cloud.average(&self.q_prop, isa, threads);
                    Self::average_or(avg, &self.q_prop).0
                }
                Fiducial::Propagated => {
                    let mean = self
                        .cloud
                        .moments(&self.q_prop, &self.beta_hat, isa, threads)
                        .mean;
                    Grp::MRP
                        .to_quaternion(&Vector3::new(mean[0], mean[1], mean[2]))
                        .compose(&self.q_prop)
                }
            };
            let st = self.cloud.moments(&fid, &self.beta_hat, isa, threads);
            Self::estimate_from(&fid, &st.mean, &st.cov)
        } else {
            (self.q_hat, self.beta_hat, self.p_hat)
        };
        Estimate {
            t_s: 0.0,
            q: q.canonical(),
            bias_rad_s: bias,
            covariance: cov,
            diagnostics: self.diagnostics.clone(),
        }
    }
}
