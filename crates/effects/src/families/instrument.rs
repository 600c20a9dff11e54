//! Effects of the measuring set-up and the instrument.
//!
//! - **`setup-drift`**: a set-up parameter (the R-test head, the ball-bar pivot, a sensor's
//!   zero) creeps steadily from the set-up's first use, `rate·(t − t_s)` (driver `t`), or
//!   settles, `a·(1 − e^{−(t − t_s)/τ})` (driver `t, settling`). Plant keys `setup`,
//!   `nuisance`, and `rate_um_per_h` or `amplitude_um` and `tau_s`. Not proposed for a
//!   parameter that moves the readings, at every pose its set-up is seen at, as a fixed shift
//!   of the tool in the machine frame does ([`crate::SetupView::field_like`]: a ball of a
//!   volumetric test visited at one place, or its height where only a table turning about Z
//!   takes it elsewhere — its drift and the machine's deformation there look alike; the
//!   machine's families say what the data show, and a field that differs from place to place
//!   without a family is said to remain unexplained), nor for the `tool_length` of a set-up
//!   whose tool visits other set-ups in turn (one head going from ball to ball: its length is
//!   one for all, and its drift the spindle's).
//! - **`instrument-scale`**: a reading channel's gain is off, `g·reading` (an R-test sensor's
//!   scale, a laser's wavelength compensation, a ball-bar transducer); shared by every set-up
//!   of that instrument. Plant keys `instrument` (optional when unambiguous), `channel`,
//!   `gain_ppm`.

use super::{channel_aim, nuisance_aim, number, plant_aim, plant_values};
use crate::basic::{AmplitudeUnit, Basic, Feature};
use crate::view::SessionView;
use crate::{Candidate, EffectFamily, PlantError, Planted, Target};
use std::sync::Arc;

/// A set-up parameter's drift: steady (`settling_tau_s` none) or settling with that time
/// constant from the set-up's first use.
fn drift(view: &SessionView, s: usize, index: usize, settling_tau_s: Option<f64>) -> Basic {
    let aim = nuisance_aim(view, s, index);
    let (driver, feature) = match settling_tau_s {
        None => ("t", Feature::SetupHours(s)),
        Some(_) => ("t, settling", Feature::SetupSettling(s)),
    };
    Basic::new(
        aim.info("setup-drift", Some(driver.into())),
        feature,
        aim.target,
        aim.words,
        aim.unit,
        settling_tau_s,
    )
}

fn drift_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    for (s, setup) in view.setups.iter().enumerate() {
        // The set-up must be in use for a while in fitted runs: a first and a later time.
        let Some((first, last)) = fitted_span(view, s) else {
            continue;
        };
        let span = last - first;
        if span.is_nan() || span <= 0.0 {
            continue;
        }
        // A settling starts from a quarter of the set-up's use; the refit refines τ.
        let settling_tau_s = (0.25 * span).max(5.0 * view.median_interval());
        let shared_tool = tool_visits_others(view, s);
        for (j, n) in setup.nuisance.iter().enumerate() {
            if (shared_tool && n.name == super::spindle::TOOL_LENGTH)
                || setup.field_like.get(j).copied().unwrap_or(false)
            {
                continue;
            }
            if n.unit == mtcal_instrument::Unit::Um {
                out.push(Candidate::Effect(Arc::new(drift(view, s, j, None))));
                out.push(Candidate::Effect(Arc::new(drift(
                    view,
                    s,
                    j,
                    Some(settling_tau_s),
                ))));
            }
        }
    }
    out
}

/// The fitted time span of set-up `s` (s), if it has fitted samples.
fn fitted_span(view: &SessionView, s: usize) -> Option<(f64, f64)> {
    let times: Vec<f64> = view
        .runs
        .iter()
        .filter(|r| r.setup == s && r.fit)
        .flat_map(|r| [r.first_time(), r.last_time()])
        .flatten()
        .collect();
    let lo = times.iter().copied().reduce(f64::min)?;
    let hi = times.iter().copied().reduce(f64::max)?;
    Some((lo, hi))
}

