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

use super::{
    Diagnostics, Driver, Estimate, Fiducial, FilterConfig, FilterCore, FilterError, FilterKind,
    FilterSpec, FilterState, GyroErrors, InitialState, QpfState,
};
use crate::attitude::quaternion::half_angle_terms;
use crate::attitude::{AverageAccumulator, Grp, Quaternion};
use crate::rng::Xoshiro256PlusPlus;
use crate::rng::{standard_normal, ziggurat};
use crate::sensors::gyro::normal3;
use crate::sensors::{imu, GyroNoise, VectorObservation};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_distr::{Beta, Distribution, StandardNormal};

/// Regularisation kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    Gaussian,
    Epanechnikov,
}

/// QPF tuning. Defaults are the values that measured well (docs/algorithms.md §3, tuning).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QpfOptions {
    pub kernel: Kernel,
    /// Scale on the optimal bandwidth `h_opt = A N^{−1/(n+4)}`; 1–2 work with the shrinkage kernel.
    pub bandwidth_scale: f64,
    /// Resample when `N_eff < resample_fraction · N`.
    pub resample_fraction: f64,
    /// Progressive correction: largest log-likelihood spread `T` applied in one stage.
    pub pc_spread: f64,
    /// Progressive correction: at most this many stages; the last applies the rest of the likelihood.
    pub pc_max_stages: u32,
    /// Relative covariance inflation per regularisation (keeps the nearly static bias cloud from
    /// collapsing; ≈ 2% made the ANEES honest).
    pub inflation: f64,
}

impl Default for QpfOptions {
    fn default() -> Self {
        QpfOptions {
            kernel: Kernel::Gaussian,
            bandwidth_scale: 1.5,
            resample_fraction: 0.5,
            pc_spread: 8.0,
            pc_max_stages: 30,
            inflation: 0.02,
        }
    }
}

impl QpfOptions {
    pub(super) fn validate(&self) -> Result<(), FilterError> {
        let bad = |what: &str| Err(FilterError::InvalidConfig(what.to_string()));
        if !(self.bandwidth_scale > 0.0 && self.bandwidth_scale.is_finite()) {
            return bad("bandwidth_scale must be positive");
        }
        if !(self.resample_fraction > 0.0 && self.resample_fraction <= 1.0) {
            return bad("resample_fraction must be in (0, 1]");
        }
        if !(self.pc_spread > 0.0) || self.pc_max_stages == 0 {
            return bad("progressive correction needs pc_spread > 0 and pc_max_stages ≥ 1");
        }
        if !(self.inflation >= 0.0 && self.inflation < 1.0) {
            return bad("inflation must be in [0, 1)");
        }
        Ok(())
    }
}

const STATE_DIM: f64 = 6.0;
/// `δα ≈ 4 δp` for the MRP.
const MRP_TO_RAD: f64 = 4.0;

impl Kernel {
    /// The optimal bandwidth `h_opt = A N^{−1/(n+4)}` for `n = 6`: Gaussian `A = (4/(n+2))^{1/(n+4)}`,
    /// Epanechnikov `A = [(8/c_n)(n+4)(2√π)ⁿ]^{1/(n+4)}` with `c_n = π³/6` the volume of the unit 6-ball.
    pub fn optimal_bandwidth(&self, n_particles: usize) -> f64 {
        let n = STATE_DIM;
        let a = match self {
            Kernel::Gaussian => (4.0 / (n + 2.0)).powf(1.0 / (n + 4.0)),
            Kernel::Epanechnikov => {
                let c_n = std::f64::consts::PI.powi(3) / 6.0;
                let two_sqrt_pi = 2.0 * std::f64::consts::PI.sqrt();
                (8.0 / c_n * (n + 4.0) * two_sqrt_pi.powf(n)).powf(1.0 / (n + 4.0))
            }
        };
        a * (n_particles.max(1) as f64).powf(-1.0 / (n + 4.0))
    }

