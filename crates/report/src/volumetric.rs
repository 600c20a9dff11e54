//! The volumetric thermal test's page (`cargo xtask volumetric --report FILE.html`): one
//! self-contained page in the identification report's style with the verdict and its table,
//! one vector plot per phase (the points in the XY and XZ planes, each with its deformation as
//! an arrow on a stated scale), and the time plots of the mean deformation per axis and of the
//! spread between points (max − min, standard deviation) with their noise floors. Renders
//! only: every number is given ([`VolumetricPage`]).
//!
//! Section ids: `verdict`, `phases`, `time`, `details`. Each plot is a `<figure class="plot">`
//! (`data-plot="vectors"`, `"mean"`, `"range"`, `"std"`).

use std::fmt::Write as _;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use crate::ReportError;
use crate::escape::escape;
use crate::page::{READY, figure, head};
use crate::plots::{GRID, INK, span, svg, text_style, xy_chart};

/// The colours of X, Y and Z.
pub(crate) const AXIS_COLOURS: [RGBColor; 3] = [
    RGBColor(0xD6, 0x27, 0x28),
    RGBColor(0x2C, 0xA0, 0x2C),
    RGBColor(0x1F, 0x77, 0xB4),
];
const AXES: [char; 3] = ['X', 'Y', 'Z'];

/// Everything the page shows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VolumetricPage {
    /// `mtcal volumetric — <session>`.
    pub title: String,
    pub session: String,
    /// `uniform`, `not uniform`, `cannot decide`.
    pub verdict: String,
    pub sentence: String,
    /// The verdict's instant, h, and the tolerance share (0.2).
    pub verdict_t_h: f64,
    pub tolerance_share: f64,
    /// Per axis at the verdict's instant.
    pub rows: Vec<VolumetricRow>,
    /// How the evaluation was done (cycles, time base, noise) and its notes, one line each.
    pub facts: Vec<String>,
    pub series: VolumetricSeries,
    pub phases: Vec<VectorField>,
}

/// One axis at the verdict's instant, µm; shares as fractions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VolumetricRow {
    pub axis: char,
    pub mean_um: f64,
    pub mean_u95_um: f64,
    pub range_um: f64,
    pub range_interval_um: [f64; 2],
    pub range_floor_um: f64,
    pub share: Option<f64>,
    pub share_interval: Option<[f64; 2]>,
    pub std_um: f64,
    pub std_interval_um: [f64; 2],
    pub std_floor_um: f64,
    pub verdict: String,
}

/// The instants' statistics, per axis X, Y, Z; all series as long as `t_h`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VolumetricSeries {
    /// Time of each instant, h.
    pub t_h: Vec<f64>,
    pub mean_um: [Vec<f64>; 3],
    pub mean_u95_um: [Vec<f64>; 3],
    pub range_um: [Vec<f64>; 3],
    pub range_floor_um: [Vec<f64>; 3],
    pub std_um: [Vec<f64>; 3],
    pub std_floor_um: [Vec<f64>; 3],
}

/// The deformation vectors of every point at one instant.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VectorField {
    /// `2.7 h (cycle 12)`.
    pub title: String,
    pub points: Vec<VectorPoint>,
}

/// One point: where it is (commanded X, Y, Z, mm) and its deformation (µm).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VectorPoint {
    pub name: String,
    pub position_mm: [f64; 3],
    pub deformation_um: [f64; 3],
}

