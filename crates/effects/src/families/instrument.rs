//! Effects of the measuring set-up and the instrument.
//!
//! - **`setup-drift`**: a set-up parameter (the R-test head, the ball-bar pivot, a sensor's
//!   zero) creeps steadily from the set-up's first use, `rate·(t − t_s)` (driver `t`), or
//!   settles, `a·(1 − e^{−(t − t_s)/τ})` (driver `t, settling`). Plant keys `setup`,
//!   `nuisance`, and `rate_um_per_h` or `amplitude_um` and `tau_s`. Not proposed for a
//!   set-up whose fitted samples are all at one pose of the machine (its drift and the
//!   machine's deformation there look alike).
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
        let times: Vec<f64> = view
            .runs
            .iter()
            .filter(|r| r.setup == s && r.fit)
            .flat_map(|r| [r.first_time(), r.last_time()])
            .flatten()
            .collect();
        let span = times.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - times.iter().copied().fold(f64::INFINITY, f64::min);
        if span.is_nan() || span <= 0.0 || at_one_pose(view, s) {
            continue;
        }
        // A settling starts from a quarter of the set-up's use; the refit refines τ.
        let settling_tau_s = (0.25 * span).max(5.0 * view.median_interval());
        for (j, n) in setup.nuisance.iter().enumerate() {
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

/// Whether every fitted sample of set-up `s` is at one pose of the machine (the commanded
/// axes the same): a ball of a volumetric thermal test visited at one place, a displacement
/// sensor at its held position. There the set-up's drift and the machine's own deformation at
/// that place move the readings alike — no data of that set-up tell them apart —, so a drift
/// is not claimed for the set-up: the machine's families (an axis' drift, a channel's own) say
/// what the data show, and a field that differs from place to place without a family is said
/// to remain unexplained. A set-up seen at several poses (a ball visited at several table
/// angles, an R-test sweep) moves with the part it is fixed to, not with the machine's field.
fn at_one_pose(view: &SessionView, s: usize) -> bool {
    let mut first: Option<(usize, usize)> = None;
    for (r, run) in view.runs.iter().enumerate() {
        if run.setup != s || !run.fit {
            continue;
        }
        for i in 0..run.len() {
            let (r0, i0) = *first.get_or_insert((r, i));
            if (0..view.axes.len()).any(|a| (view.q(r, i, a) - view.q(r0, i0, a)).abs() > 1e-9) {
                return false;
            }
        }
    }
    true
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
    }
}

inventory::submit! {
    EffectFamily {
        name: "instrument-scale",
        about: "a reading channel's gain error, shared by every set-up of the instrument",
        candidates: scale_candidates,
        plant: Some(scale_plant),
    }
}
