//! Thermal effects.
//!
//! **`thermal-drift`** — the machine (or a sensor modelled on its own) drifts as it warms:
//! - driver `t`: `A·(1 − exp(−(t − t₀)/τ))` from the session's start (a first-order node
//!   settling; plant keys `amplitude_um`, `tau_s`), a steady `rate·(t − t₀)` (plant key
//!   `rate_um_per_h`), or — several nodes warming and cooling, nothing recorded that drives
//!   them — a curve of free shape, piecewise linear through up to eight points at equal steps
//!   (four minutes apart at least) over the session, zero at its start (proposed by the search;
//!   not planted);
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
//! on its own; and for a temperature recorded only in one set-up's runs (an instrument's own,
//! such as a ball bar's), that set-up's parameters in µm (the bar's length growing with it).
//!
//! **`thermal-expansion`** — an axis' scale (its screw or glass scale) grows with a recorded
//! temperature: the axis is effectively at `q + s·ΔT·(q − q_mid)`, the scale change `s`
//! (ppm/K) about the middle of the positions the axis stands at over the fitted samples, `ΔT`
//! the temperature's rise (driver `T_<name>`), through a first-order lag when the static form
//! is already in the model. Where the scale is fixed is an offset that follows the
//! temperature: a `temperature-coupling` of the axis, a candidate of its own (about the
//! stroke's middle, a scale seen over a few ball heights far from it would be mostly that
//! offset). Without a recorded temperature a scale warming in time is not
//! proposed: over the few heights an R-test sees, it is a drift of the axis by another name.
//! Plant keys `axis`, `driver`, `scale_ppm_per_K`, `tau_s` for the lagged form. Targets: each
//! linear axis that stands at different places over the fitted samples (within a run or
//! between runs: the balls of a volumetric test), when some channel reads the tool pose.

use super::{
    Aim, axis_aim, drift_taus, lag_taus, linear_axis_aims, nuisance_aim, number, plant_aim,
    plant_values, positions_vary, static_and_lagged, string, thermal_aims,
};
use crate::Target;
use crate::bank::{Bank, BankColumn};
use crate::basic::{Basic, Feature};
use crate::view::{Input, SessionView};
use crate::{Candidate, Effect, EffectFamily, PlantError, Planted};
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

/// A drift in time through several thermal nodes at once (warming and cooling, fast and
/// slow): a bank of first-order rises at the drift's time constants ([`Bank`]).
fn several_nodes(view: &SessionView, aim: &Aim, taus: &[f64]) -> Bank {
    let mut info = aim.info("thermal-drift", Some("t".into()));
    info.label = format!("thermal-drift {} (t, several nodes)", aim.short);
    Bank::new(
        info,
        aim.target.clone(),
        aim.words.clone(),
        (aim.unit.unit.clone(), aim.unit.per_si),
        taus.iter().map(|&t| BankColumn::Rise(t)).collect(),
        view,
        1e-6,
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
    let mut out: Vec<Candidate> = out
        .into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect();
    let taus = drift_taus(view);
    if taus.len() >= 3 {
        for aim in thermal_aims(view) {
            out.push(Candidate::Effect(Arc::new(several_nodes(
                view, &aim, &taus,
            ))));
        }
    }
    out
}

fn drift_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
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
            return Err(PlantError::at(
                "driver",
                format!(
                    "`driver = \"{other}\"`: a thermal drift follows \"t\", \"S\" or \"S^2\" \
                 (a temperature column is a temperature-coupling)"
                ),
            ));
        }
    };
    let values = plant_values(&effect, table, &["driver"])?;
    Ok((Arc::new(effect), values))
}

/// Temperatures recorded in the runs of one set-up only (an instrument's own), with the set-up.
fn own_columns(view: &SessionView) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for column in view.temperature_columns() {
        let setups: Vec<usize> = view
            .runs
            .iter()
            .filter(|r| r.context_column(&column).is_some())
            .map(|r| r.setup)
            .collect();
        let one = setups.first().copied();
        let elsewhere = view
            .runs
            .iter()
            .any(|r| Some(r.setup) != one && r.context_column(&column).is_none());
        if let Some(s) = one
            && setups.iter().all(|&x| x == s)
            && elsewhere
        {
            out.push((s, column));
        }
    }
    out
}

fn coupling_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    let columns = view.temperature_columns();
    // An instrument's own temperature drives its own set-up's lengths.
    for (s, column) in own_columns(view) {
        for (j, n) in view.setups[s].nuisance.iter().enumerate() {
            if n.unit == mtcal_instrument::Unit::Um {
                let aim = nuisance_aim(view, s, j);
                let input = Input::Context(column.clone());
                out.push(coupling(&aim, Feature::Static(input), &column, None));
            }
        }
    }
    for aim in thermal_aims(view) {
        for column in &columns {
            out.extend(static_and_lagged(view, column, |feature, tau| {
                coupling(&aim, feature, column, tau)
            }));
        }
    }
    out.into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn coupling_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
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

fn expansion(aim: &Aim, feature: Feature, driver: &str, shape: Option<f64>) -> Basic {
    Basic::new(
        aim.info("thermal-expansion", Some(driver.to_string())),
        feature,
        aim.target.clone(),
        aim.words.clone(),
        aim.unit.clone(),
        shape,
    )
}

