//! The study report: `summary.json`, `study.json`, `summary.md` and PNG plots, see [`write_report`].
//!
//! Plots are drawn with `plotters` on a bitmap backend. No system fonts are assumed: the bundled
//! DejaVu Sans is registered once as the `sans-serif` family before anything is drawn.

use super::{FilterResult, FilterSummary, RunTrace, StudyResult};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
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

/// An axis tick: up to four significant digits without trailing zeros, scientific when very large or
/// very small.
fn tick(v: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    let a = v.abs();
    if a < 1e-12 {
        return "0".to_string();
    }
    if !(1e-4..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        return match s.split_once('e') {
            Some((m, e)) => {
                let m = if m.contains('.') {
                    m.trim_end_matches('0').trim_end_matches('.')
                } else {
                    m
                };
                format!("{m}e{e}")
            }
            None => s,
        };
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

// ---------------------------------------------------------------------------------------------
// Markdown.

/// The definitions, copied from the doc comment of `study/mod.rs` at compile time.
fn definitions() -> String {
    const MODULE: &str = include_str!("mod.rs");
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
            "| filter | particles | converged | convergence time (s) | steady RMS x/y/z ({u}) | PCRB x/y/z ({u}) | RMS/PCRB x/y/z | ANEES [95% interval] | µs/step |"
        );
        let _ = writeln!(md, "|---|--:|--:|--:|--:|--:|--:|--:|--:|");
        let mut any_outside = false;
        for fr in &study.filters {
            let s = &fr.summary;
            let particles = s
                .particles
                .or(fr.particles)
                .map_or("—".to_string(), |p| p.to_string());
            let mut converged = format!("{}/{}", s.converged_runs, s.runs);
            if s.failed_runs > 0 {
                let _ = write!(converged, " ({} failed)", s.failed_runs);
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

// ---------------------------------------------------------------------------------------------
// Plot helpers.

pub(super) const WIDTH: u32 = 1200;
pub(super) const HEIGHT: u32 = 900;
pub(super) const FONT: &str = "sans-serif";
pub(super) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];
pub(super) const AXES: [&str; 3] = ["x", "y", "z"];

/// Registers the bundled font as `sans-serif` (once per process).
fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(
            FONT,
            plotters::style::FontStyle::Normal,
            include_bytes!("../../assets/fonts/DejaVuSans.ttf"),
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the bundled font assets/fonts/DejaVuSans.ttf could not be loaded".to_string())
    }
}

/// Draws one plot: registers the font, turns a panic into an error, removes a partial file on error.
pub(super) fn run_plot(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<bool, String>,
) -> Result<bool, String> {
    ensure_font()?;
    let result = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| draw(path))) {
        Ok(r) => r,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(format!("plotting panicked: {message}"))
        }
    };
    if result.is_err() {
        let _ = std::fs::remove_file(path);
    }
    result
}

pub(super) fn pe<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// One entry of a plot's legend.
pub(super) struct LegendEntry {
    label: String,
    color: RGBAColor,
    width: u32,
    dashed: bool,
}

impl LegendEntry {
    pub(super) fn new(
        label: impl Into<String>,
        color: RGBAColor,
        width: u32,
        dashed: bool,
    ) -> Self {
        LegendEntry {
            label: label.into(),
            color,
            width,
            dashed,
        }
    }
}

