//! The particle cloud (structure of arrays), quaternion arithmetic on its rows, and its moments in
//! the local chart.

use super::*;

/// The particle cloud, structure of arrays (the layout the per-particle loops vectorise over):
/// quaternion components, gyro biases (rad/s) and normalised weights (`Σ w = 1`), all of one length.
#[derive(Debug, Default, PartialEq)]
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

impl Clone for Cloud {
    fn clone(&self) -> Self {
        let mut c = Cloud::default();
        c.clone_from(self);
        c
    }

    /// Copies into the arrays already there (a history's recycled state): no allocation when the
    /// sizes agree.
    fn clone_from(&mut self, source: &Self) {
        let Cloud {
            qx,
            qy,
            qz,
            qw,
            bx,
            by,
            bz,
            w,
        } = self;
        qx.clone_from(&source.qx);
        qy.clone_from(&source.qy);
        qz.clone_from(&source.qz);
        qw.clone_from(&source.qw);
        bx.clone_from(&source.bx);
        by.clone_from(&source.by);
        bz.clone_from(&source.bz);
        w.clone_from(&source.w);
    }
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

    pub(super) fn with_len(n: usize) -> Self {
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

    pub(super) fn len(&self) -> usize {
        self.w.len()
    }

    pub(super) fn q(&self, i: usize) -> Quaternion {
        Quaternion::new(self.qx[i], self.qy[i], self.qz[i], self.qw[i])
    }

    pub(super) fn beta(&self, i: usize) -> Vector3<f64> {
        Vector3::new(self.bx[i], self.by[i], self.bz[i])
    }

    pub(super) fn set(&mut self, i: usize, q: &Quaternion, b: &Vector3<f64>) {
        self.qx[i] = q.x;
        self.qy[i] = q.y;
        self.qz[i] = q.z;
        self.qw[i] = q.w;
        self.bx[i] = b[0];
        self.by[i] = b[1];
        self.bz[i] = b[2];
    }

    /// Copies `other` into `self` without reallocating.
    pub(super) fn copy_from(&mut self, other: &Cloud) {
        self.qx.copy_from_slice(&other.qx);
        self.qy.copy_from_slice(&other.qy);
        self.qz.copy_from_slice(&other.qz);
        self.qw.copy_from_slice(&other.qw);
        self.bx.copy_from_slice(&other.bx);
        self.by.copy_from_slice(&other.by);
        self.bz.copy_from_slice(&other.bz);
        self.w.copy_from_slice(&other.w);
    }
}

pub(super) fn components(q: &Quaternion) -> [f64; 4] {
    [q.x, q.y, q.z, q.w]
}

/// The weighted mean and covariance of the local states `[MRP(qᵢ ⊗ fid⁻¹); βᵢ]` and `Σwᵢ²`. The bias
/// is taken relative to a reference (the current estimate) so that the second moment does not cancel
/// catastrophically.
pub(super) struct Stats {
    pub mean: Vector6<f64>,
    pub cov: Matrix6<f64>,
    pub sum_w2: f64,
}

impl Stats {
    /// From a moments pass over normalised weights.
    pub(super) fn from_sums(m: &Moments, b_ref: &Vector3<f64>) -> Stats {
        let sum = &m[..6];
        let mut mean = Vector6::from_column_slice(sum);
        let mut cov = Matrix6::zeros();
        let mut k = 6;
        for r in 0..6 {
            for col in r..6 {
                let mut v = m[k] - sum[r] * sum[col];
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
        Stats {
            mean,
            cov,
            sum_w2: m[28],
        }
    }
}

/// Adds block sums in block order.
pub(super) fn add_to<const K: usize>(total: &mut [f64; K]) -> impl FnMut([f64; K]) + '_ {
    move |part| {
        for (t, p) in total.iter_mut().zip(part) {
            *t += p;
        }
    }
}

pub(super) fn local(fid: &Quaternion, b_ref: &Vector3<f64>) -> Local {
    Local {
        fid_inv: components(&fid.inverse()),
        b_ref: [b_ref[0], b_ref[1], b_ref[2]],
    }
}

impl Cloud {
    fn quaternions(&self) -> [&[f64]; 4] {
        [&self.qx, &self.qy, &self.qz, &self.qw]
    }

    fn biases(&self) -> [&[f64]; 3] {
        [&self.bx, &self.by, &self.bz]
    }

    /// The moments of the local states about `fid` (weights unchanged).
    pub(super) fn moments(
        &self,
        fid: &Quaternion,
        b_ref: &Vector3<f64>,
        isa: Isa,
        threads: usize,
    ) -> Stats {
        let c = local(fid, b_ref);
        let mut total = [0.0; 29];
        par::blocks(
            threads,
            self.len(),
            ((self.quaternions(), self.biases()), &self.w[..]),
            |_, ((q, b), w)| kernels::moments_of(isa, &c, q, b, w),
            add_to(&mut total),
        );
        Stats::from_sums(&total, b_ref)
    }

    /// The moments of the local states about `fid`, scaling the weights by `scale` first (`1/Σw`
    /// after a weight update: the normalisation costs no pass of its own).
    pub(super) fn moments_scaling(
        &mut self,
        fid: &Quaternion,
        b_ref: &Vector3<f64>,
        scale: f64,
        isa: Isa,
        threads: usize,
    ) -> Stats {
        let c = local(fid, b_ref);
        let mut total = [0.0; 29];
        let n = self.len();
        let q = [&self.qx[..], &self.qy, &self.qz, &self.qw];
        let b = [&self.bx[..], &self.by, &self.bz];
        par::blocks(
            threads,
            n,
            ((q, b), &mut self.w[..]),
            |_, ((q, b), w)| kernels::moments(isa, &c, scale, q, b, w),
            add_to(&mut total),
        );
        Stats::from_sums(&total, b_ref)
    }

    /// The weighted quaternion average (sign-continuous with `previous`).
    pub(super) fn average(
        &self,
        previous: &Quaternion,
        isa: Isa,
        threads: usize,
    ) -> Result<crate::attitude::QuaternionAverage, crate::attitude::AverageError> {
        let mut total = [0.0; 11];
        par::blocks(
            threads,
            self.len(),
            (self.quaternions(), &self.w[..]),
            |_, (q, w)| kernels::average_sums(isa, q[0], q[1], q[2], q[3], w),
            add_to(&mut total),
        );
        average_of(&total, self.len(), previous)
    }
}

/// The average from the sums of [`kernels::weigh`] or [`kernels::average_sums`].
pub(super) fn average_of(
    sums: &Average,
    n: usize,
    previous: &Quaternion,
) -> Result<crate::attitude::QuaternionAverage, crate::attitude::AverageError> {
    let m: [f64; 10] = std::array::from_fn(|k| sums[k + 1]);
    AverageAccumulator::from_sums(m, sums[0], n).finish(Some(previous))
}
