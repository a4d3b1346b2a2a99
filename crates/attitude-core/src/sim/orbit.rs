//! The simulator's environment: a circular orbit, a tilted rotating dipole geomagnetic field, a fixed
//! sun direction, and the LVLH (Earth-pointing) attitude.
//!
//! Frames: ECI is the reference frame of every attitude (`b = A(q) r_eci`). Units: metres, seconds,
//! radians, nanotesla.

use nalgebra::{Matrix3, Vector3};

use crate::attitude::Quaternion;

/// Equatorial Earth radius (WGS-84), m.
pub const EARTH_RADIUS_M: f64 = 6_378_137.0;
/// Earth's gravitational parameter, m³/s².
pub const EARTH_MU_M3_S2: f64 = 3.986_004_418e14;
/// Earth's rotation rate (sidereal), rad/s.
pub const EARTH_RATE_RAD_S: f64 = 7.292_115_9e-5;
/// Mean obliquity of the ecliptic (J2000), rad.
pub const OBLIQUITY_RAD: f64 = 23.439_291 * std::f64::consts::PI / 180.0;

/// A circular Keplerian orbit about a spherical Earth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircularOrbit {
    /// Altitude above [`EARTH_RADIUS_M`], m (default 400 km).
    pub altitude_m: f64,
    /// Inclination, rad (default 35°).
    pub inclination_rad: f64,
    /// Right ascension of the ascending node, rad (default 0).
    pub raan_rad: f64,
    /// Argument of latitude at `t = 0` (angle from the ascending node along the orbit), rad (default 0).
    pub arg_lat0_rad: f64,
}

impl Default for CircularOrbit {
    fn default() -> Self {
        CircularOrbit {
            altitude_m: 400_000.0,
            inclination_rad: 35f64.to_radians(),
            raan_rad: 0.0,
            arg_lat0_rad: 0.0,
        }
    }
}

impl CircularOrbit {
    /// Orbit radius, m.
    pub fn radius_m(&self) -> f64 {
        EARTH_RADIUS_M + self.altitude_m
    }

    /// Orbit (mean motion) rate `n = √(μ/a³)`, rad/s.
    pub fn rate_rad_s(&self) -> f64 {
        let a = self.radius_m();
        (EARTH_MU_M3_S2 / (a * a * a)).sqrt()
    }

    /// Orbit period `2π/n`, s.
    pub fn period_s(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.rate_rad_s()
    }

    /// Argument of latitude at `t_s`, rad.
    pub fn arg_lat_rad(&self, t_s: f64) -> f64 {
        self.arg_lat0_rad + self.rate_rad_s() * t_s
    }

    /// ECI position (m) and velocity (m/s) at `t_s`.
    pub fn state_eci(&self, t_s: f64) -> (Vector3<f64>, Vector3<f64>) {
        let a = self.radius_m();
        let n = self.rate_rad_s();
        let u = self.arg_lat_rad(t_s);
        let (su, cu) = u.sin_cos();
        let (so, co) = self.raan_rad.sin_cos();
        let (si, ci) = self.inclination_rad.sin_cos();
        // r = R3(−Ω) R1(−i) [a cos u, a sin u, 0].
        let p = Vector3::new(co * cu - so * ci * su, so * cu + co * ci * su, si * su);
        let q = Vector3::new(-co * su - so * ci * cu, -so * su + co * ci * cu, si * cu);
        (p * a, q * (a * n))
    }

    /// ECI position at `t_s`, m.
    pub fn position_eci(&self, t_s: f64) -> Vector3<f64> {
        self.state_eci(t_s).0
    }

    /// The LVLH attitude at `t_s` ([`lvlh_attitude`] of the orbit state).
    pub fn lvlh_attitude(&self, t_s: f64) -> Quaternion {
        let (r, v) = self.state_eci(t_s);
        lvlh_attitude(&r, &v)
    }

