//! Effects of an axis' motion. Each acts on the axis itself (it is effectively displaced along
//! its own motion, µm, or turned about its own axis, µrad), driven by the axis; `lateral-play`
//! acts across it, on another linear axis.
//!
//! Which side an axis arrived from before a run is not in the run's file: until it first moves
//! within a run its direction is unknown and the direction-driven features are 0 there (the
//! mean of the two sides; [`crate::view::AxisMotion`]); a transient after a reversal
//! (`stick-slip`, `reversal-spike`) counts in full after a reversal within the run and after a
//! first motion against the side the axis arrived from.
//!
//! Where the side is unknown over a stretch of fitted samples (the session's first run
//! recorded with the axis standing, a turn that may have gone either way round), a
//! `reversal` or `lateral-play` candidate fits the axis' state there as a nuisance side per
//! stretch (`start_<run>`; [`Basic::with_start_states`]): not a claim, the approach the file
//! does not hold. A `reversal-spike` candidate of a linear axis fits the same side in every run
//! the axis arrived at from an unknown side: it decides whether the run's first motion was a
//! turn.
//!
//! - **`reversal`**: the axis lags by half its backlash `B` behind the commanded position in
//!   the direction it last moved, `±B/2` (plant key `backlash_um`; rotary `backlash_urad`).
//!   With lost motion that changes along the stroke (a worn screw, a load that grows towards
//!   one end), `−½·s·(B + ΔB·û)`: `B` at the middle of a span, `ΔB` its change from there to
//!   the span's positive end, `û` the position normalised to `[−1, 1]` over the span (label
//!   `reversal X (along X)`; plant keys `backlash_um`, `backlash_change_um`). A candidate's span
//!   is the positions the fitted runs cover ([`crate::basic::Span::fitted`]: its numbers say
//!   nothing beyond them), a plant's the stroke. Proposed for
//!   every axis that reverses in a fitted run; the form along the stroke for linear axes and
//!   rotary axes of less than a turn.
//! - **`lateral-play`**: when axis `A` reverses, the tool steps across its motion along another
//!   linear axis `B` (play of the carriage in its guides; a ball-bar's lateral play):
//!   `−½·s_A·P` on `B`, `P` the step between the two directions; component the straightness
//!   `E<B><A>` (`EYX`), label `lateral-play X (in Y)`. Plant keys `axis = "X"` (the axis whose
//!   reversal drives it), `across = "Y"`, `play_um`. Proposed for every linear axis that
//!   reverses in a fitted run and every other linear axis. The carriage may cross its
//!   clearance over some travel rather than at once: `−½·s·P·(1 − 2·e^{−d/λ})` after a
//!   reversal, `d` the travel since the turning point (label `lateral-play X (in Y, taken
//!   up)`, plant key `take_up_mm`), proposed beside the step.
//! - **`reversal-spike`**: after a reversal the axis trails by a spike that decays in time,
//!   `h·s·exp(−Δt/τ)` with `Δt` the time since it left the turning point (a friction or servo
//!   transient; `stick-slip` decays with travel instead). Plant keys `height_um` (rotary
//!   `height_urad`), `tau_s` (1 ms … 30 s). Proposed where an axis reverses, at τ of 0.05,
//!   0.2, 1 and 5 s that the sampling can show (at least half a sample interval). A position
//!   loop rebuilding the friction force recovers as a critically damped loop,
//!   `h·s·(1 + Δt/τ)·exp(−Δt/τ)` (label `reversal-spike X (X, damped)`, plant key
//!   `recovery = "damped"`), proposed beside it.
//! - **`cyclic`**: a screw (or worm) error periodic in the axis position, `a·sin(2πq/p) +
//!   b·cos(2πq/p)` (plant keys `sin_um`, `cos_um`, `pitch_mm`; rotary `sin_urad`, `cos_urad`,
//!   `period_deg`).
//! - **`servo-lag`**: the axis trails the command by a lag time, `−T·v` (plant key `lag_ms`).
//! - **`stick-slip`**: after a reversal the axis sticks and catches up, `h·s·exp(−d/λ)` with
//!   `s` the direction and `d` the travel since the reversal (plant keys `height_um`,
//!   `decay_mm`).
//! - **`cross-coupling`**: an error of axis `L` that grows with the product of two axes'
//!   positions, `c·û_K·û_M/k` (positions normalised to ±1 over the strokes; `c` is the value
//!   at a corner, `k` the product there: [`crate::basic::Corner`]): the table sagging under an
//!   overhanging carriage. A candidate gives `c` at the corner of the positions the fitted runs
//!   cover farthest from the strokes' middles, a plant at the strokes' corner. Plant keys
//!   `axis = "L"`, `driver = "K*M"`, `corner_um`.
//!
//! Candidates need the right motion in some fitted run: motion both ways for `reversal` (a
//! reversal within a run, or runs that move the axis one way and others the other: a rotary
//! axis turned forward in one run and back in the next), reversals within a run for the form
//! along the stroke, `lateral-play`, `reversal-spike` and `stick-slip`, travel over at least
//! one pitch with 2.5 samples per pitch for `cyclic`,
//! motion read on the fly for `servo-lag` (not a laser's or a tracer's points, read with the
//! axes standing), both driving axes moving for `cross-coupling`.