/// The page's HTML.
pub fn render_volumetric(p: &VolumetricPage) -> Result<String, ReportError> {
    check_series(&p.series)?;
    let mut h = String::with_capacity(1 << 18);
    head(&mut h, &p.title);
    let _ = write!(
        h,
        "<p>session <code>{}</code></p></header>\n<nav><a href=\"#verdict\">Verdict</a>\
         <a href=\"#phases\">Deformation vectors</a><a href=\"#time\">Over time</a>\
         <a href=\"#details\">How</a></nav>\n<main>\n",
        escape(&p.session)
    );
    let sections = [
        ("verdict", "Verdict", verdict(p)),
        ("phases", "Deformation vectors", phases(&p.phases)?),
        ("time", "Over time", time(p)?),
        ("details", "How it was evaluated", details(&p.facts)),
    ];
    for (id, heading, body) in sections {
        let _ = write!(
            h,
            "<section id=\"{id}\">\n<h2>{heading}</h2>\n{body}</section>\n"
        );
    }
    let _ = write!(h, "</main>\n<script>{READY}</script>\n</body>\n</html>\n");
    Ok(h)
}

fn check_series(s: &VolumetricSeries) -> Result<(), ReportError> {
    let n = s.t_h.len();
    let all = [
        &s.mean_um,
        &s.mean_u95_um,
        &s.range_um,
        &s.range_floor_um,
        &s.std_um,
        &s.std_floor_um,
    ];
    let bad = all.iter().flat_map(|a| a.iter()).any(|v| v.len() != n);
    let not_finite = all
        .iter()
        .flat_map(|a| a.iter())
        .flatten()
        .chain(&s.t_h)
        .any(|v| !v.is_finite());
    if n == 0 || bad || not_finite {
        return Err(ReportError::Invalid {
            what: "volumetric series".into(),
            message: format!("expected {n} finite values in every series and at least one instant"),
        });
    }
    Ok(())
}

fn pct(x: f64) -> String {
    format!("{:.0}", 100.0 * x)
}

fn verdict_colour(v: &str) -> &'static str {
    match v {
        "uniform" => "#2CA02C",
        "not uniform" => "#C02020",
        _ => "#B8860B",
    }
}

fn verdict(p: &VolumetricPage) -> String {
    let mut h = format!(
        "<p><b class=\"verdict\" data-verdict=\"{v}\" style=\"color:{}\">{}</b></p>\n<p>{}</p>\n",
        verdict_colour(&p.verdict),
        escape(&p.verdict.to_uppercase()),
        escape(&p.sentence),
        v = escape(&p.verdict),
    );
    let _ = write!(
        h,
        "<table id=\"verdict-table\">\n<tr><th>axis</th><th>mean (µm)</th><th>max − min (µm) \
         [95 %]</th><th>noise floor (µm)</th><th>share of |mean| [95 %]</th><th>std (µm) \
         [95 %]</th><th>std floor (µm)</th><th>verdict (tolerance {} %)</th></tr>\n",
        pct(p.tolerance_share)
    );
    for r in &p.rows {
        let share = match (r.share, r.share_interval) {
            (Some(s), Some([lo, hi])) => format!("{} % [{}–{}]", pct(s), pct(lo), pct(hi)),
            _ => "—".into(),
        };
        let _ = writeln!(
            h,
            "<tr data-axis=\"{a}\"><td>{a}</td><td class=\"n\">{:.2} ± {:.2}</td>\
             <td class=\"n\">{:.2} [{:.2}–{:.2}]</td><td class=\"n\">{:.2}</td>\
             <td class=\"n\">{share}</td><td class=\"n\">{:.2} [{:.2}–{:.2}]</td>\
             <td class=\"n\">{:.2}</td><td>{}</td></tr>",
            r.mean_um,
            r.mean_u95_um,
            r.range_um,
            r.range_interval_um[0],
            r.range_interval_um[1],
            r.range_floor_um,
            r.std_um,
            r.std_interval_um[0],
            r.std_interval_um[1],
            r.std_floor_um,
            escape(&r.verdict),
            a = r.axis,
        );
    }
    h.push_str("</table>\n");
    let _ = writeln!(
        h,
        "<p class=\"numbers\">At {:.2} h, the instant of the largest mean deformation. The \
         intervals are for the field's own spread (noise removed); the values shown include the \
         noise; the floor is what noise alone gives (95 %).</p>",
        p.verdict_t_h
    );
    h
}

