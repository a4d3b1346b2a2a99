//! Vector-observation sensor models for the simulator: a star camera over a synthetic catalogue, a sun
//! sensor and a three-axis magnetometer (docs/algorithms.md §2: `b̃ = A(q) r + v`,
//! `v ~ N(0, σ² I₃)`, never renormalised).
//!
//! Numeric core: no I/O and no panics on any input (non-finite inputs give non-finite or empty outputs).

use std::fmt;
use std::sync::Arc;

use crate::rng::Xoshiro256PlusPlus;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};

use super::gyro::normal3;
use super::{Aspect, VectorObservation};
use crate::attitude::Quaternion;

const DEG: f64 = std::f64::consts::PI / 180.0;
const ARCSEC: f64 = DEG / 3600.0;

/// The catalogue size for which about 8 stars fall in a 4° half-angle cone:
/// `N ≈ 8 / ((1 − cos 4°)/2) ≈ 6570` (the cone covers the fraction `(1 − cos α)/2` of the sphere).
pub const DEFAULT_CATALOGUE_SIZE: usize = 6570;

/// The seed of the catalogue used by the standard scenarios.
pub const DEFAULT_CATALOGUE_SEED: u64 = 0x5EED_57A5;

/// The jitter of [`StarCatalogue::synthetic`], as a fraction of the mean lattice spacing `√(4π/N)`.
/// Small enough that every 4° cone still holds at least 3 stars of the default catalogue: over 10⁶ random
/// boresights the count ranges from 4 to 12 (mean 8.0; 6 to 9 in 97 % of cases) before the camera's cap
/// of 10; the unjittered lattice gives 5 to 11.
pub const DEFAULT_JITTER_FRACTION: f64 = 0.25;

/// A deterministic synthetic star catalogue: unit vectors in the reference frame on a Fibonacci-sphere
/// lattice, optionally displaced by a small seeded jitter.
///
/// The stars are kept sorted by their reference-frame `z` so that a cone search only scans the band of
/// declinations the cone can reach.
#[derive(Clone, PartialEq)]
pub struct StarCatalogue {
    /// Unit vectors, reference frame, sorted by ascending `z`.
    stars: Vec<Vector3<f64>>,
    seed: u64,
    jitter_fraction: f64,
}

impl fmt::Debug for StarCatalogue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("StarCatalogue")
            .field("n_stars", &self.stars.len())
            .field("seed", &self.seed)
            .field("jitter_fraction", &self.jitter_fraction)
            .finish()
    }
}

impl Default for StarCatalogue {
    fn default() -> Self {
        StarCatalogue::synthetic(DEFAULT_CATALOGUE_SIZE, DEFAULT_CATALOGUE_SEED)
    }
}

impl StarCatalogue {
    /// The plain Fibonacci lattice of `n_stars` points (no jitter):
    /// `z_i = 1 − (2i + 1)/N`, longitude `i · π(3 − √5)`.
    pub fn fibonacci(n_stars: usize) -> Self {
        StarCatalogue::with_jitter(n_stars, 0, 0.0)
    }

    /// The Fibonacci lattice of `n_stars` points, each moved by a seeded random jitter of up to
    /// [`DEFAULT_JITTER_FRACTION`] of the mean lattice spacing (uniform over a small disc). The same
    /// `(n_stars, seed)` always gives the same catalogue.
    pub fn synthetic(n_stars: usize, seed: u64) -> Self {
        StarCatalogue::with_jitter(n_stars, seed, DEFAULT_JITTER_FRACTION)
    }

    /// As [`StarCatalogue::synthetic`] with a chosen jitter (a fraction of the mean lattice spacing
    /// `√(4π/N)` rad; zero, negative or non-finite means no jitter).
    pub fn with_jitter(n_stars: usize, seed: u64, jitter_fraction: f64) -> Self {
        let jitter_fraction = if jitter_fraction.is_finite() && jitter_fraction > 0.0 {
            jitter_fraction
        } else {
            0.0
        };
        let n = n_stars as f64;
        let golden_angle = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let spacing = if n_stars > 0 {
            (4.0 * std::f64::consts::PI / n).sqrt()
        } else {
            0.0
        };
        let max_jitter = jitter_fraction * spacing;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut stars = Vec::with_capacity(n_stars);
        for i in 0..n_stars {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n;
            let rho = (1.0 - z * z).max(0.0).sqrt();
            let lon = golden_angle * i as f64;
            let p = Vector3::new(rho * lon.cos(), rho * lon.sin(), z);
            let p = if max_jitter > 0.0 {
                // Uniform over a disc of angular radius `max_jitter` about p.
                let a = max_jitter * rng.random::<f64>().sqrt();
                let phi = 2.0 * std::f64::consts::PI * rng.random::<f64>();
                let (e1, e2) = tangent_basis(&p);
                let d = e1 * phi.cos() + e2 * phi.sin();
                let moved = p * a.cos() + d * a.sin();
                let norm = moved.norm();
                if norm > 0.0 {
                    moved / norm
                } else {
                    p
                }
            } else {
                p
            };
            stars.push(p);
        }
        stars.sort_by(|a, b| a[2].total_cmp(&b[2]));
        StarCatalogue {
            stars,
            seed,
            jitter_fraction,
        }
    }