use super::{
    axis_aim, moves, moves_both_ways, number, plant_aim, plant_values, reverses, single_letter,
    string,
};
use crate::basic::{Basic, Corner, Feature, Span};
use crate::view::SessionView;
use crate::{Candidate, EffectFamily, PlantError, Planted, Target};
use mtcal_machine::from_identify::{CompensableDiscovery, Discovery, FoundReversal};
use std::sync::Arc;

/// Screw pitches tried (mm).
const PITCHES_MM: [f64; 15] = [
    2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0, 25.0, 32.0, 40.0, 50.0,
];
/// Cycles per turn tried for rotary axes (periods of 360°/n).
const CYCLES_PER_TURN: [u32; 16] = [3, 4, 5, 6, 8, 9, 10, 12, 15, 18, 20, 24, 30, 36, 45, 60];
/// Decay lengths of stick-slip tried (mm, or degrees on a rotary axis).
const DECAYS: [f64; 5] = [0.2, 0.5, 1.0, 2.0, 5.0];

fn on_axis(
    view: &SessionView,
    a: usize,
    class: &'static str,
    feature: Feature,
    shape: Option<f64>,
) -> Basic {
    let aim = axis_aim(view, a);
    Basic::new(
        aim.info(class, Some(view.axes[a].letter.to_string())),
        feature,
        aim.target,
        aim.words,
        aim.unit,
        shape,
    )
}

fn wrap(effects: Vec<Basic>) -> Vec<Candidate> {
    effects
        .into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn pose_axes(view: &SessionView) -> Vec<usize> {
    if view.any_pose_reading() {
        (0..view.axes.len()).collect()
    } else {
        Vec::new()
    }
}

fn plant_axis(table: &toml::Table, view: &SessionView) -> Result<usize, PlantError> {
    let aim = plant_aim(table, view)?;
    match aim.target {
        Target::Axis(a) => Ok(a),
        _ => Err("this effect acts on an axis: give `axis = \"X\"`".into()),
    }
}

/// One candidate of `class` without a shape parameter on every pose axis `shows` it on.
fn unshaped_candidates(
    view: &SessionView,
    class: &'static str,
    feature: fn(usize) -> Feature,
    shows: fn(&SessionView, usize) -> bool,
) -> Vec<Candidate> {
    wrap(
        pose_axes(view)
            .into_iter()
            .filter(|&a| shows(view, a))
            .map(|a| on_axis(view, a, class, feature(a), None))
            .collect(),
    )
}

/// The planted effect of `class` on the plant table's axis; `shape` reads its shape parameter
/// (SI) from the table, given the axis.
fn plant_on_axis(
    table: &toml::Table,
    view: &SessionView,
    class: &'static str,
    feature: fn(usize) -> Feature,
    shape: impl Fn(usize) -> Result<Option<f64>, PlantError>,
) -> Result<Planted, PlantError> {
    let a = plant_axis(table, view)?;
    let e = on_axis(view, a, class, feature(a), shape(a)?);
    let v = plant_values(&e, table, &[])?;
    Ok((Arc::new(e), v))
}

/// Backlash of an axis that changes along the span `span` of its positions; without a change
/// along it, the plain backlash.
fn reversal_along(view: &SessionView, span: Span) -> Basic {
    let a = span.axis;
    let aim = axis_aim(view, a);
    let letter = view.axes[a].letter;
    let mut info = aim.info("reversal", Some(letter.to_string()));
    info.label = format!("reversal {letter} (along {letter})");
    let change = format!("backlash_change_{}", aim.unit.unit);
    let plain = on_axis(view, a, "reversal", Feature::Reversal(a), None).with_start_states(view, a);
    Basic::new(
        info,
        Feature::ReversalAlong(span),
        aim.target,
        aim.words,
        aim.unit,
        None,
    )
    .becoming_without(&change, plain)
}

/// Whether a backlash along axis `a`'s stroke means something: a linear axis, or a rotary one
/// with limits short of a turn (on an endless one `û` would jump where the stroke closes).
fn has_ends(view: &SessionView, a: usize) -> bool {
    let ax = &view.axes[a];
    let (lo, hi) = ax.stroke;
    !ax.rotary || hi - lo < std::f64::consts::TAU - 1e-6
}

fn reversal_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    for a in pose_axes(view) {
        if !moves_both_ways(view, a) {
            continue;
        }
        out.push(
            on_axis(view, a, "reversal", Feature::Reversal(a), None).with_start_states(view, a),
        );
        if reverses(view, a) && has_ends(view, a) {
            out.push(reversal_along(view, Span::fitted(view, a)).with_start_states(view, a));
        }
    }
    wrap(out)
}

