//! The SVG plots, drawn with `plotters`' SVG backend into strings.
//!
//! Every plot is one `<svg>` element with a `viewBox`, so the page can scale it. Colours are
//! fixed per role ([`MEASURED`], [`MODEL`], [`BEFORE`]) so the page's legends and the tests can
//! name them.

use crate::escape::display_unit;
use crate::{
    ComponentCurve, LocationSeriesPlot, MapSlice, PathPoint, PolarRun, ReportError, ResidualPlot,
};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Measured readings.
pub(crate) const MEASURED: RGBColor = RGBColor(0x22, 0x22, 0x22);
/// The identified model (after the physics search, when it ran).
pub(crate) const MODEL: RGBColor = RGBColor(0x1F, 0x77, 0xB4);
/// The model before the physics search.
pub(crate) const BEFORE: RGBColor = RGBColor(0xD9, 0x5F, 0x02);
pub(crate) const GRID: RGBColor = RGBColor(0xBB, 0xBB, 0xBB);
pub(crate) const INK: RGBColor = RGBColor(0x44, 0x44, 0x44);

/// At most this many markers per residual panel; beyond it every k-th residual is drawn
/// ([`stride`]), so a long session still gives a page of a few hundred kB.
pub(crate) const MAX_MARKERS: usize = 1500;

const FONT: &str = "sans-serif";
/// Tick labels and axis descriptions, in plotters' font units (a pixel is 1.24 of them).
const LABEL: f64 = 14.0;
const DESC: f64 = 15.0;

/// A tick label: at most four decimals, no trailing zeros, a real minus sign.
pub(crate) fn tick(v: &f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.replace('-', "−")
    }
}

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Drawn = Result<(), DrawingAreaErrorKind<std::io::Error>>;

/// Draws into a fresh SVG of `size` pixels; a backend error names the plot.
pub(crate) fn svg(
    size: (u32, u32),
    plot: &str,
    draw: impl FnOnce(&Area<'_>) -> Drawn,
) -> Result<String, ReportError> {
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, size).into_drawing_area();
        draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| ReportError::Plot {
                plot: plot.to_string(),
                message: e.to_string(),
            })?;
    }
    Ok(buf)
}

type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart on `area` in the report's style: the title as caption, room for the tick labels,
/// axes with their descriptions `(x, y)`, ticks by [`tick`], and no grid lines.
pub(crate) fn xy_chart<'a, 'b>(
    area: &'a Area<'b>,
    title: &str,
    (x, y): (std::ops::Range<f64>, std::ops::Range<f64>),
    (x_desc, y_desc): (&str, &str),
) -> Result<Chart<'a, 'b>, DrawingAreaErrorKind<std::io::Error>> {
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 17))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .label_style((FONT, LABEL))
        .axis_desc_style((FONT, DESC))
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()?;
    Ok(chart)
}

fn invalid(what: &str, message: String) -> ReportError {
    ReportError::Invalid {
        what: what.to_string(),
        message,
    }
}

/// The smallest of 1, 2, 5 × 10ᵏ that is ≥ `x` (`x` > 0).
pub(crate) fn nice_ceil(x: f64) -> f64 {
    let x = if x.is_finite() && x > 0.0 { x } else { 1.0 };
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&v| v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * p)
}

/// Every `stride(n)`-th of `n` residuals is drawn.
pub(crate) fn stride(n: usize) -> usize {
    n.div_ceil(MAX_MARKERS).max(1)
}

/// `lo..hi` widened to a usable range (a constant variable gets ±1, or ±1 % of its value).
pub(crate) fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    if hi - lo <= 1e-12 * hi.abs().max(lo.abs()).max(1e-300) {
        let pad = if lo == 0.0 { 1.0 } else { 0.01 * lo.abs() };
        return (lo - pad, hi + pad);
    }
    let pad = 0.02 * (hi - lo);
    (lo - pad, hi + pad)
}

pub(crate) fn text_style(
    size: f64,
    color: &'static RGBColor,
    h: HPos,
    v: VPos,
) -> TextStyle<'static> {
    TextStyle::from((FONT, size).into_font())
        .color(color)
        .pos(Pos::new(h, v))
}

