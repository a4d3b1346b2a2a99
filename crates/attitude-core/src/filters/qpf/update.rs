//! One update of the QPF: likelihoods (with progressive correction), resampling and regularisation,
//! the estimate from the cloud.

use super::*;

impl Qpf {
    pub(super) fn log_likelihoods(&mut self, evidence: &Evidence<'_>) {
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
    pub(super) fn apply_likelihood(&mut self, lambda: f64) -> bool {
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
    pub(super) fn resample_and_regularize(
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
    pub(super) fn estimate_from(
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
    pub(super) fn update_with(&mut self, evidence: &Evidence<'_>) -> Result<(), FilterError> {
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

    pub(super) fn try_update(&mut self, evidence: &Evidence<'_>) -> Result<(), FilterError> {
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
pub(super) enum Evidence<'a> {
    Vectors(&'a [VectorObservation]),
    /// A direct observation of the bias and its 1σ, rad/s.
    Bias(Vector3<f64>, f64),
}
