//! Runs filters on the same simulated data and reduces the errors against the Cramér–Rao bound.
//!
//! Runs are independent and spread over threads; every random number comes from seeds derived from
//! the study seed and the run index, so the result does not depend on the thread count or scheduling
//! (except the wall-clock timings).

use super::{FilterResult, FilterSummary, RunTrace, StudyResult};
use attitude_core::bounds::Pcrb;
use attitude_core::filters::{build_filter, FilterConfig, FilterKind, FilterSpec, InitialState};
use attitude_core::rng::derive_seed;
use attitude_core::sensors::Measurement;
use attitude_core::sim::scenario::{simulate, ScenarioParams, SimulatedRun};
use attitude_core::stats::chi_square_quantile;
use nalgebra::{Matrix3, Vector3};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// Stored samples per run trace (the statistics use every sample).
pub const MAX_TRACE_POINTS: usize = 1500;

/// What to run.
#[derive(Clone, Debug)]
pub struct StudyConfig {
    pub scenario: ScenarioParams,
    pub filters: Vec<FilterSpec>,
    pub runs: usize,
    pub seed: u64,
    /// Particle count of the QPF.
    pub particles: usize,
    /// Sparse-grid level of the SGHQF.
    pub level: u8,
    /// A refused input is skipped and counted (as the service's vehicle rolls it back) instead of
    /// ending the run as failed.
    pub skip_refused: bool,
    /// Worker threads (≥ 1).
    pub jobs: usize,
}

/// Runs the study. `on_run_done` is called once per finished run (for a progress bar).
pub fn run_study(config: &StudyConfig, on_run_done: &(dyn Fn() + Sync)) -> StudyResult {
    let runs = config.runs;
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Vec<RunTrace>>>> = Mutex::new(vec![None; runs]);
    let jobs = config.jobs.clamp(1, runs.max(1));
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let r = next.fetch_add(1, Ordering::Relaxed);
                if r >= runs {
                    break;
                }
                let traces = run_one(config, r);
                results.lock().unwrap_or_else(|e| e.into_inner())[r] = Some(traces);
                on_run_done();
            });
        }
    });
    let per_run: Vec<Vec<RunTrace>> = results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.unwrap_or_default())
        .collect();
    let filters = config
        .filters
        .iter()
        .enumerate()
        .map(|(fi, spec)| {
            let traces: Vec<RunTrace> = per_run
                .iter()
                .map(|r| r.get(fi).cloned().unwrap_or_default())
                .collect();
            let particles = (spec.kind == FilterKind::Qpf).then_some(config.particles);
            let level = (spec.kind == FilterKind::Sghqf).then_some(config.level);
            let summary = summarize(spec, particles, level, &traces);
            FilterResult {
                spec: *spec,
                particles,
                level,
                runs: traces,
                summary,
            }
        })
        .collect();
    StudyResult {
        scenario: config.scenario.name.to_string(),
        scenario_description: config.scenario.describe(),
        seed: config.seed,
        runs,
        duration_s: config.scenario.duration_s,
        convergence_threshold_rad: config.scenario.convergence_threshold_rad,
        filters,
    }
}

/// The bound's 1σ per axis at every vector-observation epoch of a run.
fn pcrb_along_truth(config: &StudyConfig, sim: &SimulatedRun) -> Vec<[f64; 3]> {
    let init = &sim.initial;
    let mut pcrb = Pcrb::from_sigmas(
        config.scenario.gyro,
        &init.sigma_att_rad,
        &init.bias_sigma_rad_s,
    );
    let dt = config.scenario.dt_gyro_s;
    let mut t_prev = sim.truth.first().map(|s| s.t_s).unwrap_or(0.0);
    let mut out = Vec::new();
    for m in &sim.measurements {
        let t = m.t_s();
        if t > t_prev {
            let omega = truth_at(sim, t_prev, dt).omega_rad_s;
            pcrb.propagate(&omega, t - t_prev);
            t_prev = t;
        }
        if let Measurement::Vectors(set) = m {
            let q_true = truth_at(sim, t, dt).q;
            for o in &set.observations {
                pcrb.observe(&q_true, &o.reference, o.sigma);
            }
            let s = pcrb.sigma_att_rad();
            out.push([s[0], s[1], s[2]]);
        }
    }
    out
}

