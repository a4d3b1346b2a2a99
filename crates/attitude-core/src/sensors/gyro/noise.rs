//! The Farrenkopf gyro model (docs/algorithms.md §2): `ω̃ = ω + β + η_v`, `β̇ = η_u`.

use nalgebra::Vector3;
use rand::Rng;
use rand_distr::StandardNormal;

/// Gyro noise spectral densities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroNoise {
    /// Angle random walk `σ_v`, rad/s^½.
    pub sigma_v: f64,
    /// Rate (bias) random walk `σ_u`, rad/s^{3/2}.
    pub sigma_u: f64,
}

impl GyroNoise {
    /// The standard values of the Crassidis examples: `σ_v = √10·10⁻⁷ rad/s^½`, `σ_u = √10·10⁻¹⁰ rad/s^{3/2}`.
    pub fn standard() -> Self {
        GyroNoise {
            sigma_v: 10f64.sqrt() * 1e-7,
            sigma_u: 10f64.sqrt() * 1e-10,
        }
    }

    /// The 1σ of the white part of one discrete sample over `dt_s`: `(σ_v²/Δt + σ_u² Δt/12)^{½}`.
    pub fn discrete_rate_sigma(&self, dt_s: f64) -> f64 {
        (self.sigma_v * self.sigma_v / dt_s + self.sigma_u * self.sigma_u * dt_s / 12.0).sqrt()
    }
}

/// Exact discrete simulation of the Farrenkopf model: the sample taken at `t_k` is the mean measured
/// rate over `[t_k, t_k + Δt]`, `ω̃_k = ω_k + ½(β_{k+1} + β_k) + (σ_v²/Δt + σ_u²Δt/12)^{½} N_v`,
/// `β_{k+1} = β_k + σ_u √Δt N_u`.
#[derive(Clone, Debug)]
pub struct GyroSimulator {
    pub noise: GyroNoise,
    /// The true bias now, rad/s.
    pub bias_rad_s: Vector3<f64>,
}

impl GyroSimulator {
    pub fn new(noise: GyroNoise, initial_bias_rad_s: Vector3<f64>) -> Self {
        GyroSimulator {
            noise,
            bias_rad_s: initial_bias_rad_s,
        }
    }

    /// Draws the measured rate for the interval that starts now and advances the true bias by `dt_s`.
    pub fn sample<R: Rng + ?Sized>(
        &mut self,
        omega_true_rad_s: &Vector3<f64>,
        dt_s: f64,
        rng: &mut R,
    ) -> Vector3<f64> {
        let b0 = self.bias_rad_s;
        let nu = normal3(rng);
        let nv = normal3(rng);
        let b1 = b0 + nu * (self.noise.sigma_u * dt_s.sqrt());
        self.bias_rad_s = b1;
        omega_true_rad_s + (b0 + b1) * 0.5 + nv * self.noise.discrete_rate_sigma(dt_s)
    }
}

/// Three independent standard normal draws.
pub fn normal3<R: Rng + ?Sized>(rng: &mut R) -> Vector3<f64> {
    Vector3::new(
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
    )
}
