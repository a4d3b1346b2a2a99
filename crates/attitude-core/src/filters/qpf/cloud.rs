//! The particle cloud (structure of arrays), quaternion arithmetic on its rows, and its moments in
//! the local chart.

use super::*;

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

    pub(super) fn ess(&self) -> f64 {
        1.0 / self.w.iter().map(|w| w * w).sum::<f64>()
    }

    pub(super) fn average(
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
pub(super) fn compose(p: [f64; 4], q: [f64; 4]) -> [f64; 4] {
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
pub(super) fn mrp_about(q: [f64; 4], fid_inv: [f64; 4]) -> [f64; 3] {
    let d = compose(q, fid_inv);
    let k = if d[3] < 0.0 { -1.0 } else { 1.0 };
    let f = k / (1.0 + k * d[3]);
    [d[0] * f, d[1] * f, d[2] * f]
}

/// `MRP⁻¹(p) ⊗ fid` on components: `δq = [2p; 1 − ‖p‖²]/(1 + ‖p‖²)`, unit by construction.
#[inline(always)]
pub(super) fn from_mrp(p: [f64; 3], fid: [f64; 4]) -> [f64; 4] {
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

pub(super) fn components(q: &Quaternion) -> [f64; 4] {
    [q.x, q.y, q.z, q.w]
}

/// The weighted mean and covariance of the local states `[MRP(qᵢ ⊗ fid⁻¹); βᵢ]` in one pass, storing the
/// states in `local` when given. The bias is taken relative to `b_ref` (the current estimate) so that
/// the second moment does not cancel catastrophically.
pub(super) fn cloud_moments(
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
