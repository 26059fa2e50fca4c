//! Plots of a calibration, drawn from its typed results (the [`FitTable`], the history and
//! the [`ErrorReport`]), as SVG and PNG with an embedded font (DejaVu Sans; no system fonts):
//! - `fit`: measured, start (the model at the job's start values) and optimized trajectories
//!   of each output (the paper's Figures 6 and 9), the measurements thinned to at most [`MAX_MARKERS`] light dots under the lines;
//! - `error`: absolute error on a log scale, start against optimized (Figures 7 and 10);
//! - `convergence`: best f against evaluations, one marker per completed batch, and below it
//!   each parameter's best value placed in its bounds (0 = lower, 1 = upper).
//!
//! The axes carry the units of the model description (time in s, each output in its unit);
//! the fit and error plots mark where the validation window starts, and every legend stands in
//! a column beside the data area ([`LEGEND_WIDTH`]), so it never covers a trace.
//!
//! `fmucal plot DIR` reads an existing result folder and calls [`draw_all`].
//!
//! Values a plot cannot place (non-finite, or beyond ±[`PLOT_LIMIT`], whose axis arithmetic
//! would overflow) are left out, and drawing is given [`DRAW_TIME_LIMIT`]: a plot never keeps a
//! run from ending.

use std::path::Path;
use std::sync::Once;

use fmucal_shared::job::{ErrorReport, FitTable, HistoryPoint, ParameterRange};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("cannot draw {path}: {message}")]
    Draw { path: String, message: String },
}

/// One output's finite points.
struct Series {
    name: String,
    unit: Option<String>,
    measured: Vec<(f64, f64)>,
    nominal: Vec<(f64, f64)>,
    optimized: Vec<(f64, f64)>,
}

/// One parameter's best value after each batch, placed in its bounds.
struct Path01 {
    name: String,
    /// The bounds the path is placed in (0 at `lower`, 1 at `upper`).
    lower: f64,
    upper: f64,
    points: Vec<(f64, f64)>,
}

/// Largest magnitude drawn: an axis spanning more overflows (its padding, its log-scale
/// ticks), and no measurement is that large.
pub(crate) const PLOT_LIMIT: f64 = 1e150;

/// How long [`draw_all`] may take before it gives up on the plots.
pub const DRAW_TIME_LIMIT: std::time::Duration = std::time::Duration::from_secs(120);

/// Most measured points drawn per panel of the fit plot: more are thinned to every k-th, so
/// thousands of samples do not bury the fitted line.
pub const MAX_MARKERS: usize = 400;

/// Width in pixels of the column right of each data area that holds its legend.
pub const LEGEND_WIDTH: u32 = 230;

/// Most characters of a legend entry that fit its column; longer ones are cut with "…".
const LEGEND_CHARS: usize = 28;

/// The time axis' label (FMI time is in seconds).
const TIME_LABEL: &str = "time [s]";

/// Colours: measurements, the model at the start values and optimized, the validation window.
const MEASURED: RGBColor = RGBColor(90, 90, 90);
const NOMINAL: RGBColor = RGBColor(40, 90, 220);
const OPTIMIZED: RGBColor = RGBColor(220, 20, 20);
const VALIDATION: RGBColor = RGBColor(120, 120, 120);

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
            out.push(Series {
                name: o.variable.clone(),
                unit: o.unit.clone(),
                measured: vec![],
                nominal: vec![],
                optimized: vec![],
            });
        }
        let s = out.last_mut().expect("pushed above");
        s.measured.extend(finite(&fit.time, o.measured.iter().map(|v| Some(*v))));
        s.nominal.extend(finite(&fit.time, o.nominal.iter().copied()));
        s.optimized.extend(finite(&fit.time, o.optimized.iter().copied()));
    }
    out
}