    /// The body rate of the LVLH attitude, `[0, −n, 0]` rad/s.
    pub fn lvlh_body_rate_rad_s(&self) -> Vector3<f64> {
        Vector3::new(0.0, -self.rate_rad_s(), 0.0)
    }
}

/// The LVLH (local-vertical, local-horizontal) attitude of a spacecraft at ECI position `r` with velocity
/// `v`: body `z = −r̂` (nadir), `y = −ĥ` with `h = r × v` (negative orbit normal), `x = y × z` (along track
/// for a circular orbit). The rows of `A` are these axes in ECI.
///
/// For a circular orbit this frame turns at `n ĥ` in ECI, i.e. the body rate is `ω = [0, −n, 0]`.
/// Degenerate input (zero or parallel `r`, `v`, non-finite) gives the identity.
pub fn lvlh_attitude(r_eci: &Vector3<f64>, v_eci: &Vector3<f64>) -> Quaternion {
    let h = r_eci.cross(v_eci);
    let (rn, hn) = (r_eci.norm(), h.norm());
    if !(rn > 0.0 && hn > 0.0 && rn.is_finite() && hn.is_finite()) {
        return Quaternion::IDENTITY;
    }
    let z = -r_eci / rn;
    let y = -h / hn;
    let x = y.cross(&z);
    let a = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
    Quaternion::from_attitude_matrix(&a)
}

/// A centred, tilted dipole geomagnetic field that rotates with the Earth.
///
/// `B(r) = B₀ (R_E/‖r‖)³ [3 (m̂·r̂) r̂ − m̂]` with `m̂` the dipole-moment direction. Earth's moment points
/// roughly to geographic south: `m̂ = −p̂`, where `p̂` is the north geomagnetic pole, at colatitude `tilt`
/// from the ECI `+z` (spin) axis and right ascension `lon0 + ω_E t`. So at the magnetic equator on the
/// surface the field is `B₀` pointing north (`−B₀ m̂`), and at the magnetic poles it is `2 B₀`, pointing down
/// into the Earth at the north magnetic pole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DipoleField {
    /// Equatorial field at the surface, nT (default 30 000).
    pub b0_nt: f64,
    /// Angle between the dipole axis and the spin axis, rad (default 11°).
    pub tilt_rad: f64,
    /// Right ascension of the north geomagnetic pole at `t = 0`, rad (default 0: the pole leans toward
    /// ECI `+x` at `t = 0`).
    pub lon0_rad: f64,
    /// Earth rotation rate, rad/s (default 7.2921159e-5).
    pub earth_rate_rad_s: f64,
}

impl Default for DipoleField {
    fn default() -> Self {
        DipoleField {
            b0_nt: 30_000.0,
            tilt_rad: 11f64.to_radians(),
            lon0_rad: 0.0,
            earth_rate_rad_s: EARTH_RATE_RAD_S,
        }
    }
}

impl DipoleField {
    /// The north geomagnetic pole direction `p̂` in ECI at `t_s` (unit).
    pub fn north_pole_eci(&self, t_s: f64) -> Vector3<f64> {
        let lon = self.lon0_rad + self.earth_rate_rad_s * t_s;
        let (st, ct) = self.tilt_rad.sin_cos();
        Vector3::new(st * lon.cos(), st * lon.sin(), ct)
    }

    /// The dipole-moment direction `m̂ = −p̂` in ECI at `t_s` (unit).
    pub fn moment_axis_eci(&self, t_s: f64) -> Vector3<f64> {
        -self.north_pole_eci(t_s)
    }

    /// The field at ECI position `r_eci_m` (m) and time `t_s`, in ECI, nT. Zero at the origin and for
    /// non-finite input it is not finite.
    pub fn field_eci_nt(&self, r_eci_m: &Vector3<f64>, t_s: f64) -> Vector3<f64> {
        let r = r_eci_m.norm();
        if r == 0.0 {
            return Vector3::zeros();
        }
        let rh = r_eci_m / r;
        let m = self.moment_axis_eci(t_s);
        let k = self.b0_nt * (EARTH_RADIUS_M / r).powi(3);
        (rh * (3.0 * m.dot(&rh)) - m) * k
    }
}

