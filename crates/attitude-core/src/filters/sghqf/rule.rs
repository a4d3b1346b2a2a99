//! Smolyak sparse-grid Gauss–Hermite quadrature for a standard normal (Jia, Xin & Cheng 2011;
//! docs/algorithms.md §3, SGHQF).
//!
//! A rule is a set of points `ξᵢ ∈ Rⁿ` and weights `wᵢ` with `Σ wᵢ f(ξᵢ) ≈ E[f(ξ)]`, `ξ ~ N(0, I)`.
//! It is built from univariate Gauss–Hermite rules `U_l` (level `l ≥ 1`, `m(l)` points, exact for
//! polynomials of degree `2m − 1`) by Smolyak's combination:
//!
//! `Q_L = Σ_{L−n ≤ q ≤ L−1} (−1)^{L−1−q} C(n−1, L−1−q) Σ_{|i| = n+q} U_{i₁} ⊗ … ⊗ U_{iₙ}`, entries `iₖ ≥ 1`,
//!
//! with coincident points merged (their weights added). Level `L` integrates every polynomial of total
//! degree `≤ 2L − 1` exactly. Weights sum to one and, for `n ≥ 2` and `L ≥ 2`, some are negative:
//! the combination subtracts lower-level tensor grids.
//!
//! The filter uses [`Growth::Odd`] (`m = 2l − 1`: 1, 3, 5, 7 points): for `n = 6` it has 13, 97 and 533
//! points at `L = 2, 3, 4`, centre weights −1, −2/15 and +2/945, and the smallest `Σ|wᵢ|` of the three
//! growth rules (3, 7.93, 18.1). `L = 2` is the unscented rule with `κ = 3 − n`: the centre and
//! `±√3 eₖ` with weight 1/6.

use std::collections::BTreeMap;
use std::sync::OnceLock;
use thiserror::Error;

/// How many univariate points level `l` uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Growth {
    /// `m = l` (the rule chaospy's `sparse_grid` builds); weights large and of both signs.
    Linear,
    /// `m = 2l − 1`: odd rules, all sharing the centre (the filter's).
    Odd,
    /// `m = 2ˡ − 1` (Bin Jia's code, "manner 3").
    Doubling,
}

impl Growth {
    /// The univariate point count of level `l ≥ 1`.
    pub fn points(self, l: usize) -> usize {
        match self {
            Growth::Linear => l,
            Growth::Odd => 2 * l - 1,
            Growth::Doubling => (1usize << l) - 1,
        }
    }
}

/// Why a rule cannot be built.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum RuleError {
    #[error("sparse-grid rule: dimension {dim} and level {level} must be at least 1")]
    TooSmall { dim: usize, level: usize },
    #[error("sparse-grid rule: dimension {dim} at level {level} is beyond the sizes built here (dimension ≤ 12, level ≤ 6)")]
    TooLarge { dim: usize, level: usize },
}

/// Points and weights of a quadrature rule for `N(0, I)` in `dim` dimensions.
#[derive(Clone, Debug, PartialEq)]
pub struct Rule {
    pub dim: usize,
    pub level: usize,
    pub growth: Growth,
    /// Point `i` is `nodes[i·dim .. (i+1)·dim]`; the centre (all zeros), when present, is point 0.
    pub nodes: Vec<f64>,
    pub weights: Vec<f64>,
}

impl Rule {
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    pub fn point(&self, i: usize) -> &[f64] {
        &self.nodes[i * self.dim..(i + 1) * self.dim]
    }

    /// Total degree integrated exactly: `2L − 1`.
    pub fn degree(&self) -> usize {
        2 * self.level - 1
    }

    /// `Σ wᵢ f(ξᵢ)`.
    pub fn integrate(&self, f: impl Fn(&[f64]) -> f64) -> f64 {
        (0..self.len())
            .map(|i| self.weights[i] * f(self.point(i)))
            .sum()
    }
}

