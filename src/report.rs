//! Plots of a calibration, drawn from its typed results (the [`FitTable`], the history and
//! the [`ErrorReport`]), as SVG and PNG with an embedded font (DejaVu Sans; no system fonts):
//! - `fit`: measured, nominal and optimized trajectories of each output (the paper's Figures 6
//!   and 9);
//! - `error`: absolute error on a log scale, nominal against optimized, with the end of the
//!   calibration window marked when there is a validation window (Figures 7 and 10);
//! - `convergence`: best f against evaluations, one marker per completed batch.
//!
//! `fmucal plot DIR` reads an existing result folder and calls [`draw_all`].
//!
//! Values a plot cannot place (non-finite, or beyond ±[`PLOT_LIMIT`], whose axis arithmetic
//! would overflow) are left out, and drawing is given [`DRAW_TIME_LIMIT`]: a plot never keeps a
//! run from ending.

use std::path::Path;
use std::sync::Once;

use fmucal_shared::job::{ErrorReport, FitTable, HistoryPoint};
use plotters::coord::Shift;
use plotters::prelude::*;

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("cannot draw {path}: {message}")]
    Draw { path: String, message: String },
}

/// One output's finite points.
struct Series {
    name: String,
    measured: Vec<(f64, f64)>,
    nominal: Vec<(f64, f64)>,
    optimized: Vec<(f64, f64)>,
}

/// Largest magnitude drawn: an axis spanning more overflows (its padding, its log-scale
/// ticks), and no measurement is that large.
pub(crate) const PLOT_LIMIT: f64 = 1e150;

/// How long [`draw_all`] may take before it gives up on the plots.
pub const DRAW_TIME_LIMIT: std::time::Duration = std::time::Duration::from_secs(120);

/// Whether a plot can place `v`.
pub(crate) fn plottable(v: f64) -> bool {
    v.is_finite() && v.abs() <= PLOT_LIMIT
}

/// The points of `values` at `time` that a plot can place.
fn finite(time: &[f64], values: impl IntoIterator<Item = Option<f64>>) -> Vec<(f64, f64)> {
    let points = time.iter().zip(values).filter(|(t, _)| plottable(**t));
    points.filter_map(|(t, v)| v.filter(|v| plottable(*v)).map(|v| (*t, v))).collect()
}

/// One panel per output; consecutive outputs of the same variable share a panel.
fn series(fit: &FitTable) -> Vec<Series> {
    let mut out: Vec<Series> = vec![];
    for o in &fit.outputs {
        if out.last().is_none_or(|s| s.name != o.variable) {
            out.push(Series { name: o.variable.clone(), measured: vec![], nominal: vec![], optimized: vec![] });
        }
        let s = out.last_mut().expect("pushed above");
        s.measured.extend(finite(&fit.time, o.measured.iter().map(|v| Some(*v))));
        s.nominal.extend(finite(&fit.time, o.nominal.iter().copied()));
        s.optimized.extend(finite(&fit.time, o.optimized.iter().copied()));
    }
    out
}

pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
}

pub(crate) fn range(points: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) =
        points.filter(|v| plottable(*v)).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-12);
    (lo - pad, hi + pad)
}

pub(crate) type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// Draws `points` as a line in `style`, labelled in the legend with a short line of that style.
pub(crate) fn draw_line<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    points: impl IntoIterator<Item = (f64, f64)>,
    style: ShapeStyle,
    label: &str,
) -> DrawResult
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: CoordTranslate<From = (f64, f64)>,
{
    chart
        .draw_series(LineSeries::new(points, style))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
    Ok(())
}

/// The legend of the labelled series (at the middle right of the chart).
pub(crate) fn draw_legend<'a, DB, CT>(chart: &mut ChartContext<'a, DB, CT>) -> DrawResult
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    CT: CoordTranslate,
{
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}