/// Each parameter's best value after each batch, as (evaluations, position in its bounds);
/// a parameter without finite bounds is placed in the range its path spans. Empty if the
/// history does not hold the best points (a result written before they were kept).
fn parameter_paths(history: &[HistoryPoint], parameters: &[ParameterRange]) -> Vec<Path01> {
    let rows: Vec<&HistoryPoint> = history.iter().filter(|h| h.best_x.len() == parameters.len()).collect();
    if rows.is_empty() {
        return vec![];
    }
    let mut paths = vec![];
    for (i, p) in parameters.iter().enumerate() {
        let values: Vec<(f64, f64)> = rows.iter().map(|h| (h.evaluations as f64, h.best_x[i])).collect();
        let (lo, hi) = if p.lower.is_finite() && p.upper.is_finite() && p.upper > p.lower {
            (p.lower, p.upper)
        } else {
            let span = values.iter().map(|v| v.1).filter(|v| v.is_finite());
            let (lo, hi) = span.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
            if hi > lo { (lo, hi) } else { (lo - 1.0, lo + 1.0) }
        };
        let points = values.iter().map(|(e, x)| (*e, (x - lo) / (hi - lo))).filter(|p| plottable(p.1)).collect();
        paths.push(Path01 { name: p.name.clone(), lower: lo, upper: hi, points });
    }
    paths
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

/// How a legend entry shows its series.
#[derive(Clone, Copy)]
enum Key {
    Line(ShapeStyle),
    Dot(ShapeStyle),
    Shade(ShapeStyle),
}

/// Splits a panel into its chart (left) and its legend column ([`LEGEND_WIDTH`], right).
fn with_legend_column<DB: DrawingBackend>(panel: &DrawingArea<DB, Shift>) -> [DrawingArea<DB, Shift>; 2] {
    let (w, _) = panel.dim_in_pixel();
    let (chart, legend) = panel.split_horizontally(w.saturating_sub(LEGEND_WIDTH));
    [chart, legend]
}

/// Draws `entries` in a framed box in the legend column `area`, its top level with the top of
/// `chart`'s data area.
fn draw_key<DB, CT>(
    area: &DrawingArea<DB, Shift>,
    chart: &ChartContext<'_, DB, CT>,
    entries: &[(String, Key)],
) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    CT: CoordTranslate,
{
    if entries.is_empty() {
        return Ok(());
    }
    let top = chart.plotting_area().get_pixel_range().1.start - area.get_pixel_range().1.start;
    let (w, _) = area.dim_in_pixel();
    let (x0, x1) = (6, w as i32 - 4);
    let y1 = top + 6 + 20 * entries.len() as i32;
    area.draw(&Rectangle::new([(x0, top), (x1, y1)], WHITE.filled()))?;
    area.draw(&Rectangle::new([(x0, top), (x1, y1)], BLACK.stroke_width(1)))?;
    let font = ("sans-serif", 12).into_font().color(&BLACK);
    for (k, (label, key)) in entries.iter().enumerate() {
        let y = top + 14 + 20 * k as i32;
        match *key {
            Key::Line(style) => area.draw(&PathElement::new(vec![(x0 + 8, y), (x0 + 30, y)], style))?,
            Key::Dot(style) => area.draw(&Circle::new((x0 + 19, y), 3, style))?,
            Key::Shade(style) => area.draw(&Rectangle::new([(x0 + 8, y - 6), (x0 + 30, y + 6)], style))?,
        }
        area.draw(&Text::new(cut(label, LEGEND_CHARS), (x0 + 38, y - 7), font.clone()))?;
    }
    Ok(())
}

/// A tick label on an axis spanning `span`: to the digits the span needs, in E notation for
/// very large or small spans, never "-0".
fn tick(v: f64, span: f64) -> String {
    let magnitude = span.abs().log10().floor();
    let text = if !(-3.0..=5.0).contains(&magnitude) {
        format!("{v:.1e}")
    } else {
        format!("{v:.*}", (1.0 - magnitude).clamp(0.0, 6.0) as usize)
    };
    match text.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_owned(),
        _ => text,
    }
}