    /// Every star, unit vectors in the reference frame (sorted by ascending `z`).
    pub fn stars(&self) -> &[Vector3<f64>] {
        &self.stars
    }

    pub fn len(&self) -> usize {
        self.stars.len()
    }

    pub fn is_empty(&self) -> bool {
        self.stars.is_empty()
    }

    /// The seed the jitter was drawn with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The jitter, as a fraction of the mean lattice spacing.
    pub fn jitter_fraction(&self) -> f64 {
        self.jitter_fraction
    }

    /// The stars within `half_angle_rad` of `boresight_ref` (reference frame, any non-zero length),
    /// nearest to the boresight first, at most `max`. Empty for a zero or non-finite boresight or a
    /// negative or NaN half angle.
    pub fn stars_in_cone(
        &self,
        boresight_ref: &Vector3<f64>,
        half_angle_rad: f64,
        max: usize,
    ) -> Vec<Vector3<f64>> {
        let norm = boresight_ref.norm();
        if max == 0
            || !norm.is_finite()
            || norm <= 0.0
            || half_angle_rad.is_nan()
            || half_angle_rad < 0.0
        {
            return Vec::new();
        }
        let b = boresight_ref / norm;
        let alpha = half_angle_rad.min(std::f64::consts::PI);
        let cos_alpha = alpha.cos();
        // Colatitude of the boresight; the cone reaches colatitudes [θ − α, θ + α].
        let theta = b[2].clamp(-1.0, 1.0).acos();
        let z_max = (theta - alpha).max(0.0).cos();
        let z_min = (theta + alpha).min(std::f64::consts::PI).cos();
        // Small margin for rounding in the band limits; the dot-product test is exact.
        let lo = self.stars.partition_point(|s| s[2] < z_min - 1e-12);
        let hi = self.stars.partition_point(|s| s[2] <= z_max + 1e-12);
        let mut found: Vec<(f64, Vector3<f64>)> = self.stars[lo..hi.max(lo)]
            .iter()
            .filter_map(|s| {
                let c = s.dot(&b);
                (c >= cos_alpha).then_some((c, *s))
            })
            .collect();
        found.sort_by(|x, y| y.0.total_cmp(&x.0));
        found.truncate(max);
        found.into_iter().map(|(_, s)| s).collect()
    }
}

/// Two unit vectors completing `p` (unit) to a right-handed orthonormal triad.
fn tangent_basis(p: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    // Cross with the coordinate axis least aligned with p.
    let axis = if p[0].abs() <= p[1].abs() && p[0].abs() <= p[2].abs() {
        Vector3::x()
    } else if p[1].abs() <= p[2].abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let e1 = p.cross(&axis);
    let n = e1.norm();
    let e1 = if n > 0.0 { e1 / n } else { Vector3::x() };
    let e2 = p.cross(&e1);
    (e1, e2)
}

/// A star camera: every catalogue star within `half_angle_rad` of the boresight (at most `max_stars`,
/// nearest first) gives one unit-vector observation `b̃ = A(q) r + σ N(0, I₃)` (not renormalised), named
/// `"st1"`.
#[derive(Clone, Debug, PartialEq)]
pub struct StarCamera {
    /// Boresight, body frame (default `+z`).
    pub boresight_body: Vector3<f64>,
    /// Field-of-view half angle, rad (default 4°).
    pub half_angle_rad: f64,
    /// At most this many stars per frame (default 10).
    pub max_stars: usize,
    /// Per-axis 1σ noise, rad (default 6 arcsec).
    pub sigma_rad: f64,
    /// The catalogue (shared: cloning the camera does not copy it).
    pub catalogue: Arc<StarCatalogue>,
}

impl Default for StarCamera {
    fn default() -> Self {
        StarCamera::new(Arc::new(StarCatalogue::default()))
    }
}

