//! The scenario options shared by `simulate`, `demo` and the lab's studies, and the parameters they make.

use crate::sim::{BiasSpec, InitialError, ScenarioName, ScenarioParams, DEG, DEG_PER_HR};
use anyhow::{bail, Result};
use clap::Args;
use nalgebra::Vector3;

/// The scenario and its overrides (studies, simulate, demo).
#[derive(Args, Clone)]
pub struct ScenarioArgs {
    /// Scenario: star-tracker, magnetometer-leo or lost-in-space (see `attitude-lab scenarios`). Required, except
    /// for `demo` (magnetometer-leo).
    #[arg(long)]
    pub scenario: Option<ScenarioName>,
    /// Run length, s (default: the scenario's; 14400 for `demo`).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Initial attitude error, deg: one value for every axis or three comma-separated. The 3-2-1 Euler
    /// magnitudes (random signs) for magnetometer-leo; otherwise a per-axis Gaussian 1σ, and the filter
    /// is told the same 1σ (this replaces lost-in-space's uniformly random attitude).
    #[arg(long, value_delimiter = ',', num_args = 1..=3)]
    pub init_error_deg: Option<Vec<f64>>,
    /// Start every run from a uniformly random attitude (lost in space), whatever the scenario.
    #[arg(long)]
    pub uniform_init: bool,
    /// Largest true gyro bias per axis, deg/hr (drawn uniformly in ±this; the filter's initial bias
    /// 1σ is set to the same value).
    #[arg(long)]
    pub bias_deg_hr: Option<f64>,
}

/// The scenario's standard parameters with the overrides of `args`, validated.
pub fn scenario_from_args(args: &ScenarioArgs) -> Result<ScenarioParams> {
    let Some(name) = args.scenario else {
        bail!("--scenario is required (star-tracker, magnetometer-leo or lost-in-space)");
    };
    let mut p = ScenarioParams::default_for(name);
    if let Some(d) = args.duration {
        p.duration_s = d;
    }
    if let Some(e) = &args.init_error_deg {
        let v = match e.as_slice() {
            [a] => Vector3::repeat(*a),
            [a, b, c] => Vector3::new(*a, *b, *c),
            _ => bail!("--init-error-deg takes one or three values"),
        } * DEG;
        p.initial_error = match p.initial_error {
            InitialError::PerAxisGaussian { .. } => {
                p.filter_init_sigma_att_rad = v;
                InitialError::PerAxisGaussian { sigma_rad: v }
            }
            InitialError::Euler321Magnitudes { .. } => InitialError::Euler321Magnitudes {
                roll_rad: v[0],
                pitch_rad: v[1],
                yaw_rad: v[2],
            },
            // A Gaussian error instead of the uniformly random attitude.
            InitialError::UniformRandom => {
                p.filter_init_sigma_att_rad = v;
                InitialError::PerAxisGaussian { sigma_rad: v }
            }
        };
    }
    if args.uniform_init {
        p.initial_error = InitialError::UniformRandom;
        p.filter_init_sigma_att_rad = Vector3::repeat(std::f64::consts::PI);
    }
    if let Some(b) = args.bias_deg_hr {
        p.true_bias_rad_s = BiasSpec::UniformPerAxis {
            max_rad_s: b * DEG_PER_HR,
        };
        p.filter_init_bias_sigma_rad_s = Vector3::repeat((b * DEG_PER_HR).max(1e-3 * DEG_PER_HR));
    }
    p.validate()
        .map_err(|e| anyhow::anyhow!("invalid scenario parameters: {e}"))?;
    Ok(p)
}