/// Draws the title and a horizontal legend (wrapped over several rows if needed) at the top of `root`
/// and returns the area below them, so the legend never hides data.
pub(super) fn draw_header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    legend: &[LegendEntry],
) -> Result<DrawingArea<DB, Shift>, String> {
    let (w, _) = root.dim_in_pixel();
    let w = w as i32;
    let title_style = TextStyle::from((FONT, 26).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Center));
    let legend_style = TextStyle::from((FONT, 17).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    const LINE: i32 = 36;
    const GAP: i32 = 8;
    const SPACING: i32 = 28;
    const ROW: i32 = 26;
    const TITLE_H: i32 = 44;

    // Lay the entries out in rows.
    let mut rows: Vec<Vec<(usize, i32)>> = vec![Vec::new()];
    let mut row_width = 0;
    for (i, e) in legend.iter().enumerate() {
        let (tw, _) = root
            .estimate_text_size(&e.label, &legend_style)
            .map_err(pe)?;
        let item = LINE + GAP + tw as i32;
        let needed = if row_width == 0 {
            item
        } else {
            row_width + SPACING + item
        };
        if row_width > 0 && needed > w - 40 {
            rows.push(Vec::new());
            row_width = item;
        } else {
            row_width = needed;
        }
        rows.last_mut().expect("one row at least").push((i, item));
    }
    let n_rows = if legend.is_empty() {
        0
    } else {
        rows.len() as i32
    };
    let header_h = TITLE_H + n_rows * ROW + if n_rows > 0 { 8 } else { 0 };
    let (header, rest) = root.split_vertically(header_h);
    header
        .draw(&Text::new(
            title.to_string(),
            (w / 2, TITLE_H / 2 + 2),
            title_style,
        ))
        .map_err(pe)?;
    for (r, row) in rows.iter().enumerate().take(n_rows as usize) {
        let total: i32 =
            row.iter().map(|(_, iw)| iw).sum::<i32>() + SPACING * (row.len() as i32 - 1);
        let mut x = (w - total) / 2;
        let y = TITLE_H + r as i32 * ROW + ROW / 2;
        for &(i, item) in row {
            let e = &legend[i];
            let style = ShapeStyle::from(&e.color).stroke_width(e.width.max(1));
            if e.dashed {
                for k in 0..3 {
                    let x0 = x + k * 14;
                    header
                        .draw(&PathElement::new(vec![(x0, y), (x0 + 8, y)], style))
                        .map_err(pe)?;
                }
            } else {
                header
                    .draw(&PathElement::new(vec![(x, y), (x + LINE, y)], style))
                    .map_err(pe)?;
            }
            header
                .draw(&Text::new(
                    e.label.clone(),
                    (x + LINE + GAP, y),
                    legend_style.clone(),
                ))
                .map_err(pe)?;
            x += item + SPACING;
        }
    }
    Ok(rest)
}

/// Splits a polyline at non-finite points and clips it to the rectangle `x` × `y`, returning the
/// visible pieces (each with two points at least).
fn clip_polyline(
    points: impl IntoIterator<Item = (f64, f64)>,
    x: (f64, f64),
    y: (f64, f64),
) -> Vec<Vec<(f64, f64)>> {
    fn flush(pieces: &mut Vec<Vec<(f64, f64)>>, cur: &mut Vec<(f64, f64)>) {
        if cur.len() >= 2 {
            pieces.push(std::mem::take(cur));
        } else {
            cur.clear();
        }
    }
    let mut pieces = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    let mut prev: Option<(f64, f64)> = None;
    for p in points {
        if !(p.0.is_finite() && p.1.is_finite()) {
            flush(&mut pieces, &mut cur);
            prev = None;
            continue;
        }
        if let Some(a) = prev {
            match clip_segment(a, p, x, y) {
                None => flush(&mut pieces, &mut cur),
                Some((t0, t1)) => {
                    let at = |t: f64| (a.0 + t * (p.0 - a.0), a.1 + t * (p.1 - a.1));
                    if t0 > 0.0 || cur.is_empty() {
                        flush(&mut pieces, &mut cur);
                        cur.push(if t0 > 0.0 { at(t0) } else { a });
                    }
                    cur.push(if t1 < 1.0 { at(t1) } else { p });
                    if t1 < 1.0 {
                        flush(&mut pieces, &mut cur);
                    }
                }
            }
        }
        prev = Some(p);
    }
    flush(&mut pieces, &mut cur);
    pieces
}

/// Liang–Barsky: the parameter interval of the segment `a`→`b` inside the rectangle, if any.
fn clip_segment(a: (f64, f64), b: (f64, f64), x: (f64, f64), y: (f64, f64)) -> Option<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0: f64 = 0.0;
    let mut t1: f64 = 1.0;
    for (p, q) in [
        (-dx, a.0 - x.0),
        (dx, x.1 - a.0),
        (-dy, a.1 - y.0),
        (dy, y.1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                if r > t1 {
                    return None;
                }
                t0 = t0.max(r);
            } else {
                if r < t0 {
                    return None;
                }
                t1 = t1.min(r);
            }
        }
    }
    Some((t0, t1))
}