fn reversal_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let along = ["backlash_change_um", "backlash_change_urad"]
        .iter()
        .any(|k| table.contains_key(*k));
    if !along {
        return plant_on_axis(table, view, "reversal", Feature::Reversal, |_| Ok(None));
    }
    let a = plant_axis(table, view)?;
    if !has_ends(view, a) {
        return Err(PlantError::at(
            "axis",
            format!(
                "`axis = \"{}\"`: a backlash along the stroke needs an axis with ends (linear, or rotary of less than a turn)",
                view.axes[a].letter
            ),
        ));
    }
    let e = reversal_along(view, Span::stroke(view, a));
    let v = plant_values(&e, table, &[])?;
    Ok((Arc::new(e), v))
}

/// The linear axes (as targets of translations) when some channel reads the tool pose.
fn linear_pose_axes(view: &SessionView) -> Vec<usize> {
    pose_axes(view)
        .into_iter()
        .filter(|&a| !view.axes[a].rotary)
        .collect()
}

/// Lateral play: axis `a`'s reversal steps the tool along linear axis `b`; taken up over
/// `take_up` of travel (m) if given, a step otherwise.
fn lateral_play(view: &SessionView, a: usize, b: usize, take_up: Option<f64>) -> Basic {
    let (la, lb) = (view.axes[a].letter, view.axes[b].letter);
    let aim = axis_aim(view, b);
    let info = crate::EffectInfo {
        class: "lateral-play",
        axis: Some(la),
        component: super::straightness_name(lb, la),
        driver: Some(la.to_string()),
        label: match take_up {
            None => format!("lateral-play {la} (in {lb})"),
            Some(_) => format!("lateral-play {la} (in {lb}, taken up)"),
        },
    };
    Basic::new(
        info,
        match take_up {
            None => Feature::LateralPlay(a),
            Some(_) => Feature::LateralTakeUp(a),
        },
        aim.target,
        format!("{lb} when {la} reverses"),
        aim.unit,
        take_up,
    )
}

/// The travel over which a lateral play's take-up is first tried (m): the refit finds its own.
const TAKE_UP_START_M: f64 = 1e-3;

fn lateral_candidates(view: &SessionView) -> Vec<Candidate> {
    let linear = linear_pose_axes(view);
    let mut out = Vec::new();
    for &a in &linear {
        if !reverses(view, a) {
            continue;
        }
        for &b in linear.iter().filter(|&&b| b != a) {
            let plain = lateral_play(view, a, b, None).with_start_states(view, a);
            // Taken up over no travel, the carriage is on its new flank at once: the plain play.
            let taken_up = lateral_play(view, a, b, Some(TAKE_UP_START_M))
                .with_start_states(view, a)
                .becoming_at_edge("take_up_mm", true, plain.clone());
            out.push(plain);
            out.push(taken_up);
        }
    }
    wrap(out)
}

