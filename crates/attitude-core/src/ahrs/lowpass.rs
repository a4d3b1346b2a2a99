//! Second-order Butterworth low-pass filters with a time constant, for samples at any (varying)
//! interval. The cut-off is `f_c = √2 / (2π τ)`, which gives the step response the time constant `τ`
//! of its non-oscillating part (the choice of Laidig & Seel's VQF, so that `τ` means the same here).
//! Coefficients by the bilinear transform with pre-warping, recomputed when the interval changes;
//! direct form I (the last two inputs and outputs are the state, so a change of interval only changes
//! the coefficients applied to them); started in the steady state of the first input (no start-up
//! transient).

use nalgebra::Vector3;

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
    pub fn update(&mut self, x: &Vector3<f64>, dt_s: f64) -> Vector3<f64> {
        if !(self.tau_s > 0.0) {
            self.y = Some([*x, *x]);
            return *x;
        }
        let Some(y) = self.y else {
            // The steady state of a constant input x.
            self.x = [*x, *x];
            self.y = Some([*x, *x]);
            return *x;
        };
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return y[0];
        }
        if (dt_s - self.dt_s).abs() > 1e-9 * dt_s || self.dt_s.is_nan() {
            self.c = coefficients(self.tau_s, dt_s);
            self.dt_s = dt_s;
        }
        let [b0, b1, b2, a1, a2] = self.c;
        // (Per component, in the order of the vector expression x b₀ + x₁ b₁ + x₂ b₂ − y₁ a₁ − y₂ a₂.)
        let (x1, x2, y1, y2) = (&self.x[0], &self.x[1], &y[0], &y[1]);
        let out =
            Vector3::from_fn(|i, _| x[i] * b0 + x1[i] * b1 + x2[i] * b2 - y1[i] * a1 - y2[i] * a2);
        if !(out[0].is_finite() && out[1].is_finite() && out[2].is_finite()) {
            // Restart rather than carry a non-finite state.
            *self = Lowpass3::new(self.tau_s);
            return self.update(x, dt_s);
        }
        self.x = [*x, self.x[0]];
        self.y = Some([out, y[0]]);
        out
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