/// `label` in at most `n` characters: if longer, its start and its end joined by "…" (the
/// end tells `k@sine` from `k@steps`).
fn cut(label: &str, n: usize) -> String {
    let chars: Vec<char> = label.chars().collect();
    if chars.len() <= n {
        return label.to_owned();
    }
    let head = n.saturating_sub(1) / 2;
    let tail = n.saturating_sub(1) - head;
    let (start, end): (String, String) = (chars[..head].iter().collect(), chars[chars.len() - tail..].iter().collect());
    format!("{start}…{end}")
}

/// An axis label: `name [unit]`, or `name` alone when the unit is unknown.
fn axis_label(name: &str, unit: Option<&str>) -> String {
    match unit {
        Some(u) if !u.is_empty() => format!("{name} [{u}]"),
        _ => name.to_owned(),
    }
}

/// Where `split` lies inside the chart's time axis, shades the validation window from it to the
/// right end of the axis and marks its start with a vertical line labelled "validation →" at
/// the top. Returns the panel's first legend entries: the window's, where it was drawn.
fn draw_split<'a, DB, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    split: Option<f64>,
) -> Result<Vec<(String, Key)>, Box<dyn std::error::Error>>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    Y: Ranged<ValueType = f64>,
{
    let (x, y) = (chart.x_range(), chart.y_range());
    let (t0, t1, y0, y1) = (x.start, x.end, y.start, y.end);
    let Some(split) = split.filter(|t| *t > t0 && *t < t1) else { return Ok(vec![]) };
    chart.draw_series([Rectangle::new([(split, y0), (t1, y1)], VALIDATION.mix(0.08).filled())])?;
    chart.draw_series(LineSeries::new([(split, y0), (split, y1)], VALIDATION.stroke_width(2)))?;
    let font = ("sans-serif", 12).into_font().color(&BLACK);
    chart.draw_series([EmptyElement::at((split, y1)) + Text::new("validation →", (5, 4), font)])?;
    Ok(vec![("validation window".to_owned(), Key::Shade(VALIDATION.mix(0.25).filled()))])
}

/// Draws one panel per output, stacked, each by `draw` given the output, the panel's data
/// area and its legend column.
fn draw_panels<B: DrawingBackend>(
    root: DrawingArea<B, Shift>,
    series: &[Series],
    mut draw: impl FnMut(&Series, &DrawingArea<B, Shift>, &DrawingArea<B, Shift>) -> DrawResult,
) -> DrawResult
where
    B::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let panels = root.split_evenly((series.len().max(1), 1));
    for (s, panel) in series.iter().zip(panels) {
        let [area, legend] = with_legend_column(&panel);
        draw(s, &area, &legend)?;
    }
    root.present()?;
    Ok(())
}

/// A chart on `area` with `caption` above it and room for the axis labels, `x` across and `y`
/// up.
fn panel_chart<'a, DB, X, Y>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    x: X,
    y: Y,
) -> Result<ChartContext<'a, DB, Cartesian2d<X::CoordDescType, Y::CoordDescType>>, Box<dyn std::error::Error>>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: AsRangedCoord,
    Y: AsRangedCoord,
{
    Ok(ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(75)
        .build_cartesian_2d(x, y)?)
}

/// A [`panel_chart`] over the time span `t`, its y axis `y` labelled `y_desc` with ticks
/// written by `y_tick`, with its mesh drawn.
fn time_chart<'a, DB, Y>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    (t0, t1): (f64, f64),
    y: Y,
    y_desc: String,
    y_tick: &dyn Fn(&f64) -> String,
) -> Result<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y::CoordDescType>>, Box<dyn std::error::Error>>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = panel_chart(area, caption, t0..t1, y)?;
    chart
        .configure_mesh()
        .x_desc(TIME_LABEL)
        .y_desc(y_desc)
        .y_label_formatter(y_tick)
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 14))
        .draw()?;
    Ok(chart)
}

