//! **`spindle-growth`** — the spindle growing along its own tool axis as it warms (however the
//! head is tilted): every set-up's tool length grows by the same amount, one amplitude acting
//! on the `tool_length` parameter of every set-up that has one (the R-test's and the
//! ball-bar's; [`Basic::shared`]). Driver `t`: `A·(1 − exp(−(t − t₀)/τ))` from the session's
//! start, at the time constants of `thermal-drift` (plant keys `amplitude_um`, `tau_s`);
//! driver `S`, when the spindle speed is recorded and varies: `g·lag(S/1000 rpm, τ)` at the
//! spindle's time constants (plant keys `driver = "S"`, `gain_um_per_krpm`, `tau_s`).
//! Component `tool axis`, no axis, label `spindle-growth tool axis (t)`. Positive: a longer
//! tool (the spindle nose moving towards the workpiece).
//!
//! Proposed when some set-up with a `tool_length` has fitted runs.

use super::{drift_taus, lag_taus, number, plant_values, string};
use crate::basic::{AmplitudeUnit, Basic, Feature};
use crate::view::{Input, SessionView};
use crate::{Candidate, EffectFamily, EffectInfo, PlantError, Planted, Target};
use std::sync::Arc;

/// The set-up parameter the spindle's growth acts on.
pub(super) const TOOL_LENGTH: &str = "tool_length";

/// Every set-up's `tool_length` (sharing the first one's unit), and that unit.
fn targets(view: &SessionView) -> Option<(Vec<Target>, AmplitudeUnit)> {
    let mut unit = None;
    let mut out = Vec::new();
    for (s, setup) in view.setups.iter().enumerate() {
        let Some(index) = setup.nuisance.iter().position(|n| n.name == TOOL_LENGTH) else {
            continue;
        };
        let u = setup.nuisance[index].unit;
        if *unit.get_or_insert(u) == u {
            out.push(Target::Nuisance { setup: s, index });
        }
    }
    let unit = unit?;
    Some((
        out,
        AmplitudeUnit {
            unit: unit.as_str().to_string(),
            per_si: unit.per_si(),
        },
    ))
}

fn growth(view: &SessionView, feature: Feature, driver: &str, tau: f64) -> Option<Basic> {
    let (targets, unit) = targets(view)?;
    let info = EffectInfo {
        class: "spindle-growth",
        axis: None,
        component: Some("tool axis".into()),
        driver: Some(driver.into()),
        label: format!("spindle-growth tool axis ({driver})"),
    };
    Some(Basic::shared(
        info,
        feature,
        targets,
        "the spindle along its tool axis (every set-up's tool length)".into(),
        unit,
        Some(tau),
    ))
}

fn candidates(view: &SessionView) -> Vec<Candidate> {
    let Some((targets, _)) = targets(view) else {
        return Vec::new();
    };
    let fitted = targets.iter().any(|t| match t {
        Target::Nuisance { setup, .. } => view.runs.iter().any(|r| r.fit && r.setup == *setup),
        _ => false,
    });
    if !fitted {
        return Vec::new();
    }
    let mut out: Vec<Basic> = drift_taus(view)
        .into_iter()
        .filter_map(|tau| growth(view, Feature::Saturating, "t", tau))
        .collect();
    if view.has_varying_column("S") {
        out.extend(
            lag_taus(view)
                .into_iter()
                .filter_map(|tau| growth(view, Feature::Lag(Input::Speed), "S", tau)),
        );
    }
    out.into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let feature = match string(table, "driver")?.unwrap_or("t") {
        "t" => Feature::Saturating,
        "S" => Feature::Lag(Input::Speed),
        other => {
            return Err(PlantError::at(
                "driver",
                format!(
                    "`driver = \"{other}\"`: the spindle grows in time (\"t\") or with its speed (\"S\")"
                ),
            ));
        }
    };
    let driver = if feature == Feature::Saturating {
        "t"
    } else {
        "S"
    };
    let tau = number(table, "tau_s", 1.0)?.unwrap_or((view.duration() / 4.0).max(1.0));
    let e = growth(view, feature, driver, tau).ok_or_else(|| {
        PlantError::from("no set-up of the plan has a `tool_length` for the spindle to grow")
    })?;
    let values = plant_values(&e, table, &["driver"])?;
    Ok((Arc::new(e), values))
}

inventory::submit! {
    EffectFamily {
        name: "spindle-growth",
        about: "the spindle growing along its tool axis as it warms: every set-up's tool length, one amplitude, in time or with spindle speed",
        candidates,
        plant: Some(plant),
        separated_by: None,
        told_from: &[],
    }
}