fn lateral_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let a = plant_axis(table, view)?;
    let across = string(table, "across")?.ok_or_else(|| {
        "a lateral play needs `across = \"Y\"` (the axis the tool steps along)".to_string()
    })?;
    let c = single_letter(across)?;
    let b = view.axis_index(c).ok_or_else(|| {
        PlantError::at(
            "across",
            format!("`across = \"{across}\"`: the machine has no axis {c}"),
        )
    })?;
    for (key, k) in [("axis", a), ("across", b)] {
        if view.axes[k].rotary {
            return Err(PlantError::at(
                key,
                format!(
                    "`{key} = \"{}\"`: a lateral play is between two linear axes",
                    view.axes[k].letter
                ),
            ));
        }
    }
    if a == b {
        return Err(PlantError::at(
            "across",
            "`across`: the tool steps across the axis, along another one (the axis' own is a reversal)",
        ));
    }
    let take_up = number(table, "take_up_mm", 1e3)?;
    let e = lateral_play(view, a, b, take_up);
    let v = plant_values(&e, table, &["across"])?;
    Ok((Arc::new(e), v))
}

/// Time constants of a reversal spike tried (s).
const SPIKE_TAUS: [f64; 4] = [0.05, 0.2, 1.0, 5.0];

fn spike_candidates(view: &SessionView) -> Vec<Candidate> {
    // A spike faster than half a sample interval has gone before the next sample shows it.
    let floor = 0.5 * view.median_interval();
    let mut out = Vec::new();
    for a in pose_axes(view) {
        if !reverses(view, a) {
            continue;
        }
        for tau in SPIKE_TAUS.into_iter().filter(|&t| t >= floor) {
            for damped in [false, true] {
                let candidate = spike(view, a, tau, damped);
                // Whether a linear axis' first motion in a run is a turn is unknown (the
                // approach is not in the file): its share of the spike there, between none and
                // all of it, is fitted per run as the reversal's side is. An endless rotary
                // axis keeps the previous run's guess: it turns in few runs, each starting
                // after a half turn that went either way, and a free transient at the start of
                // each would fit any run's first samples.
                out.push(match view.axes[a].rotary {
                    false => candidate.with_start_states(view, a),
                    true => candidate,
                });
            }
        }
    }
    wrap(out)
}

/// A reversal spike of axis `a` starting at time constant `tau` (s): decaying as a first-order
/// recovery, or as a critically damped one (`damped`).
fn spike(view: &SessionView, a: usize, tau: f64, damped: bool) -> Basic {
    let aim = axis_aim(view, a);
    let letter = view.axes[a].letter;
    let mut info = aim.info("reversal-spike", Some(letter.to_string()));
    if damped {
        info.label = format!("reversal-spike {letter} ({letter}, damped)");
    }
    let feature = match damped {
        false => Feature::ReversalSpike(a),
        true => Feature::ReversalSpikeDamped(a),
    };
    Basic::new(info, feature, aim.target, aim.words, aim.unit, Some(tau))
}

fn spike_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let damped = match string(table, "recovery")? {
        None | Some("first-order") => false,
        Some("damped") => true,
        Some(other) => {
            return Err(PlantError::at(
                "recovery",
                format!("`recovery = \"{other}\"`: \"first-order\" or \"damped\""),
            ));
        }
    };
    let a = plant_axis(table, view)?;
    let tau = number(table, "tau_s", 1.0)?.unwrap_or(1.0);
    let e = spike(view, a, tau, damped);
    let v = plant_values(&e, table, &["recovery"])?;
    Ok((Arc::new(e), v))
}

/// Harmonics of a rotary axis' angular positioning error that the error model already
/// covers: those of its Fourier basis (estimated, or proposed as an omitted parameter) and, if
/// estimated, the higher orders `component-order` proposes. A cyclic error at those periods is
/// that component error, proposed by those families.
fn covered_harmonics(view: &SessionView, a: usize) -> u32 {
    let letter = view.axes[a].letter;
    let Some(name) = super::positioning_name(letter, true) else {
        return 0;
    };
    view.model
        .iter()
        .find(|p| p.name.to_string() == name)
        .map_or(0, |p| match p.order {
            crate::BasisOrder::Fourier(h) if p.estimated => (h + super::model::EXTRA_ORDERS) as u32,
            crate::BasisOrder::Fourier(h) => h as u32,
            _ => 0,
        })
}

/// Pitches (SI) a run can show on axis `a`: at least one period travelled, two and a half
/// samples per period (beyond Nyquist's two, so a cycle is not its own alias).
fn pitches(view: &SessionView, a: usize) -> Vec<f64> {
    let grid: Vec<f64> = if view.axes[a].rotary {
        let covered = covered_harmonics(view, a);
        CYCLES_PER_TURN
            .iter()
            .filter(|&&n| n > covered)
            .map(|&n| std::f64::consts::TAU / f64::from(n))
            .collect()
    } else {
        PITCHES_MM.iter().map(|p| p * 1e-3).collect()
    };
    grid.into_iter()
        .filter(|&p| {
            (0..view.runs.len()).any(|r| {
                let m = view.motion(r, a);
                view.runs[r].fit && m.moves && m.range.1 - m.range.0 >= p && 2.5 * m.step <= p
            })
        })
        .collect()
}