/// The univariate Gauss–Hermite rule of `m ≥ 1` points for a standard normal (nodes ascending, weights
/// summing to one). Golub–Welsch eigenvalues as starting values, then Newton on the orthonormal
/// Hermite polynomials and the Christoffel weights `1/Σ_{k<m} pₖ(x)²`, which are accurate to rounding
/// where eigenvector components lose relative accuracy in the small tail weights. The rule is made
/// exactly symmetric (`x_{m−1−j} = −x_j`, a centre of exactly 0), which the fiducial's symmetry
/// argument relies on.
pub fn gauss_hermite(m: usize) -> (Vec<f64>, Vec<f64>) {
    if m == 0 {
        return (Vec::new(), Vec::new());
    }
    // Jacobi matrix of the probabilists' Hermite polynomials: zero diagonal, √k off the diagonal.
    let jacobi = nalgebra::DMatrix::from_fn(m, m, |r, c| {
        if r + 1 == c || c + 1 == r {
            (r.max(c) as f64).sqrt()
        } else {
            0.0
        }
    });
    let mut x: Vec<f64> = jacobi.symmetric_eigenvalues().iter().copied().collect();
    x.sort_by(f64::total_cmp);
    let mut w = vec![0.0; m];
    for (xi, wi) in x.iter_mut().zip(w.iter_mut()) {
        for _ in 0..100 {
            let (pm, pm1, _) = orthonormal_hermite(m, *xi);
            let step = pm / ((m as f64).sqrt() * pm1);
            *xi -= step;
            if !(step.abs() > 1e-16 * xi.abs().max(1.0)) {
                break;
            }
        }
        let (_, _, sum_sq) = orthonormal_hermite(m, *xi);
        *wi = 1.0 / sum_sq;
    }
    for j in 0..m / 2 {
        let (a, b) = (0.5 * (x[m - 1 - j] - x[j]), 0.5 * (w[j] + w[m - 1 - j]));
        x[j] = -a;
        x[m - 1 - j] = a;
        w[j] = b;
        w[m - 1 - j] = b;
    }
    if m % 2 == 1 {
        x[m / 2] = 0.0;
    }
    let total: f64 = w.iter().sum();
    w.iter_mut().for_each(|v| *v /= total);
    (x, w)
}

/// `(p_m(x), p_{m−1}(x), Σ_{k<m} pₖ(x)²)` of the orthonormal Hermite polynomials `pₖ = Heₖ/√k!`
/// (`p_{k+1} = (x pₖ − √k p_{k−1})/√(k+1)`).
fn orthonormal_hermite(m: usize, x: f64) -> (f64, f64, f64) {
    let (mut prev, mut cur, mut sum_sq) = (0.0, 1.0, 0.0);
    for k in 0..m {
        sum_sq += cur * cur;
        let next = (x * cur - (k as f64).sqrt() * prev) / ((k + 1) as f64).sqrt();
        prev = cur;
        cur = next;
    }
    (cur, prev, sum_sq)
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, j| acc * (n - j) as f64 / (j + 1) as f64)
}

/// Weights whose magnitude falls below this after merging are cancellations to rounding, not points.
pub const MERGED_ZERO: f64 = 1e-13;

/// The Smolyak sparse-grid rule of `level` in `dim` dimensions.
pub fn smolyak(dim: usize, level: usize, growth: Growth) -> Result<Rule, RuleError> {
    if dim == 0 || level == 0 {
        return Err(RuleError::TooSmall { dim, level });
    }
    if dim > 12 || level > 6 {
        return Err(RuleError::TooLarge { dim, level });
    }
    let univariate: Vec<(Vec<f64>, Vec<f64>)> = (1..=level)
        .map(|l| gauss_hermite(growth.points(l)))
        .collect();
    // Coincident points are found by their nodes rounded to 1e-12 (distinct Gauss–Hermite nodes of
    // these sizes are at least 0.1 apart; the shared centre is exactly 0).
    let key_of = |x: f64| (x * 1e12).round() as i64;
    let mut merged: BTreeMap<Vec<i64>, (Vec<f64>, f64)> = BTreeMap::new();
    let mut index = vec![1usize; dim];
    loop {
        let total: usize = index.iter().sum();
        if total >= level.max(dim) && total < level + dim {
            let q = total - dim;
            let k = level - 1 - q;
            let coeff = if k.is_multiple_of(2) { 1.0 } else { -1.0 } * binomial(dim - 1, k);
            add_tensor(&univariate, &index, coeff, &key_of, &mut merged);
        }
        // Next index vector in [1, level]^dim (odometer), skipping sums that cannot qualify.
        let mut d = 0;
        loop {
            if d == dim {
                return Ok(finish(dim, level, growth, merged));
            }
            index[d] += 1;
            if index[d] <= level && index.iter().sum::<usize>() < level + dim {
                break;
            }
            index[d] = 1;
            d += 1;
        }
    }
}