fn draw_fit<B: DrawingBackend>(root: DrawingArea<B, Shift>, series: &[Series], split: Option<f64>) -> DrawResult
where
    B::ErrorType: 'static,
{
    draw_panels(root, series, |s, area, legend| {
        let t = range(s.measured.iter().chain(&s.optimized).map(|p| p.0));
        let (y0, y1) = range(s.measured.iter().chain(&s.nominal).chain(&s.optimized).map(|p| p.1));
        let y_desc = axis_label(&s.name, s.unit.as_deref());
        let mut chart = time_chart(area, &s.name, t, y0..y1, y_desc, &|v| tick(*v, y1 - y0))?;
        let mut keys = draw_split(&mut chart, split)?;
        // Measurements first, thinned and light, so the fitted line on top stays visible.
        let every = s.measured.len().div_ceil(MAX_MARKERS).max(1);
        let dot = MEASURED.mix(0.35).filled();
        chart.draw_series(s.measured.iter().step_by(every).map(|p| Circle::new(*p, 3, dot)))?;
        let nominal = NOMINAL.stroke_width(1);
        let optimized = OPTIMIZED.stroke_width(2);
        chart.draw_series(LineSeries::new(s.nominal.iter().copied(), nominal))?;
        chart.draw_series(LineSeries::new(s.optimized.iter().copied(), optimized))?;
        let measured = match every {
            1 => "measured".to_owned(),
            k => format!("measured (1 in {k})"),
        };
        keys.extend([
            (measured, Key::Dot(MEASURED.filled())),
            ("start".to_owned(), Key::Line(nominal)),
            ("optimized".to_owned(), Key::Line(optimized)),
        ]);
        draw_key(legend, &chart, &keys)
    })
}

fn abs_errors(measured: &[(f64, f64)], sim: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let lookup: std::collections::HashMap<u64, f64> = sim.iter().map(|(t, v)| (t.to_bits(), *v)).collect();
    measured.iter().filter_map(|(t, m)| lookup.get(&t.to_bits()).map(|s| (*t, (s - m).abs().max(1e-16)))).collect()
}

