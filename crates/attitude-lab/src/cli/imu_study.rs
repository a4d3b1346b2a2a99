//! `imu-study`: recorded IMU trials through the service's vehicle pipeline ([`crate::tools::imu_study`]),
//! scored, printed as a table or JSON; with `--tune`, the tuning by coordinate descent and leave-one-out.

use crate::tools::imu_study::{
    effective_config, load_config, objective, read_trial, start_point, study, table, trial_paths,
    Setup, Trial, TuneSpec, Tuner,
};
use anyhow::Result;
use attitude_core::filters::FilterSpec;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ImuStudyArgs {
    /// Trial files, or directories of them (*.trial).
    #[arg(required = true)]
    trials: Vec<PathBuf>,
    /// The service configuration the vehicles run.
    #[arg(long, default_value = "config/imu.json5")]
    config: PathBuf,
    /// Replace a configuration value: PATH=JSON, e.g. service.imu.acc.motion_gain=1.5 (repeatable).
    #[arg(long = "set")]
    sets: Vec<String>,
    /// The filter instead of the configuration's: mekf, usque[:…], qpf[:average|:propagated].
    #[arg(long)]
    filter: Option<FilterSpec>,
    /// Particles of a qpf.
    #[arg(long)]
    particles: Option<usize>,
    /// The vehicle id the trials run as (it seeds a particle filter, as a served vehicle's id does):
    /// another id, another draw of the particles.
    #[arg(long, default_value = "study")]
    vehicle: String,
    /// Print one JSON array instead of a table.
    #[arg(long)]
    json: bool,
    /// For a trial whose truth has its own frames (`align: both`): fit the alignment without this
    /// fraction of the samples, those with the largest error (e.g. 0.1; every sample is still scored).
    /// Default 0: the fit on every movement sample, as docs/recordings.md describes.
    #[arg(long, default_value_t = 0.0, value_parser = trim_fraction)]
    align_trim: f64,
    /// Write each trial's estimates, truth and pipeline state per sample to DIR/TRIAL.csv.
    #[arg(long)]
    series: Option<PathBuf>,
    /// Tune the parameters of this specification (e.g. config/imu-tuning.json5) by coordinate
    /// descent over all the trials, starting from the configuration's values; prints the values and
    /// the tuned table.
    #[arg(long)]
    tune: Option<PathBuf>,
    /// With --tune: also leave one out (tune on all trials but one, score that one, for each trial)
    /// and report every trial's held-out scores beside its in-sample ones.
    #[arg(long, requires = "tune")]
    loo: bool,
    /// With --tune: also leave one set out (the trials of a folder: tune on the other sets, score that
    /// one, for each set) and report every trial's held-out scores beside its in-sample ones.
    #[arg(long, requires = "tune")]
    loo_sets: bool,
    /// With --tune: write the whole result (values, tables, folds) to this JSON file.
    #[arg(long, requires = "tune")]
    out: Option<PathBuf>,
}

/// A fraction in [0, 0.5).
fn trim_fraction(s: &str) -> std::result::Result<f64, String> {
    let f: f64 = s.parse().map_err(|e| format!("{s}: {e}"))?;
    if (0.0..0.5).contains(&f) {
        Ok(f)
    } else {
        Err(format!(
            "{s}: the fraction left out of the fit must be in [0, 0.5)"
        ))
    }
}

/// `imu-study`: the trials scored (or tuned with `--tune`).
pub fn imu_study(args: ImuStudyArgs) -> Result<()> {
    let service = load_config(&args.config, &args.sets)?;
    let mut setup = Setup::new(&service, args.filter, args.particles);
    setup.vehicle = args.vehicle.clone();
    let mut trials = trial_paths(&args.trials)?
        .iter()
        .map(|p| read_trial(p))
        .collect::<Result<Vec<_>, _>>()?;
    for t in &mut trials {
        t.truth_model.align_trim = args.align_trim;
    }
    if let Some(spec_path) = &args.tune {
        return tune(&args, spec_path, &trials);
    }
    if let Some(dir) = &args.series {
        std::fs::create_dir_all(dir)?;
    }
    let results = study(&trials, &setup, args.series.as_deref());
    if args.json {
        println!("{}", serde_json::to_string(&results)?);
    } else {
        print!("{}", table(&results));
    }
    Ok(())
}

