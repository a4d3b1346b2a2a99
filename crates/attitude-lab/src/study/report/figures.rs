//! The figures of a study report: `errors_<label>.png`, `error_angle_<label>.png` and
//! `rms_vs_pcrb.png` (captions in [`super::write_report`]).

use super::{num, AngleUnit};
use crate::study::plot::{
    clip_polyline, clip_polyline_log, draw_header, log_range, pe, tick, time_range, LegendEntry,
    AXES, FONT, HEIGHT, PALETTE, WIDTH,
};
use crate::study::{FilterResult, RunTrace, StudyResult};
use plotters::prelude::*;
use std::path::Path;

fn get3(v: &[[f64; 3]], k: usize, axis: usize) -> f64 {
    v.get(k).map_or(f64::NAN, |x| x[axis])
}

/// `errors_<label>.png`: run 0's error per body axis with the filter's and the PCRB's ±3σ.
pub(super) fn plot_errors(
    path: &Path,
    study: &StudyResult,
    fr: &FilterResult,
    unit: AngleUnit,
) -> Result<bool, String> {
    let Some(run) = fr.runs.first() else {
        return Ok(false);
    };
    let n = run.t_s.len().min(run.err_rad.len());
    let t = &run.t_s[..n];
    let Some((t0, t1)) = time_range(t) else {
        return Ok(false);
    };
    let s = unit.per_rad();
    let t_mid = t0 + 0.5 * (t1 - t0);
    // Half-height of each panel: from the last half of the run, or the whole run if that has nothing.
    let mut half = [f64::NAN; 3];
    for (axis, h) in half.iter_mut().enumerate() {
        let extent = |k: usize| {
            [
                get3(&run.err_rad, k, axis).abs(),
                3.0 * get3(&run.sigma_rad, k, axis).abs(),
                3.0 * get3(&run.pcrb_rad, k, axis).abs(),
            ]
            .into_iter()
            .filter(|v| v.is_finite())
            .fold(f64::NAN, f64::max)
                * s
        };
        let steady = (0..n)
            .filter(|&k| t[k] >= t_mid)
            .map(extent)
            .fold(f64::NAN, f64::max);
        *h = if steady.is_finite() && steady > 0.0 {
            1.3 * steady
        } else {
            1.3 * (0..n).map(extent).fold(f64::NAN, f64::max)
        };
    }
    if half.iter().all(|h| !(h.is_finite() && *h > 0.0)) {
        return Ok(false);
    }

    let root = BitMapBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(pe)?;
    let err_color = PALETTE[0];
    let sigma_color = PALETTE[3];
    let legend = [
        LegendEntry::new("error (run 0)", err_color.to_rgba(), 2, false),
        LegendEntry::new("filter ±3σ", sigma_color.to_rgba(), 2, false),
        LegendEntry::new("PCRB ±3σ", BLACK.to_rgba(), 2, true),
    ];
    let title = format!(
        "{} — attitude error vs ±3σ, run 0 — scenario {}",
        fr.spec, study.scenario
    );
    let body = draw_header(&root, &title, &legend)?;
    let panels = body.split_evenly((3, 1));
    for (axis, panel) in panels.iter().enumerate() {
        let last = axis == 2;
        let h = if half[axis].is_finite() && half[axis] > 0.0 {
            half[axis]
        } else {
            1.0
        };
        let mut chart = ChartBuilder::on(panel)
            .margin_left(10)
            .margin_right(25)
            .margin_top(8)
            .margin_bottom(if last { 8 } else { 4 })
            .x_label_area_size(if last { 55 } else { 28 })
            .y_label_area_size(95)
            .build_cartesian_2d(t0..t1, -h..h)
            .map_err(pe)?;
        let mut mesh = chart.configure_mesh();
        mesh.label_style((FONT, 15))
            .axis_desc_style((FONT, 18))
            .light_line_style(RGBColor(238, 238, 238))
            .x_max_light_lines(1)
            .y_max_light_lines(4)
            .bold_line_style(RGBColor(215, 215, 215))
            .x_labels(12)
            .y_labels(6)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .y_desc(format!("{} error ({})", AXES[axis], unit.name));
        if last {
            mesh.x_desc("time (s)");
        }
        mesh.draw().map_err(pe)?;

        let xr = (t0, t1);
        let yr = (-h, h);
        let series = |v: &[[f64; 3]], sign: f64| {
            clip_polyline((0..n).map(|k| (t[k], sign * get3(v, k, axis) * s)), xr, yr)
        };
        let bound = |v: &[[f64; 3]], sign: f64| {
            clip_polyline(
                (0..n).map(|k| (t[k], sign * 3.0 * get3(v, k, axis).abs() * s)),
                xr,
                yr,
            )
        };
        for piece in series(&run.err_rad, 1.0) {
            chart
                .draw_series(LineSeries::new(piece, err_color.stroke_width(1)))
                .map_err(pe)?;
        }
        for sign in [1.0, -1.0] {
            for piece in bound(&run.sigma_rad, sign) {
                chart
                    .draw_series(LineSeries::new(piece, sigma_color.stroke_width(2)))
                    .map_err(pe)?;
            }
            for piece in bound(&run.pcrb_rad, sign) {
                chart
                    .draw_series(DashedLineSeries::new(piece, 10, 6, BLACK.stroke_width(2)))
                    .map_err(pe)?;
            }
        }
    }
    root.present().map_err(pe)?;
    Ok(true)
}