/// The sun direction in ECI (unit) for a sun at ecliptic longitude `lambda_rad` on the ecliptic
/// (obliquity [`OBLIQUITY_RAD`]): `[cos λ, cos ε sin λ, sin ε sin λ]`.
pub fn sun_direction_eci(ecliptic_longitude_rad: f64) -> Vector3<f64> {
    let (sl, cl) = ecliptic_longitude_rad.sin_cos();
    let (se, ce) = OBLIQUITY_RAD.sin_cos();
    Vector3::new(cl, ce * sl, se * sl)
}

/// The fixed sun direction of the standard scenarios: the sun at the June solstice (ecliptic longitude
/// 90°), `[0, cos ε, sin ε] ≈ [0, 0.9175, 0.3978]`. It is held fixed over a run (it moves about 1°/day).
pub fn default_sun_direction_eci() -> Vector3<f64> {
    sun_direction_eci(std::f64::consts::FRAC_PI_2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_is_circular_with_the_right_rate() {
        let o = CircularOrbit::default();
        let n = o.rate_rad_s();
        // 400 km: period about 92.6 min.
        assert!(
            (o.period_s() / 60.0 - 92.56).abs() < 0.05,
            "{}",
            o.period_s() / 60.0
        );
        for k in 0..20 {
            let t = 300.0 * k as f64;
            let (r, v) = o.state_eci(t);
            assert!((r.norm() - o.radius_m()).abs() < 1e-6);
            assert!((v.norm() - o.radius_m() * n).abs() < 1e-9);
            assert!(r.dot(&v).abs() < 1e-3);
            // Orbit normal is fixed at the inclination.
            let h = r.cross(&v).normalize();
            assert!((h[2] - o.inclination_rad.cos()).abs() < 1e-12);
            // Velocity is the derivative of position.
            let dt = 1e-3;
            let dr = (o.position_eci(t + dt) - o.position_eci(t - dt)) / (2.0 * dt);
            assert!((dr - v).norm() < 1e-3);
        }
        // Ascending node at t = 0 (u = 0): on the x axis moving north.
        let (r, v) = o.state_eci(0.0);
        assert!((r.normalize() - Vector3::x()).norm() < 1e-12);
        assert!(v[2] > 0.0);
    }

    #[test]
    fn lvlh_axes_and_rate() {
        let o = CircularOrbit {
            raan_rad: 0.7,
            arg_lat0_rad: 0.3,
            ..CircularOrbit::default()
        };
        let (r, v) = o.state_eci(123.0);
        let a = lvlh_attitude(&r, &v).attitude_matrix();
        // Nadir is body +z, velocity is body +x, orbit normal is body −y.
        assert!((a * (-r.normalize()) - Vector3::z()).norm() < 1e-12);
        assert!((a * v.normalize() - Vector3::x()).norm() < 1e-12);
        assert!((a * r.cross(&v).normalize() + Vector3::y()).norm() < 1e-12);
        assert!((a.determinant() - 1.0).abs() < 1e-12);
        assert_eq!(lvlh_attitude(&Vector3::zeros(), &v), Quaternion::IDENTITY);
        assert_eq!(lvlh_attitude(&r, &(r * 2.0)), Quaternion::IDENTITY);
    }

    #[test]
    fn lvlh_propagated_at_orbit_rate_matches_the_orbit() {
        for (raan, u0, inc) in [
            (0.0, 0.0, 35.0),
            (1.3, 2.0, 35.0),
            (-0.4, 0.9, 97.0),
            (2.0, -1.0, 0.0),
        ] {
            let o = CircularOrbit {
                raan_rad: raan,
                arg_lat0_rad: u0,
                inclination_rad: f64::to_radians(inc),
                ..CircularOrbit::default()
            };
            let q0 = o.lvlh_attitude(0.0);
            let omega = o.lvlh_body_rate_rad_s();
            assert_eq!(omega, Vector3::new(0.0, -o.rate_rad_s(), 0.0));
            let quarter = o.period_s() / 4.0;
            // In one step and in many small steps.
            let q1 = q0.propagate(&omega, quarter);
            let steps = 1000;
            let mut qs = q0;
            for _ in 0..steps {
                qs = qs.propagate(&omega, quarter / steps as f64);
            }
            let expected = o.lvlh_attitude(quarter);
            assert!(expected.small_angle_error(&q1).norm() < 1e-9);
            assert!(expected.small_angle_error(&qs).norm() < 1e-9);
            // And q0 itself is 90° away (sanity: the test is not vacuous).
            assert!(
                (expected.small_angle_error(&q0).norm()
                    - 2.0 * (std::f64::consts::FRAC_PI_4).sin())
                .abs()
                    < 1e-9
            );
        }
    }

    #[test]
    fn dipole_magnitudes_and_directions() {
        let f = DipoleField::default();
        let t = 1234.5;
        let p = f.north_pole_eci(t);
        assert!((p.norm() - 1.0).abs() < 1e-15);
        assert!((p[2] - f.tilt_rad.cos()).abs() < 1e-15);
        // Surface at the north magnetic pole: 2 B0, pointing down (along −p̂).
        let b = f.field_eci_nt(&(p * EARTH_RADIUS_M), t);
        assert!((b.norm() - 2.0 * f.b0_nt).abs() < 1e-9);
        assert!((b.normalize() + p).norm() < 1e-12);
        // South magnetic pole: 2 B0, pointing up (also along −p̂).
        let b = f.field_eci_nt(&(-p * EARTH_RADIUS_M), t);
        assert!((b.norm() - 2.0 * f.b0_nt).abs() < 1e-9);
        assert!((b.normalize() + p).norm() < 1e-12);
        // Magnetic equator: B0 pointing to the north magnetic pole direction.
        let e = p.cross(&Vector3::new(0.3, -0.5, 0.1)).normalize();
        let b = f.field_eci_nt(&(e * EARTH_RADIUS_M), t);
        assert!((b.norm() - f.b0_nt).abs() < 1e-9);
        assert!((b.normalize() - p).norm() < 1e-12);
        // Falls off as r⁻³.
        let b2 = f.field_eci_nt(&(e * 2.0 * EARTH_RADIUS_M), t);
        assert!((b2.norm() - f.b0_nt / 8.0).abs() < 1e-9);
        // At 400 km the magnitude lies in [B0, 2 B0] (R_E/r)³.
        let o = CircularOrbit::default();
        let s = (EARTH_RADIUS_M / o.radius_m()).powi(3);
        for k in 0..100 {
            let t = 60.0 * k as f64;
            let b = f.field_eci_nt(&o.position_eci(t), t).norm();
            assert!(b >= f.b0_nt * s - 1e-9 && b <= 2.0 * f.b0_nt * s + 1e-9);
        }
        // The geographic north pole is near the magnetic one: field points mostly down there.
        let b = f.field_eci_nt(&(Vector3::z() * EARTH_RADIUS_M), 0.0);
        assert!(b[2] < -0.9 * b.norm());
        // Rotates with the Earth: after one sidereal day the pole is back.
        let day = 2.0 * std::f64::consts::PI / f.earth_rate_rad_s;
        assert!((f.north_pole_eci(day) - f.north_pole_eci(0.0)).norm() < 1e-12);
        assert!((f.north_pole_eci(day / 2.0) - f.north_pole_eci(0.0)).norm() > 0.3);
        assert_eq!(f.field_eci_nt(&Vector3::zeros(), 0.0), Vector3::zeros());
    }

    #[test]
    fn sun_direction() {
        let s = default_sun_direction_eci();
        assert!((s.norm() - 1.0).abs() < 1e-15);
        assert!(s[0].abs() < 1e-15);
        assert!((s[2].asin() - OBLIQUITY_RAD).abs() < 1e-12);
        assert!((sun_direction_eci(0.0) - Vector3::x()).norm() < 1e-15);
    }
}
