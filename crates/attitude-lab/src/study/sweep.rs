//! Particle-count sweep: the same study at several particle counts, reported as accuracy (RMS/PCRB),
//! convergence and cost per step against N.

use super::plot::{draw_header, pe, run_plot, LegendEntry, AXES, FONT, HEIGHT, PALETTE, WIDTH};
use super::report::{write_file, ReportError};
use super::runner::{run_study, StudyConfig};
use super::FilterSummary;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One row per particle count (the summary of the single filter of `config`).
pub fn run_sweep(
    config: &StudyConfig,
    particle_counts: &[usize],
    on_run_done: &(dyn Fn() + Sync),
) -> Vec<FilterSummary> {
    particle_counts
        .iter()
        .filter_map(|&n| {
            let mut c = config.clone();
            c.particles = n;
            let study = run_study(&c, on_run_done);
            study.filters.into_iter().next().map(|f| f.summary)
        })
        .collect()
}

/// Writes `sweep.json` (the rows), `sweep.md` (a table) and `sweep.png` (RMS/PCRB and µs/step vs N).
pub fn write_sweep_report(
    scenario: &str,
    seed: u64,
    rows: &[FilterSummary],
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(|e| ReportError::Io {
        path: dir.to_path_buf(),
        message: e.to_string(),
    })?;
    let json_path = dir.join("sweep.json");
    let json = serde_json::to_string_pretty(rows).map_err(|e| ReportError::Json {
        path: json_path.clone(),
        message: e.to_string(),
    })?;
    write_file(&json_path, json.as_bytes())?;
    let png_path = dir.join("sweep.png");
    let plotted = run_plot(&png_path, |p| plot_sweep(p, scenario, rows));
    let md_path = dir.join("sweep.md");
    write_file(
        &md_path,
        markdown(scenario, seed, rows, &plotted).as_bytes(),
    )?;
    let mut files = vec![json_path, md_path];
    match plotted {
        Ok(true) => files.push(png_path),
        Ok(false) => {}
        Err(message) => {
            return Err(ReportError::Plot {
                path: png_path,
                message,
            })
        }
    }
    Ok(files)
}

fn markdown(
    scenario: &str,
    seed: u64,
    rows: &[FilterSummary],
    plotted: &Result<bool, String>,
) -> String {
    let mut md = String::new();
    let filter = rows.first().map(|r| r.filter.as_str()).unwrap_or("?");
    let runs = rows.first().map(|r| r.runs).unwrap_or(0);
    let _ = writeln!(
        md,
        "# Particle-count sweep of `{filter}` on `{scenario}` (seed {seed}, {runs} runs per row)\n"
    );
    let _ = writeln!(md, "| particles | converged | convergence time (s) | RMS/PCRB x / y / z | ANEES [95% interval] | µs/step | µs/step/particle |");
    let _ = writeln!(md, "|--:|--:|--:|--:|--:|--:|--:|");
    for r in rows {
        let n = r.particles.unwrap_or(0);
        let _ =
            writeln!(
            md,
            "| {n} | {}/{} | {} | {:.2} / {:.2} / {:.2} | {:.2} [{:.2}, {:.2}] | {:.0} | {:.3} |",
            r.converged_runs,
            r.runs,
            r.convergence_time_s.map(|t| format!("{t:.0}")).unwrap_or_else(|| "—".into()),
            r.rms_over_pcrb[0],
            r.rms_over_pcrb[1],
            r.rms_over_pcrb[2],
            r.anees,
            r.anees_interval[0],
            r.anees_interval[1],
            r.us_per_step,
            r.us_per_step / n.max(1) as f64,
        );
    }
    match plotted {
        Ok(true) => {
            let _ = writeln!(md, "\n![sweep.png](sweep.png)\n\n`sweep.png`: RMS/PCRB per axis (top) and cost per step (bottom) against the particle count.");
        }
        Ok(false) => {
            let _ = writeln!(md, "\n(sweep.png not drawn: no data)");
        }
        Err(e) => {
            let _ = writeln!(md, "\n(sweep.png failed: {e})");
        }
    }
    md
}