fn cyclic_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    for a in pose_axes(view) {
        for p in pitches(view, a) {
            out.push(on_axis(view, a, "cyclic", Feature::Cyclic(a), Some(p)));
        }
    }
    wrap(out)
}

fn cyclic_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    plant_on_axis(table, view, "cyclic", Feature::Cyclic, |a| {
        if view.axes[a].rotary {
            number(table, "period_deg", 180.0 / std::f64::consts::PI)
        } else {
            number(table, "pitch_mm", 1e3)
        }
    })
}

fn servo_candidates(view: &SessionView) -> Vec<Candidate> {
    unshaped_candidates(view, "servo-lag", Feature::Velocity, moves_while_read)
}

/// Whether axis `a` moves in a fitted run whose instrument reads on the fly: a lag behind the
/// command shows only in readings taken while the axis moves (a laser's ISO 230-2 targets are
/// read with it standing, [`crate::view::SetupView::at_standstill`]).
fn moves_while_read(view: &SessionView, a: usize) -> bool {
    (0..view.runs.len())
        .any(|r| view.runs[r].fit && !view.read_at_standstill(r) && view.motion(r, a).moves)
}

fn servo_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    plant_on_axis(table, view, "servo-lag", Feature::Velocity, |_| Ok(None))
}

fn decay_per_si(view: &SessionView, a: usize) -> f64 {
    if view.axes[a].rotary {
        180.0 / std::f64::consts::PI
    } else {
        1e3
    }
}

fn stick_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    for a in pose_axes(view) {
        if !reverses(view, a) {
            continue;
        }
        for d in DECAYS {
            let lambda = d / decay_per_si(view, a);
            out.push(on_axis(
                view,
                a,
                "stick-slip",
                Feature::StickSlip(a),
                Some(lambda),
            ));
        }
    }
    wrap(out)
}

fn stick_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    plant_on_axis(table, view, "stick-slip", Feature::StickSlip, |a| {
        let key = if view.axes[a].rotary {
            "decay_deg"
        } else {
            "decay_mm"
        };
        number(table, key, decay_per_si(view, a))
    })
}

/// Axis `l`'s error growing with the product of axes `k` and `m`, its amplitude given at the
/// corner of `over` (the two axes' spans) farthest from the strokes' middles.
fn coupling_effect(view: &SessionView, l: usize, over: [Span; 2]) -> Basic {
    let aim = axis_aim(view, l);
    let (kl, ml) = (over[0].letter, over[1].letter);
    Basic::new(
        aim.info("cross-coupling", Some(format!("{kl}*{ml}"))),
        Feature::Bilinear(Corner::of(view, over)),
        aim.target,
        format!(
            "{} error growing with the product of {kl} and {ml}",
            view.axes[l].letter
        ),
        aim.unit,
        None,
    )
}

fn coupling_candidates(view: &SessionView) -> Vec<Candidate> {
    let linear: Vec<usize> = pose_axes(view)
        .into_iter()
        .filter(|&a| !view.axes[a].rotary)
        .collect();
    let mut out = Vec::new();
    for &l in &linear {
        for (i, &k) in linear.iter().enumerate() {
            for &m in &linear[i + 1..] {
                if moves(view, k) && moves(view, m) {
                    out.push(coupling_effect(
                        view,
                        l,
                        [Span::fitted(view, k), Span::fitted(view, m)],
                    ));
                }
            }
        }
    }
    wrap(out)
}

fn coupling_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let l = plant_axis(table, view)?;
    let driver = string(table, "driver")?
        .ok_or_else(|| "a cross-coupling needs `driver = \"K*M\"` (two axes)".to_string())?;
    let (k, m) = driver.split_once('*').ok_or_else(|| {
        PlantError::at(
            "driver",
            format!("`driver = \"{driver}\"`: expected two axes as \"K*M\""),
        )
    })?;
    let index = |s: &str| -> Result<usize, PlantError> {
        let c = single_letter(s.trim())?;
        view.axis_index(c).ok_or_else(|| {
            PlantError::at("driver", format!("`driver`: the machine has no axis {c}"))
        })
    };
    let (k, m) = (index(k)?, index(m)?);
    if k == m {
        return Err(PlantError::at(
            "driver",
            "`driver`: a cross-coupling needs two different axes",
        ));
    }
    let (k, m) = (k.min(m), k.max(m));
    let e = coupling_effect(view, l, [Span::stroke(view, k), Span::stroke(view, m)]);
    let v = plant_values(&e, table, &["driver"])?;
    Ok((Arc::new(e), v))
}