fn details(facts: &[String]) -> String {
    let mut h = String::from("<ul>\n");
    for f in facts {
        let _ = writeln!(h, "<li>{}</li>", escape(f));
    }
    h.push_str("</ul>\n");
    h
}

fn key(colour: RGBColor, label: &str) -> String {
    format!(
        "<span class=\"key\" style=\"background:#{:02X}{:02X}{:02X}\"></span>{label}",
        colour.0, colour.1, colour.2
    )
}

fn axis_keys() -> String {
    (0..3)
        .map(|i| key(AXIS_COLOURS[i], &AXES[i].to_string()))
        .collect()
}

fn phases(fields: &[VectorField]) -> Result<String, ReportError> {
    let mut h = String::from("<div class=\"plots\">\n");
    for f in fields {
        let (svg, scale) = vectors(f)?;
        let caption = match scale {
            Some((mm_per_um, reference_um)) => format!(
                "{}: each point (commanded X, Y, Z) with its deformation as an arrow, 1 µm drawn \
                 as {} mm (the reference arrow is {} µm); left XY seen from +Z, right XZ seen \
                 from −Y",
                escape(&f.title),
                crate::plots::tick(&mm_per_um),
                crate::plots::tick(&reference_um)
            ),
            None => format!("{}: no deformation to draw", escape(&f.title)),
        };
        h.push_str(&figure("vectors", &f.title, &svg, &caption));
    }
    h.push_str("</div>\n");
    Ok(h)
}

/// A plane of the vector plot: which position and deformation components go along x and y.
struct Plane {
    name: &'static str,
    x: usize,
    y: usize,
}

const PLANES: [Plane; 2] = [
    Plane {
        name: "XY",
        x: 0,
        y: 1,
    },
    Plane {
        name: "XZ",
        x: 0,
        y: 2,
    },
];
/// Each panel's pixels, and roughly its plotting area's (the chart's margins and labels off).
const PANEL: (u32, u32) = (440, 400);
const PLOT_AREA: (f64, f64) = (440.0 - 76.0, 400.0 - 75.0);

/// The vector plot, and (mm per µm, reference arrow µm) when there is anything to draw.
fn vectors(f: &VectorField) -> Result<(String, Option<(f64, f64)>), ReportError> {
    let finite = f.points.iter().all(|p| {
        p.position_mm
            .iter()
            .chain(&p.deformation_um)
            .all(|v| v.is_finite())
    });
    if f.points.is_empty() || !finite {
        return Err(ReportError::Invalid {
            what: f.title.clone(),
            message: "a vector plot needs points with finite positions and deformations".into(),
        });
    }
    let largest_um = f
        .points
        .iter()
        .flat_map(|p| {
            PLANES
                .iter()
                .map(move |pl| p.deformation_um[pl.x].hypot(p.deformation_um[pl.y]))
        })
        .fold(0.0f64, f64::max);
    let extent_mm = PLANES
        .iter()
        .flat_map(|pl| {
            let (x0, x1) = span(f.points.iter().map(|p| p.position_mm[pl.x]));
            let (y0, y1) = span(f.points.iter().map(|p| p.position_mm[pl.y]));
            [x1 - x0, y1 - y0]
        })
        .fold(1.0f64, f64::max);
    // The longest arrow about a fifth of the points' extent, on a 1-2-5 scale.
    let scale = (largest_um > 0.0).then(|| nice_floor(0.2 * extent_mm / largest_um));
    let reference_um = scale.map(|_| nice_floor(0.6 * largest_um).max(f64::MIN_POSITIVE));
    let s = scale.unwrap_or(0.0);
    let svg = svg((2 * PANEL.0, PANEL.1), &f.title, |root| {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, 2));
        for (area, plane) in areas.iter().zip(&PLANES) {
            let (xr, yr) = equal_ranges(f, plane, s);
            let title = format!("{} — {}", f.title, plane.name);
            let x_desc = format!("{} (mm)", AXES[plane.x]);
            let y_desc = format!("{} (mm)", AXES[plane.y]);
            let mut chart = xy_chart(area, &title, (xr.clone(), yr.clone()), (&x_desc, &y_desc))?;
            for p in &f.points {
                let (x, y) = (p.position_mm[plane.x], p.position_mm[plane.y]);
                chart.draw_series(std::iter::once(Circle::new((x, y), 3, INK.filled())))?;
                let tip = (
                    x + s * p.deformation_um[plane.x],
                    y + s * p.deformation_um[plane.y],
                );
                chart.draw_series(arrow((x, y), tip, xr.end - xr.start, AXIS_COLOURS[2]))?;
            }
            if let Some(r) = reference_um {
                let from = (
                    xr.start + 0.06 * (xr.end - xr.start),
                    yr.start + 0.06 * (yr.end - yr.start),
                );
                let to = (from.0 + s * r, from.1);
                chart.draw_series(arrow(from, to, xr.end - xr.start, INK))?;
                let label = format!("{} µm", crate::plots::tick(&r));
                let style = text_style(13.0, &INK, HPos::Left, VPos::Bottom);
                chart.draw_series(std::iter::once(Text::new(
                    label,
                    (from.0, from.1 + 0.02 * (yr.end - yr.start)),
                    style,
                )))?;
            }
        }
        Ok(())
    })?;
    Ok((svg, scale.zip(reference_um)))
}

