//! Second-order Butterworth low-pass filters with a time constant, for samples at any (varying)
//! interval. The cut-off is `f_c = √2 / (2π τ)`, which gives the step response the time constant `τ`
//! of its non-oscillating part (the choice of Laidig & Seel's VQF, so that `τ` means the same here).
//! Coefficients by the bilinear transform with pre-warping, recomputed when the interval changes;
//! direct form I (the last two inputs and outputs are the state, so a change of interval only changes
//! the coefficients applied to them); started in the steady state of the first input (no start-up
//! transient). An interval much longer than the one the filter runs at (a gap in the samples) is
//! crossed in steps of about the usual interval with the new input held ([`GAP_RATIO`]): the
//! recursion's state holds samples at the usual spacing, and a single step with the long interval's
//! coefficients applied to it rings for seconds; a gap of many time constants restarts the filter at
//! the new input. Two filters that take samples of the same interval (the rest detector's gyro and
//! accelerometer, the gravity channel's two time constants) step together in one pass of six lanes
//! ([`Lowpass3::update_pair`]), with the same values as one after the other.

use nalgebra::Vector3;

/// An interval longer than this many of the filter's usual one is a gap, crossed in steps.
pub const GAP_RATIO: f64 = 4.0;
/// A gap longer than this many time constants restarts the filter at the new input (what it held
/// has decayed to below 1e-4 of it).
const RESTART_TAUS: f64 = 10.0;

/// `[b₀, b₁, b₂, a₁, a₂]` of the filter for `τ` and the interval `dt`.
fn coefficients(tau_s: f64, dt_s: f64) -> [f64; 5] {
    let fc = std::f64::consts::SQRT_2 / (2.0 * std::f64::consts::PI) / tau_s;
    let c = (std::f64::consts::PI * fc * dt_s).tan();
    let d = c * c + std::f64::consts::SQRT_2 * c + 1.0;
    let b0 = c * c / d;
    [
        b0,
        2.0 * b0,
        b0,
        2.0 * (c * c - 1.0) / d,
        (1.0 - std::f64::consts::SQRT_2 * c + c * c) / d,
    ]
}

/// A second-order Butterworth low-pass of a 3-vector.
#[derive(Clone, Debug, PartialEq)]
pub struct Lowpass3 {
    pub tau_s: f64,
    /// The interval the coefficients are for, and the coefficients.
    pub dt_s: f64,
    pub c: [f64; 5],
    /// The last two inputs and outputs (`x[0]`, `y[0]` the latest); `None` before the first input.
    pub x: [Vector3<f64>; 2],
    pub y: Option<[Vector3<f64>; 2]>,
}

impl Lowpass3 {
    /// `tau_s > 0`; `tau_s = 0` passes the input through.
    pub fn new(tau_s: f64) -> Self {
        Lowpass3 {
            tau_s,
            dt_s: f64::NAN,
            c: [1.0, 0.0, 0.0, 0.0, 0.0],
            x: [Vector3::zeros(); 2],
            y: None,
        }
    }

    /// The last output (`None` before the first input).
    pub fn value(&self) -> Option<Vector3<f64>> {
        self.y.map(|y| y[0])
    }

    /// Filters `x`, taken `dt_s` after the previous input (ignored for the first; a non-positive
    /// interval leaves the filter as it was).
    #[inline]
    pub fn update(&mut self, x: &Vector3<f64>, dt_s: f64) -> Vector3<f64> {
        let x = [x[0], x[1], x[2]];
        match self.step(&x, dt_s) {
            Some(out) => Vector3::from(out),
            None => self.restart(&x, dt_s),
        }
    }

    /// The filter's step on plain arrays; `None` when the output is not finite (nothing changed).
    #[inline(always)]
    fn step(&mut self, x: &[f64; 3], dt_s: f64) -> Option<[f64; 3]> {
        if !(self.tau_s > 0.0) {
            let v = Vector3::from(*x);
            self.y = Some([v, v]);
            return Some(*x);
        }
        let Some(y) = &self.y else {
            // The steady state of a constant input x.
            let v = Vector3::from(*x);
            self.x = [v, v];
            self.y = Some([v, v]);
            return Some(*x);
        };
        // (0 < Δt < ∞: neither NaN nor infinite.)
        if !(dt_s > 0.0 && dt_s < f64::INFINITY) {
            return Some(y[0].into());
        }
        if self.dt_s > 0.0 && dt_s > GAP_RATIO * self.dt_s {
            return self.cross_gap(x, dt_s);
        }
        if (dt_s - self.dt_s).abs() > 1e-9 * dt_s || self.dt_s.is_nan() {
            self.c = coefficients(self.tau_s, dt_s);
            self.dt_s = dt_s;
        }
        let x = Vector3::from(*x);
        let out = self.recursion(&x);
        // Finite: 0·v is 0 for a finite v and NaN otherwise.
        if out[0] * 0.0 + out[1] * 0.0 + out[2] * 0.0 != 0.0 {
            return None;
        }
        self.shift(&x, &Vector3::from(out));
        Some(out)
    }