/// `imu-study --tune SPEC`: the tuned values, and with `--loo` every fold's held-out scores.
fn tune(args: &ImuStudyArgs, spec_path: &std::path::Path, trials: &[Trial]) -> Result<()> {
    let mut spec: TuneSpec = json5::from_str(&std::fs::read_to_string(spec_path)?)
        .map_err(|e| anyhow::anyhow!("{}: {e}", spec_path.display()))?;
    if let Some(r) = &spec.reference {
        let path = spec_path
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join(r);
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path)?)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        for t in trials {
            let at = &v[&t.name];
            if let (Some(total), Some(incl)) = (
                at["total_rmse_deg"].as_f64(),
                at["inclination_rmse_deg"].as_f64(),
            ) {
                spec.reference_scores.insert(t.name.clone(), (total, incl));
            }
        }
    }
    let mut tuner = Tuner::new(&args.config, &args.sets, &spec, trials, args.filter)?;
    let all: Vec<usize> = (0..trials.len()).collect();
    let start = start_point(&spec, &effective_config(&args.config)?);
    let values = |point: &[usize]| -> serde_json::Value {
        spec.parameters
            .iter()
            .zip(point)
            .map(|(p, &k)| (p.path.clone(), serde_json::json!(p.values[k])))
            .collect::<serde_json::Map<_, _>>()
            .into()
    };
    let start_scores = tuner.scores(&start)?;
    let tuned = tuner.descend(&start, &all)?;
    let tuned_scores = tuner.scores(&tuned)?;
    eprintln!(
        "tuned on all {} trials: objective {:.4} (start {:.4}), {} evaluations",
        trials.len(),
        objective(&spec, trials, &tuned_scores, &all),
        objective(&spec, trials, &start_scores, &all),
        tuner.evaluations
    );
    println!("{}", serde_json::to_string_pretty(&values(&tuned))?);
    let mut folds = Vec::new();
    if args.loo {
        for held in 0..trials.len() {
            let rest: Vec<usize> = all.iter().copied().filter(|&i| i != held).collect();
            let point = tuner.descend(&tuned, &rest)?;
            let s = tuner.scores(&point)?;
            eprintln!(
                "fold {held} ({}): held-out total {:.2}° incl {:.2}° (in-sample {:.2}° {:.2}°), {} evaluations so far",
                trials[held].name,
                s[held].total_rmse_deg,
                s[held].inclination_rmse_deg,
                tuned_scores[held].total_rmse_deg,
                tuned_scores[held].inclination_rmse_deg,
                tuner.evaluations
            );
            folds.push(serde_json::json!({
                "trial": trials[held].name,
                "values": values(&point),
                "held_out": s[held],
                "in_sample": tuned_scores[held],
            }));
        }
        println!("| trial | in-sample total ° | held-out total ° | in-sample incl. ° | held-out incl. ° | held-out tilt in 99% | held-out NEES med. |");
        println!("|---|---:|---:|---:|---:|---:|---:|");
        for f in &folds {
            let (i, h) = (&f["in_sample"], &f["held_out"]);
            println!(
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} | {:.2} |",
                f["trial"].as_str().unwrap_or(""),
                i["total_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                h["total_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                i["inclination_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                h["inclination_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                h["tilt_in99"].as_f64().unwrap_or(f64::NAN),
                h["tilt_nees_median"].as_f64().unwrap_or(f64::NAN),
            );
        }
    }
    let mut set_folds = Vec::new();
    if args.loo_sets {
        let mut sets: Vec<&str> = trials.iter().map(|t| t.set.as_str()).collect();
        sets.sort_unstable();
        sets.dedup();
        for held in &sets {
            let rest: Vec<usize> = all
                .iter()
                .copied()
                .filter(|&i| trials[i].set != *held)
                .collect();
            let point = tuner.descend(&tuned, &rest)?;
            let s = tuner.scores(&point)?;
            eprintln!(
                "set fold {held}: tuned on the other sets, {} evaluations so far",
                tuner.evaluations
            );
            let rows: Vec<serde_json::Value> = all
                .iter()
                .filter(|&&i| trials[i].set == *held)
                .map(|&i| {
                    serde_json::json!({
                        "trial": trials[i].name,
                        "held_out": s[i],
                        "in_sample": tuned_scores[i],
                        "reference": spec.reference_scores.get(&trials[i].name).map(|r| r.0),
                    })
                })
                .collect();
            set_folds.push(serde_json::json!({
                "set": held,
                "values": values(&point),
                "trials": rows,
            }));
        }
        println!("| set | trial | in-sample total ° | held-out total ° | reference total ° | held-out tilt in 99% | held-out 3-axis in 99% | held-out tilt NEES med. |");
        println!("|---|---|---:|---:|---:|---:|---:|---:|");
        for f in &set_folds {
            for r in f["trials"].as_array().into_iter().flatten() {
                let (i, h) = (&r["in_sample"], &r["held_out"]);
                println!(
                    "| {} | {} | {:.2} | {:.2} | {:.2} | {:.3} | {:.3} | {:.2} |",
                    f["set"].as_str().unwrap_or(""),
                    r["trial"].as_str().unwrap_or(""),
                    i["total_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                    h["total_rmse_deg"].as_f64().unwrap_or(f64::NAN),
                    r["reference"].as_f64().unwrap_or(f64::NAN),
                    h["tilt_in99"].as_f64().unwrap_or(f64::NAN),
                    h["att_in99"].as_f64().unwrap_or(f64::NAN),
                    h["tilt_nees_median"].as_f64().unwrap_or(f64::NAN),
                );
            }
        }
    }
    if let Some(out) = &args.out {
        let names: Vec<&str> = trials.iter().map(|t| t.name.as_str()).collect();
        let doc = serde_json::json!({
            "spec": spec,
            "config": args.config,
            "sets": args.sets,
            "trials": names,
            "start": values(&start),
            "start_scores": start_scores,
            "tuned": values(&tuned),
            "tuned_scores": tuned_scores,
            "folds": folds,
            "set_folds": set_folds,
            "evaluations": tuner.evaluations,
        });
        std::fs::write(out, serde_json::to_string_pretty(&doc)?)?;
    }
    Ok(())
}