/// Whether the tool of set-up `s` visits other set-ups in turn: another set-up with a
/// `tool_length` is in use over the same time (the balls of a volumetric test, one head going
/// from ball to ball). The tool's length is then one for all of them, and its drift the
/// spindle's (`spindle-growth`), not one set-up's.
fn tool_visits_others(view: &SessionView, s: usize) -> bool {
    let has_tool = |k: usize| {
        view.setups[k]
            .nuisance
            .iter()
            .any(|n| n.name == super::spindle::TOOL_LENGTH)
    };
    let Some((lo, hi)) = fitted_span(view, s) else {
        return false;
    };
    has_tool(s)
        && (0..view.setups.len())
            .filter(|&k| k != s && has_tool(k))
            .filter_map(|k| fitted_span(view, k))
            .any(|(a, b)| a < hi && lo < b)
}

fn drift_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let aim = plant_aim(table, view)?;
    let Target::Nuisance { setup, index } = aim.target else {
        return Err(
            "a set-up drift acts on a set-up parameter: give `setup` and `nuisance`".into(),
        );
    };
    let e = drift(view, setup, index, number(table, "tau_s", 1.0)?);
    let v = plant_values(&e, table, &[])?;
    Ok((Arc::new(e), v))
}

fn scale(view: &SessionView, instrument: &str, channel: &str) -> Option<Basic> {
    let aim = channel_aim(view, instrument, channel)?;
    let Target::Channel { per_setup } = aim.target.clone() else {
        unreachable!("channel targets are channels")
    };
    Some(Basic::new(
        aim.info("instrument-scale", None),
        Feature::Constant,
        Target::Gain { per_setup },
        format!("the {instrument} channel {channel}"),
        AmplitudeUnit {
            unit: "ppm".into(),
            per_si: 1e6,
        },
        None,
    ))
}

fn scale_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut seen: Vec<(String, String)> = Vec::new();
    for s in &view.setups {
        for (c, ch) in s.channels.iter().enumerate() {
            let key = (s.instrument.clone(), ch.name.clone());
            if s.reads_pose[c] && !seen.contains(&key) {
                seen.push(key);
            }
        }
    }
    seen.iter()
        .filter_map(|(i, c)| scale(view, i, c))
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn scale_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let aim = plant_aim(table, view)?;
    let Some(component) = aim
        .component
        .as_deref()
        .filter(|_| matches!(aim.target, Target::Channel { .. }))
    else {
        return Err("an instrument scale acts on a channel: give `channel`".into());
    };
    let (instrument, channel) = component
        .split_once('.')
        .expect("channel targets are named instrument.channel");
    let e = scale(view, instrument, channel).expect("the target exists");
    let v = plant_values(&e, table, &[])?;
    Ok((Arc::new(e), v))
}

inventory::submit! {
    EffectFamily {
        name: "setup-drift",
        about: "a set-up parameter (head, pivot, sensor zero) creeping steadily in time",
        candidates: drift_candidates,
        plant: Some(drift_plant),
        separated_by: Some("repeat a reference point (or the first run) at the end of the session, or measure the runs in random order: a drift in time then no longer follows the path"),
        told_from: &[
            ("thermal-drift", "re-measure the first run with a second set-up at the end (a set-up's drift stays with its set-up, a machine's shows in every set-up)"),
            ("temperature-coupling", "re-measure the first run with a second set-up at the end (a set-up's drift stays with its set-up, a machine's shows in every set-up)"),
            ("thermal-expansion", "re-measure the first run with a second set-up at the end (a set-up's drift stays with its set-up, a machine's shows in every set-up)"),
        ],
    }
}

inventory::submit! {
    EffectFamily {
        name: "instrument-scale",
        about: "a reading channel's gain error, shared by every set-up of the instrument",
        candidates: scale_candidates,
        plant: Some(scale_plant),
        separated_by: Some("measure the same motion with the instrument turned or at a second range (or against a calibrated reference)"),
        told_from: &[],
    }
}