fn truth_at(sim: &SimulatedRun, t_s: f64, dt_s: f64) -> &attitude_core::sim::scenario::TruthSample {
    let k = ((t_s - sim.truth[0].t_s) / dt_s).round().max(0.0) as usize;
    &sim.truth[k.min(sim.truth.len() - 1)]
}

fn run_one(config: &StudyConfig, run: usize) -> Vec<RunTrace> {
    let run_seed = derive_seed(config.seed, run as u64);
    let sim = simulate(&config.scenario, run_seed);
    if sim.truth.is_empty() {
        // Invalid parameters simulate to an empty run; callers validate first, but never panic here.
        let failed = RunTrace {
            failure: Some("the scenario produced no data (invalid parameters)".into()),
            ..RunTrace::default()
        };
        return vec![failed; config.filters.len()];
    }
    let pcrb = pcrb_along_truth(config, &sim);
    let epochs = pcrb.len();
    let stride = epochs.div_ceil(MAX_TRACE_POINTS).max(1);
    config
        .filters
        .iter()
        .map(|spec| {
            // Common random numbers: every filter of a run gets the same RNG seed, so comparisons
            // between filters (e.g. the two fiducials) are paired and do not depend on the order of
            // --filters.
            let filter_seed = derive_seed(run_seed, 1000);
            run_filter(config, spec, &sim, &pcrb, stride, filter_seed)
        })
        .collect()
}

fn run_filter(
    config: &StudyConfig,
    spec: &FilterSpec,
    sim: &SimulatedRun,
    pcrb: &[[f64; 3]],
    stride: usize,
    seed: u64,
) -> RunTrace {
    let mut trace = RunTrace::default();
    let mut filter_config = FilterConfig::new(*spec, config.scenario.gyro);
    filter_config.particles = config.particles;
    filter_config.level = config.level;
    let init = &sim.initial;
    let initial = InitialState {
        t_s: Some(sim.truth[0].t_s),
        q: init.q,
        sigma_att_rad: init.sigma_att_rad,
        bias_rad_s: init.bias_rad_s,
        bias_sigma_rad_s: init.bias_sigma_rad_s,
        uniform_attitude: init.uniform_attitude,
        covariance: None,
    };
    let mut filter = match build_filter(&filter_config, &initial, seed) {
        Ok(f) => f,
        Err(e) => {
            trace.failure = Some(e.to_string());
            return trace;
        }
    };
    let t0 = sim.truth[0].t_s;
    let duration = config.scenario.duration_s;
    let window_start = t0 + duration / 2.0;
    let converged_after = t0 + 0.75 * duration;
    let threshold = config.scenario.convergence_threshold_rad;
    let dt = config.scenario.dt_gyro_s;
    let mut last_above: Option<f64> = None;
    let mut first_epoch_after_above: Option<f64> = None;
    let mut epoch = 0usize;
    let mut wall = 0.0;
    for m in &sim.measurements {
        let start = Instant::now();
        let result = filter.process(m);
        wall += start.elapsed().as_secs_f64();
        if let Err(e) = result {
            if config.skip_refused {
                // The filter is as before the input (propagated to its time): go on.
                trace.refused += 1;
            } else {
                trace.failure = Some(format!("t = {} s: {e}", m.t_s()));
                break;
            }
        }
        let Measurement::Vectors(_) = m else { continue };
        let t = m.t_s();
        let est = filter.estimate();
        let truth = truth_at(sim, t, dt);
        let err = truth.q.small_angle_error(&est.q);
        let angle = truth.q.compose(&est.q.inverse()).angle();
        let sigma = est.sigma_att_rad();
        let bound = pcrb.get(epoch).copied().unwrap_or([f64::NAN; 3]);
        if !(angle <= threshold) {
            last_above = Some(t);
            first_epoch_after_above = None;
        } else if first_epoch_after_above.is_none() {
            first_epoch_after_above = Some(t);
        }
        if t >= window_start {
            trace.window_samples += 1;
            for i in 0..3 {
                trace.window_err_sq[i] += err[i] * err[i];
                trace.window_pcrb_var[i] += bound[i] * bound[i];
            }
            trace.window_nees_sum +=
                attitude_nees(&est.covariance.fixed_view::<3, 3>(0, 0).into_owned(), &err);
        }
        if epoch % stride == 0 {
            trace.t_s.push(t);
            trace.err_rad.push([err[0], err[1], err[2]]);
            trace.sigma_rad.push([sigma[0], sigma[1], sigma[2]]);
            trace.pcrb_rad.push(bound);
            trace.angle_rad.push(angle);
        }
        epoch += 1;
    }
    trace.steps = epoch;
    trace.wall_s = wall;
    let completed = trace.failure.is_none();
    trace.converged = completed && epoch > 0 && last_above.is_none_or(|t| t < converged_after);
    if trace.converged {
        // The first epoch of the final stretch below the threshold.
        trace.convergence_time_s = Some(first_epoch_after_above.unwrap_or(t0) - t0);
    }
    trace
}

