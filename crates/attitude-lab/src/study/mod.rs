//! Monte-Carlo accuracy studies: run filters on the same simulated data, measure them against the
//! posterior Cramér–Rao bound, and report (`report` writes `summary.json`, `summary.md` and plots,
//! `sweep` the particle-count sweep, both drawing with the toolkit of `plot`).
//!
//! Definitions used in every summary (also in `docs/montecarlo.md`):
//! * error: `δα = 2·vec(q_true ⊗ q̂⁻¹)` (shortest rotation), per body axis, rad; error angle `‖δα‖`-like
//!   rotation angle of `q_true ⊗ q̂⁻¹`.
//! * converged: the error angle stays below the scenario's threshold over the last quarter of the run;
//!   convergence time: the time after which the error angle never again exceeds the threshold.
//! * steady window: the last half of the run. `steady_rms_deg` is the RMS of each axis' error over the
//!   converged runs and the window (over all runs when none converged), `pcrb_deg` the RMS of the
//!   bound's √diag over the same samples, `anees` the mean attitude NEES `δαᵀ P_att⁻¹ δα` over the same
//!   samples (3 is ideal) with its 95% interval `χ²₃ₙ(0.025, 0.975)/n` for `n` runs.
//! * `us_per_step`: the filter's wall time divided by the number of vector-observation epochs (each step
//!   includes the gyro propagations since the previous epoch).

pub mod broad;
mod plot;
pub mod report;
pub mod runner;
pub mod sweep;

use attitude_core::filters::FilterSpec;

/// Per-run statistics and a decimated time series for plots.
#[derive(Clone, Debug, Default)]
pub struct RunTrace {
    /// Times of the stored samples, s (decimated to at most [`runner::MAX_TRACE_POINTS`]).
    pub t_s: Vec<f64>,
    /// Attitude error per body axis, rad.
    pub err_rad: Vec<[f64; 3]>,
    /// The filter's own 1σ per axis, rad.
    pub sigma_rad: Vec<[f64; 3]>,
    /// The PCRB's 1σ per axis, rad, at the same times.
    pub pcrb_rad: Vec<[f64; 3]>,
    /// Error angle, rad.
    pub angle_rad: Vec<f64>,
    pub converged: bool,
    pub convergence_time_s: Option<f64>,
    /// Sums over the steady window (all samples, not decimated).
    pub window_samples: usize,
    pub window_err_sq: [f64; 3],
    pub window_pcrb_var: [f64; 3],
    pub window_nees_sum: f64,
    /// Vector-observation epochs processed and the filter's wall time for the whole run, s.
    pub steps: usize,
    pub wall_s: f64,
    /// Set when the filter returned an error (the run then counts as not converged).
    pub failure: Option<String>,
    /// Inputs the filter refused and the run skipped (`StudyConfig::skip_refused`).
    pub refused: usize,
}

/// The summary row of one filter, the content of `summary.json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FilterSummary {
    /// `mekf`, `usque:average`, … (the `--filters` spelling).
    pub filter: String,
    /// `mekf`, `usque`, `qpf` or `sghqf`.
    pub kind: String,
    /// `propagated`, `average`, or null for the MEKF.
    pub fiducial: Option<String>,
    /// Particle count (QPF only).
    pub particles: Option<usize>,
    /// Sparse-grid level (SGHQF only; absent from older summaries).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<u8>,
    pub runs: usize,
    pub converged_runs: usize,
    /// Median over converged runs, s (null when none converged).
    pub convergence_time_s: Option<f64>,
    /// Statistics without samples are NaN, written as JSON `null` and read back as NaN.
    #[serde(deserialize_with = "nan_or_numbers")]
    pub steady_rms_deg: [f64; 3],
    #[serde(deserialize_with = "nan_or_numbers")]
    pub pcrb_deg: [f64; 3],
    #[serde(deserialize_with = "nan_or_numbers")]
    pub rms_over_pcrb: [f64; 3],
    #[serde(deserialize_with = "nan_or_number")]
    pub anees: f64,
    /// The 95% interval of the ANEES for this many runs.
    #[serde(deserialize_with = "nan_or_numbers")]
    pub anees_interval: [f64; 2],
    #[serde(deserialize_with = "nan_or_number")]
    pub us_per_step: f64,
    /// Runs in which the filter reported an error.
    pub failed_runs: usize,
    /// Inputs refused and skipped over all runs (with `--skip-refused`; absent from older summaries).
    #[serde(default)]
    pub refused_inputs: usize,
}

fn nan_or_number<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v: Option<f64> = serde::Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::NAN))
}

fn nan_or_numbers<'de, D: serde::Deserializer<'de>, const N: usize>(
    d: D,
) -> Result<[f64; N], D::Error> {
    let v: Vec<Option<f64>> = serde::Deserialize::deserialize(d)?;
    let v: Vec<f64> = v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect();
    v.try_into().map_err(|v: Vec<f64>| {
        serde::de::Error::invalid_length(v.len(), &format!("{N} numbers").as_str())
    })
}

/// All traces of one filter.
#[derive(Clone, Debug)]
pub struct FilterResult {
    pub spec: FilterSpec,
    pub particles: Option<usize>,
    pub level: Option<u8>,
    pub runs: Vec<RunTrace>,
    pub summary: FilterSummary,
}

/// A whole study.
#[derive(Clone, Debug)]
pub struct StudyResult {
    /// Scenario name as given on the command line.
    pub scenario: String,
    /// Human-readable parameter description of the scenario.
    pub scenario_description: String,
    pub seed: u64,
    pub runs: usize,
    pub duration_s: f64,
    pub convergence_threshold_rad: f64,
    pub filters: Vec<FilterResult>,
}