fn add_tensor(
    univariate: &[(Vec<f64>, Vec<f64>)],
    index: &[usize],
    coeff: f64,
    key_of: &dyn Fn(f64) -> i64,
    merged: &mut BTreeMap<Vec<i64>, (Vec<f64>, f64)>,
) {
    let rules: Vec<&(Vec<f64>, Vec<f64>)> = index.iter().map(|&l| &univariate[l - 1]).collect();
    let mut j = vec![0usize; index.len()];
    loop {
        let point: Vec<f64> = rules.iter().zip(&j).map(|(r, &jk)| r.0[jk]).collect();
        let w: f64 = rules.iter().zip(&j).map(|(r, &jk)| r.1[jk]).product();
        let key: Vec<i64> = point.iter().map(|&x| key_of(x)).collect();
        merged.entry(key).or_insert((point, 0.0)).1 += coeff * w;
        let mut d = 0;
        loop {
            if d == j.len() {
                return;
            }
            j[d] += 1;
            if j[d] < rules[d].0.len() {
                break;
            }
            j[d] = 0;
            d += 1;
        }
    }
}

fn finish(
    dim: usize,
    level: usize,
    growth: Growth,
    merged: BTreeMap<Vec<i64>, (Vec<f64>, f64)>,
) -> Rule {
    let mut entries: Vec<(Vec<f64>, f64)> = merged
        .into_values()
        .filter(|(_, w)| w.abs() > MERGED_ZERO)
        .collect();
    // The centre first (the filter's central point), the rest in the map's (key) order.
    if let Some(c) = entries
        .iter()
        .position(|(p, _)| p.iter().all(|&x| x == 0.0))
    {
        let centre = entries.remove(c);
        entries.insert(0, centre);
    }
    Rule {
        dim,
        level,
        growth,
        nodes: entries
            .iter()
            .flat_map(|(p, _)| p.iter().copied())
            .collect(),
        weights: entries.iter().map(|(_, w)| *w).collect(),
    }
}

/// Dimension of the filter's state `[δp; β]`.
pub const STATE_DIM: usize = 6;
/// The accuracy levels the filter offers.
pub const LEVELS: std::ops::RangeInclusive<u8> = 2..=4;