impl StarCamera {
    /// The sensor name written into every observation.
    pub const SENSOR_NAME: &'static str = "st1";

    /// The default camera (+z boresight, 4° half angle, ≤ 10 stars, σ = 6″) over `catalogue`.
    pub fn new(catalogue: Arc<StarCatalogue>) -> Self {
        StarCamera {
            boresight_body: Vector3::z(),
            half_angle_rad: 4.0 * DEG,
            max_stars: 10,
            sigma_rad: 6.0 * ARCSEC,
            catalogue,
        }
    }

    /// The stars (reference frame) in the field of view at the true attitude, nearest first.
    pub fn visible_stars(&self, q_true: &Quaternion) -> Vec<Vector3<f64>> {
        let boresight_ref = q_true.attitude_matrix().transpose() * self.boresight_body;
        self.catalogue
            .stars_in_cone(&boresight_ref, self.half_angle_rad, self.max_stars)
    }

    /// One frame: an observation per visible star.
    pub fn observe<R: Rng + ?Sized>(
        &self,
        q_true: &Quaternion,
        rng: &mut R,
    ) -> Vec<VectorObservation> {
        let a = q_true.attitude_matrix();
        self.visible_stars(q_true)
            .into_iter()
            .map(|r| VectorObservation {
                body: a * r + normal3(rng) * self.sigma_rad,
                reference: r,
                sigma: self.sigma_rad,
                sensor: Some(Self::SENSOR_NAME.to_string()),
                aspect: Aspect::Full,
            })
            .collect()
    }
}

/// A sun sensor: the sun direction (unit vector) with per-axis noise `σ` rad, when the sun is within
/// `fov_half_angle_rad` of the boresight. Named `"sun"`. Eclipses are not modelled.
#[derive(Clone, Debug, PartialEq)]
pub struct SunSensor {
    /// Per-axis 1σ noise, rad (default 0.05°).
    pub sigma_rad: f64,
    /// Field-of-view half angle, rad (default π: the sun is always seen).
    pub fov_half_angle_rad: f64,
    /// Boresight, body frame (default `−z`: zenith in the LVLH attitude). Irrelevant with the default
    /// field of view.
    pub boresight_body: Vector3<f64>,
}

impl Default for SunSensor {
    fn default() -> Self {
        SunSensor {
            sigma_rad: 0.05 * DEG,
            fov_half_angle_rad: std::f64::consts::PI,
            boresight_body: Vector3::new(0.0, 0.0, -1.0),
        }
    }
}

impl SunSensor {
    pub const SENSOR_NAME: &'static str = "sun";

    /// Observes the sun direction `sun_ref` (reference frame; normalised here). `None` when the sun is
    /// outside the field of view or `sun_ref` is zero or not finite.
    pub fn observe<R: Rng + ?Sized>(
        &self,
        q_true: &Quaternion,
        sun_ref_unit: &Vector3<f64>,
        rng: &mut R,
    ) -> Option<VectorObservation> {
        let n = sun_ref_unit.norm();
        if !n.is_finite() || n <= 0.0 {
            return None;
        }
        let r = sun_ref_unit / n;
        let b = q_true.attitude_matrix() * r;
        // A field of view of π or more sees the whole sky; a NaN one sees nothing.
        if self.fov_half_angle_rad.is_nan() || self.fov_half_angle_rad < std::f64::consts::PI {
            let bn = self.boresight_body.norm();
            if !bn.is_finite() || bn <= 0.0 {
                return None;
            }
            let cos_angle = b.dot(&self.boresight_body) / (bn * b.norm());
            let cos_limit = self.fov_half_angle_rad.cos();
            // A non-finite attitude sees nothing.
            if cos_angle.is_nan() || cos_limit.is_nan() || cos_angle < cos_limit {
                return None;
            }
        }
        Some(VectorObservation {
            body: b + normal3(rng) * self.sigma_rad,
            reference: r,
            sigma: self.sigma_rad,
            sensor: Some(Self::SENSOR_NAME.to_string()),
            aspect: Aspect::Full,
        })
    }
}

/// A three-axis magnetometer: `b̃ = A(q) B + σ N(0, I₃)` in nT, named `"mag"`. The reference vector is the
/// modelled field in nT (never normalised).
#[derive(Clone, Debug, PartialEq)]
pub struct MagnetometerModel {
    /// Per-axis 1σ noise, nT (default 50).
    pub sigma_nt: f64,
}

impl Default for MagnetometerModel {
    fn default() -> Self {
        MagnetometerModel { sigma_nt: 50.0 }
    }
}