/// The finite time range of a trace (widened when degenerate).
fn time_range(t: &[f64]) -> Option<(f64, f64)> {
    let (lo, hi) = t
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return None;
    }
    Some(if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    })
}

/// A log-axis range for `values` (their positive, finite ones): from the decade below 0.7 × their 1st
/// percentile (lower values are clamped to it when drawn) to the decade above their maximum, at most
/// `max_decades` wide (higher values are clipped).
fn log_range(mut values: Vec<f64>, max_decades: f64) -> Option<(f64, f64)> {
    values.retain(|v| v.is_finite() && *v > 0.0);
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let low = values[values.len() / 100];
    let high = values[values.len() - 1];
    let lo = 10f64.powf((0.7 * low).log10().floor());
    let hi = 10f64
        .powf(high.log10().ceil())
        .min(lo * 10f64.powf(max_decades));
    Some(if hi > lo { (lo, hi) } else { (lo, lo * 10.0) })
}

/// [`clip_polyline`] for a log y axis: clips in log space so the clipped ends lie on the drawn line.
fn clip_polyline_log(
    points: impl IntoIterator<Item = (f64, f64)>,
    x: (f64, f64),
    y: (f64, f64),
) -> Vec<Vec<(f64, f64)>> {
    let log = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
    let mut pieces = clip_polyline(
        points.into_iter().map(|(t, v)| (t, log(v))),
        x,
        (log(y.0), log(y.1)),
    );
    for piece in &mut pieces {
        for p in piece.iter_mut() {
            // Keep the ends exactly on the range so rounding never puts them outside.
            p.1 = 10f64.powf(p.1).clamp(y.0, y.1);
        }
    }
    pieces
}

fn get3(v: &[[f64; 3]], k: usize, axis: usize) -> f64 {
    v.get(k).map_or(f64::NAN, |x| x[axis])
}

// ---------------------------------------------------------------------------------------------
// The plots.

/// `errors_<label>.png`: run 0's error per body axis with the filter's and the PCRB's ±3σ.
fn plot_errors(
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
fn plot_error_angle(path: &Path, study: &StudyResult, fr: &FilterResult) -> Result<bool, String> {
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
fn plot_rms_vs_pcrb(path: &Path, study: &StudyResult, unit: AngleUnit) -> Result<bool, String> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filters::FilterSpec;
    use crate::study::FilterResult;

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
                    runs: (0..3).map(|j| run(j, 200, 1.0)).collect(),
                    summary: summary("mekf", "mekf", None, None, 3.1),
                },
                FilterResult {
                    spec: qpf,
                    particles: Some(500),
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
                runs: Vec::new(),
                summary: s.clone(),
            },
            FilterResult {
                spec: mekf,
                particles: None,
                runs: vec![nan, RunTrace::default()],
                summary: summary("mekf", "mekf", None, None, 3.0),
            },
            FilterResult {
                spec: mekf,
                particles: None,
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
    fn clipping_keeps_points_inside_and_splits_at_nan() {
        let pts = vec![
            (0.0, 0.0),
            (1.0, 10.0),
            (2.0, 0.0),
            (3.0, f64::NAN),
            (4.0, 0.5),
            (5.0, 0.2),
        ];
        let pieces = clip_polyline(pts, (0.0, 5.0), (-1.0, 1.0));
        assert_eq!(pieces.len(), 3);
        for piece in &pieces {
            assert!(piece.len() >= 2);
            for &(x, y) in piece {
                assert!(
                    (0.0..=5.0).contains(&x) && (-1.0..=1.0 + 1e-12).contains(&y),
                    "{x} {y}"
                );
            }
        }
        assert_eq!(pieces[0], vec![(0.0, 0.0), (0.1, 1.0)]);
        assert_eq!(pieces[2], vec![(4.0, 0.5), (5.0, 0.2)]);
        // A segment entirely outside is dropped.
        assert!(clip_polyline(vec![(0.0, 5.0), (1.0, 6.0)], (0.0, 1.0), (-1.0, 1.0)).is_empty());
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