fn draw_error<B: DrawingBackend>(root: DrawingArea<B, Shift>, series: &[Series], split: Option<f64>) -> DrawResult
where
    B::ErrorType: 'static,
{
    draw_panels(root, series, |s, area, legend| {
        let nominal = abs_errors(&s.measured, &s.nominal);
        let optimized = abs_errors(&s.measured, &s.optimized);
        let t = range(s.measured.iter().map(|p| p.0));
        let all = nominal.iter().chain(&optimized).map(|p| p.1);
        let (lo, hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
        let (lo, hi) = if lo.is_finite() && hi > 0.0 { (lo.max(1e-12) * 0.5, hi * 2.0) } else { (1e-6, 1.0) };
        let caption = format!("{}: absolute error", s.name);
        let y_desc = axis_label("|measured − simulated|", s.unit.as_deref());
        let mut chart = time_chart(area, &caption, t, (lo..hi).log_scale(), y_desc, &|v| format!("{v:.0e}"))?;
        let mut keys = draw_split(&mut chart, split)?;
        let (n_style, o_style) = (NOMINAL.stroke_width(1), OPTIMIZED.stroke_width(1));
        chart.draw_series(LineSeries::new(nominal, n_style))?;
        chart.draw_series(LineSeries::new(optimized, o_style))?;
        keys.extend([("start".to_owned(), Key::Line(n_style)), ("optimized".to_owned(), Key::Line(o_style))]);
        draw_key(legend, &chart, &keys)
    })
}

/// `v` in at most about 8 characters: as Rust prints it if that is short, else in E notation.
fn short(v: f64) -> String {
    let plain = format!("{v}");
    if plain.len() <= 8 { plain } else { format!("{v:.2e}") }
}

/// The colour of parameter `k`'s path.
fn path_colour(k: usize) -> RGBColor {
    const COLOURS: [RGBColor; 8] = [
        RGBColor(220, 20, 20),
        RGBColor(40, 90, 220),
        RGBColor(20, 150, 60),
        RGBColor(230, 140, 0),
        RGBColor(140, 60, 180),
        RGBColor(0, 160, 170),
        RGBColor(120, 80, 40),
        RGBColor(230, 80, 170),
    ];
    COLOURS[k % COLOURS.len()]
}

fn draw_convergence<B: DrawingBackend>(
    root: DrawingArea<B, Shift>,
    points: &[(f64, f64)],
    paths: &[Path01],
) -> DrawResult
where
    B::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (e0, e1) = range(points.iter().map(|p| p.0).chain(paths.iter().flat_map(|p| p.points.iter().map(|q| q.0))));
    let e0 = e0.max(0.0);
    let panels = root.split_evenly((if paths.is_empty() { 1 } else { 2 }, 1));
    let [area, legend] = with_legend_column(&panels[0]);
    let positive: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.1 > 0.0 && plottable(p.1)).collect();
    let (lo, hi) = positive.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    // A log axis shows f falling over decades; over less than one it would show no tick, so
    // f gets a linear axis then.
    macro_rules! best_f_panel {
        ($y:expr, $format:expr) => {{
            let mut chart = panel_chart(&area, "convergence: best f after each batch", e0..e1, $y)?;
            chart
                .configure_mesh()
                .x_desc("evaluations")
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_desc("best f")
                .y_label_formatter($format)
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 14))
                .draw()?;
            chart.draw_series(LineSeries::new(positive.iter().copied(), OPTIMIZED.stroke_width(1)))?;
            chart.draw_series(positive.iter().map(|p| Circle::new(*p, 3, OPTIMIZED.filled())))?;
            draw_key(&legend, &chart, &[("best f after a batch".to_owned(), Key::Dot(OPTIMIZED.filled()))])?;
        }};
    }
    if !lo.is_finite() {
        best_f_panel!((1e-6..1.0).log_scale(), &|v| format!("{v:.0e}"));
    } else if hi / lo >= 10.0 {
        best_f_panel!((lo * 0.5..hi * 2.0).log_scale(), &|v| format!("{v:.0e}"));
    } else {
        let (y0, y1) = range(positive.iter().map(|p| p.1));
        best_f_panel!(y0..y1, &|v| tick(*v, y1 - y0));
    }
    if let Some(panel) = panels.get(1) {
        let [area, legend] = with_legend_column(panel);
        let mut chart = panel_chart(&area, "parameters: best point after each batch", e0..e1, -0.05..1.05)?;
        chart
            .configure_mesh()
            .x_desc("evaluations")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_desc("place in bounds (0 lower, 1 upper)")
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 14))
            .draw()?;
        let bound = BLACK.mix(0.4).stroke_width(1);
        for b in [0.0, 1.0] {
            chart.draw_series(LineSeries::new([(e0, b), (e1, b)], bound))?;
        }
        let mut keys = vec![];
        for (k, p) in paths.iter().enumerate() {
            let style = path_colour(k).stroke_width(2);
            chart.draw_series(LineSeries::new(p.points.iter().copied(), style))?;
            chart.draw_series(p.points.iter().map(|q| Circle::new(*q, 2, style.filled())))?;
            // The bounds stay whole; a long name is cut to leave them room.
            let bounds = format!(" [{}, {}]", short(p.lower), short(p.upper));
            let name = cut(&p.name, LEGEND_CHARS.saturating_sub(bounds.chars().count()).max(4));
            keys.push((name + &bounds, Key::Line(style)));
        }
        draw_key(&legend, &chart, &keys)?;
    }
    root.present()?;
    Ok(())
}