fn expansion_candidates(view: &SessionView) -> Vec<Candidate> {
    let mut out = Vec::new();
    let columns = view.temperature_columns();
    for aim in linear_axis_aims(view) {
        let Target::Axis(a) = aim.target else {
            continue;
        };
        // Where the axis stands at different places (within a run or between runs), its
        // scale shows.
        if !positions_vary(view, a) {
            continue;
        }
        for column in &columns {
            let input = Input::Context(column.clone());
            let stat = expansion(&aim, Feature::Expansion(input.clone(), a), column, None);
            let followed = view.has_current(&stat.info().label);
            out.push(stat);
            if followed {
                for tau in lag_taus(view) {
                    let f = Feature::LaggedExpansion(input.clone(), a);
                    out.push(expansion(&aim, f, column, Some(tau)));
                }
            }
        }
    }
    out.into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

fn expansion_plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let aim = plant_aim(table, view)?;
    let Target::Axis(a) = aim.target else {
        return Err("a thermal expansion acts on a linear axis: give `axis = \"X\"`".into());
    };
    if view.axes[a].rotary {
        return Err(PlantError::at(
            "axis",
            format!(
                "`axis = \"{}\"`: a thermal expansion acts on a linear axis",
                view.axes[a].letter
            ),
        ));
    }
    let aim = axis_aim(view, a);
    let driver = string(table, "driver")?
        .ok_or_else(|| "a thermal expansion needs `driver = \"T_<column>\"`".to_string())?;
    let tau = number(table, "tau_s", 1.0)?;
    let effect = match (driver, tau) {
        (column, tau) if column.starts_with("T_") => {
            let input = Input::Context(column.to_string());
            match tau {
                Some(tau) => expansion(&aim, Feature::LaggedExpansion(input, a), column, Some(tau)),
                None => expansion(&aim, Feature::Expansion(input, a), column, None),
            }
        }
        (other, _) => {
            return Err(PlantError::at(
                "driver",
                format!(
                    "`driver = \"{other}\"`: a thermal expansion follows a temperature \"T_<name>\""
                ),
            ));
        }
    };
    let values = plant_values(&effect, table, &["driver"])?;
    Ok((Arc::new(effect), values))
}

/// Time constants of a joint thermal model's lags: 5 min, growing fourfold, no shorter than
/// five sample intervals and no longer than a sixth of the fitted span (a longer one is a
/// trend the fitted runs cannot tell from the slow drift of the room, and it extrapolates
/// wrongly).
fn model_taus(view: &SessionView) -> Vec<f64> {
    let floor = 5.0 * view.median_interval();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for run in view.runs.iter().filter(|r| r.fit) {
        if let (Some(a), Some(b)) = (run.first_time(), run.last_time()) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    let cap = (hi - lo) / 6.0;
    (0..8)
        .map(|k| 300.0 * 4f64.powi(k))
        .filter(|&tau| tau >= floor && tau <= cap)
        .collect()
}

/// The joint thermal model of every target over every recorded input ([`Bank`]): each
/// temperature as recorded and through first-order lags, the spindle speed and its square
/// through lags. Proposed when two inputs or more are recorded (one is a coupling).
fn model_candidates(view: &SessionView) -> Vec<Candidate> {
    let temps = view.temperature_columns();
    let speed = view.has_varying_column("S");
    let taus = model_taus(view);
    if temps.len() + usize::from(speed) < 2 || taus.is_empty() {
        return Vec::new();
    }
    let mut columns = Vec::new();
    let mut drivers = Vec::new();
    if speed {
        drivers.push("S".to_string());
        for input in [Input::Speed, Input::SpeedSquared] {
            columns.extend(taus.iter().map(|&t| BankColumn::Lag(input.clone(), t)));
        }
    }
    for t in &temps {
        drivers.push(t.clone());
        let input = Input::Context(t.clone());
        columns.push(BankColumn::Static(input.clone()));
        columns.extend(taus.iter().map(|&tau| BankColumn::Lag(input.clone(), tau)));
    }
    thermal_aims(view)
        .iter()
        .map(|aim| {
            let mut info = aim.info("thermal-model", Some(drivers.join(",")));
            info.label = format!("thermal-model {}", aim.short);
            Candidate::Effect(Arc::new(Bank::new(
                info,
                aim.target.clone(),
                aim.words.clone(),
                (aim.unit.unit.clone(), aim.unit.per_si),
                columns.clone(),
                view,
                1e-6,
            )))
        })
        .collect()
}

inventory::submit! {
    EffectFamily {
        name: "thermal-model",
        about: "a joint thermal model: the target follows every recorded temperature and the spindle speed through lags at several time constants, fitted together with a ridge prior",
        candidates: model_candidates,
        plant: None,
        separated_by: None,
        told_from: &[],
    }
}

inventory::submit! {
    EffectFamily {
        name: "thermal-expansion",
        about: "an axis' scale growing with a temperature (or as the machine warms): error proportional to position",
        candidates: expansion_candidates,
        plant: Some(expansion_plant),
        separated_by: None,
        told_from: &[],
    }
}

inventory::submit! {
    EffectFamily {
        name: "thermal-drift",
        about: "first-order thermal drift in time, or driven by spindle speed through a time constant",
        candidates: drift_candidates,
        plant: Some(drift_plant),
        separated_by: Some("repeat a reference point (or the first run) at the end of the session, or measure the runs in random order: a drift in time then no longer follows the path"),
        told_from: &[],
    }
}

inventory::submit! {
    EffectFamily {
        name: "temperature-coupling",
        about: "an error following a recorded temperature, static or through a first-order lag",
        candidates: coupling_candidates,
        plant: Some(coupling_plant),
        separated_by: Some("repeat a reference point (or the first run) at the end of the session, or measure the runs in random order: a drift in time then no longer follows the path"),
        told_from: &[],
    }
}