    /// Per-axis variance of a draw of the unit kernel: 1 (Gaussian), `1/(n+4)` (Epanechnikov).
    fn unit_variance(&self) -> f64 {
        match self {
            Kernel::Gaussian => 1.0,
            Kernel::Epanechnikov => 1.0 / (STATE_DIM + 4.0),
        }
    }
}

/// The particle cloud, structure of arrays (the layout the per-particle loops vectorise over):
/// quaternion components, gyro biases (rad/s) and normalised weights (`Σ w = 1`), all of one length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cloud {
    pub qx: Vec<f64>,
    pub qy: Vec<f64>,
    pub qz: Vec<f64>,
    pub qw: Vec<f64>,
    pub bx: Vec<f64>,
    pub by: Vec<f64>,
    pub bz: Vec<f64>,
    pub w: Vec<f64>,
}

impl Cloud {
    /// A cloud read back from elsewhere (a checkpoint) is usable: two or more particles, every array
    /// of one length, finite unit quaternions and biases, non-negative weights summing to 1.
    pub fn check(&self) -> Result<(), String> {
        let n = self.w.len();
        let cols = [
            &self.qx, &self.qy, &self.qz, &self.qw, &self.bx, &self.by, &self.bz,
        ];
        if n < 2 || cols.iter().any(|c| c.len() != n) {
            return Err(format!(
                "particle cloud of inconsistent length (weights: {n})"
            ));
        }
        if !cols.iter().all(|c| c.iter().all(|v| v.is_finite())) {
            return Err("particle cloud is not finite".into());
        }
        for i in 0..n {
            let n2 =
                self.qx[i].powi(2) + self.qy[i].powi(2) + self.qz[i].powi(2) + self.qw[i].powi(2);
            if (n2 - 1.0).abs() > 1e-6 {
                return Err(format!("particle {i} is not a unit quaternion"));
            }
        }
        let sum: f64 = self.w.iter().sum();
        if !self.w.iter().all(|w| *w >= 0.0 && w.is_finite()) || (sum - 1.0).abs() > 1e-6 {
            return Err(format!("particle weights are not normalised (sum {sum})"));
        }
        Ok(())
    }

    fn with_len(n: usize) -> Self {
        let z = vec![0.0; n];
        Cloud {
            qx: z.clone(),
            qy: z.clone(),
            qz: z.clone(),
            qw: z.clone(),
            bx: z.clone(),
            by: z.clone(),
            bz: z.clone(),
            w: vec![1.0 / n as f64; n],
        }
    }

    fn len(&self) -> usize {
        self.w.len()
    }

    fn q(&self, i: usize) -> Quaternion {
        Quaternion::new(self.qx[i], self.qy[i], self.qz[i], self.qw[i])
    }

    fn beta(&self, i: usize) -> Vector3<f64> {
        Vector3::new(self.bx[i], self.by[i], self.bz[i])
    }

    fn set(&mut self, i: usize, q: &Quaternion, b: &Vector3<f64>) {
        self.qx[i] = q.x;
        self.qy[i] = q.y;
        self.qz[i] = q.z;
        self.qw[i] = q.w;
        self.bx[i] = b[0];
        self.by[i] = b[1];
        self.bz[i] = b[2];
    }

    /// Copies `other` into `self` without reallocating.
    fn copy_from(&mut self, other: &Cloud) {
        self.qx.copy_from_slice(&other.qx);
        self.qy.copy_from_slice(&other.qy);
        self.qz.copy_from_slice(&other.qz);
        self.qw.copy_from_slice(&other.qw);
        self.bx.copy_from_slice(&other.bx);
        self.by.copy_from_slice(&other.by);
        self.bz.copy_from_slice(&other.bz);
        self.w.copy_from_slice(&other.w);
    }

    fn ess(&self) -> f64 {
        1.0 / self.w.iter().map(|w| w * w).sum::<f64>()
    }

    fn average(
        &self,
        previous: &Quaternion,
    ) -> Result<crate::attitude::QuaternionAverage, crate::attitude::AverageError> {
        let mut acc = AverageAccumulator::new();
        acc.add_slices(&self.qx, &self.qy, &self.qz, &self.qw, &self.w);
        acc.finish(Some(previous))
    }
}

