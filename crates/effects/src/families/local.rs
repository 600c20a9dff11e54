//! **`local-error`** — a local error of a component no low-order polynomial holds: a bump
//! along linear axis `A` displacing the tool along linear axis `B` (`B = A`: a positioning
//! error, `EXX`; otherwise a straightness, `EYX`), the compact cubic B-spline of
//! [`Feature::LocalBump`]: `h·bump((q_A − c)/w)`, peak `h` at the centre `c`, zero beyond the
//! half-width `w`. The centre and the half-width are shape parameters: the fit moves the
//! bump's knots where the data want them, the centre kept within the stroke of `A` the fitted
//! runs cover, the half-width between a thirty-second of that stretch (and two sample steps)
//! and its half. Component `E<B><A>`, axis and driver `A`, label `local-error EYX (X)`.
//!
//! Candidates, where `A` moves in a fitted run and some channel reads the pose: for every
//! linear `B`, half-widths of a quarter of the covered stretch (centres at its quarters) and
//! an eighth (centres at its odd eighths): seven per pair of axes. Before a candidate is
//! refitted its centre is scanned over the stretch at a quarter of its half-width
//! ([`crate::Effect::shape_scan`]).
//!
//! Plant keys: `axis = "X"` (`A`), `across = "Y"` (`B`; `A` itself when left out),
//! `amplitude_um`, `centre_mm`, `half_width_mm` (within the bounds above; starting values
//! when configured without them: the middle of the covered stretch and an eighth of it).

use super::{axis_aim, moves, plant_aim, plant_values, single_letter, straightness_name, string};
use crate::basic::{Basic, Feature, ShapeStart};
use crate::view::SessionView;
use crate::{Candidate, EffectFamily, EffectInfo, PlantError, Planted, Target};
use std::sync::Arc;

/// Half-widths (fractions of the covered stretch) and the centres (fractions) tried at each.
const GRID: [(f64, &[f64]); 2] = [
    (0.25, &[0.25, 0.5, 0.75]),
    (0.125, &[0.125, 0.375, 0.625, 0.875]),
];

/// The stretch of axis `a` the fitted runs cover, `(lo, hi)`, and the finest step they move
/// it by (SI); the stroke and no step if no fitted run moves it.
fn covered(view: &SessionView, a: usize) -> ((f64, f64), f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    let mut step = f64::INFINITY;
    for r in (0..view.runs.len()).filter(|&r| view.runs[r].fit) {
        let m = view.motion(r, a);
        if m.moves {
            lo = lo.min(m.range.0);
            hi = hi.max(m.range.1);
            step = step.min(m.step);
        }
    }
    if hi > lo {
        ((lo, hi), step)
    } else {
        (view.axes[a].stroke, 0.0)
    }
}

/// The bounds (SI) of a bump's half-width over a covered stretch of length `length`.
fn width_bounds(length: f64, step: f64) -> (f64, f64) {
    ((length / 32.0).max(2.0 * step), 0.5 * length)
}

/// A bump of axis `a`'s position on linear axis `b`, starting at `centre` and `half_width`.
fn bump(view: &SessionView, a: usize, b: usize, centre: f64, half_width: f64) -> Basic {
    let (la, lb) = (view.axes[a].letter, view.axes[b].letter);
    let aim = axis_aim(view, b);
    let component = straightness_name(lb, la);
    let info = EffectInfo {
        class: "local-error",
        axis: Some(la),
        label: format!("local-error {} ({la})", component.as_deref().unwrap_or("?")),
        component,
        driver: Some(la.to_string()),
    };
    let words = if a == b {
        format!("{la}'s positioning")
    } else {
        format!("{la}'s straightness along {lb}")
    };
    let ((lo, hi), step) = covered(view, a);
    let length = hi - lo;
    Basic::new(
        info,
        Feature::LocalBump(a),
        aim.target,
        words,
        aim.unit,
        None,
    )
    .with_shapes(&[
        ShapeStart {
            initial: centre,
            bounds: (lo, hi),
            scale: 0.5 * length,
        },
        ShapeStart {
            initial: half_width,
            bounds: width_bounds(length, step),
            scale: half_width,
        },
    ])
}

fn linear_axes(view: &SessionView) -> Vec<usize> {
    if !view.any_pose_reading() {
        return Vec::new();
    }
    (0..view.axes.len())
        .filter(|&a| !view.axes[a].rotary)
        .collect()
}

fn candidates(view: &SessionView) -> Vec<Candidate> {
    let linear = linear_axes(view);
    let mut out = Vec::new();
    for &a in linear.iter().filter(|&&a| moves(view, a)) {
        let ((lo, hi), step) = covered(view, a);
        let length = hi - lo;
        let (w_min, w_max) = width_bounds(length, step);
        for &b in &linear {
            for (fraction, centres) in GRID {
                let w = fraction * length;
                let usable = w >= w_min && w <= w_max;
                if !usable {
                    continue;
                }
                for c in centres {
                    out.push(Candidate::Effect(Arc::new(bump(
                        view,
                        a,
                        b,
                        lo + c * length,
                        w,
                    ))));
                }
            }
        }
    }
    out
}

fn plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let aim = plant_aim(table, view)?;
    let Target::Axis(a) = aim.target else {
        return Err("a local error runs along an axis: give `axis = \"X\"`".into());
    };
    let b = match string(table, "across")? {
        None => a,
        Some(across) => {
            let c = single_letter(across)?;
            view.axis_index(c).ok_or_else(|| {
                PlantError::at(
                    "across",
                    format!("`across = \"{across}\"`: the machine has no axis {c}"),
                )
            })?
        }
    };
    for (key, k) in [("axis", a), ("across", b)] {
        if view.axes[k].rotary {
            return Err(PlantError::at(
                key,
                format!(
                    "`{key} = \"{}\"`: a local error is of a linear axis, along a linear axis",
                    view.axes[k].letter
                ),
            ));
        }
    }
    let ((lo, hi), _) = covered(view, a);
    let e = bump(view, a, b, 0.5 * (lo + hi), 0.125 * (hi - lo));
    let values = plant_values(&e, table, &["across"])?;
    // Built again starting from the table's shape values, if it gives them.
    let start = |k: usize, default: f64| values[k].unwrap_or(default);
    let e = bump(
        view,
        a,
        b,
        start(1, 0.5 * (lo + hi)),
        start(2, 0.125 * (hi - lo)),
    );
    Ok((Arc::new(e), values))
}

inventory::submit! {
    EffectFamily {
        name: "local-error",
        about: "a local bump of a positioning or straightness error along a linear axis, its centre and width fitted",
        candidates,
        plant: Some(plant),
        separated_by: None,
        told_from: &[],
    }
}