/// `error_angle_<label>.png`: the error angle of every run, their median and the threshold, log scale.
pub(super) fn plot_error_angle(
    path: &Path,
    study: &StudyResult,
    fr: &FilterResult,
) -> Result<bool, String> {
    let runs: Vec<&RunTrace> = fr
        .runs
        .iter()
        .filter(|r| r.t_s.len().min(r.angle_rad.len()) > 0)
        .collect();
    let all_t: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.t_s[..r.t_s.len().min(r.angle_rad.len())].iter().copied())
        .collect();
    let Some((t0, t1)) = time_range(&all_t) else {
        return Ok(false);
    };
    let angles: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.angle_rad.iter().map(|a| a.to_degrees()))
        .filter(|a| a.is_finite())
        .collect();
    if angles.is_empty() {
        return Ok(false);
    }
    let threshold_deg = study.convergence_threshold_rad.to_degrees();
    let mut range_values = angles;
    if threshold_deg.is_finite() && threshold_deg > 0.0 {
        range_values.push(threshold_deg);
    }
    // 1e-4 deg (or lower if the errors are) up to 180 deg (or less if the errors stay smaller).
    let Some((low, _)) = log_range(range_values.clone(), 9.0) else {
        return Ok(false);
    };
    let high = range_values.iter().copied().fold(f64::NAN, f64::max);
    let hi = 10f64.powf(high.log10().ceil()).min(180.0);
    let lo = low.min(1e-4).max(hi / 1e9);
    let clamp = |a: f64| a.clamp(lo, hi);

    let root = BitMapBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(pe)?;
    let mut legend = vec![
        LegendEntry::new(
            format!("each run ({})", runs.len()),
            PALETTE[0].mix(0.45),
            1,
            false,
        ),
        LegendEntry::new("median over runs", BLACK.to_rgba(), 2, false),
    ];
    let draw_threshold = threshold_deg.is_finite() && threshold_deg > 0.0;
    if draw_threshold {
        legend.push(LegendEntry::new(
            format!("convergence threshold ({}°)", num(threshold_deg)),
            PALETTE[3].to_rgba(),
            2,
            true,
        ));
    }
    let title = format!(
        "{} — error angle of every run — scenario {}",
        fr.spec, study.scenario
    );
    let body = draw_header(&root, &title, &legend)?;
    let mut chart = ChartBuilder::on(&body)
        .margin_left(10)
        .margin_right(25)
        .margin_top(8)
        .margin_bottom(8)
        .x_label_area_size(55)
        .y_label_area_size(95)
        .build_cartesian_2d(t0..t1, (lo..hi).log_scale())
        .map_err(pe)?;
    chart
        .configure_mesh()
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 18))
        .light_line_style(RGBColor(238, 238, 238))
        .x_max_light_lines(1)
        .y_max_light_lines(4)
        .bold_line_style(RGBColor(215, 215, 215))
        .x_labels(12)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .x_desc("time (s)")
        .y_desc("error angle (deg)")
        .draw()
        .map_err(pe)?;

    for (i, run) in runs.iter().enumerate() {
        let n = run.t_s.len().min(run.angle_rad.len());
        let color = if runs.len() > 10 {
            PALETTE[0].mix(0.3)
        } else {
            PALETTE[i % PALETTE.len()].mix(0.55)
        };
        let points = (0..n).map(|k| (run.t_s[k], clamp(run.angle_rad[k].to_degrees())));
        for piece in clip_polyline_log(points, (t0, t1), (lo, hi)) {
            chart
                .draw_series(LineSeries::new(piece, color.stroke_width(1)))
                .map_err(pe)?;
        }
    }
    // Median over the runs at each sample index (the runs share their time grid).
    if let Some(grid) = runs
        .iter()
        .max_by_key(|r| r.t_s.len().min(r.angle_rad.len()))
    {
        let n = grid.t_s.len().min(grid.angle_rad.len());
        let median = (0..n).map(|k| {
            let mut v: Vec<f64> = runs
                .iter()
                .filter_map(|r| r.angle_rad.get(k))
                .map(|a| a.to_degrees())
                .filter(|a| a.is_finite())
                .collect();
            if v.is_empty() {
                return (grid.t_s[k], f64::NAN);
            }
            v.sort_by(f64::total_cmp);
            let m = if v.len() % 2 == 1 {
                v[v.len() / 2]
            } else {
                0.5 * (v[v.len() / 2 - 1] + v[v.len() / 2])
            };
            (grid.t_s[k], clamp(m))
        });
        for piece in clip_polyline_log(median.collect::<Vec<_>>(), (t0, t1), (lo, hi)) {
            chart
                .draw_series(LineSeries::new(piece, BLACK.stroke_width(2)))
                .map_err(pe)?;
        }
    }
    if draw_threshold {
        let y = clamp(threshold_deg);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(t0, y), (t1, y)],
                12,
                8,
                PALETTE[3].stroke_width(2),
            ))
            .map_err(pe)?;
    }
    root.present().map_err(pe)?;
    Ok(true)
}