/// `p ⊗ q` on components (Shuster product, see `Quaternion::compose`).
#[inline(always)]
fn compose(p: [f64; 4], q: [f64; 4]) -> [f64; 4] {
    let [px, py, pz, pw] = p;
    let [qx, qy, qz, qw] = q;
    [
        pw * qx + qw * px - (py * qz - pz * qy),
        pw * qy + qw * py - (pz * qx - px * qz),
        pw * qz + qw * pz - (px * qy - py * qx),
        pw * qw - (px * qx + py * qy + pz * qz),
    ]
}

/// The MRP of `q ⊗ fid⁻¹` on components (shortest rotation: no shadow set).
#[inline(always)]
fn mrp_about(q: [f64; 4], fid_inv: [f64; 4]) -> [f64; 3] {
    let d = compose(q, fid_inv);
    let k = if d[3] < 0.0 { -1.0 } else { 1.0 };
    let f = k / (1.0 + k * d[3]);
    [d[0] * f, d[1] * f, d[2] * f]
}

/// `MRP⁻¹(p) ⊗ fid` on components: `δq = [2p; 1 − ‖p‖²]/(1 + ‖p‖²)`, unit by construction.
#[inline(always)]
fn from_mrp(p: [f64; 3], fid: [f64; 4]) -> [f64; 4] {
    let n2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    let f = 1.0 / (1.0 + n2);
    compose(
        [
            2.0 * p[0] * f,
            2.0 * p[1] * f,
            2.0 * p[2] * f,
            (1.0 - n2) * f,
        ],
        fid,
    )
}

fn components(q: &Quaternion) -> [f64; 4] {
    [q.x, q.y, q.z, q.w]
}

/// The quaternion particle filter.
#[derive(Clone, Debug)]
pub struct Qpf {
    fiducial: Fiducial,
    options: QpfOptions,
    gyro: GyroNoise,
    gyro_errors: GyroErrors,
    cloud: Cloud,
    /// Preallocated: the cloud being built by resampling, and a backup for rolling a failed update back.
    /// (Working buffers are not part of a checkpoint: they are sized again on a restore.)
    scratch: Cloud,
    backup: Cloud,
    log_lik: Vec<f64>,
    /// Per-observation constants of the current update (reused buffer).
    obs_terms: Vec<[f64; 11]>,
    resample_index: Vec<usize>,
    /// Local states `[δp; β − β_ref]` of every particle about the fiducial of the last
    /// `locals_and_moments` (reused by the regularisation that may follow).
    local: [Vec<f64>; 6],
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
            cloud: s.cloud,
            log_lik: vec![0.0; n],
            obs_terms: Vec::with_capacity(16),
            resample_index: vec![0; n],
            local: std::array::from_fn(|_| vec![0.0; n]),
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
            cloud,
            log_lik: vec![0.0; n],
            obs_terms: Vec::with_capacity(16),
            resample_index: vec![0; n],
            local: std::array::from_fn(|_| vec![0.0; n]),
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

    /// The weighted average of the cloud (sign-continuous with `reference`), or `reference` itself
    /// when the average is undecidable. Returns whether it fell back, and the concentration and gap.
    fn average_or(&self, reference: &Quaternion) -> (Quaternion, bool, Option<(f64, f64)>) {
        match self.cloud.average(reference) {
            Ok(avg) => (avg.q, false, Some((avg.concentration, avg.gap))),
            Err(_) => (*reference, true, None),
        }
    }

    /// Moves the chart centre onto the current weights (the key to large initial errors): the
    /// weighted average for `average`, `MRP⁻¹(Σ wᵢ δpᵢ) ⊗ fid` for `propagated`.
    fn recenter(&mut self, fid: &Quaternion) -> Quaternion {
        match self.fiducial {
            Fiducial::Average => {
                let (q, fell_back, conc) = self.average_or(fid);
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
                let (mean, _) = self.locals_and_moments(fid);
                Grp::MRP
                    .to_quaternion(&Vector3::new(mean[0], mean[1], mean[2]))
                    .compose(fid)
            }
        }
    }