/// The polar plot of a ball-bar circle: `dr` magnified about a reference circle of radius
/// `2s`, with rings at `±s` (`s` the nicely rounded largest |dr|), one trace per series.
pub(crate) fn polar(run: &PolarRun) -> Result<String, ReportError> {
    let n = run.angles_deg.len();
    let mut series: Vec<(&[f64], RGBColor, u32)> = vec![(&run.measured_um, MEASURED, 1)];
    if let Some(before) = &run.model_before_um {
        series.push((before, BEFORE, 2));
    }
    series.push((&run.model_um, MODEL, 2));
    for (data, _, _) in &series {
        if data.len() != n {
            return Err(invalid(
                &run.name,
                format!("{} angles but {} values of dr", n, data.len()),
            ));
        }
    }
    let largest = series
        .iter()
        .flat_map(|(d, _, _)| d.iter())
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let s = nice_ceil(largest.max(1e-3));
    let r0 = 2.0 * s;
    let lim = 3.5 * s;
    let letters: Vec<char> = run.plane.chars().collect();
    svg((440, 440), &run.name, |root| {
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(root)
            .margin(6)
            .build_cartesian_2d(-lim..lim, -lim..lim)?;
        let ring = |r: f64| {
            (0..=180).map(move |k| {
                let a = k as f64 * std::f64::consts::TAU / 180.0;
                (r * a.cos(), r * a.sin())
            })
        };
        for (k, r) in [(-1.0, r0 - s), (0.0, r0), (1.0, r0 + s)] {
            let width = if k == 0.0 { 2 } else { 1 };
            chart.draw_series(LineSeries::new(ring(r), GRID.stroke_width(width)))?;
            let label = if k == 0.0 {
                "0".to_string()
            } else {
                format!("{}{} µm", if k < 0.0 { "−" } else { "+" }, s)
            };
            let a = 67.5f64.to_radians();
            chart.draw_series(std::iter::once(Text::new(
                label,
                (r * a.cos(), r * a.sin()),
                text_style(13.0, &INK, HPos::Center, VPos::Bottom),
            )))?;
        }
        for k in 0..8 {
            let a = (k as f64 * 45.0).to_radians();
            let (c, si) = (a.cos(), a.sin());
            chart.draw_series(LineSeries::new(
                [((r0 - s) * c, (r0 - s) * si), ((r0 + s) * c, (r0 + s) * si)],
                GRID,
            ))?;
            let mut label = format!("{}°", k * 45);
            match (k, letters.as_slice()) {
                (0, [a, _]) => label = format!("+{a} {label}"),
                (2, [_, b]) => label = format!("+{b} {label}"),
                _ => {}
            }
            let r = r0 + 1.25 * s;
            chart.draw_series(std::iter::once(Text::new(
                label,
                (r * c, r * si),
                text_style(15.0, &INK, HPos::Center, VPos::Center),
            )))?;
        }
        for (data, color, width) in &series {
            let points = run
                .angles_deg
                .iter()
                .zip(data.iter())
                .filter(|(a, d)| a.is_finite() && d.is_finite())
                .map(|(a, d)| {
                    let a = a.to_radians();
                    ((r0 + d) * a.cos(), (r0 + d) * a.sin())
                });
            chart.draw_series(LineSeries::new(points, color.stroke_width(*width)))?;
        }
        Ok(())
    })
}

/// One panel of a residual plot: its title, `(variable, residual)` points and their colour.
type Panel<'a> = (&'static str, &'a [(f64, f64)], RGBColor);

/// Residuals against one variable: one panel, or before | after on one scale.
pub(crate) fn residuals(p: &ResidualPlot) -> Result<String, ReportError> {
    let mut panels: Vec<Panel<'_>> = Vec::new();
    if let Some(before) = &p.before {
        panels.push(("before the physics search", before, BEFORE));
        panels.push(("after the physics search", &p.after, MODEL));
    } else {
        panels.push(("identified model", &p.after, MODEL));
    }
    let all = || panels.iter().flat_map(|(_, pts, _)| pts.iter());
    let (x0, x1) = span(all().map(|&(x, _)| x));
    let ymax = nice_ceil(
        all()
            .map(|&(_, y)| y)
            .filter(|y| y.is_finite())
            .fold(0.0f64, |m, y| m.max(y.abs()))
            .max(1e-6),
    );
    let unit = display_unit(&p.unit);
    let x_desc = if unit.is_empty() {
        p.variable.clone()
    } else {
        format!("{} ({unit})", p.variable)
    };
    let y_desc = format!("reading − model ({})", display_unit(&p.residual_unit));
    let width = 460 * panels.len() as u32;
    svg(
        (width, 340),
        &format!("residuals along {}", p.variable),
        |root| {
            root.fill(&WHITE)?;
            let areas = root.split_evenly((1, panels.len()));
            for (area, (title, pts, color)) in areas.iter().zip(&panels) {
                let mut chart = xy_chart(area, title, (x0..x1, -ymax..ymax), (&x_desc, &y_desc))?;
                chart.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], GRID))?;
                let k = stride(pts.len());
                chart.draw_series(
                    pts.iter()
                        .step_by(k)
                        .filter(|(x, y)| x.is_finite() && y.is_finite())
                        .map(|&(x, y)| Circle::new((x, y), 2, color.mix(0.55).filled())),
                )?;
            }
            Ok(())
        },
    )
}

