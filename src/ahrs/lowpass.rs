//! Second-order Butterworth low-pass filters with a time constant, for samples at any (varying)
//! interval. The cut-off is `f_c = √2 / (2π τ)`, which gives the step response the time constant `τ`
//! of its non-oscillating part (the choice of Laidig & Seel's VQF, so that `τ` means the same here).
//! Coefficients by the bilinear transform with pre-warping, recomputed when the interval changes;
//! direct form II transposed; started in the steady state of the first input (no start-up transient).

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
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Lowpass3 {
    tau_s: f64,
    /// The interval the coefficients are for, and the coefficients.
    dt_s: f64,
    c: [f64; 5],
    s0: Vector3<f64>,
    s1: Vector3<f64>,
    y: Option<Vector3<f64>>,
}

impl Lowpass3 {
    /// `tau_s > 0`; `tau_s = 0` passes the input through.
    pub fn new(tau_s: f64) -> Self {
        Lowpass3 {
            tau_s,
            dt_s: f64::NAN,
            c: [1.0, 0.0, 0.0, 0.0, 0.0],
            s0: Vector3::zeros(),
            s1: Vector3::zeros(),
            y: None,
        }
    }

    /// The last output (`None` before the first input).
    pub fn value(&self) -> Option<Vector3<f64>> {
        self.y
    }

    /// Filters `x`, taken `dt_s` after the previous input (ignored for the first).
    pub fn update(&mut self, x: &Vector3<f64>, dt_s: f64) -> Vector3<f64> {
        if !(self.tau_s > 0.0) {
            self.y = Some(*x);
            return *x;
        }
        if (dt_s - self.dt_s).abs() > 1e-9 * dt_s.abs() || self.dt_s.is_nan() {
            if dt_s > 0.0 && dt_s.is_finite() {
                self.c = coefficients(self.tau_s, dt_s);
                self.dt_s = dt_s;
            }
        }
        let [b0, b1, b2, a1, a2] = self.c;
        let y = match self.y {
            None => {
                // The steady state of a constant input x: y = x.
                self.s1 = x * (b2 - a2);
                self.s0 = x * (b1 - a1) + self.s1;
                *x
            }
            Some(_) if !(dt_s > 0.0) => return self.y.unwrap_or(*x),
            Some(_) => {
                let y = x * b0 + self.s0;
                self.s0 = x * b1 - y * a1 + self.s1;
                self.s1 = x * b2 - y * a2;
                y
            }
        };
        if !y.iter().all(|v| v.is_finite()) {
            // Restart rather than carry a non-finite state.
            *self = Lowpass3::new(self.tau_s);
            return *x;
        }
        self.y = Some(y);
        y
    }
}

/// A first-order low-pass `y ← y + (x − y)(1 − e^{−Δt/τ})` of a scalar (for slowly adapting levels).
pub fn first_order(y: f64, x: f64, dt_s: f64, tau_s: f64) -> f64 {
    if !(tau_s > 0.0) {
        return x;
    }
    y + (x - y) * (1.0 - (-dt_s / tau_s).exp())
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
