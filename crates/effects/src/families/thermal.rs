//! Thermal effects.
//!
//! **`thermal-drift`** — the machine (or a sensor modelled on its own) drifts as it warms:
//! - driver `t`: `A·(1 − exp(−(t − t₀)/τ))` from the session's start (a first-order node
//!   settling; plant keys `amplitude_um`, `tau_s`), or a steady `rate·(t − t₀)` (plant key
//!   `rate_um_per_h`);
//! - driver `S` / `S^2`: a first-order node heated by the spindle, `g·lag(S/1000 rpm, τ)` or
//!   `g·lag((S/1000 rpm)², τ)` (heat from friction grows faster than the speed); plant keys
//!   `driver = "S"` or `"S^2"`, `gain_um_per_krpm` or `gain_um_per_krpm2`, `tau_s`. Several
//!   time constants come as several effects (the search adds one at a time).
//!
//! **`temperature-coupling`** — the error follows a recorded temperature `T_<name>`, static
//! `g·(T − T₀)` or through a first-order lag `g·lag(T − T₀, τ)` (the sensor is not where the
//! heat is); `T₀` is the column's first value in the session. Plant keys `driver = "T_<name>"`,
//! `gain_um_per_K` and, for the lagged form, `tau_s`. The lagged form is proposed for a
//! temperature the target already follows (is that sensor late?): every temperature at every
//! time constant would be sixteen columns times eight lags of nearly the same curves, and the
//! search would fit one of them to the noise of the cycles it saw.
//!
//! Targets: each linear axis (when some channel reads the tool pose) and each channel modelled
//! on its own.

use super::{Aim, drift_taus, lag_taus, number, plant_aim, plant_values, string, thermal_aims};
use crate::basic::{Basic, Feature};
use crate::view::{Input, SessionView};
use crate::{Candidate, Effect, EffectFamily, Planted};
use std::sync::Arc;

fn drift(aim: &Aim, feature: Feature, driver: &str, shape: Option<f64>) -> Basic {
    Basic::new(
        aim.info("thermal-drift", Some(driver.to_string())),
        feature,
        aim.target.clone(),
        aim.words.clone(),
        aim.unit.clone(),
        shape,
    )
}

fn coupling(aim: &Aim, feature: Feature, column: &str, shape: Option<f64>) -> Basic {
    Basic::new(
        aim.info("temperature-coupling", Some(column.to_string())),
        feature,
        aim.target.clone(),
        aim.words.clone(),
        aim.unit.clone(),
        shape,
    )
}

fn drift_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    let speed = view.has_varying_column("S");
    for aim in thermal_aims(view) {
        for tau in drift_taus(view) {
            out.push(drift(&aim, Feature::Saturating, "t", Some(tau)));
        }
        out.push(drift(&aim, Feature::Hours, "t", None));
        if speed {
            for (input, driver) in [(Input::Speed, "S"), (Input::SpeedSquared, "S^2")] {
                for tau in lag_taus(view) {
                    out.push(drift(&aim, Feature::Lag(input.clone()), driver, Some(tau)));
                }
            }
        }
    }
    out.into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn drift_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, String> {
    let aim = plant_aim(table, view)?;
    let driver = string(table, "driver")?.unwrap_or("t");
    let tau = number(table, "tau_s", 1.0)?;
    let effect = match (driver, tau) {
        ("t", Some(tau)) => drift(&aim, Feature::Saturating, "t", Some(tau)),
        ("t", None) => drift(&aim, Feature::Hours, "t", None),
        ("S", Some(tau)) => drift(&aim, Feature::Lag(Input::Speed), "S", Some(tau)),
        ("S^2", Some(tau)) => drift(&aim, Feature::Lag(Input::SpeedSquared), "S^2", Some(tau)),
        ("S" | "S^2", None) => return Err("a drift driven by spindle speed needs `tau_s`".into()),
        (other, _) => {
            return Err(format!(
                "`driver = \"{other}\"`: a thermal drift follows \"t\", \"S\" or \"S^2\" \
                 (a temperature column is a temperature-coupling)"
            ));
        }
    };
    let values = plant_values(&effect, table, &["driver"])?;
    Ok((Arc::new(effect), values))
}

fn coupling_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    let columns = view.temperature_columns();
    for aim in thermal_aims(view) {
        for column in &columns {
            let input = Input::Context(column.clone());
            let stat = coupling(&aim, Feature::Static(input.clone()), column, None);
            let followed = view.has_current(&stat.info().label);
            out.push(stat);
            if followed {
                for tau in lag_taus(view) {
                    out.push(coupling(
                        &aim,
                        Feature::Lag(input.clone()),
                        column,
                        Some(tau),
                    ));
                }
            }
        }
    }
    out.into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn coupling_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, String> {
    let aim = plant_aim(table, view)?;
    let column = string(table, "driver")?
        .filter(|d| d.starts_with("T_"))
        .ok_or_else(|| "a temperature coupling needs `driver = \"T_<column>\"`".to_string())?;
    let input = Input::Context(column.to_string());
    let effect = match number(table, "tau_s", 1.0)? {
        Some(tau) => coupling(&aim, Feature::Lag(input), column, Some(tau)),
        None => coupling(&aim, Feature::Static(input), column, None),
    };
    let values = plant_values(&effect, table, &["driver"])?;
    Ok((Arc::new(effect), values))
}

inventory::submit! {
    EffectFamily {
        name: "thermal-drift",
        about: "first-order thermal drift in time, or driven by spindle speed through a time constant",
        candidates: drift_candidates,
        plant: Some(drift_plant),
    }
}

inventory::submit! {
    EffectFamily {
        name: "temperature-coupling",
        about: "an error following a recorded temperature, static or through a first-order lag",
        candidates: coupling_candidates,
        plant: Some(coupling_plant),
    }
}