/// A component error along its axis with its 95 % band (a filled polygon: the upper edge
/// forwards, the lower edge backwards).
pub(crate) fn component(c: &ComponentCurve) -> Result<String, ReportError> {
    let pts: Vec<_> = c
        .samples
        .iter()
        .filter(|p| p.position.is_finite() && p.value.is_finite() && p.u95.is_finite())
        .copied()
        .collect();
    if pts.len() < 2 {
        return Err(invalid(
            &c.name,
            format!("a curve needs two finite samples, found {}", pts.len()),
        ));
    }
    let (x0, x1) = span(pts.iter().map(|p| p.position));
    let (y0, y1) = span(
        pts.iter()
            .flat_map(|p| [p.value - p.u95.abs(), p.value + p.u95.abs(), 0.0]),
    );
    let pad = 0.06 * (y1 - y0);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let x_desc = format!("position ({})", display_unit(&c.position_unit));
    let y_desc = format!("{} ({})", c.name, display_unit(&c.value_unit));
    svg((460, 300), &c.name, |root| {
        root.fill(&WHITE)?;
        let mut chart = xy_chart(root, &c.name, (x0..x1, y0..y1), (&x_desc, &y_desc))?;
        chart.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], GRID))?;
        let band: Vec<(f64, f64)> = pts
            .iter()
            .map(|p| (p.position, p.value + p.u95.abs()))
            .chain(
                pts.iter()
                    .rev()
                    .map(|p| (p.position, p.value - p.u95.abs())),
            )
            .collect();
        chart.draw_series(std::iter::once(Polygon::new(band, MODEL.mix(0.2).filled())))?;
        chart.draw_series(LineSeries::new(
            pts.iter().map(|p| (p.position, p.value)),
            MODEL.stroke_width(2),
        ))?;
        Ok(())
    })
}

/// A location error's changes cycle by cycle: each cycle's own value as a dot with its 95 %
/// interval as a bar (hollow for a validation cycle), the model's change as a line through
/// the cycles.
pub(crate) fn location_series(p: &LocationSeriesPlot) -> Result<String, ReportError> {
    let pts: Vec<_> = p
        .cycles
        .iter()
        .filter(|c| c.t_h.is_finite() && c.model.is_finite())
        .copied()
        .collect();
    if pts.len() < 2 {
        return Err(invalid(
            &p.name,
            format!("a series needs two cycles, found {}", pts.len()),
        ));
    }
    let (x0, x1) = span(pts.iter().map(|c| c.t_h));
    let (y0, y1) = span(pts.iter().flat_map(|c| {
        let own = match (c.value, c.u95) {
            (Some(v), Some(u)) if v.is_finite() && u.is_finite() => vec![v - u, v + u],
            _ => Vec::new(),
        };
        own.into_iter().chain([c.model, 0.0])
    }));
    let pad = 0.06 * (y1 - y0);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let y_desc = format!("change of {} ({})", p.name, display_unit(&p.unit));
    svg((460, 300), &p.name, |root| {
        root.fill(&WHITE)?;
        let mut chart = xy_chart(root, &p.name, (x0..x1, y0..y1), ("time (h)", &y_desc))?;
        chart.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], GRID))?;
        chart.draw_series(LineSeries::new(
            pts.iter().map(|c| (c.t_h, c.model)),
            MODEL.stroke_width(2),
        ))?;
        for c in &pts {
            if let (Some(v), Some(u)) = (c.value, c.u95)
                && v.is_finite()
                && u.is_finite()
            {
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(c.t_h, v - u), (c.t_h, v + u)],
                    MEASURED.mix(0.6),
                )))?;
                let style = if c.validation {
                    MEASURED.stroke_width(1)
                } else {
                    MEASURED.filled()
                };
                chart.draw_series(std::iter::once(Circle::new((c.t_h, v), 3, style)))?;
            }
        }
        Ok(())
    })
}