/// The largest of 1, 2, 5 × 10ᵏ that is ≤ `x` (`x` > 0).
fn nice_floor(x: f64) -> f64 {
    let x = if x.is_finite() && x > 0.0 { x } else { 1.0 };
    let p = 10f64.powf(x.log10().floor());
    let m = x / p * (1.0 + 1e-12);
    [5.0, 2.0, 1.0].into_iter().find(|&k| k <= m).unwrap_or(1.0) * p
}

/// Ranges holding every point and arrow tip, widened so that a mm is as long along x as
/// along y (an arrow's direction is drawn true).
fn equal_ranges(
    f: &VectorField,
    plane: &Plane,
    s: f64,
) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let along = |c: usize| {
        f.points
            .iter()
            .flat_map(move |p| [p.position_mm[c], p.position_mm[c] + s * p.deformation_um[c]])
    };
    let (x0, x1) = span(along(plane.x));
    let (y0, y1) = span(along(plane.y));
    let pad = 0.08 * (x1 - x0).max(y1 - y0).max(1.0);
    let (mut x0, mut x1, mut y0, mut y1) = (x0 - pad, x1 + pad, y0 - pad, y1 + pad);
    let per_px = ((x1 - x0) / PLOT_AREA.0).max((y1 - y0) / PLOT_AREA.1);
    let widen = |lo: &mut f64, hi: &mut f64, len: f64| {
        let extra = 0.5 * (len - (*hi - *lo));
        *lo -= extra;
        *hi += extra;
    };
    widen(&mut x0, &mut x1, per_px * PLOT_AREA.0);
    widen(&mut y0, &mut y1, per_px * PLOT_AREA.1);
    (x0..x1, y0..y1)
}

/// A line from `from` to `to` with an arrowhead, the head a thirtieth of `width` long.
fn arrow(
    from: (f64, f64),
    to: (f64, f64),
    width: f64,
    colour: RGBColor,
) -> Vec<PathElement<(f64, f64)>> {
    let (dx, dy) = (to.0 - from.0, to.1 - from.1);
    let len = dx.hypot(dy);
    let mut out = vec![PathElement::new(vec![from, to], colour.stroke_width(2))];
    if len > 0.0 {
        let head = (width / 30.0).min(0.5 * len);
        let (ux, uy) = (dx / len, dy / len);
        for side in [-1.0, 1.0] {
            let (c, s) = (0.42f64.cos(), side * 0.42f64.sin());
            let back = (-(ux * c - uy * s), -(ux * s + uy * c));
            out.push(PathElement::new(
                vec![to, (to.0 + head * back.0, to.1 + head * back.1)],
                colour.stroke_width(2),
            ));
        }
    }
    out
}