/// `rms_vs_pcrb.png`: per body axis, each filter's RMS over runs against the PCRB 1σ, log scale.
pub(super) fn plot_rms_vs_pcrb(
    path: &Path,
    study: &StudyResult,
    unit: AngleUnit,
) -> Result<bool, String> {
    let s = unit.per_rad();
    // Per filter: the time grid (its longest run) and the RMS over runs at each sample index.
    let mut curves: Vec<(String, Vec<f64>, Vec<[f64; 3]>)> = Vec::new();
    for fr in &study.filters {
        let len = |r: &RunTrace| r.t_s.len().min(r.err_rad.len());
        let Some(grid) = fr.runs.iter().max_by_key(|r| len(r)) else {
            continue;
        };
        let n = len(grid);
        if n == 0 {
            continue;
        }
        let rms: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let mut out = [f64::NAN; 3];
                for (axis, o) in out.iter_mut().enumerate() {
                    let (sum, count) = fr
                        .runs
                        .iter()
                        .filter(|r| k < len(r))
                        .map(|r| r.err_rad[k][axis] * s)
                        .filter(|e| e.is_finite())
                        .fold((0.0, 0usize), |(sum, c), e| (sum + e * e, c + 1));
                    if count > 0 {
                        *o = (sum / count as f64).sqrt();
                    }
                }
                out
            })
            .collect();
        curves.push((fr.spec.to_string(), grid.t_s[..n].to_vec(), rms));
    }
    // The PCRB from run 0 of the first filter that has one.
    let pcrb: Option<(Vec<f64>, Vec<[f64; 3]>)> = study
        .filters
        .iter()
        .filter_map(|f| f.runs.first())
        .find(|r| r.t_s.len().min(r.pcrb_rad.len()) > 0)
        .map(|r| {
            let n = r.t_s.len().min(r.pcrb_rad.len());
            let p = r.pcrb_rad[..n]
                .iter()
                .map(|v| [v[0].abs() * s, v[1].abs() * s, v[2].abs() * s])
                .collect();
            (r.t_s[..n].to_vec(), p)
        });

    let all_t: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.1.iter().copied())
        .chain(pcrb.iter().flat_map(|p| p.0.iter().copied()))
        .collect();
    let Some((t0, t1)) = time_range(&all_t) else {
        return Ok(false);
    };
    let mut ranges = [None; 3];
    for (axis, r) in ranges.iter_mut().enumerate() {
        let values: Vec<f64> = curves
            .iter()
            .flat_map(|c| c.2.iter().map(move |v| v[axis]))
            .chain(pcrb.iter().flat_map(|p| p.1.iter().map(move |v| v[axis])))
            .collect();
        *r = log_range(values, 6.0);
    }
    if ranges.iter().all(Option::is_none) {
        return Ok(false);
    }

    let root = BitMapBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(pe)?;
    let mut legend: Vec<LegendEntry> = curves
        .iter()
        .enumerate()
        .map(|(i, c)| {
            LegendEntry::new(
                format!("{} RMS", c.0),
                PALETTE[i % PALETTE.len()].to_rgba(),
                2,
                false,
            )
        })
        .collect();
    if pcrb.is_some() {
        legend.push(LegendEntry::new("PCRB 1σ", BLACK.to_rgba(), 2, true));
    }
    let title = format!(
        "RMS error over {} runs vs PCRB — scenario {}",
        study.runs, study.scenario
    );
    let body = draw_header(&root, &title, &legend)?;
    let panels = body.split_evenly((3, 1));
    for (axis, panel) in panels.iter().enumerate() {
        let last = axis == 2;
        let (lo, hi) = ranges[axis].unwrap_or((0.1, 1.0));
        let mut chart = ChartBuilder::on(panel)
            .margin_left(10)
            .margin_right(25)
            .margin_top(8)
            .margin_bottom(if last { 8 } else { 4 })
            .x_label_area_size(if last { 55 } else { 28 })
            .y_label_area_size(95)
            .build_cartesian_2d(t0..t1, (lo..hi).log_scale())
            .map_err(pe)?;
        let mut mesh = chart.configure_mesh();
        mesh.label_style((FONT, 15))
            .axis_desc_style((FONT, 18))
            .light_line_style(RGBColor(238, 238, 238))
            .x_max_light_lines(1)
            .y_max_light_lines(4)
            .bold_line_style(RGBColor(215, 215, 215))
            .x_labels(12)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .y_desc(format!("{} RMS error ({})", AXES[axis], unit.name));
        if last {
            mesh.x_desc("time (s)");
        }
        mesh.draw().map_err(pe)?;
        let clamp = |v: f64| v.max(lo);
        for (i, (_, t, rms)) in curves.iter().enumerate() {
            let points = t.iter().zip(rms).map(|(&t, v)| (t, clamp(v[axis])));
            for piece in clip_polyline_log(points, (t0, t1), (lo, hi)) {
                chart
                    .draw_series(LineSeries::new(
                        piece,
                        PALETTE[i % PALETTE.len()].stroke_width(2),
                    ))
                    .map_err(pe)?;
            }
        }
        if let Some((t, p)) = &pcrb {
            let points = t.iter().zip(p).map(|(&t, v)| (t, clamp(v[axis])));
            for piece in clip_polyline_log(points, (t0, t1), (lo, hi)) {
                chart
                    .draw_series(DashedLineSeries::new(piece, 10, 6, BLACK.stroke_width(2)))
                    .map_err(pe)?;
            }
        }
    }
    root.present().map_err(pe)?;
    Ok(true)
}