inventory::submit! {
    EffectFamily {
        name: "reversal",
        about: "backlash: an axis lags by half its lost motion behind the command, flipping with its direction",
        candidates: reversal_candidates,
        plant: Some(reversal_plant),
        separated_by: Some("measure each path in both directions (CW and CCW, up and down): a reversal error flips with the direction, geometry does not"),
        told_from: &[],
    }
}

inventory::submit! {
    CompensableDiscovery { as_reversal: reversal_in_a_table }
}

/// A `reversal` discovery of a linear axis as a bidirectional table holds it (`compensate
/// --params id.json`): the backlash at the middle of the span it was measured over, its change
/// to the span's positive end (0 when constant), µm, and the span. A rotary axis' backlash
/// (µrad) is no table's.
fn reversal_in_a_table(d: &Discovery) -> Option<FoundReversal> {
    if d.effect != "reversal" {
        return None;
    }
    let axis = d.axis_letter()?;
    let backlash = d.parameter("backlash_um", "um")?;
    let change = d.parameter("backlash_change_um", "um");
    Some(FoundReversal {
        label: d.label.clone(),
        axis,
        backlash_um: backlash.value,
        backlash_u95_um: backlash.u95,
        change_um: change.map_or(0.0, |c| c.value),
        change_u95_um: change.and_then(|c| c.u95),
        span_mm: d.span(axis, "mm"),
    })
}

inventory::submit! {
    EffectFamily {
        name: "lateral-play",
        about: "a straightness step flipping with an axis' direction: the tool shifts across the axis when it reverses",
        candidates: lateral_candidates,
        plant: Some(lateral_plant),
        separated_by: None,
        told_from: &[],
    }
}

inventory::submit! {
    EffectFamily {
        name: "reversal-spike",
        about: "an axis trailing by a spike after each reversal that decays in time",
        candidates: spike_candidates,
        plant: Some(spike_plant),
        separated_by: None,
        told_from: &[],
    }
}

inventory::submit! {
    EffectFamily {
        name: "cyclic",
        about: "a cyclic error of an axis at a screw pitch (or worm period)",
        candidates: cyclic_candidates,
        plant: Some(cyclic_plant),
        separated_by: Some("step the axis finer than a quarter of the pitch over several pitches"),
        told_from: &[
            ("component-order", "step the axis finer than a quarter of the pitch over its whole stroke: a cycle repeats, a higher order does not"),
            ("omitted-parameter", "step the axis finer than a quarter of the pitch over its whole stroke: a cycle repeats, a higher order does not"),
        ],
    }
}

inventory::submit! {
    EffectFamily {
        name: "servo-lag",
        about: "an axis trailing its command by a lag time: proportional to velocity, flipping with direction",
        candidates: servo_candidates,
        plant: Some(servo_plant),
        separated_by: Some("repeat a path at a second feed: a lag grows with the velocity, geometry does not"),
        told_from: &[
            ("reversal", "repeat a path at a second feed: a lag grows with the velocity, lost motion does not"),
            ("stick-slip", "repeat a path at a second feed: a lag grows with the velocity, lost motion does not"),
        ],
    }
}

inventory::submit! {
    EffectFamily {
        name: "stick-slip",
        about: "an axis sticking after a reversal and catching up over a decay length",
        candidates: stick_candidates,
        plant: Some(stick_plant),
        separated_by: Some("measure each path in both directions (CW and CCW, up and down): a reversal error flips with the direction, geometry does not"),
        told_from: &[
            ("reversal", "approach a reversal in steps finer than the decay: stick-slip fades with the travel, lost motion does not"),
        ],
    }
}

inventory::submit! {
    EffectFamily {
        name: "cross-coupling",
        about: "an error of one axis growing with the product of two axes' positions (sag)",
        candidates: coupling_candidates,
        plant: Some(coupling_plant),
        separated_by: Some("repeat the measurement at a second position of the other axes"),
        told_from: &[],
    }
}