    /// A gap of `dt_s` (more than [`GAP_RATIO`] usual intervals): steps of about the usual interval
    /// with the input `x` held, or a restart at `x` after [`RESTART_TAUS`] time constants.
    #[cold]
    fn cross_gap(&mut self, x: &[f64; 3], dt_s: f64) -> Option<[f64; 3]> {
        let usual = self.dt_s;
        if dt_s > RESTART_TAUS * self.tau_s {
            let v = Vector3::from(*x);
            self.x = [v, v];
            self.y = Some([v, v]);
            return Some(*x);
        }
        let n = (dt_s / usual).ceil().max(1.0);
        let step = dt_s / n;
        self.c = coefficients(self.tau_s, step);
        self.dt_s = step;
        let v = Vector3::from(*x);
        let mut out = [0.0; 3];
        for _ in 0..n as usize {
            out = self.recursion(&v);
            if out[0] * 0.0 + out[1] * 0.0 + out[2] * 0.0 != 0.0 {
                return None;
            }
            self.shift(&v, &Vector3::from(out));
        }
        // The filter goes on at its usual interval.
        self.c = coefficients(self.tau_s, usual);
        self.dt_s = usual;
        Some(out)
    }

    /// True when a step over `dt_s` (positive and finite) is the plain recursion: a filter that has
    /// started, with the coefficients of that interval (`update`'s test for new ones fails: a NaN
    /// `self.dt_s` fails `≤` as well).
    #[inline(always)]
    fn steady(&self, dt_s: f64) -> bool {
        self.tau_s > 0.0 && self.y.is_some() && (dt_s - self.dt_s).abs() <= 1e-9 * dt_s
    }

    /// Two low-passes of the same interval (the rest detector's gyro and accelerometer, the gravity
    /// channel's two time constants) in one pass of six lanes: the values of `a.update(xa, dt_s)` and
    /// `b.update(xb, dt_s)`, bit for bit (the same operations in the same order per component).
    #[inline]
    pub fn update_pair(
        a: &mut Lowpass3,
        xa: &Vector3<f64>,
        b: &mut Lowpass3,
        xb: &Vector3<f64>,
        dt_s: f64,
    ) -> (Vector3<f64>, Vector3<f64>) {
        if dt_s > 0.0 && dt_s < f64::INFINITY && a.steady(dt_s) && b.steady(dt_s) {
            let (oa, ob) = (a.recursion(xa), b.recursion(xb));
            let zero: f64 = oa.iter().chain(&ob).map(|v| v * 0.0).sum();
            if zero == 0.0 {
                let (oa, ob) = (Vector3::from(oa), Vector3::from(ob));
                a.shift(xa, &oa);
                b.shift(xb, &ob);
                return (oa, ob);
            }
        }
        (a.update(xa, dt_s), b.update(xb, dt_s))
    }

    /// The recursion's output for the input `x` (a started filter with its coefficients), per
    /// component in the order of `x b₀ + x₁ b₁ + x₂ b₂ − y₁ a₁ − y₂ a₂`.
    #[inline(always)]
    fn recursion(&self, x: &Vector3<f64>) -> [f64; 3] {
        let [b0, b1, b2, a1, a2] = self.c;
        let (x1, x2) = (&self.x[0], &self.x[1]);
        let Some([y1, y2]) = &self.y else {
            return [f64::NAN; 3];
        };
        std::array::from_fn(|i| x[i] * b0 + x1[i] * b1 + x2[i] * b2 - y1[i] * a1 - y2[i] * a2)
    }

    /// Takes the input `x` and the output `y` into the state.
    #[inline(always)]
    fn shift(&mut self, x: &Vector3<f64>, y: &Vector3<f64>) {
        self.x[1] = self.x[0];
        self.x[0] = *x;
        if let Some(h) = &mut self.y {
            h[1] = h[0];
            h[0] = *y;
        }
    }