/// Draws `fit`, `error` and `convergence` as SVG and PNG into `dir`, the fit and error plots
/// with the calibration/validation split of `errors` if it has a validation window, and the
/// convergence plot with the path of each of `parameters` (in the order of the history's
/// best points) if the history holds them.
///
/// # Errors
/// [`ReportError`] if a plot cannot be written, or if drawing takes longer than
/// [`DRAW_TIME_LIMIT`] (the drawing threads are then left to end with the process).
pub fn draw_all(
    dir: &Path,
    fit: &FitTable,
    history: &[HistoryPoint],
    parameters: &[ParameterRange],
    errors: Option<&ErrorReport>,
) -> Result<(), ReportError> {
    register_font();
    let series = std::sync::Arc::new(series(fit));
    let conv: std::sync::Arc<(Vec<(f64, f64)>, Vec<Path01>)> = std::sync::Arc::new((
        history.iter().map(|h| (h.evaluations as f64, h.best_f)).collect(),
        parameter_paths(history, parameters),
    ));
    let split = errors.and_then(ErrorReport::validation_split).filter(|t| plottable(*t));
    let height = 300 * series.len().max(1) as u32;
    let conv_height = if conv.1.is_empty() { 450 } else { 800 };
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
            let size = if name == "convergence" { (1000, conv_height) } else { (1000, height) };
            let (points, paths) = (&conv.0, &conv.1);
            let drawn = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match (name, ext) {
                ("fit", "svg") => draw_fit(SVGBackend::new(&path, size).into_drawing_area(), &series, split),
                ("fit", _) => draw_fit(BitMapBackend::new(&path, size).into_drawing_area(), &series, split),
                ("error", "svg") => draw_error(SVGBackend::new(&path, size).into_drawing_area(), &series, split),
                ("error", _) => draw_error(BitMapBackend::new(&path, size).into_drawing_area(), &series, split),
                (_, "svg") => draw_convergence(SVGBackend::new(&path, size).into_drawing_area(), points, paths),
                _ => draw_convergence(BitMapBackend::new(&path, size).into_drawing_area(), points, paths),
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
                unit: None,
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
                best_x: vec![],
            })
            .collect::<Vec<_>>();
        draw_all(dir.path(), &fit, &history, &[], None).unwrap();
        for file in ["fit.svg", "fit.png", "error.svg", "error.png", "convergence.svg", "convergence.png"] {
            assert!(std::fs::metadata(dir.path().join(file)).unwrap().len() > 0, "{file}");
        }
        let s = series(&fit);
        assert_eq!((s[0].measured.as_slice(), s[0].nominal.as_slice()), (&[(2.0, 1.0)][..], &[(0.0, 0.5)][..]));
    }

    /// The opening tags of the SVG elements `tag` (e.g. `polyline`) in document order, each
    /// with its text content for a `text` element.
    fn elements<'a>(svg: &'a str, tag: &str) -> Vec<(&'a str, &'a str)> {
        let open = format!("<{tag} ");
        let mut out = vec![];
        let mut rest = svg;
        while let Some(at) = rest.find(&open) {
            rest = &rest[at..];
            let end = rest.find('>').unwrap();
            let content = rest[end + 1..].split('<').next().unwrap_or_default().trim();
            out.push((&rest[..end], content));
            rest = &rest[end..];
        }
        out
    }

    fn attr<'a>(element: &'a str, name: &str) -> &'a str {
        let key = format!(" {name}=\"");
        let at = element.find(&key).unwrap_or_else(|| panic!("{element} has no {name}")) + key.len();
        element[at..].split('"').next().unwrap()
    }

    fn number(element: &str, name: &str) -> f64 {
        attr(element, name).parse().unwrap()
    }

    fn points(element: &str) -> Vec<(f64, f64)> {
        let p = attr(element, "points").split_whitespace();
        p.map(|xy| xy.split_once(',').map(|(x, y)| (x.parse().unwrap(), y.parse().unwrap())).unwrap()).collect()
    }

    /// The x of each `text` element that reads `label`.
    fn text_x(svg: &str, label: &str) -> Vec<f64> {
        elements(svg, "text").into_iter().filter(|e| e.1 == label).map(|e| number(e.0, "x")).collect()
    }

    /// The right edge of the data areas: the grid lines span them.
    fn data_right(svg: &str) -> f64 {
        elements(svg, "line").iter().map(|e| number(e.0, "x2")).fold(f64::NEG_INFINITY, f64::max)
    }

    /// The optimized model's trace: the widest red polyline with more than two points.
    fn optimized_trace(svg: &str) -> Vec<(f64, f64)> {
        let lines = elements(svg, "polyline");
        let red = lines.iter().filter(|e| attr(e.0, "stroke") == "#DC1414" || attr(e.0, "stroke") == "#FF0000");
        red.map(|e| points(e.0)).filter(|p| p.len() > 2).max_by_key(Vec::len).expect("an optimized trace")
    }

    /// An output `y` in rad sampled 4,000 times over 10 s (a sine, nominal at 0.8 of it),
    /// with a validation window after 6 s.
    fn sine() -> (FitTable, ErrorReport) {
        let time: Vec<f64> = (0..4000).map(|i| i as f64 * 10.0 / 3999.0).collect();
        let y: Vec<f64> = time.iter().map(|t| t.sin()).collect();
        let fit = FitTable {
            time: time.clone(),
            outputs: vec![FitColumns {
                variable: "y".into(),
                unit: Some("rad".into()),
                measured: y.iter().zip(&time).map(|(y, t)| y + 0.01 * (37.0 * t).sin()).collect(),
                nominal: y.iter().map(|y| Some(0.8 * y)).collect(),
                optimized: y.iter().map(|y| Some(*y)).collect(),
            }],
        };
        let window = |start, stop| fmucal_shared::job::result::WindowError {
            start_time: start,
            stop_time: stop,
            rms_start: 1.0,
            rms_optimized: 0.1,
            scaled_rms: 0.1,
        };
        (fit, ErrorReport { calibration: window(0.0, 6.0), validation: Some(window(6.0, 10.0)), outputs: vec![] })
    }

    fn draw_sine(history: &[HistoryPoint], parameters: &[ParameterRange]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        let (fit, errors) = sine();
        draw_all(dir.path(), &fit, history, parameters, Some(&errors)).unwrap();
        dir
    }

    /// The history of `rounds` batches of `size` points each, batch k ending with `best(k)`:
    /// the best f and point.
    fn batches(rounds: u64, size: u64, best: impl Fn(u64) -> (f64, Vec<f64>)) -> Vec<HistoryPoint> {
        let point = |k| {
            let (best_f, best_x) = best(k);
            HistoryPoint { round: k, evaluations: size * k, best_f, batch_wall_s: 0.1, best_x }
        };
        (1..=rounds).map(point).collect()
    }

    fn read(dir: &tempfile::TempDir, file: &str) -> String {
        std::fs::read_to_string(dir.path().join(file)).unwrap()
    }

    #[test]
    fn axes_are_labelled_with_the_units_of_the_model_description() {
        let dir = draw_sine(&[], &[]);
        let (fit, error) = (read(&dir, "fit.svg"), read(&dir, "error.svg"));
        for svg in [&fit, &error] {
            assert_eq!(text_x(svg, "time [s]").len(), 1, "{svg}");
        }
        assert_eq!(text_x(&fit, "y [rad]").len(), 1);
        assert_eq!(text_x(&error, "|measured − simulated| [rad]").len(), 1);
        assert_eq!(axis_label("y", None), "y");
        assert_eq!([cut("pendulumJoint.phi", 8), cut("phi", 8)], ["pen….phi", "phi"]);
        // Tick labels carry the digits their axis needs, and no minus zero.
        assert_eq!(
            [tick(-0.0001, 2.2), tick(0.4, 2.2), tick(15.0, 20.0), tick(2e-5, 4e-5)],
            ["0.0", "0.4", "15", "2.0e-5"]
        );
    }

    #[test]
    fn every_legend_stands_right_of_the_data_area() {
        let history = batches(3, 4, |k| (1.0 / k as f64, vec![k as f64]));
        let dir = draw_sine(&history, &[ParameterRange { name: "a".into(), lower: 0.0, upper: 4.0 }]);
        for (file, labels) in [
            ("fit.svg", &["optimized", "start", "measured (1 in 10)", "validation window"][..]),
            ("error.svg", &["optimized", "start", "validation window"][..]),
            ("convergence.svg", &["best f after a batch", "a [0, 4]"][..]),
        ] {
            let svg = read(&dir, file);
            let right = data_right(&svg);
            for label in labels {
                let x = text_x(&svg, label);
                assert!(
                    !x.is_empty() && x.iter().all(|x| *x > right),
                    "{file}: {label} at {x:?}, data area to {right}"
                );
            }
            // The legend's frame, too: every framed box lies right of the data area.
            let frames = elements(&svg, "rect").into_iter().filter(|e| attr(e.0, "stroke") == "#000000");
            let frames: Vec<f64> = frames.map(|e| number(e.0, "x")).collect();
            assert!(!frames.is_empty() && frames.iter().all(|x| *x > right), "{file}: {frames:?} vs {right}");
        }
    }

    #[test]
    fn the_fit_plot_marks_where_validation_starts() {
        let dir = draw_sine(&[], &[]);
        let svg = read(&dir, "fit.svg");
        // The trace maps time to pixels: 0 s at its first point, 10 s at its last.
        let trace = optimized_trace(&svg);
        let (first, last) = (trace[0].0, trace[trace.len() - 1].0);
        let expected = first + 0.6 * (last - first);
        let vertical: Vec<f64> = elements(&svg, "polyline")
            .iter()
            .filter(|e| attr(e.0, "stroke") == "#787878")
            .map(|e| points(e.0))
            .filter(|p| p.len() == 2 && p[0].0 == p[1].0)
            .map(|p| p[0].0)
            .collect();
        assert_eq!(vertical.len(), 1, "one marker: {vertical:?}");
        assert!((vertical[0] - expected).abs() <= 1.5, "marker at {}, 6 s at {expected}", vertical[0]);
        let label = text_x(&svg, "validation →");
        assert!(label.len() == 1 && label[0] > vertical[0] && label[0] < vertical[0] + 10.0, "{label:?}");
    }

    #[test]
    fn thousands_of_measurements_are_thinned_under_the_fitted_line() {
        let dir = draw_sine(&[], &[]);
        let svg = read(&dir, "fit.svg");
        let dots = svg.matches("<circle ").count();
        assert!((100..=MAX_MARKERS + 1).contains(&dots), "{dots} markers for 4,000 samples");
        // The fitted line is drawn after (over) the last measured point (the legend's dot,
        // opaque, comes later).
        let last_dot = svg.rfind(r#" r="3" opacity="0.35""#).unwrap();
        let trace = optimized_trace(&svg);
        let trace_at = svg.find(&format!("points=\"{},{}", trace[0].0, trace[0].1)).unwrap();
        assert!(trace_at > last_dot, "the optimized line is drawn under the measurements");
    }

    #[test]
    fn the_convergence_plot_shows_each_parameter_in_its_bounds() {
        let parameters = [
            ParameterRange { name: "k".into(), lower: 0.0, upper: 10.0 },
            ParameterRange { name: "d".into(), lower: -1.0, upper: 1.0 },
        ];
        let history = batches(4, 3, |k| (10.0 / k as f64, vec![2.5 * k as f64, 0.0]));
        let paths = parameter_paths(&history, &parameters);
        assert_eq!(paths.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["k", "d"]);
        assert_eq!(paths[0].points, [(3.0, 0.25), (6.0, 0.5), (9.0, 0.75), (12.0, 1.0)]);
        assert!(paths[1].points.iter().all(|p| p.1 == 0.5));
        let svg = read(&draw_sine(&history, &parameters), "convergence.svg");
        assert_eq!(text_x(&svg, "parameters: best point after each batch").len(), 1);
        assert_eq!(text_x(&svg, "place in bounds (0 lower, 1 upper)").len(), 1);
        assert!(!text_x(&svg, "k [0, 10]").is_empty() && !text_x(&svg, "d [-1, 1]").is_empty());
        // A result written before the history kept its best points: f alone.
        let old: Vec<HistoryPoint> = history.iter().map(|h| HistoryPoint { best_x: vec![], ..h.clone() }).collect();
        assert!(parameter_paths(&old, &parameters).is_empty());
        let svg = read(&draw_sine(&old, &parameters), "convergence.svg");
        assert!(text_x(&svg, "parameters: best point after each batch").is_empty());
        assert_eq!(text_x(&svg, "convergence: best f after each batch").len(), 1);
    }
}
