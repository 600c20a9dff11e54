//! **`thermal-location`** — a constant of the machine's geometry follows a recorded
//! temperature: the line of a rotary axis moves (its location errors, `EY0A`, `EB0C`) or a
//! linear axis' direction turns (its squareness, `EC0Y`) as bearing housings, a cradle or a
//! column warm unevenly. Source 000 measured A's and C's location errors and the X–Y
//! squareness changing between the load cycles of the rotary drives. The change is
//! `ΔL = g·ΔT` (`ΔT` the temperature's rise, driver `T_<name>`), or `g·lag(ΔT, τ)` when the
//! static form is already in the model (the sensor is not where the heat is); it acts as the
//! parameter itself does ([`Target::Location`]), so it shows where the parameter shows: a
//! ball turned by the axis, a circle whose shape the squareness draws.
//!
//! Proposed for every location error the fit estimates (its static value must be determined
//! for a change of it to be) and every recorded temperature, when some channel reads the tool
//! pose — but a squareness only where a turn of the tool side (`thermal-tilt`) would not draw
//! the same field ([`told_from_a_turn`]): where the tool point travels along one direction
//! only, a head nodding with a drive's temperature moves it across in proportion to that
//! travel, exactly as a squareness of that axis would. What moves the parts an axis carries as a whole besides its line (a cradle lifting
//! the table with the line) is an offset that follows the temperature: a
//! `temperature-coupling`, a candidate of its own.
//!
//! Plant keys: `parameter = "EY0A"`, `driver = "T_<name>"`, `gain_um_per_K` (`gain_urad_per_K`
//! for an orientation or a squareness) and, for the lagged form, `tau_s`.

use super::tilt::{LEVER_REACH_M, lever_changes};
use super::{plant_values, static_and_lagged, string, temperature_driver};
use crate::basic::{AmplitudeUnit, Basic, Feature};
use crate::view::SessionView;
use crate::{Candidate, EffectFamily, EffectInfo, PlantError, Planted, Target};
use mtcal_kinematics::ParamName;
use std::sync::Arc;

/// The change of location error `name` following `feature` of temperature `column`.
fn location(name: ParamName, feature: Feature, column: &str, tau: Option<f64>) -> Basic {
    let rotation = name.direction().is_rotation();
    let axis = name.axis().map(|a| a.as_char());
    let what = match name.axis() {
        Some(a) if a.is_rotary() => format!("the line of {} ({name})", a.as_char()),
        Some(a) => format!("the direction of {} ({name}, a squareness)", a.as_char()),
        None => name.to_string(),
    };
    let info = EffectInfo {
        class: "thermal-location",
        axis,
        component: Some(name.to_string()),
        driver: Some(column.to_string()),
        label: format!("thermal-location {name} ({column})"),
    };
    let unit = if rotation {
        AmplitudeUnit::urad()
    } else {
        AmplitudeUnit::um()
    };
    Basic::new(info, feature, Target::Location(name), what, unit, tau)
}

fn candidates(view: &SessionView) -> Vec<Candidate> {
    if !view.any_pose_reading() || view.locations.is_empty() {
        return Vec::new();
    }
    let mut out = Vec::new();
    let told = view.locations.iter().filter(|n| told_from_a_turn(view, n));
    for &name in told {
        for column in view.temperature_columns() {
            out.extend(static_and_lagged(view, &column, |feature, tau| {
                location(name, feature, &column, tau)
            }));
        }
    }
    out.into_iter()
        .map(|e| Candidate::Effect(Arc::new(e)))
        .collect()
}

/// Whether a change of `name` can be told from a turn of the tool side (`thermal-tilt`): a
/// rotary axis' line always; the squareness of linear axis `a` about direction `k` unless a
/// turn about `k` is proposed while the tool point does not travel along the third direction
/// `b`. The turn then moves the tool across in proportion to its travel along `a` alone — the
/// squareness's field (on a three-axis machine whose table carries X and Y, the head nodding
/// about X is `EA0Z` changing: the independent simulator's volumetric test named the one for
/// the other).
fn told_from_a_turn(view: &SessionView, name: &ParamName) -> bool {
    let Some(axis) = name.axis() else {
        return false;
    };
    if axis.is_rotary() {
        return true;
    }
    let (a, k) = (axis.nominal_cartesian(), name.direction().cartesian());
    if a == k {
        return false;
    }
    let b = 3 - a - k;
    !(lever_changes(view, k) && view.tool_reach_m[b] < LEVER_REACH_M)
}

fn plant(table: &toml::Table, view: &SessionView) -> Result<Planted, PlantError> {
    let text = string(table, "parameter")?.ok_or_else(|| {
        "a thermal location change needs `parameter = \"EY0A\"` (a location error or a \
         squareness)"
            .to_string()
    })?;
    let name: ParamName = text
        .parse()
        .ok()
        .filter(|n| matches!(n, ParamName::Location { .. }))
        .ok_or_else(|| {
            PlantError::at(
                "parameter",
                format!("`parameter = \"{text}\"`: a location error (EY0A) or a squareness (EC0Y)"),
            )
        })?;
    if !view.locations.contains(&name) {
        return Err(PlantError::at(
            "parameter",
            format!("`parameter = \"{text}\"`: the fit does not estimate it"),
        ));
    }
    let (column, feature, tau) = temperature_driver(table, view, "a thermal location change")?;
    let effect = location(name, feature, column, tau);
    let values = plant_values(&effect, table, &["driver", "parameter"])?;
    Ok((Arc::new(effect), values))
}

inventory::submit! {
    EffectFamily {
        name: "thermal-location",
        about: "a location error or squareness following a recorded temperature (an axis line moving as its bearing housings or a column warm)",
        candidates,
        plant: Some(plant),
        separated_by: None,
        told_from: &[],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(reach_m: [f64; 3]) -> SessionView {
        SessionView::new(Vec::new(), Vec::new(), Vec::new(), Vec::new())
            .with_tool_travel([0.0; 3], reach_m)
    }

    fn name(text: &str) -> ParamName {
        text.parse().unwrap()
    }

    #[test]
    fn a_squareness_is_proposed_only_where_a_turn_draws_another_field() {
        // The tool point moves along Z only (the table carries X and Y): a nod about X or Y
        // is Z's squareness by another name; X–Y's squareness has no turn to be confused with.
        let three_axis = view([0.0, 0.0, 0.3]);
        assert!(!told_from_a_turn(&three_axis, &name("EA0Z")));
        assert!(!told_from_a_turn(&three_axis, &name("EB0Z")));
        assert!(told_from_a_turn(&three_axis, &name("EC0Y")));
        // The tool travelling along X, Y and Z (a trunnion's head): every one is told apart,
        // and a rotary axis' line always is.
        let trunnion = view([0.5, 0.4, 0.3]);
        for n in ["EA0Z", "EB0Z", "EC0Y", "EY0A", "EX0C"] {
            assert!(told_from_a_turn(&trunnion, &name(n)), "{n}");
        }
        assert!(told_from_a_turn(&three_axis, &name("EY0A")));
    }
}