    /// Computes every particle's local state about `fid` into `self.local` (for the regulariser that
    /// may follow) and returns the weighted mean and covariance of `[δp; β]`, in one pass.
    fn locals_and_moments(&mut self, fid: &Quaternion) -> (Vector6<f64>, Matrix6<f64>) {
        cloud_moments(&self.cloud, fid, &self.beta_hat, Some(&mut self.local))
    }

    fn log_likelihoods(&mut self, evidence: &Evidence<'_>) {
        let observations = match evidence {
            Evidence::Vectors(o) => *o,
            Evidence::Bias(z, sigma) => {
                // −½ ‖z − βᵢ‖²/σ²: a direct observation of the bias.
                let k = -0.5 / (sigma * sigma);
                let c = &self.cloud;
                for (i, out) in self.log_lik.iter_mut().enumerate() {
                    let d = [z[0] - c.bx[i], z[1] - c.by[i], z[2] - c.bz[i]];
                    *out = k * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                }
                return;
            }
        };
        // Per observation: reference, measurement and −½σ⁻², computed once (the buffer is reused).
        // A tilt-only observation has the likelihood of its full direction (gravity says nothing about
        // the heading, so the weights cannot turn the cloud about the vertical).
        self.obs_terms.clear();
        // A heading-only observation (crate::sensors::imu) holds [e₁; b; −½σ_ψ⁻²; e₂; 1]: its
        // log-likelihood is −½ψ²/σ_ψ², ψ = atan2(b·(A e₂), b·(A e₁)). One whose reference has no
        // horizontal part says nothing and is left out.
        self.obs_terms.extend(observations.iter().filter_map(|o| {
            let b = &o.body;
            match o.aspect.heading_axis() {
                None => {
                    let r = &o.reference;
                    Some([
                        r[0],
                        r[1],
                        r[2],
                        b[0],
                        b[1],
                        b[2],
                        -0.5 / (o.sigma * o.sigma),
                        0.0,
                        0.0,
                        0.0,
                        0.0,
                    ])
                }
                Some(up) => {
                    let (e1, e2, horizontal) = imu::heading_basis(&o.reference, up)?;
                    let s = imu::heading_sigma_rad(o.sigma, horizontal);
                    Some([
                        e1[0],
                        e1[1],
                        e1[2],
                        b[0],
                        b[1],
                        b[2],
                        -0.5 / (s * s),
                        e2[0],
                        e2[1],
                        e2[2],
                        1.0,
                    ])
                }
            }
        }));
        let terms = &self.obs_terms[..];
        let c = &self.cloud;
        let particles =
            c.qx.iter()
                .zip(&c.qy)
                .zip(&c.qz)
                .zip(&c.qw)
                .zip(self.log_lik.iter_mut());
        for ((((&x, &y), &z), &w), out) in particles {
            // A(q) = (w² − ϱᵀϱ) I + 2 ϱϱᵀ − 2 w [ϱ×], written out.
            let (xx, yy, zz, ww) = (x * x, y * y, z * z, w * w);
            let (xy, xz, yz, xw, yw, zw) = (x * y, x * z, y * z, x * w, y * w, z * w);
            let a = [
                ww + xx - yy - zz,
                2.0 * (xy + zw),
                2.0 * (xz - yw),
                2.0 * (xy - zw),
                ww - xx + yy - zz,
                2.0 * (yz + xw),
                2.0 * (xz + yw),
                2.0 * (yz - xw),
                ww - xx - yy + zz,
            ];
            let mut ll = 0.0;
            for t in terms {
                if t[10] != 0.0 {
                    // b·(A e₁), b·(A e₂).
                    let c = t[3] * (a[0] * t[0] + a[1] * t[1] + a[2] * t[2])
                        + t[4] * (a[3] * t[0] + a[4] * t[1] + a[5] * t[2])
                        + t[5] * (a[6] * t[0] + a[7] * t[1] + a[8] * t[2]);
                    let sn = t[3] * (a[0] * t[7] + a[1] * t[8] + a[2] * t[9])
                        + t[4] * (a[3] * t[7] + a[4] * t[8] + a[5] * t[9])
                        + t[5] * (a[6] * t[7] + a[7] * t[8] + a[8] * t[9]);
                    let psi = sn.atan2(c);
                    ll += t[6] * psi * psi;
                    continue;
                }
                let d0 = t[3] - (a[0] * t[0] + a[1] * t[1] + a[2] * t[2]);
                let d1 = t[4] - (a[3] * t[0] + a[4] * t[1] + a[5] * t[2]);
                let d2 = t[5] - (a[6] * t[0] + a[7] * t[1] + a[8] * t[2]);
                ll += t[6] * (d0 * d0 + d1 * d1 + d2 * d2);
            }
            *out = ll;
        }
    }