/// `δαᵀ P⁻¹ δα` by a Cholesky solve; NaN when `P` is not positive definite.
fn attitude_nees(p: &Matrix3<f64>, err: &Vector3<f64>) -> f64 {
    match p.cholesky() {
        Some(c) => err.dot(&c.solve(err)),
        None => f64::NAN,
    }
}

/// The 95% interval of the ANEES of a 3-dof state over `n` runs: `χ²₃ₙ(0.025, 0.975)/n`.
pub fn anees_interval(n: usize) -> [f64; 2] {
    if n == 0 {
        return [f64::NAN, f64::NAN];
    }
    let k = 3.0 * n as f64;
    let bound = |p| chi_square_quantile(k, p).map_or(f64::NAN, |x| x / n as f64);
    [bound(0.025), bound(0.975)]
}

fn summarize(
    spec: &FilterSpec,
    particles: Option<usize>,
    level: Option<u8>,
    runs: &[RunTrace],
) -> FilterSummary {
    let converged: Vec<&RunTrace> = runs.iter().filter(|r| r.converged).collect();
    let pool: Vec<&RunTrace> = if converged.is_empty() {
        runs.iter().filter(|r| r.window_samples > 0).collect()
    } else {
        converged.clone()
    };
    let samples: usize = pool.iter().map(|r| r.window_samples).sum();
    let mut rms = [f64::NAN; 3];
    let mut bound = [f64::NAN; 3];
    let mut ratio = [f64::NAN; 3];
    let mut anees = f64::NAN;
    if samples > 0 {
        let n = samples as f64;
        for i in 0..3 {
            rms[i] = (pool.iter().map(|r| r.window_err_sq[i]).sum::<f64>() / n)
                .sqrt()
                .to_degrees();
            bound[i] = (pool.iter().map(|r| r.window_pcrb_var[i]).sum::<f64>() / n)
                .sqrt()
                .to_degrees();
            ratio[i] = rms[i] / bound[i];
        }
        anees = pool.iter().map(|r| r.window_nees_sum).sum::<f64>() / n;
    }
    let mut times: Vec<f64> = converged
        .iter()
        .filter_map(|r| r.convergence_time_s)
        .collect();
    times.sort_by(f64::total_cmp);
    let median = match times.len() {
        0 => None,
        n if n % 2 == 1 => Some(times[n / 2]),
        n => Some(0.5 * (times[n / 2 - 1] + times[n / 2])),
    };
    let steps: usize = runs.iter().map(|r| r.steps).sum();
    let wall: f64 = runs.iter().map(|r| r.wall_s).sum();
    FilterSummary {
        filter: spec.to_string(),
        kind: spec.kind.as_str().to_string(),
        fiducial: spec.fiducial.map(|f| f.as_str().to_string()),
        particles,
        level,
        runs: runs.len(),
        converged_runs: converged.len(),
        convergence_time_s: median,
        steady_rms_deg: rms,
        pcrb_deg: bound,
        rms_over_pcrb: ratio,
        anees,
        anees_interval: anees_interval(pool.len()),
        us_per_step: if steps > 0 {
            wall / steps as f64 * 1e6
        } else {
            f64::NAN
        },
        failed_runs: runs.iter().filter(|r| r.failure.is_some()).count(),
        refused_inputs: runs.iter().map(|r| r.refused).sum(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anees_interval_is_the_chi_square_interval_over_n() {
        // χ²₆₀ (tables): 2.5% = 40.482, 97.5% = 83.298, over 20 runs.
        let [lo, hi] = anees_interval(20);
        assert!(
            (lo - 2.0241).abs() < 1e-4 && (hi - 4.1649).abs() < 1e-4,
            "{lo} {hi}"
        );
        assert!(anees_interval(0).iter().all(|x| x.is_nan()));
    }
}