fn draw_fit<B: DrawingBackend>(root: DrawingArea<B, Shift>, series: &[Series]) -> DrawResult
where
    B::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let panels = root.split_evenly((series.len().max(1), 1));
    for (s, area) in series.iter().zip(panels) {
        let (t0, t1) = range(s.measured.iter().chain(&s.optimized).map(|p| p.0));
        let (y0, y1) = range(s.measured.iter().chain(&s.nominal).chain(&s.optimized).map(|p| p.1));
        let mut chart = ChartBuilder::on(&area)
            .caption(&s.name, ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1, y0..y1)?;
        chart.configure_mesh().x_desc("time").label_style(("sans-serif", 12)).draw()?;
        draw_line(&mut chart, s.nominal.iter().copied(), BLUE.into(), "nominal")?;
        draw_line(&mut chart, s.optimized.iter().copied(), RED.into(), "optimized")?;
        // Measurements on top, so they stay visible where the fit is good.
        chart
            .draw_series(s.measured.iter().map(|p| Circle::new(*p, 1, BLACK.mix(0.5).filled())))?
            .label("measured")
            .legend(|(x, y)| Circle::new((x + 10, y), 3, BLACK.filled()));
        draw_legend(&mut chart)?;
    }
    root.present()?;
    Ok(())
}

fn abs_errors(measured: &[(f64, f64)], sim: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let lookup: std::collections::HashMap<u64, f64> = sim.iter().map(|(t, v)| (t.to_bits(), *v)).collect();
    measured.iter().filter_map(|(t, m)| lookup.get(&t.to_bits()).map(|s| (*t, (s - m).abs().max(1e-16)))).collect()
}

fn draw_error<B: DrawingBackend>(root: DrawingArea<B, Shift>, series: &[Series], split: Option<f64>) -> DrawResult
where
    B::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let panels = root.split_evenly((series.len().max(1), 1));
    for (s, area) in series.iter().zip(panels) {
        let nominal = abs_errors(&s.measured, &s.nominal);
        let optimized = abs_errors(&s.measured, &s.optimized);
        let (t0, t1) = range(s.measured.iter().map(|p| p.0));
        let all = nominal.iter().chain(&optimized).map(|p| p.1);
        let (lo, hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
        let (lo, hi) = if lo.is_finite() && hi > 0.0 { (lo.max(1e-12) * 0.5, hi * 2.0) } else { (1e-6, 1.0) };
        let mut chart = ChartBuilder::on(&area)
            .caption(
                match split {
                    Some(_) => format!("{}: absolute error (calibration | validation)", s.name),
                    None => format!("{}: absolute error (calibration window)", s.name),
                },
                ("sans-serif", 18),
            )
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1, (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("time")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style(("sans-serif", 12))
            .draw()?;
        draw_line(&mut chart, nominal, BLUE.into(), "measurement - nominal")?;
        draw_line(&mut chart, optimized, RED.into(), "measurement - optimized")?;
        if let Some(t) = split {
            draw_line(&mut chart, [(t, lo), (t, hi)], BLACK.stroke_width(2), "end of the calibration window")?;
        }
        draw_legend(&mut chart)?;
    }
    root.present()?;
    Ok(())
}

fn draw_convergence<B: DrawingBackend>(root: DrawingArea<B, Shift>, points: &[(f64, f64)]) -> DrawResult
where
    B::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (e0, e1) = range(points.iter().map(|p| p.0));
    let fs = points.iter().map(|p| p.1).filter(|v| plottable(*v) && *v > 0.0);
    let (lo, hi) = fs.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let (lo, hi) = if lo.is_finite() { (lo * 0.5, hi * 2.0) } else { (1e-6, 1.0) };
    let mut chart = ChartBuilder::on(&root)
        .caption("convergence: best f after each batch", ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(e0.max(0.0)..e1, (lo..hi).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("evaluations")
        .y_desc("best f")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 12))
        .draw()?;
    let positive: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.1 > 0.0 && plottable(p.1)).collect();
    chart.draw_series(LineSeries::new(positive.iter().copied(), RED.stroke_width(1)))?;
    chart.draw_series(positive.iter().map(|p| Circle::new(*p, 3, RED.filled())))?;
    root.present()?;
    Ok(())
}