    /// Multiplies the weights by `L^λ` and renormalises; false when every weight vanished. The
    /// factor `exp(λ (log Lᵢ − max log L))` is at most 1 and is 1 for a live particle, so no logarithm
    /// of the weights is needed and the sum cannot vanish.
    fn apply_likelihood(&mut self, lambda: f64) -> bool {
        let mut max = f64::NEG_INFINITY;
        for (ll, w) in self.log_lik.iter().zip(&self.cloud.w) {
            if *w > 0.0 && *ll > max {
                max = *ll;
            }
        }
        if !max.is_finite() {
            return false;
        }
        let mut sum = 0.0;
        for (ll, w) in self.log_lik.iter().zip(self.cloud.w.iter_mut()) {
            *w *= (lambda * (ll - max)).exp();
            sum += *w;
        }
        if !(sum > 0.0 && sum.is_finite()) {
            return false;
        }
        let inv = 1.0 / sum;
        for w in &mut self.cloud.w {
            *w *= inv;
        }
        true
    }

    /// Systematic resampling, then the shrinkage kernel in the local space about `fid` (whose local
    /// states, mean and covariance `locals_and_moments` just computed):
    /// `xᵢ ← x̄ + s [a (x_idx(i) − x̄) + h D εᵢ]`, `a = √(1 − h_eff²)`, `D Dᵀ = S`, `s = √(1 + inflation)`,
    /// which keeps the cloud's mean in expectation and (up to the inflation) its covariance; then the
    /// cloud is shifted so that its mean is exactly `x̄`.
    fn resample_and_regularize(
        &mut self,
        fid: &Quaternion,
        mean: &Vector6<f64>,
        cov: &Matrix6<f64>,
    ) {
        let n = self.cloud.len();
        // Systematic resampling: one uniform offset, O(N).
        let step = 1.0 / n as f64;
        let mut u = self.rng.random::<f64>() * step;
        let mut cum = self.cloud.w[0];
        let mut j = 0;
        for i in 0..n {
            while u > cum && j < n - 1 {
                j += 1;
                cum += self.cloud.w[j];
            }
            self.resample_index[i] = j;
            u += step;
        }
        let d = regularization_factor(cov);
        let h = self.options.kernel.optimal_bandwidth(n) * self.options.bandwidth_scale;
        let h_eff = (h * h * self.options.kernel.unit_variance())
            .sqrt()
            .min(0.99);
        let a = (1.0 - h_eff * h_eff).sqrt();
        let h_draw = h_eff / self.options.kernel.unit_variance().sqrt();
        let s = (1.0 + self.options.inflation).sqrt();
        let fid = components(fid);
        let b_ref = self.beta_hat;
        // Local states are relative to b_ref in the bias part; so is the mean here.
        let m = [
            mean[0],
            mean[1],
            mean[2],
            mean[3] - b_ref[0],
            mean[4] - b_ref[1],
            mean[5] - b_ref[2],
        ];
        let beta = Beta::new(STATE_DIM / 2.0, 2.0).ok();
        for i in 0..n {
            let j = self.resample_index[i];
            let eps = match (self.options.kernel, &beta) {
                (Kernel::Epanechnikov, Some(b)) => epanechnikov_draw(&mut self.rng, b),
                _ => Vector6::from_fn(|_, _| standard_normal(&mut self.rng)),
            };
            let de = d * eps;
            let mut xn = [0.0; 6];
            for (r, out) in xn.iter_mut().enumerate() {
                *out = m[r] + s * (a * (self.local[r][j] - m[r]) + h_draw * de[r]);
            }
            // (The local states, kept in the scratch cloud until the mean is known.)
            let sc = &mut self.scratch;
            (sc.qx[i], sc.qy[i], sc.qz[i]) = (xn[0], xn[1], xn[2]);
            (sc.bx[i], sc.by[i], sc.bz[i]) = (xn[3], xn[4], xn[5]);
        }
        // Mean-preserving: the new cloud is shifted so that its mean in the local space is the
        // weighted mean before resampling. Which particles a resampling happens to pick moves the
        // mean at random; in a direction the observations do not see (the heading while the
        // magnetometer is rejected, the vertical bias) those moves add up to a random walk of the
        // estimate that no information caused.
        let sc = &mut self.scratch;
        let inv_n = 1.0 / n as f64;
        let mean_of = |v: &[f64]| v.iter().sum::<f64>() * inv_n;
        let shift = [
            m[0] - mean_of(&sc.qx),
            m[1] - mean_of(&sc.qy),
            m[2] - mean_of(&sc.qz),
            m[3] - mean_of(&sc.bx),
            m[4] - mean_of(&sc.by),
            m[5] - mean_of(&sc.bz),
        ];
        for i in 0..n {
            let q = from_mrp(
                [
                    sc.qx[i] + shift[0],
                    sc.qy[i] + shift[1],
                    sc.qz[i] + shift[2],
                ],
                fid,
            );
            (sc.qx[i], sc.qy[i], sc.qz[i], sc.qw[i]) = (q[0], q[1], q[2], q[3]);
            sc.bx[i] += shift[3] + b_ref[0];
            sc.by[i] += shift[4] + b_ref[1];
            sc.bz[i] += shift[5] + b_ref[2];
        }
        std::mem::swap(&mut self.cloud, &mut self.scratch);
        self.cloud.w.fill(step);
        *self.diagnostics.resamples.get_or_insert(0) += 1;
    }

