//! The plotting toolkit of the study reports (`report`, `sweep`): size, palette and font of a figure,
//! the drawing of one plot (a failure becomes an error, never a panic or a partial file), the
//! title-and-legend header, the clipping of polylines to the axes, axis ranges and ticks.
//!
//! Plots are drawn with `plotters` on a bitmap backend. No system fonts are assumed: the bundled
//! DejaVu Sans is registered once as the `sans-serif` family before anything is drawn.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::OnceLock;

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
            include_bytes!("../../../../assets/fonts/DejaVuSans.ttf"),
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
pub(super) fn clip_polyline(
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
pub(super) fn time_range(t: &[f64]) -> Option<(f64, f64)> {
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
pub(super) fn log_range(mut values: Vec<f64>, max_decades: f64) -> Option<(f64, f64)> {
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
pub(super) fn clip_polyline_log(
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

/// An axis tick: up to four significant digits without trailing zeros, scientific when very large or
/// very small.
pub(super) fn tick(v: f64) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