fn time(p: &VolumetricPage) -> Result<String, ReportError> {
    let s = &p.series;
    let mut h = String::from("<div class=\"plots\">\n");
    let mean = line_plot(
        "mean deformation",
        s,
        &s.mean_um,
        Some(&s.mean_u95_um),
        None,
        p.verdict_t_h,
    )?;
    let caption = format!(
        "The mean over the points per axis with its 95 % band; {}; the grey line marks the \
         verdict's instant",
        axis_keys()
    );
    h.push_str(&figure("mean", "mean", &mean, &caption));
    let range = line_plot(
        "max − min between points",
        s,
        &s.range_um,
        None,
        Some(&s.range_floor_um),
        p.verdict_t_h,
    )?;
    let caption = format!(
        "The largest difference between two points per axis; {}; thin: what noise alone \
         gives (95 %)",
        axis_keys()
    );
    h.push_str(&figure("range", "range", &range, &caption));
    let std = line_plot(
        "standard deviation between points",
        s,
        &s.std_um,
        None,
        Some(&s.std_floor_um),
        p.verdict_t_h,
    )?;
    let caption = format!(
        "The standard deviation over the points per axis; {}; thin: what noise alone gives \
         (95 %)",
        axis_keys()
    );
    h.push_str(&figure("std", "std", &std, &caption));
    h.push_str("</div>\n");
    Ok(h)
}

/// Three lines over time (X, Y, Z), with 95 % bands or thin floor lines.
fn line_plot(
    title: &str,
    s: &VolumetricSeries,
    values: &[Vec<f64>; 3],
    band: Option<&[Vec<f64>; 3]>,
    floor: Option<&[Vec<f64>; 3]>,
    marker_h: f64,
) -> Result<String, ReportError> {
    let (x0, x1) = span(s.t_h.iter().copied().chain([marker_h]));
    let ys = (0..3).flat_map(|i| {
        let u = move |k: usize| band.map_or(0.0, |b| b[i][k]);
        let f = move |k: usize| floor.map_or(0.0, |f| f[i][k]);
        (0..s.t_h.len()).flat_map(move |k| [values[i][k] - u(k), values[i][k] + u(k), f(k)])
    });
    let (y0, y1) = span(ys.chain([0.0]));
    svg((460, 320), title, |root| {
        root.fill(&WHITE)?;
        let mut chart = xy_chart(root, title, (x0..x1, y0..y1), ("time (h)", "µm"))?;
        chart.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], GRID))?;
        chart.draw_series(LineSeries::new(
            [(marker_h, y0), (marker_h, y1)],
            GRID.stroke_width(2),
        ))?;
        for i in 0..3 {
            let colour = AXIS_COLOURS[i];
            let pts = || s.t_h.iter().copied().zip(values[i].iter().copied());
            if let Some(b) = band {
                let upper = pts().zip(&b[i]).map(|((t, v), u)| (t, v + u));
                let lower = pts().zip(&b[i]).map(|((t, v), u)| (t, v - u));
                let poly: Vec<(f64, f64)> = upper
                    .chain(lower.collect::<Vec<_>>().into_iter().rev())
                    .collect();
                chart.draw_series(std::iter::once(Polygon::new(
                    poly,
                    colour.mix(0.2).filled(),
                )))?;
            }
            if let Some(f) = floor {
                chart.draw_series(LineSeries::new(
                    s.t_h.iter().copied().zip(f[i].iter().copied()),
                    colour.mix(0.6).stroke_width(1),
                ))?;
            }
            chart.draw_series(LineSeries::new(pts(), colour.stroke_width(2)))?;
        }
        Ok(())
    })
}