    /// The estimate about the re-centred fiducial from the moments of the local states.
    fn estimate_from(
        fid: &Quaternion,
        mean: &Vector6<f64>,
        cov: &Matrix6<f64>,
    ) -> (Quaternion, Vector3<f64>, Matrix6<f64>) {
        let q = Grp::MRP
            .to_quaternion(&Vector3::new(mean[0], mean[1], mean[2]))
            .compose(fid);
        let mut j = Matrix6::identity();
        for i in 0..3 {
            j[(i, i)] = MRP_TO_RAD;
        }
        (q, Vector3::new(mean[3], mean[4], mean[5]), j * cov * j)
    }

    /// One update, rolled back on failure: the cloud and the weights are restored from a
    /// preallocated copy.
    fn update_with(&mut self, evidence: &Evidence<'_>) -> Result<(), FilterError> {
        self.backup.copy_from(&self.cloud);
        let saved = (self.q_prop, self.diagnostics.clone());
        let result = self.try_update(evidence);
        if result.is_err() {
            self.cloud.copy_from(&self.backup);
            self.q_prop = saved.0;
            self.diagnostics = saved.1;
        }
        result
    }

    fn try_update(&mut self, evidence: &Evidence<'_>) -> Result<(), FilterError> {
        // 1. The propagated estimate is the chart centre of `propagated`, and for `average` the sign
        //    reference and the fallback; the average itself is taken after the weights change (a
        //    prior-weight average would be replaced at once by the re-centring below).
        let mut fid = self.q_prop;
        // 2–3. Progressive correction with re-centring after every weight change.
        self.log_likelihoods(evidence);
        let mut remaining = 1.0;
        let mut stages = 0u32;
        loop {
            stages += 1;
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for (ll, w) in self.log_lik.iter().zip(&self.cloud.w) {
                if *w > 0.0 {
                    lo = lo.min(*ll);
                    hi = hi.max(*ll);
                }
            }
            let spread = hi - lo;
            let lambda = if stages >= self.options.pc_max_stages || !(spread > 0.0) {
                remaining
            } else {
                (self.options.pc_spread / spread).min(remaining)
            };
            if !self.apply_likelihood(lambda) {
                return Err(FilterError::WeightsVanished);
            }
            remaining -= lambda;
            fid = self.recenter(&fid);
            if remaining <= 1e-12 {
                break;
            }
            let (mean, cov) = self.locals_and_moments(&fid);
            self.resample_and_regularize(&fid, &mean, &cov);
            self.log_likelihoods(evidence);
        }
        // 4. The estimate before the final resampling.
        let (mean, cov) = self.locals_and_moments(&fid);
        let (q_hat, beta_hat, p_hat) = Self::estimate_from(&fid, &mean, &cov);
        let ess = self.cloud.ess();
        if !(q_hat.is_finite()
            && beta_hat.iter().all(|b| b.is_finite())
            && p_hat.iter().all(|x| x.is_finite()))
        {
            return Err(FilterError::NonFinite {
                step: "particle update",
            });
        }
        // 5. Resample when the effective sample size drops.
        if ess < self.options.resample_fraction * self.cloud.len() as f64 {
            self.resample_and_regularize(&fid, &mean, &cov);
        }
        self.q_hat = q_hat.canonical();
        self.q_prop = q_hat;
        self.beta_hat = beta_hat;
        self.p_hat = p_hat;
        self.stale = false;
        self.diagnostics.ess = Some(ess);
        self.diagnostics.pc_stages = Some(stages);
        self.diagnostics.updates += 1;
        Ok(())
    }
}