/// The predicted error along a tool path: |error| against distance, and the tool-axis tilt
/// when given. One line per panel with one vertex per point.
pub(crate) fn path_error(title: &str, points: &[PathPoint]) -> Result<String, ReportError> {
    let finite: Vec<PathPoint> = points
        .iter()
        .filter(|p| p.along_mm.is_finite() && p.error_um.is_finite())
        .copied()
        .collect();
    if finite.len() < 2 {
        return Err(invalid(
            title,
            format!("a path needs two finite points, found {}", finite.len()),
        ));
    }
    let tilts: Vec<(f64, f64)> = finite
        .iter()
        .filter_map(|p| {
            p.tilt_urad
                .filter(|t| t.is_finite())
                .map(|t| (p.along_mm, t))
        })
        .collect();
    let errors: Vec<(f64, f64)> = finite.iter().map(|p| (p.along_mm, p.error_um)).collect();
    // (title, points, axis description)
    type PathPanel<'a> = (&'static str, &'a [(f64, f64)], &'static str);
    let mut panels: Vec<PathPanel<'_>> = vec![("tool-tip error", &errors, "|error| (µm)")];
    if tilts.len() >= 2 {
        panels.push(("tool-axis tilt", &tilts, "tilt (µrad)"));
    }
    let (x0, x1) = span(errors.iter().map(|&(x, _)| x));
    svg((460 * panels.len() as u32, 320), title, |root| {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, panels.len()));
        for (area, (name, pts, desc)) in areas.iter().zip(&panels) {
            let top = nice_ceil(
                pts.iter()
                    .fold(0.0f64, |m, &(_, y)| m.max(y.abs()))
                    .max(1e-6),
            );
            let mut chart = xy_chart(
                area,
                name,
                (x0..x1, 0.0..top),
                ("along the path (mm)", desc),
            )?;
            chart.draw_series(LineSeries::new(pts.iter().copied(), MODEL.stroke_width(2)))?;
        }
        Ok(())
    })
}

