//! The plots of a diagnosis, as SVG and PNG with the report's embedded font:
//! - `residuals`: per output, simulated − measured over both windows for the base model
//!   (before) and the model with the named effects (after), the worst time windows of the base
//!   residual shaded and the end of the fitted window marked;
//! - `correlation`: per output, the base residual against the signal it correlates with most.

use std::path::Path;

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::report::{DrawResult, draw_legend, draw_line, range, register_font};
use fmucal_diagnose::driver::Outcome;
use fmucal_diagnose::driver::look::Look;

/// Worst windows shaded per output.
const SHADED: usize = 3;

/// Per output: (time, residual) over both windows.
fn residual_points(l: &Look) -> Vec<(String, Vec<(f64, f64)>)> {
    l.fit
        .outputs
        .iter()
        .map(|o| {
            let points = l
                .fit
                .time
                .iter()
                .zip(o.optimized.iter().zip(&o.measured))
                .filter_map(|(t, (s, m))| s.map(|s| (*t, s - m)).filter(|p| p.1.is_finite()))
                .collect();
            (o.variable.clone(), points)
        })
        .collect()
}

fn draw_residuals<B: DrawingBackend>(root: DrawingArea<B, Shift>, outcome: &Outcome) -> DrawResult
where
    B::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (before, after) = (residual_points(&outcome.before), residual_points(&outcome.after));
    let split = outcome.diagnosis.windows.calibration_stop;
    let localised = outcome.diagnosis.rounds.first().map(|r| &r.localisation.outputs);
    let panels = root.split_evenly((before.len().max(1), 1));
    for (k, ((name, b), area)) in before.iter().zip(panels).enumerate() {
        let a = after.get(k).map(|x| x.1.as_slice()).unwrap_or_default();
        let (t0, t1) = range(b.iter().map(|p| p.0));
        let (y0, y1) = range(b.iter().chain(a).map(|p| p.1));
        let mut chart = ChartBuilder::on(&area)
            .caption(format!("{name}: simulated − measured"), ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(70)
            .build_cartesian_2d(t0..t1, y0..y1)?;
        chart.configure_mesh().x_desc("time").label_style(("sans-serif", 12)).draw()?;
        if let Some(out) = localised.and_then(|o| o.get(k)) {
            chart.draw_series(out.windows.iter().take(SHADED).map(|w| {
                Rectangle::new([(w.start_time, y0), (w.stop_time, y1)], RGBColor(255, 200, 0).mix(0.25).filled())
            }))?;
        }
        chart.draw_series(LineSeries::new([(split, y0), (split, y1)], BLACK.mix(0.6).stroke_width(1)))?;
        draw_line(&mut chart, b.iter().copied(), BLUE.into(), "before (base model)")?;
        draw_line(&mut chart, a.iter().copied(), RED.into(), "after (with the named effects)")?;
        draw_legend(&mut chart)?;
    }
    root.present()?;
    Ok(())
}

fn draw_correlation<B: DrawingBackend>(root: DrawingArea<B, Shift>, outcome: &Outcome) -> DrawResult
where
    B::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let outputs = outcome.diagnosis.rounds.first().map(|r| r.localisation.outputs.as_slice()).unwrap_or_default();
    let panels = root.split_evenly((outputs.len().max(1), 1));
    for ((out, (_, residual)), area) in outputs.iter().zip(&outcome.before.residuals).zip(panels) {
        let Some(best) = out.correlations.first() else { continue };
        let Some((_, signal)) = outcome.signals.iter().find(|(n, _)| *n == best.signal) else { continue };
        let points: Vec<(f64, f64)> = signal
            .iter()
            .zip(residual)
            .map(|(s, r)| (*s, *r))
            .filter(|(s, r)| s.is_finite() && r.is_finite())
            .collect();
        let (x0, x1) = range(points.iter().map(|p| p.0));
        let (y0, y1) = range(points.iter().map(|p| p.1));
        let mut chart = ChartBuilder::on(&area)
            .caption(
                format!(
                    "{} residual against {} (r = {:.2}, with its sign {:.2})",
                    out.variable, best.signal, best.correlation, best.sign_correlation
                ),
                ("sans-serif", 16),
            )
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart.configure_mesh().x_desc(best.signal.as_str()).label_style(("sans-serif", 12)).draw()?;
        chart.draw_series(points.iter().map(|p| Circle::new(*p, 1, BLUE.mix(0.4).filled())))?;
    }
    root.present()?;
    Ok(())
}

/// Draws both plots into `dir`.
pub fn draw(dir: &Path, outcome: &Outcome) -> Result<()> {
    register_font();
    let height = 300 * outcome.before.fit.outputs.len().max(1) as u32;
    for ext in ["svg", "png"] {
        for name in ["residuals", "correlation"] {
            let path = dir.join(format!("{name}.{ext}"));
            let size = (1000, height);
            let r = match (name, ext) {
                ("residuals", "svg") => draw_residuals(SVGBackend::new(&path, size).into_drawing_area(), outcome),
                ("residuals", _) => draw_residuals(BitMapBackend::new(&path, size).into_drawing_area(), outcome),
                (_, "svg") => draw_correlation(SVGBackend::new(&path, size).into_drawing_area(), outcome),
                _ => draw_correlation(BitMapBackend::new(&path, size).into_drawing_area(), outcome),
            };
            r.map_err(|e| anyhow!("cannot draw {}: {e}", path.display()))?;
        }
    }
    Ok(())
}