/// What an update weighs the particles by.
enum Evidence<'a> {
    Vectors(&'a [VectorObservation]),
    /// A direct observation of the bias and its 1σ, rad/s.
    Bias(Vector3<f64>, f64),
}

/// The weighted mean and covariance of the local states `[MRP(qᵢ ⊗ fid⁻¹); βᵢ]` in one pass, storing the
/// states in `local` when given. The bias is taken relative to `b_ref` (the current estimate) so that
/// the second moment does not cancel catastrophically.
fn cloud_moments(
    c: &Cloud,
    fid: &Quaternion,
    b_ref: &Vector3<f64>,
    mut local: Option<&mut [Vec<f64>; 6]>,
) -> (Vector6<f64>, Matrix6<f64>) {
    let fid_inv = components(&fid.inverse());
    let mut sum = [0.0f64; 6];
    let mut sq = [0.0f64; 21];
    let n = c.len();
    let (qx, qy, qz, qw, bx, by, bz, wt) = (
        &c.qx[..n],
        &c.qy[..n],
        &c.qz[..n],
        &c.qw[..n],
        &c.bx[..n],
        &c.by[..n],
        &c.bz[..n],
        &c.w[..n],
    );
    for i in 0..n {
        let p = mrp_about([qx[i], qy[i], qz[i], qw[i]], fid_inv);
        let x = [
            p[0],
            p[1],
            p[2],
            bx[i] - b_ref[0],
            by[i] - b_ref[1],
            bz[i] - b_ref[2],
        ];
        if let Some(l) = local.as_deref_mut() {
            for (r, v) in x.iter().enumerate() {
                l[r][i] = *v;
            }
        }
        let w = wt[i];
        let wx = [w * x[0], w * x[1], w * x[2], w * x[3], w * x[4], w * x[5]];
        for r in 0..6 {
            sum[r] += wx[r];
        }
        // The 21 distinct products of the upper triangle, row by row.
        let mut k = 0;
        for r in 0..6 {
            for col in r..6 {
                sq[k] += wx[r] * x[col];
                k += 1;
            }
        }
    }
    let mut mean = Vector6::from_column_slice(&sum);
    let mut cov = Matrix6::zeros();
    let mut k = 0;
    for r in 0..6 {
        for col in r..6 {
            let mut v = sq[k] - sum[r] * sum[col];
            if r == col {
                // One pass: for a collapsed cloud the difference can round below zero.
                v = v.max(0.0);
            }
            cov[(r, col)] = v;
            cov[(col, r)] = v;
            k += 1;
        }
    }
    for r in 3..6 {
        mean[r] += b_ref[r - 3];
    }
    (mean, cov)
}