/// The colour of `t` ∈ [0, 1] on a viridis-like scale (dark blue → green → yellow).
pub(crate) fn colour(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (STOPS.len() - 1) as f64;
    let k = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - k as f64;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Cell edges around increasing grid positions: midway between neighbours, half a spacing
/// beyond the ends (±0.5 for a single point).
fn edges(v: &[f64]) -> Vec<f64> {
    if v.len() == 1 {
        return vec![v[0] - 0.5, v[0] + 0.5];
    }
    let mut e = Vec::with_capacity(v.len() + 1);
    e.push(v[0] - 0.5 * (v[1] - v[0]));
    for w in v.windows(2) {
        e.push(0.5 * (w[0] + w[1]));
    }
    let n = v.len();
    e.push(v[n - 1] + 0.5 * (v[n - 1] - v[n - 2]));
    e
}

/// A map slice as coloured cells on the scale 0 … `vmax` µm, with its colour bar.
pub(crate) fn map_slice(s: &MapSlice, vmax: f64) -> Result<String, ReportError> {
    let (nx, ny) = (s.xs.len(), s.ys.len());
    if nx == 0 || ny == 0 || s.values_um.len() != nx * ny {
        return Err(invalid(
            &s.title,
            format!(
                "{} values for a {nx} × {ny} grid (one per grid point expected)",
                s.values_um.len()
            ),
        ));
    }
    if s.xs.iter().chain(&s.ys).any(|v| !v.is_finite())
        || s.xs.windows(2).any(|w| w[1] <= w[0])
        || s.ys.windows(2).any(|w| w[1] <= w[0])
    {
        return Err(invalid(
            &s.title,
            "grid positions must be finite and increasing".into(),
        ));
    }
    let vmax = if vmax.is_finite() && vmax > 0.0 {
        vmax
    } else {
        1.0
    };
    let (ex, ey) = (edges(&s.xs), edges(&s.ys));
    svg((500, 400), &s.title, |root| {
        root.fill(&WHITE)?;
        let (left, right) = root.split_horizontally(414);
        let mut chart = ChartBuilder::on(&left)
            .caption(s.title.as_str(), (FONT, 17))
            .margin(8)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(ex[0]..ex[nx], ey[0]..ey[ny])?;
        chart
            .configure_mesh()
            .disable_mesh()
            .label_style((FONT, LABEL))
            .axis_desc_style((FONT, DESC))
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .x_desc(s.x_label.as_str())
            .y_desc(s.y_label.as_str())
            .draw()?;
        chart.draw_series((0..ny).flat_map(|j| {
            let (ex, ey) = (&ex, &ey);
            (0..nx).map(move |i| {
                let v = s.values_um[j * nx + i];
                Rectangle::new(
                    [(ex[i], ey[j]), (ex[i + 1], ey[j + 1])],
                    colour(v / vmax).filled(),
                )
            })
        }))?;
        let mut bar = ChartBuilder::on(&right)
            .margin_top(40)
            .margin_bottom(48)
            .margin_right(8)
            .y_label_area_size(52)
            .build_cartesian_2d(0.0..1.0, 0.0..vmax)?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .label_style((FONT, LABEL))
            .axis_desc_style((FONT, DESC))
            .y_label_formatter(&tick)
            .y_desc("|Δ| (µm)")
            .draw()?;
        const STEPS: usize = 48;
        bar.draw_series((0..STEPS).map(|k| {
            let (a, b) = (k as f64 / STEPS as f64, (k + 1) as f64 / STEPS as f64);
            Rectangle::new(
                [(0.0, a * vmax), (1.0, b * vmax)],
                colour(0.5 * (a + b)).filled(),
            )
        }))?;
        Ok(())
    })
}

/// Tolerance lines on trend plots.
const LIMIT: RGBColor = RGBColor(0xC0, 0x20, 0x20);

/// One parameter's history: each campaign's value with its 95 % interval (superseded ones
/// grey), the drift line with its 95 % band, and the tolerance lines ±limit; days since the
/// first campaign along x.
pub(crate) fn trend(v: &crate::TrendPlot) -> Result<String, ReportError> {
    let valued: Vec<(f64, f64, f64, bool)> = v
        .points
        .iter()
        .filter_map(|p| match (p.value, p.u95) {
            (Some(value), Some(u95)) => Some((p.time_s, value, u95.abs(), p.superseded)),
            _ => None,
        })
        .filter(|(t, value, u95, _)| t.is_finite() && value.is_finite() && u95.is_finite())
        .collect();
    if valued.is_empty() {
        return Err(invalid(&v.parameter, "no campaign has a value".into()));
    }
    let t0 = valued[0].0;
    let day = |t: f64| (t - t0) / 86_400.0;
    let (x0, x1) = span(valued.iter().map(|p| day(p.0)));
    let limit = v.limit.filter(|l| l.is_finite());
    let ys = valued
        .iter()
        .flat_map(|p| [p.1 - p.2, p.1 + p.2])
        .chain(limit.into_iter().flat_map(|l| [l, -l]));
    let (y0, y1) = span(ys);
    let unit = display_unit(v.unit.as_deref().unwrap_or(""));
    let y_desc = format!("{} ({unit})", v.parameter);
    let title = format!("{} of {}", v.parameter, v.machine);
    svg((460, 300), &v.parameter, |root| {
        root.fill(&WHITE)?;
        let mut chart = xy_chart(root, &title, (x0..x1, y0..y1), ("days", &y_desc))?;
        if let Some(t) = &v.trend {
            let line: Vec<(f64, f64, f64)> = (0..=40)
                .map(|k| t0 + (x0 + (x1 - x0) * f64::from(k) / 40.0) * 86_400.0)
                .map(|t_s| {
                    let (value, u95) = t.drift.value_at(t_s);
                    (day(t_s), value, u95)
                })
                .collect();
            let band: Vec<(f64, f64)> = line
                .iter()
                .map(|p| (p.0, p.1 + p.2))
                .chain(line.iter().rev().map(|p| (p.0, p.1 - p.2)))
                .collect();
            chart.draw_series(std::iter::once(Polygon::new(
                band,
                MODEL.mix(0.15).filled(),
            )))?;
            chart.draw_series(LineSeries::new(
                line.iter().map(|p| (p.0, p.1)),
                MODEL.stroke_width(2),
            ))?;
        }
        if let Some(l) = limit {
            for y in [l, -l] {
                chart.draw_series(LineSeries::new([(x0, y), (x1, y)], LIMIT.stroke_width(2)))?;
            }
        }
        for &(t, value, u95, superseded) in &valued {
            let colour = if superseded { GRID } else { MEASURED };
            let x = day(t);
            chart.draw_series(LineSeries::new(
                [(x, value - u95), (x, value + u95)],
                colour.stroke_width(1),
            ))?;
            chart.draw_series(std::iter::once(Circle::new((x, value), 3, colour.filled())))?;
        }
        Ok(())
    })
}