    /// Restarts rather than carry a non-finite state.
    #[cold]
    #[inline(never)]
    fn restart(&mut self, x: &[f64; 3], dt_s: f64) -> Vector3<f64> {
        *self = Lowpass3::new(self.tau_s);
        self.update(&Vector3::from(*x), dt_s)
    }
}

/// A first-order low-pass `y ← y + (x − y)(1 − e^{−Δt/τ})` of a scalar (for slowly adapting levels).
pub fn first_order(y: f64, x: f64, dt_s: f64, tau_s: f64) -> f64 {
    first_order_by(y, x, gain(dt_s, tau_s))
}

/// The gain `1 − e^{−Δt/τ}` of [`first_order`], for several values filtered alike (one `exp`);
/// `None` when `τ ≤ 0` (the input passes).
pub fn gain(dt_s: f64, tau_s: f64) -> Option<f64> {
    (tau_s > 0.0).then(|| 1.0 - (-dt_s / tau_s).exp())
}

/// [`first_order`] with its [`gain`].
pub fn first_order_by(y: f64, x: f64, gain: Option<f64>) -> f64 {
    match gain {
        Some(k) => y + (x - y) * k,
        None => x,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pair stepped together gives the bits of the two stepped one after the other, through the
    /// start, changes of interval, a non-positive interval and a non-finite input (a restart).
    #[test]
    fn a_pair_is_the_two_filters_bit_for_bit() {
        let (mut a, mut b) = (Lowpass3::new(0.5), Lowpass3::new(3.0));
        let (mut a1, mut b1) = (a.clone(), b.clone());
        let mut x = 0.3f64;
        for k in 0..2000 {
            // A deterministic, irregular sequence.
            x = (x * 3.7 + 0.1).fract();
            let xa = Vector3::new(x - 0.5, 2.0 * x, 9.81 - x);
            let xb = Vector3::new(-x, x * x, 1.0 + x);
            let dt = match k % 97 {
                13 => 0.0,
                40 => -0.01,
                _ if k > 1000 => 0.01,
                _ => 0.0035 + 1e-15 * f64::from(k % 7),
            };
            let xa = if k == 1500 {
                Vector3::new(f64::NAN, 0.0, 0.0)
            } else {
                xa
            };
            let (ya, yb) = Lowpass3::update_pair(&mut a, &xa, &mut b, &xb, dt);
            let (za, zb) = (a1.update(&xa, dt), b1.update(&xb, dt));
            let bits = |v: &Vector3<f64>| v.map(f64::to_bits);
            assert_eq!((bits(&ya), bits(&yb)), (bits(&za), bits(&zb)), "sample {k}");
            // (Debug: a NaN state is equal to itself here.)
            assert_eq!(format!("{a:?}{b:?}"), format!("{a1:?}{b1:?}"), "sample {k}");
        }
    }

    #[test]
    fn unit_dc_gain_and_no_start_transient() {
        let mut lp = Lowpass3::new(0.5);
        let x = Vector3::new(1.0, -2.0, 9.81);
        for _ in 0..10 {
            assert!((lp.update(&x, 0.01) - x).norm() < 1e-12);
        }
    }

    /// The step response settles with the time constant τ: after 5τ within 1 %, and it attenuates a
    /// sinusoid a decade above the cut-off by the second-order slope (≈ 1/100).
    #[test]
    fn step_and_attenuation() {
        let (tau, dt) = (1.0, 0.005);
        let mut lp = Lowpass3::new(tau);
        lp.update(&Vector3::zeros(), dt);
        let one = Vector3::new(1.0, 1.0, 1.0);
        let mut y = Vector3::zeros();
        for _ in 0..(5.0 * tau / dt) as usize {
            y = lp.update(&one, dt);
        }
        assert!((y[0] - 1.0).abs() < 0.01, "{y}");
        let fc = std::f64::consts::SQRT_2 / (2.0 * std::f64::consts::PI) / tau;
        let f = 10.0 * fc;
        let mut lp = Lowpass3::new(tau);
        let mut peak: f64 = 0.0;
        for k in 0..(40.0 / dt) as usize {
            let t = k as f64 * dt;
            let x = (2.0 * std::f64::consts::PI * f * t).sin();
            let y = lp.update(&Vector3::new(x, 0.0, 0.0), dt)[0];
            if t > 20.0 {
                peak = peak.max(y.abs());
            }
        }
        assert!(
            (peak - 0.01).abs() < 0.002,
            "gain a decade above f_c: {peak}"
        );
    }
}