/// Draws `fit`, `error` and `convergence` as SVG and PNG into `dir`, the error plot with the
/// calibration/validation split of `errors` if it has a validation window.
///
/// # Errors
/// [`ReportError`] if a plot cannot be written, or if drawing takes longer than
/// [`DRAW_TIME_LIMIT`] (the drawing threads are then left to end with the process).
pub fn draw_all(
    dir: &Path,
    fit: &FitTable,
    history: &[HistoryPoint],
    errors: Option<&ErrorReport>,
) -> Result<(), ReportError> {
    register_font();
    let series = std::sync::Arc::new(series(fit));
    let conv: std::sync::Arc<Vec<(f64, f64)>> =
        std::sync::Arc::new(history.iter().map(|h| (h.evaluations as f64, h.best_f)).collect());
    let split = errors.and_then(ErrorReport::validation_split).filter(|t| plottable(*t));
    let height = 300 * series.len().max(1) as u32;
    let fail = |name: &str, message: String| ReportError::Draw { path: dir.join(name).display().to_string(), message };
    // Six independent files: draw them on parallel threads.
    let files = [
        ("fit", "svg"),
        ("fit", "png"),
        ("error", "svg"),
        ("error", "png"),
        ("convergence", "svg"),
        ("convergence", "png"),
    ];
    let (tx, rx) = std::sync::mpsc::channel();
    for (name, ext) in files {
        let (series, conv, tx) = (series.clone(), conv.clone(), tx.clone());
        let file = format!("{name}.{ext}");
        let path = dir.join(&file);
        std::thread::spawn(move || {
            let size = if name == "convergence" { (900, 500) } else { (1000, height) };
            let drawn = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match (name, ext) {
                ("fit", "svg") => draw_fit(SVGBackend::new(&path, size).into_drawing_area(), &series),
                ("fit", _) => draw_fit(BitMapBackend::new(&path, size).into_drawing_area(), &series),
                ("error", "svg") => draw_error(SVGBackend::new(&path, size).into_drawing_area(), &series, split),
                ("error", _) => draw_error(BitMapBackend::new(&path, size).into_drawing_area(), &series, split),
                (_, "svg") => draw_convergence(SVGBackend::new(&path, size).into_drawing_area(), &conv),
                _ => draw_convergence(BitMapBackend::new(&path, size).into_drawing_area(), &conv),
            }));
            let message = match drawn {
                Ok(Ok(())) => None,
                Ok(Err(e)) => Some(e.to_string()),
                Err(_) => Some("the drawing thread panicked".to_owned()),
            };
            let _ = tx.send((file, message));
        });
    }
    drop(tx);
    let deadline = std::time::Instant::now() + DRAW_TIME_LIMIT;
    for _ in 0..files.len() {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        match rx.recv_timeout(left) {
            Ok((_, None)) => {}
            Ok((file, Some(message))) => return Err(fail(&file, message)),
            Err(_) => {
                let limit = DRAW_TIME_LIMIT.as_secs();
                return Err(fail("plots", format!("drawing took longer than {limit} s; the plots are incomplete")));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use fmucal_shared::job::report::FitColumns;

    use super::*;

    #[test]
    fn extreme_and_non_finite_values_are_left_out_of_the_plots() {
        let dir = tempfile::tempdir().unwrap();
        let time = vec![0.0, 1.0, 2.0, 3.0];
        let fit = FitTable {
            time: time.clone(),
            outputs: vec![FitColumns {
                variable: "y".into(),
                measured: vec![1e308, f64::INFINITY, 1.0, -1e308],
                nominal: vec![Some(0.5), Some(f64::NAN), Some(-1e300), None],
                optimized: vec![Some(1.0); 4],
            }],
        };
        let history = [1e308, f64::INFINITY, 1.0]
            .iter()
            .enumerate()
            .map(|(k, &f)| HistoryPoint {
                round: k as u64 + 1,
                evaluations: 4 * k as u64,
                best_f: f,
                batch_wall_s: 0.1,
            })
            .collect::<Vec<_>>();
        draw_all(dir.path(), &fit, &history, None).unwrap();
        for file in ["fit.svg", "fit.png", "error.svg", "error.png", "convergence.svg", "convergence.png"] {
            assert!(std::fs::metadata(dir.path().join(file)).unwrap().len() > 0, "{file}");
        }
        let s = series(&fit);
        assert_eq!((s[0].measured.as_slice(), s[0].nominal.as_slice()), (&[(2.0, 1.0)][..], &[(0.0, 0.5)][..]));
    }
}
