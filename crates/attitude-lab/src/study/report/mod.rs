//! The study report: `summary.json`, `study.json`, `summary.md` and PNG plots, see [`write_report`].
//! The figures are drawn in `figures` with the toolkit of `study::plot`.

mod figures;

use super::plot::run_plot;
use super::{FilterSummary, StudyResult};
use figures::{plot_error_angle, plot_errors, plot_rms_vs_pcrb};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a report could not be written. Every variant names the file and carries the underlying error.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReportError {
    #[error("cannot write {}: {message}", .path.display())]
    Io { path: PathBuf, message: String },
    #[error("cannot serialise {}: {message}", .path.display())]
    Json { path: PathBuf, message: String },
    #[error("cannot draw {}: {message}", .path.display())]
    Plot { path: PathBuf, message: String },
}

/// Writes the report of `study` into `dir` (created if needed) and returns the files written:
///
/// * `summary.json`: the list of [`FilterSummary`], one per filter, and nothing else;
/// * `study.json`: the study's metadata and the same summaries;
/// * `errors_<label>.png`, `error_angle_<label>.png` per filter (label: the spec with `:` replaced by
///   `_`) and `rms_vs_pcrb.png`; a plot without data is skipped;
/// * `summary.md`: the table of summaries, the definitions and the list of plots.
///
/// An I/O or serialisation error stops the report at once. A plot that fails to draw does not stop
/// the others nor the markdown (which notes the failure); the first such failure is returned once
/// every other file is written.
pub fn write_report(study: &StudyResult, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(|e| ReportError::Io {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut written = Vec::new();
    let summaries: Vec<&FilterSummary> = study.filters.iter().map(|f| &f.summary).collect();

    // 1. JSON.
    let path = dir.join("summary.json");
    let json = serde_json::to_string_pretty(&summaries).map_err(|e| ReportError::Json {
        path: path.clone(),
        message: e.to_string(),
    })?;
    write_file(&path, json.as_bytes())?;
    written.push(path);

    let path = dir.join("study.json");
    let meta = StudyMeta {
        scenario: &study.scenario,
        scenario_description: &study.scenario_description,
        seed: study.seed,
        runs: study.runs,
        duration_s: study.duration_s,
        convergence_threshold_deg: study.convergence_threshold_rad.to_degrees(),
        summaries: summaries.clone(),
    };
    let json = serde_json::to_string_pretty(&meta).map_err(|e| ReportError::Json {
        path: path.clone(),
        message: e.to_string(),
    })?;
    write_file(&path, json.as_bytes())?;
    written.push(path);

    // 2. Plots.
    let unit = AngleUnit::for_study(study);
    let labels = unique_labels(study);
    let mut plots: Vec<PlotOutcome> = Vec::new();
    for (fr, label) in study.filters.iter().zip(&labels) {
        let spec = fr.spec.to_string();
        let file = format!("errors_{label}.png");
        let outcome = run_plot(&dir.join(&file), |p| plot_errors(p, study, fr, unit));
        plots.push(PlotOutcome {
            file,
            caption: format!(
                "`{spec}`: run 0's attitude error about each body axis ({}) with the filter's ±3σ and \
                 the PCRB's ±3σ; the y range fits the last half of the run, so the initial transient is clipped.",
                unit.name
            ),
            outcome,
        });
        let file = format!("error_angle_{label}.png");
        let outcome = run_plot(&dir.join(&file), |p| plot_error_angle(p, study, fr));
        plots.push(PlotOutcome {
            file,
            caption: format!(
                "`{spec}`: error angle of every run (deg, log scale), their median and the convergence threshold."
            ),
            outcome,
        });
    }
    let file = "rms_vs_pcrb.png".to_string();
    let outcome = run_plot(&dir.join(&file), |p| plot_rms_vs_pcrb(p, study, unit));
    plots.push(PlotOutcome {
        file,
        caption: format!(
            "RMS over the runs of each body axis' error for every filter against the PCRB 1σ ({}, log scale).",
            unit.name
        ),
        outcome,
    });
    let mut first_plot_error = None;
    for p in &plots {
        match &p.outcome {
            Ok(true) => written.push(dir.join(&p.file)),
            Ok(false) => {}
            Err(message) => {
                if first_plot_error.is_none() {
                    first_plot_error = Some(ReportError::Plot {
                        path: dir.join(&p.file),
                        message: message.clone(),
                    });
                }
            }
        }
    }

    // 3. Markdown.
    let path = dir.join("summary.md");
    write_file(&path, markdown(study, unit, &plots).as_bytes())?;
    written.push(path);

    match first_plot_error {
        Some(e) => Err(e),
        None => Ok(written),
    }
}

/// The content of `study.json`.
#[derive(serde::Serialize)]
struct StudyMeta<'a> {
    scenario: &'a str,
    scenario_description: &'a str,
    seed: u64,
    runs: usize,
    duration_s: f64,
    convergence_threshold_deg: f64,
    summaries: Vec<&'a FilterSummary>,
}

/// A plot file, its caption, and whether it was written (`Ok(false)`: skipped for lack of data).
struct PlotOutcome {
    file: String,
    caption: String,
    outcome: Result<bool, String>,
}

pub(super) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    std::fs::write(path, bytes).map_err(|e| ReportError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// File labels: the spec with `:` replaced by `_`, made unique with `_2`, `_3`, … when two filters
/// share a spec.
fn unique_labels(study: &StudyResult) -> Vec<String> {
    let mut labels: Vec<String> = Vec::new();
    for fr in &study.filters {
        let base = fr.spec.to_string().replace(':', "_");
        let mut label = base.clone();
        let mut n = 2;
        while labels.contains(&label) {
            label = format!("{base}_{n}");
            n += 1;
        }
        labels.push(label);
    }
    labels
}

// ---------------------------------------------------------------------------------------------
// Units and number formatting.

/// The unit of the small angles of a report: arcsec when the PCRB is below 0.1°, degrees otherwise.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AngleUnit {
    name: &'static str,
    per_deg: f64,
}

impl AngleUnit {
    const DEG: AngleUnit = AngleUnit {
        name: "deg",
        per_deg: 1.0,
    };
    const ARCSEC: AngleUnit = AngleUnit {
        name: "arcsec",
        per_deg: 3600.0,
    };

    fn per_rad(&self) -> f64 {
        self.per_deg.to_degrees()
    }

    /// Arcsec when the largest PCRB of the summaries (or, when they have none, the median PCRB of the
    /// traces' last halves) is below 0.1°.
    fn for_study(study: &StudyResult) -> AngleUnit {
        let mut pcrb_deg = study
            .filters
            .iter()
            .flat_map(|f| f.summary.pcrb_deg)
            .filter(|v| v.is_finite() && *v > 0.0)
            .fold(f64::NAN, f64::max);
        if pcrb_deg.is_nan() {
            let mut values: Vec<f64> = Vec::new();
            for run in study.filters.iter().filter_map(|f| f.runs.first()) {
                let n = run.pcrb_rad.len();
                values.extend(
                    run.pcrb_rad[n / 2..]
                        .iter()
                        .flatten()
                        .map(|v| v.to_degrees()),
                );
            }
            values.retain(|v| v.is_finite() && *v > 0.0);
            values.sort_by(f64::total_cmp);
            if !values.is_empty() {
                pcrb_deg = values[values.len() / 2];
            }
        }
        if pcrb_deg < 0.1 {
            AngleUnit::ARCSEC
        } else {
            AngleUnit::DEG
        }
    }
}

/// About three significant digits; `—` for a non-finite value.
fn num(v: f64) -> String {
    if !v.is_finite() {
        return "—".to_string();
    }
    let a = v.abs();
    if a == 0.0 {
        "0".to_string()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.2e}")
    } else {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.decimals$}")
    }
}