impl MagnetometerModel {
    pub const SENSOR_NAME: &'static str = "mag";

    /// Observes the field `field_ref_nt` (reference frame, nT).
    pub fn observe<R: Rng + ?Sized>(
        &self,
        q_true: &Quaternion,
        field_ref_nt: &Vector3<f64>,
        rng: &mut R,
    ) -> VectorObservation {
        VectorObservation {
            body: q_true.attitude_matrix() * field_ref_nt + normal3(rng) * self.sigma_nt,
            reference: *field_ref_nt,
            sigma: self.sigma_nt,
            sensor: Some(Self::SENSOR_NAME.to_string()),
            aspect: Aspect::Full,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_quaternion(rng: &mut Xoshiro256PlusPlus) -> Quaternion {
        loop {
            let v = normal3(rng);
            let w: f64 = rng.sample(rand_distr::StandardNormal);
            if let Some(q) = Quaternion::new(v[0], v[1], v[2], w).normalized() {
                return q;
            }
        }
    }

    #[test]
    fn catalogue_is_deterministic_unit_and_seed_dependent() {
        let a = StarCatalogue::synthetic(DEFAULT_CATALOGUE_SIZE, 7);
        let b = StarCatalogue::synthetic(DEFAULT_CATALOGUE_SIZE, 7);
        let c = StarCatalogue::synthetic(DEFAULT_CATALOGUE_SIZE, 8);
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_eq!(a.len(), DEFAULT_CATALOGUE_SIZE);
        for s in a.stars() {
            assert!((s.norm() - 1.0).abs() < 1e-12);
        }
        assert!(a.stars().windows(2).all(|w| w[0][2] <= w[1][2]));
        // The plain lattice is deterministic too and its mean is near the origin.
        let f = StarCatalogue::fibonacci(1000);
        let mean: Vector3<f64> = f.stars().iter().sum::<Vector3<f64>>() / 1000.0;
        assert!(mean.norm() < 1e-2);
    }

    #[test]
    fn cone_search_matches_brute_force() {
        let cat = StarCatalogue::default();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
        for _ in 0..500 {
            let b = normal3(&mut rng).normalize();
            let alpha = 4.0 * DEG;
            let fast = cat.stars_in_cone(&b, alpha, usize::MAX);
            let mut brute: Vec<Vector3<f64>> = cat
                .stars()
                .iter()
                .filter(|s| s.dot(&b) >= alpha.cos())
                .copied()
                .collect();
            brute.sort_by(|x, y| y.dot(&b).total_cmp(&x.dot(&b)));
            assert_eq!(fast, brute);
            let capped = cat.stars_in_cone(&b, alpha, 3);
            assert_eq!(capped.as_slice(), &brute[..brute.len().min(3)]);
        }
        // The poles (band limits at the ends of the sorted list).
        for b in [Vector3::z(), -Vector3::z()] {
            let n = cat.stars_in_cone(&b, 4.0 * DEG, usize::MAX).len();
            let brute = cat
                .stars()
                .iter()
                .filter(|s| s.dot(&b) >= (4.0 * DEG).cos())
                .count();
            assert_eq!(n, brute);
            assert!(n >= 3);
        }
        // Whole sky.
        assert_eq!(
            cat.stars_in_cone(&Vector3::x(), 4.0, usize::MAX).len(),
            cat.len()
        );
    }

    #[test]
    fn cone_search_never_panics_on_bad_input() {
        let cat = StarCatalogue::default();
        let nan = Vector3::new(f64::NAN, 0.0, 1.0);
        assert!(cat.stars_in_cone(&nan, 0.1, 10).is_empty());
        assert!(cat.stars_in_cone(&Vector3::zeros(), 0.1, 10).is_empty());
        assert!(cat.stars_in_cone(&Vector3::z(), f64::NAN, 10).is_empty());
        assert!(cat.stars_in_cone(&Vector3::z(), -1.0, 10).is_empty());
        assert!(cat.stars_in_cone(&Vector3::z(), 0.1, 0).is_empty());
        let inf = Vector3::new(f64::INFINITY, 0.0, 0.0);
        assert!(cat.stars_in_cone(&inf, 0.1, 10).is_empty());
        assert_eq!(StarCatalogue::synthetic(0, 1).len(), 0);
        assert!(StarCatalogue::synthetic(0, 1)
            .stars_in_cone(&Vector3::z(), 0.1, 10)
            .is_empty());
        assert_eq!(StarCatalogue::synthetic(1, 1).len(), 1);
        let cam = StarCamera::default();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let bad = Quaternion::new(f64::NAN, 0.0, 0.0, 1.0);
        assert!(cam.observe(&bad, &mut rng).is_empty());
        let sun = SunSensor {
            fov_half_angle_rad: 0.5,
            ..SunSensor::default()
        };
        assert!(sun.observe(&bad, &Vector3::x(), &mut rng).is_none());
        assert!(sun
            .observe(&Quaternion::IDENTITY, &Vector3::zeros(), &mut rng)
            .is_none());
    }

    #[test]
    fn star_camera_sees_between_3_and_10_stars_at_any_attitude() {
        let cam = StarCamera::default();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
        let (mut min, mut max, mut total) = (usize::MAX, 0, 0usize);
        let trials = 200_000;
        for _ in 0..trials {
            let q = random_quaternion(&mut rng);
            let n = cam.visible_stars(&q).len();
            min = min.min(n);
            max = max.max(n);
            total += n;
        }
        assert!(min >= 3, "min {min}");
        assert!(max <= 10);
        let mean = total as f64 / trials as f64;
        // About 8 on average (the cap at 10 trims the upper tail a little).
        assert!((7.0..=8.5).contains(&mean), "mean {mean}");
    }

    #[test]
    fn star_camera_observations_follow_the_model() {
        let cam = StarCamera::default();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
        let q = Quaternion::from_euler_321(0.3, -0.2, 1.1);
        let a = q.attitude_matrix();
        let boresight_ref = a.transpose() * Vector3::z();
        let obs = cam.observe(&q, &mut rng);
        assert!(obs.len() >= 3 && obs.len() <= 10);
        let mut last = f64::INFINITY;
        for o in &obs {
            assert_eq!(o.sensor.as_deref(), Some("st1"));
            assert_eq!(o.sigma, 6.0 * ARCSEC);
            assert!((o.reference.norm() - 1.0).abs() < 1e-12);
            let c = o.reference.dot(&boresight_ref);
            assert!(c >= (4.0 * DEG).cos());
            assert!(c <= last);
            last = c;
            assert!((o.body - a * o.reference).norm() < 10.0 * 6.0 * ARCSEC);
            // Not renormalised.
            assert!(o.body.norm() != 1.0);
        }
    }

    #[test]
    fn sun_and_magnetometer_noise_statistics() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let sun = SunSensor::default();
        let mag = MagnetometerModel::default();
        let n = 20_000;
        let (mut ss_sun, mut ss_mag, mut sum_mag) = (0.0, 0.0, Vector3::zeros());
        for _ in 0..n {
            let q = random_quaternion(&mut rng);
            let a = q.attitude_matrix();
            let s = normal3(&mut rng).normalize();
            let o = sun
                .observe(&q, &(s * 3.0), &mut rng)
                .expect("always sees the sun");
            assert_eq!(o.sensor.as_deref(), Some("sun"));
            assert!((o.reference - s).norm() < 1e-12);
            ss_sun += (o.body - a * s).norm_squared();
            let b = normal3(&mut rng) * 30_000.0;
            let o = mag.observe(&q, &b, &mut rng);
            assert_eq!(o.sensor.as_deref(), Some("mag"));
            assert_eq!(o.reference, b);
            assert_eq!(o.sigma, 50.0);
            let e = o.body - a * b;
            sum_mag += e;
            ss_mag += e.norm_squared();
        }
        let std_sun = (ss_sun / (3.0 * n as f64)).sqrt();
        let std_mag = (ss_mag / (3.0 * n as f64)).sqrt();
        assert!((std_sun / (0.05 * DEG) - 1.0).abs() < 0.03, "{std_sun}");
        assert!((std_mag / 50.0 - 1.0).abs() < 0.03, "{std_mag}");
        assert!((sum_mag / n as f64).norm() < 4.0 * 50.0 / (n as f64).sqrt() * 3f64.sqrt());
    }

    #[test]
    fn sun_sensor_field_of_view() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(6);
        let sun = SunSensor {
            fov_half_angle_rad: 60.0 * DEG,
            boresight_body: Vector3::z(),
            ..SunSensor::default()
        };
        let q = Quaternion::IDENTITY;
        assert!(sun.observe(&q, &Vector3::z(), &mut rng).is_some());
        assert!(sun
            .observe(&q, &Vector3::new(0.0, 1.0, 1.0), &mut rng)
            .is_some());
        assert!(sun.observe(&q, &Vector3::x(), &mut rng).is_none());
        assert!(sun.observe(&q, &-Vector3::z(), &mut rng).is_none());
    }
}