/// The filter's rule for `level` (6-D, [`Growth::Odd`]), built once per process.
pub fn standard(level: u8) -> Option<&'static Rule> {
    static RULES: OnceLock<Vec<Rule>> = OnceLock::new();
    if !LEVELS.contains(&level) {
        return None;
    }
    // (Levels 2..=4 in 6-D are within `smolyak`'s sizes: every one is built.)
    let rules = RULES.get_or_init(|| {
        LEVELS
            .filter_map(|l| smolyak(STATE_DIM, l as usize, Growth::Odd).ok())
            .collect()
    });
    rules.get((level - LEVELS.start()) as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `E[∏ ξₖ^{eₖ}]` for a standard normal: `∏ (eₖ − 1)!!` when every exponent is even, else 0.
    fn normal_moment(e: &[usize]) -> f64 {
        e.iter()
            .map(|&k| {
                if k % 2 == 1 {
                    0.0
                } else {
                    (1..k).step_by(2).map(|j| j as f64).product::<f64>()
                }
            })
            .product()
    }

    /// Every exponent vector of total degree ≤ `max` in `dim` dimensions.
    fn exponents(dim: usize, max: usize) -> Vec<Vec<usize>> {
        let mut out = vec![vec![]];
        for _ in 0..dim {
            out = out
                .into_iter()
                .flat_map(|e: Vec<usize>| {
                    let used: usize = e.iter().sum();
                    (0..=max - used).map(move |k| {
                        let mut e = e.clone();
                        e.push(k);
                        e
                    })
                })
                .collect();
        }
        out
    }

    fn monomial(x: &[f64], e: &[usize]) -> f64 {
        x.iter().zip(e).map(|(v, &k)| v.powi(k as i32)).product()
    }

    #[test]
    fn univariate_rules_are_exact_to_degree_2m_minus_1() {
        for m in 1..=15 {
            let (x, w) = gauss_hermite(m);
            for deg in 0..=(2 * m - 1) {
                let terms = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32));
                let got: f64 = terms.clone().sum();
                // Rounding is relative to the terms summed (odd moments cancel to it).
                let scale: f64 = terms.map(f64::abs).sum();
                let want = normal_moment(&[deg]);
                assert!(
                    (got - want).abs() <= 1e-13 * scale.max(1.0),
                    "m = {m}, degree {deg}: {got} vs {want}"
                );
            }
        }
        // Known values: 3 points ±√3 (1/6) and 0 (2/3).
        let (x, w) = gauss_hermite(3);
        assert_eq!(x[1], 0.0);
        assert!((x[2] - 3f64.sqrt()).abs() < 1e-15 && (w[0] - 1.0 / 6.0).abs() < 1e-15);
    }

    #[test]
    fn six_dimensional_rules_have_the_documented_sizes_and_centre_weights() {
        for (level, count, centre) in [(2, 13, -1.0), (3, 97, -2.0 / 15.0), (4, 533, 2.0 / 945.0)] {
            let r = standard(level).unwrap();
            assert_eq!(r.len(), count, "level {level}");
            assert!(r.point(0).iter().all(|&x| x == 0.0));
            assert!((r.weights[0] - centre).abs() < 1e-12, "{}", r.weights[0]);
            assert!((r.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(r.weights.iter().any(|&w| w < 0.0));
        }
        assert!(standard(1).is_none() && standard(5).is_none());
    }

    #[test]
    fn every_monomial_up_to_the_degree_is_exact_and_the_next_is_not() {
        for growth in [Growth::Linear, Growth::Odd, Growth::Doubling] {
            for level in 1..=4 {
                let r = smolyak(6, level, growth).unwrap();
                let deg = r.degree();
                for e in exponents(6, deg) {
                    let got = r.integrate(|x| monomial(x, &e));
                    // Rounding is relative to the terms summed (Σ |wᵢ ξᵢ^e|), at least 1.
                    let scale = (0..r.len())
                        .map(|i| (r.weights[i] * monomial(r.point(i), &e)).abs())
                        .sum::<f64>()
                        .max(1.0);
                    let want = normal_moment(&e);
                    assert!(
                        (got - want).abs() <= 1e-13 * scale,
                        "{growth:?} L = {level}, exponents {e:?}: {got} vs {want}"
                    );
                }
                // The first failure: ξ₁²⋯ξ_L² (degree 2L) is not integrated exactly.
                let e: Vec<usize> = (0..6).map(|k| if k < level { 2 } else { 0 }).collect();
                let got = r.integrate(|x| monomial(x, &e));
                assert!((got - 1.0).abs() > 1e-3, "{growth:?} L = {level}: {got}");
            }
        }
    }

    #[test]
    fn level_two_is_the_unscented_rule_with_kappa_3_minus_n() {
        let r = standard(2).unwrap();
        for i in 1..r.len() {
            let p = r.point(i);
            let nonzero: Vec<f64> = p.iter().copied().filter(|&x| x != 0.0).collect();
            assert_eq!(nonzero.len(), 1);
            assert!((nonzero[0].abs() - 3f64.sqrt()).abs() < 1e-14);
            assert!((r.weights[i] - 1.0 / 6.0).abs() < 1e-14);
        }
    }

    #[test]
    fn rules_are_centrally_symmetric() {
        for level in LEVELS {
            let r = standard(level).unwrap();
            for i in 0..r.len() {
                let neg: Vec<f64> = r.point(i).iter().map(|x| -x).collect();
                let j = (0..r.len())
                    .find(|&j| r.point(j).iter().zip(&neg).all(|(a, b)| a == b))
                    .unwrap_or_else(|| panic!("L = {level}: no mirror of point {i}"));
                assert_eq!(r.weights[i], r.weights[j]);
            }
        }
    }
}