fn plot_sweep(path: &Path, scenario: &str, rows: &[FilterSummary]) -> Result<bool, String> {
    let pts: Vec<(f64, [f64; 3], f64)> = rows
        .iter()
        .filter_map(|r| Some((r.particles? as f64, r.rms_over_pcrb, r.us_per_step)))
        .filter(|(n, _, c)| *n > 0.0 && c.is_finite())
        .collect();
    if pts.len() < 2 {
        return Ok(false);
    }
    // Log axes as linear axes of log10 with formatted labels: plotters' log scale labels too sparsely.
    let n_lo = (pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min) * 0.8).log10();
    let n_hi = (pts.iter().map(|p| p.0).fold(0.0, f64::max) * 1.25).log10();
    let ratio_max = pts
        .iter()
        .flat_map(|p| p.1)
        .filter(|v| v.is_finite())
        .fold(1.5f64, f64::max)
        .min(20.0)
        * 1.1;
    let c_lo = (pts.iter().map(|p| p.2).fold(f64::INFINITY, f64::min) * 0.7).log10();
    let c_hi = (pts.iter().map(|p| p.2).fold(0.0, f64::max) * 1.4).log10();
    let pow10 = |v: &f64| format!("{:.0}", 10f64.powf(*v));
    let root = BitMapBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(pe)?;
    let filter = rows.first().map(|r| r.filter.clone()).unwrap_or_default();
    let mut legend: Vec<LegendEntry> = AXES
        .iter()
        .enumerate()
        .map(|(i, a)| LegendEntry::new(format!("RMS/PCRB {a}"), PALETTE[i].to_rgba(), 3, false))
        .collect();
    legend.push(LegendEntry::new("µs per step", BLACK.to_rgba(), 3, false));
    let body = draw_header(
        &root,
        &format!("{filter} — particle-count sweep — scenario {scenario}"),
        &legend,
    )?;
    let panels = body.split_evenly((2, 1));
    let mut top = ChartBuilder::on(&panels[0])
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(n_lo..n_hi, 0.0..ratio_max)
        .map_err(pe)?;
    top.configure_mesh()
        .x_labels(12)
        .x_label_formatter(&pow10)
        .x_desc("particles (log scale)")
        .y_desc("steady RMS / PCRB")
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .draw()
        .map_err(pe)?;
    top.draw_series(LineSeries::new(
        vec![(n_lo, 1.0), (n_hi, 1.0)],
        BLACK.stroke_width(1),
    ))
    .map_err(pe)?;
    for axis in 0..3 {
        let color = PALETTE[axis];
        let line: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.1[axis].is_finite())
            .map(|p| (p.0.log10(), p.1[axis].min(ratio_max)))
            .collect();
        top.draw_series(LineSeries::new(line.clone(), color.stroke_width(3)))
            .map_err(pe)?;
        top.draw_series(
            line.iter()
                .map(|&(x, y)| Circle::new((x, y), 5, color.filled())),
        )
        .map_err(pe)?;
    }
    let mut bottom = ChartBuilder::on(&panels[1])
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(n_lo..n_hi, c_lo..c_hi)
        .map_err(pe)?;
    bottom
        .configure_mesh()
        .x_labels(12)
        .x_label_formatter(&pow10)
        .y_labels(10)
        .y_label_formatter(&pow10)
        .x_desc("particles (log scale)")
        .y_desc("µs per step (log scale)")
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .draw()
        .map_err(pe)?;
    let cost: Vec<(f64, f64)> = pts.iter().map(|p| (p.0.log10(), p.2.log10())).collect();
    bottom
        .draw_series(LineSeries::new(cost.clone(), BLACK.stroke_width(3)))
        .map_err(pe)?;
    bottom
        .draw_series(
            cost.iter()
                .map(|&(x, y)| Circle::new((x, y), 5, BLACK.filled())),
        )
        .map_err(pe)?;
    root.present().map_err(pe)?;
    Ok(true)
}