fn triple(v: [f64; 3], scale: f64) -> String {
    format!(
        "{} / {} / {}",
        num(v[0] * scale),
        num(v[1] * scale),
        num(v[2] * scale)
    )
}

// ---------------------------------------------------------------------------------------------
// Markdown.

/// The definitions, copied from the doc comment of `study/mod.rs` at compile time.
fn definitions() -> String {
    const MODULE: &str = include_str!("../mod.rs");
    let doc: Vec<&str> = MODULE
        .lines()
        .take_while(|l| l.starts_with("//!"))
        .map(|l| {
            let l = &l[3..];
            l.strip_prefix(' ').unwrap_or(l)
        })
        .collect();
    let start = doc.iter().position(|l| l.contains("Definitions"));
    let body: Vec<&str> = match start {
        Some(i) => doc[i + 1..].to_vec(),
        None => Vec::new(),
    };
    let body = body.join("\n").trim().to_string();
    if body.is_empty() {
        "See the documentation of the `study` module and `docs/montecarlo.md`.".to_string()
    } else {
        body
    }
}

fn markdown(study: &StudyResult, unit: AngleUnit, plots: &[PlotOutcome]) -> String {
    let mut md = String::new();
    let u = unit.name;
    let _ = writeln!(
        md,
        "# Monte-Carlo study `{}` (seed {}, {} runs)\n",
        study.scenario, study.seed, study.runs
    );
    let _ = writeln!(md, "## Scenario\n");
    let description = study.scenario_description.trim();
    if !description.is_empty() {
        let _ = writeln!(md, "{description}\n");
    }
    let _ = writeln!(
        md,
        "Duration {} s per run; convergence threshold {}°.\n",
        num(study.duration_s),
        num(study.convergence_threshold_rad.to_degrees())
    );

    let _ = writeln!(md, "## Results\n");
    if study.filters.is_empty() {
        let _ = writeln!(md, "No filter was run.\n");
    } else {
        let unit_note = if unit == AngleUnit::ARCSEC {
            "Angles in arcsec (the PCRB is below 0.1°)."
        } else {
            "Angles in degrees."
        };
        let _ = writeln!(
            md,
            "{unit_note} Steady-state values over the last half of the runs, per body axis x / y / z.\n"
        );
        let _ = writeln!(
            md,
            "| filter | particles / level | converged | convergence time (s) | steady RMS x/y/z ({u}) | PCRB x/y/z ({u}) | RMS/PCRB x/y/z | ANEES [95% interval] | µs/step |"
        );
        let _ = writeln!(md, "|---|--:|--:|--:|--:|--:|--:|--:|--:|");
        let mut any_outside = false;
        for fr in &study.filters {
            let s = &fr.summary;
            let particles = match (s.particles.or(fr.particles), s.level.or(fr.level)) {
                (Some(p), _) => p.to_string(),
                (None, Some(l)) => format!("L = {l}"),
                (None, None) => "—".to_string(),
            };
            let mut converged = format!("{}/{}", s.converged_runs, s.runs);
            if s.failed_runs > 0 {
                let _ = write!(converged, " ({} failed)", s.failed_runs);
            }
            if s.refused_inputs > 0 {
                let _ = write!(converged, " ({} inputs refused)", s.refused_inputs);
            }
            let convergence = s.convergence_time_s.map_or("—".to_string(), num);
            let [lo, hi] = s.anees_interval;
            let outside = s.anees.is_finite()
                && lo.is_finite()
                && hi.is_finite()
                && (s.anees < lo || s.anees > hi);
            any_outside |= outside;
            let anees = if outside {
                format!("**{}** ⚠ [{}, {}]", num(s.anees), num(lo), num(hi))
            } else {
                format!("{} [{}, {}]", num(s.anees), num(lo), num(hi))
            };
            let _ = writeln!(
                md,
                "| `{}` | {} | {} | {} | {} | {} | {} | {} | {} |",
                fr.spec,
                particles,
                converged,
                convergence,
                triple(s.steady_rms_deg, unit.per_deg),
                triple(s.pcrb_deg, unit.per_deg),
                triple(s.rms_over_pcrb, 1.0),
                anees,
                num(s.us_per_step)
            );
        }
        md.push('\n');
        if any_outside {
            let _ = writeln!(
                md,
                "⚠ ANEES outside its 95% interval: the filter's covariance does not match its errors \
                 (above: overconfident, below: conservative).\n"
            );
        }
    }

    let _ = writeln!(md, "## Definitions\n");
    let _ = writeln!(md, "{}\n", definitions());

    let _ = writeln!(md, "## Plots\n");
    for p in plots {
        match &p.outcome {
            Ok(true) => {
                let _ = writeln!(
                    md,
                    "- [`{f}`]({f}): {c}\n\n  ![{f}]({f})\n",
                    f = p.file,
                    c = p.caption
                );
            }
            Ok(false) => {
                let _ = writeln!(md, "- `{}`: not drawn, no data.\n", p.file);
            }
            Err(e) => {
                let _ = writeln!(md, "- `{}`: failed: {}\n", p.file, e);
            }
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::plot::tick;
    use crate::study::{FilterResult, RunTrace};
    use attitude_core::filters::FilterSpec;

    fn unique_dir(tag: &str) -> PathBuf {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        std::env::temp_dir().join(format!(
            "attitude_report_{tag}_{}_{nanos}",
            std::process::id()
        ))
    }

    /// A deterministic "noise" in [-1, 1].
    fn noise(i: usize, j: usize, axis: usize) -> f64 {
        let x = (i * 7919 + j * 104_729 + axis * 1_299_709) as f64;
        (x * 12.9898).sin() * 0.5 + (x * 0.618_033_988_7).sin() * 0.5
    }

    fn summary(
        filter: &str,
        kind: &str,
        fiducial: Option<&str>,
        particles: Option<usize>,
        anees: f64,
    ) -> FilterSummary {
        FilterSummary {
            filter: filter.to_string(),
            kind: kind.to_string(),
            fiducial: fiducial.map(str::to_string),
            particles,
            level: None,
            runs: 3,
            converged_runs: 3,
            convergence_time_s: Some(21.5),
            steady_rms_deg: [0.0014, 0.0015, 0.0013],
            pcrb_deg: [0.0012, 0.0013, 0.0012],
            rms_over_pcrb: [1.17, 1.15, 1.08],
            anees,
            anees_interval: [2.26, 3.83],
            us_per_step: 123.4,
            failed_runs: 0,
            refused_inputs: 0,
        }
    }

    fn run(j: usize, n: usize, quality: f64) -> RunTrace {
        let arcsec = 1.0_f64.to_radians() / 3600.0;
        let mut r = RunTrace::default();
        for i in 0..n {
            let t = i as f64;
            // A huge initial transient (160°) decaying to a few arcsec.
            let transient = 160f64.to_radians() * (-t / 4.0).exp();
            let pcrb = 4.0 * arcsec * (1.0 + 20.0 * (-t / 10.0).exp());
            let sigma = quality * pcrb + transient;
            let err: [f64; 3] = std::array::from_fn(|a| {
                transient * if a == 0 { 1.0 } else { 0.3 } + quality * 4.0 * arcsec * noise(i, j, a)
            });
            r.t_s.push(t);
            r.err_rad.push(err);
            r.sigma_rad.push([sigma; 3]);
            r.pcrb_rad.push([pcrb, 1.1 * pcrb, 0.9 * pcrb]);
            r.angle_rad
                .push((err[0] * err[0] + err[1] * err[1] + err[2] * err[2]).sqrt());
        }
        if j == 1 {
            r.err_rad[50][1] = f64::NAN;
            r.angle_rad[50] = f64::NAN;
        }
        r.converged = true;
        r.convergence_time_s = Some(20.0);
        r
    }

    fn study() -> StudyResult {
        let mekf: FilterSpec = "mekf".parse().unwrap();
        let qpf: FilterSpec = "qpf:average".parse().unwrap();
        StudyResult {
            scenario: "tumbling".to_string(),
            scenario_description: "Tumbling at 3°/s, star tracker 5 arcsec, gyro ARW 0.01°/√h."
                .to_string(),
            seed: 42,
            runs: 3,
            duration_s: 200.0,
            convergence_threshold_rad: 1f64.to_radians(),
            filters: vec![
                FilterResult {
                    spec: mekf,
                    particles: None,
                    level: None,
                    runs: (0..3).map(|j| run(j, 200, 1.0)).collect(),
                    summary: summary("mekf", "mekf", None, None, 3.1),
                },
                FilterResult {
                    spec: qpf,
                    particles: Some(500),
                    level: None,
                    runs: (0..3).map(|j| run(j + 3, 200, 1.5)).collect(),
                    summary: summary("qpf:average", "qpf", Some("average"), Some(500), 6.7),
                },
            ],
        }
    }

    #[test]
    fn writes_every_file() {
        let study = study();
        let dir = unique_dir("full");
        let files = write_report(&study, &dir).expect("report written");
        let names = [
            "summary.json",
            "study.json",
            "summary.md",
            "errors_mekf.png",
            "errors_qpf_average.png",
            "error_angle_mekf.png",
            "error_angle_qpf_average.png",
            "rms_vs_pcrb.png",
        ];
        for name in names {
            let path = dir.join(name);
            assert!(files.contains(&path), "{name} not reported");
            assert!(path.is_file(), "{name} not written");
            if name.ends_with(".png") {
                let size = std::fs::metadata(&path).unwrap().len();
                assert!(size > 10_000, "{name} is only {size} bytes");
            }
        }
        assert_eq!(files.len(), names.len());

        let json = std::fs::read_to_string(dir.join("summary.json")).unwrap();
        let back: Vec<FilterSummary> = serde_json::from_str(&json).unwrap();
        let expected: Vec<FilterSummary> =
            study.filters.iter().map(|f| f.summary.clone()).collect();
        assert_eq!(back, expected);

        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("study.json")).unwrap())
                .unwrap();
        assert_eq!(meta["seed"], 42);
        assert_eq!(meta["scenario"], "tumbling");
        assert!((meta["convergence_threshold_deg"].as_f64().unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(meta["summaries"].as_array().unwrap().len(), 2);

        let md = std::fs::read_to_string(dir.join("summary.md")).unwrap();
        for label in ["mekf", "qpf:average"] {
            assert!(
                md.contains(&format!("`{label}`")),
                "summary.md lacks {label}"
            );
        }
        assert!(md.contains("arcsec"));
        assert!(md.contains("## Definitions"));
        assert!(md.contains("steady window"));
        assert!(md.contains("![errors_qpf_average.png](errors_qpf_average.png)"));
        // The QPF's ANEES (6.7) is outside [2.26, 3.83], the MEKF's (3.1) is not.
        assert_eq!(
            md.matches('⚠').count(),
            2,
            "one mark in the table, one in the note"
        );
        assert!(md.contains("**6.70** ⚠"));

        if std::env::var_os("ATTITUDE_REPORT_KEEP").is_some() {
            eprintln!("report kept in {}", dir.display());
        } else {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    #[test]
    fn empty_and_degenerate_inputs_do_not_panic() {
        let mut study = study();
        let mekf: FilterSpec = "mekf".parse().unwrap();
        let usque: FilterSpec = "usque:propagated".parse().unwrap();
        let nan = RunTrace {
            t_s: vec![0.0, 1.0, 2.0],
            err_rad: vec![[f64::NAN; 3]; 3],
            sigma_rad: vec![[f64::NAN; 3]; 3],
            pcrb_rad: vec![[f64::NAN; 3]; 3],
            angle_rad: vec![f64::NAN; 3],
            ..RunTrace::default()
        };
        let mut s = summary(
            "usque:propagated",
            "usque",
            Some("propagated"),
            None,
            f64::NAN,
        );
        s.runs = 0;
        s.converged_runs = 0;
        s.convergence_time_s = None;
        study.filters = vec![
            FilterResult {
                spec: usque,
                particles: None,
                level: None,
                runs: Vec::new(),
                summary: s.clone(),
            },
            FilterResult {
                spec: mekf,
                particles: None,
                level: None,
                runs: vec![nan, RunTrace::default()],
                summary: summary("mekf", "mekf", None, None, 3.0),
            },
            FilterResult {
                spec: mekf,
                particles: None,
                level: None,
                runs: vec![RunTrace::default()],
                summary: summary("mekf", "mekf", None, None, 3.0),
            },
        ];
        let dir = unique_dir("empty");
        let files = write_report(&study, &dir).expect("report written");
        for name in ["summary.json", "study.json", "summary.md"] {
            assert!(dir.join(name).is_file(), "{name} not written");
        }
        assert_eq!(files.len(), 3, "no plot has data: {files:?}");
        let md = std::fs::read_to_string(dir.join("summary.md")).unwrap();
        assert!(md.contains("`usque:propagated`"));
        assert!(md.contains("not drawn, no data"));
        assert!(
            md.contains("errors_mekf_2.png"),
            "duplicate specs get distinct files"
        );
        let _ = std::fs::remove_dir_all(&dir);

        // No filter at all.
        study.filters.clear();
        let dir = unique_dir("none");
        let files = write_report(&study, &dir).expect("report written");
        assert_eq!(files.len(), 3);
        let back: Vec<FilterSummary> =
            serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap())
                .unwrap();
        assert!(back.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn number_formats() {
        assert_eq!(num(f64::NAN), "—");
        assert_eq!(num(123.4), "123");
        assert_eq!(num(1.234), "1.23");
        assert_eq!(num(0.01234), "0.0123");
        assert_eq!(tick(0.0125), "0.0125");
        assert_eq!(tick(1500.0), "1500");
        assert_eq!(tick(1e-5), "1e-5");
        assert_eq!(tick(-2.5), "-2.5");
    }
}