/// `D` with `D Dᵀ = S`; a singular `S` (a collapsed cloud) gets a tiny relative jitter on its diagonal.
fn regularization_factor(s: &Matrix6<f64>) -> Matrix6<f64> {
    if let Some(c) = s.cholesky() {
        return c.l();
    }
    let mut j = *s;
    for i in 0..6 {
        j[(i, i)] += 1e-12 * s[(i, i)].abs() + 1e-30;
    }
    j.cholesky().map(|c| c.l()).unwrap_or_else(Matrix6::zeros)
}

/// A draw from the unit multivariate Epanechnikov kernel in 6-D: `r² ~ Beta(n/2, 2)`, uniform direction.
fn epanechnikov_draw<R: Rng>(rng: &mut R, beta: &Beta<f64>) -> Vector6<f64> {
    let dir = Vector6::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
    let n = dir.norm();
    if n == 0.0 {
        return Vector6::zeros();
    }
    let r = beta.sample(rng).sqrt();
    dir * (r / n)
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
    fn propagate(&mut self, omega_meas_rad_s: &Vector3<f64>, dt_s: f64) -> Result<(), FilterError> {
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
            .rate_variance(&(omega_meas_rad_s - self.beta_hat), dt_s);
        let sw = (self.gyro.discrete_rate_sigma(dt_s).powi(2) + extra / (dt_s * dt_s)).sqrt();
        let w_meas = [
            omega_meas_rad_s[0],
            omega_meas_rad_s[1],
            omega_meas_rad_s[2],
        ];
        let c = &mut self.cloud;
        let rng = &mut self.rng;
        let z = ziggurat();
        let particles =
            c.qx.iter_mut()
                .zip(c.qy.iter_mut())
                .zip(c.qz.iter_mut())
                .zip(c.qw.iter_mut())
                .zip(c.bx.iter_mut())
                .zip(c.by.iter_mut())
                .zip(c.bz.iter_mut());
        for ((((((qx, qy), qz), qw), bx), by), bz) in particles {
            let b0 = [*bx, *by, *bz];
            let mut b1 = [0.0; 3];
            let mut th = [0.0; 3];
            for k in 0..3 {
                let (nu, nv) = z.sample_pair(rng);
                b1[k] = phi_b * b0[k] + su * nu;
                th[k] = (w_meas[k] - 0.5 * (b0[k] + b1[k]) - sw * nv) * dt_s;
            }
            let (sf, cf) = half_angle_terms(th[0] * th[0] + th[1] * th[1] + th[2] * th[2]);
            let q = compose(
                [th[0] * sf, th[1] * sf, th[2] * sf, cf],
                [*qx, *qy, *qz, *qw],
            );
            (*qx, *qy, *qz, *qw) = (q[0], q[1], q[2], q[3]);
            (*bx, *by, *bz) = (b1[0], b1[1], b1[2]);
        }
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

    fn estimate(&self) -> Estimate {
        let (q, bias, cov) = if self.stale {
            // Between updates: the cloud's moments about its re-centred fiducial, computed without
            // storing anything (this method does not change the filter).
            let fid = match self.fiducial {
                Fiducial::Average => self.average_or(&self.q_prop).0,
                Fiducial::Propagated => {
                    let (mean, _) = cloud_moments(&self.cloud, &self.q_prop, &self.beta_hat, None);
                    Grp::MRP
                        .to_quaternion(&Vector3::new(mean[0], mean[1], mean[2]))
                        .compose(&self.q_prop)
                }
            };
            let (mean, cov) = cloud_moments(&self.cloud, &fid, &self.beta_hat, None);
            Self::estimate_from(&fid, &mean, &cov)
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
