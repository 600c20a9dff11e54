//! What an identification gives acceptance ([`mtcal_acceptance`]): every run's instrument
//! values with their expanded uncertainties, the identified parameters with their u95, each
//! component error's curve over its stroke with its 95 % band, and what the runs do not
//! determine (so that a tolerance on it reads "cannot decide" with the reason); and the units of
//! the model's names, to check a tolerance file's `[parameters]` before the fit.

use crate::base::BaseModel;
use crate::report::{Identification, component_curves_sampled};
use crate::study::Study;
use mtcal_acceptance::{CurveEvidence, Evidence, MetricEvidence, ParameterEvidence, Undetermined};
use mtcal_kinematics::model::Role;
use mtcal_kinematics::{AxisKind, ParamName};
use mtcal_solve::Solution;
use std::collections::HashMap;

/// Positions, evenly over the stroke with both ends, at which a component error's tolerance is
/// checked (the JSON's curves have 11; the maximum of a curve may lie between those).
pub const CURVE_POINTS: usize = 101;

/// The coverage factor of the instruments' uncertainties (`Metric::u95`).
const INSTRUMENT_K: f64 = 2.0;

/// The evidence of `id`, the identification of `study` by `solution`.
pub fn evidence(study: &Study, solution: &Solution, id: &Identification) -> Evidence {
    let metrics = id
        .fit
        .runs
        .iter()
        .chain(&id.validation)
        .flat_map(|run| {
            run.metrics.iter().map(move |m| MetricEvidence {
                run: run.name.clone(),
                name: m.name.clone(),
                subject: m.subject.clone(),
                value: m.value,
                u95: m.u95,
                k: INSTRUMENT_K,
                unit: m.unit.clone(),
            })
        })
        .collect();
    let parameters = id
        .parameters
        .iter()
        .map(|p| ParameterEvidence {
            name: p.name.clone(),
            value: p.value,
            u95: p.u95,
            k: crate::K95,
            unit: p.unit.clone(),
        })
        .collect();
    let mut undetermined = undetermined(id);
    let components = components(study);
    let mut curves = Vec::new();
    for curve in component_curves_sampled(study, solution, CURVE_POINTS) {
        let Some((unit, position_unit)) = components.get(&curve.name) else {
            continue;
        };
        // A coefficient held at its start or seen only in a combination makes the curve a
        // prior's, not the runs'.
        let prefix = format!("{}.", curve.name);
        let open: Vec<&str> = undetermined
            .iter()
            .flat_map(|u| &u.names)
            .filter(|n| n.starts_with(&prefix))
            .map(String::as_str)
            .collect();
        if !open.is_empty() {
            continue;
        }
        curves.push(CurveEvidence {
            name: curve.name,
            unit: unit.clone(),
            position_unit: position_unit.to_string(),
            samples: curve.samples,
            k: crate::K95,
        });
    }
    undetermined.extend(open_components(&components, &curves, &undetermined));
    Evidence {
        metrics,
        parameters,
        curves,
        undetermined,
    }
}

/// What `id` says the runs do not determine: the combinations they see (every member, with the
/// combination's value) and the directions they do not observe or barely see.
fn undetermined(id: &Identification) -> Vec<Undetermined> {
    let combinations = id.combinations.iter().map(|c| Undetermined {
        names: std::iter::once(c.name.clone())
            .chain(c.terms.iter().map(|t| t.name.clone()))
            .collect(),
        why: format!(
            "these runs see only the combination {} = {:.4} ± {:.4} {}",
            c.expression, c.value, c.u95, c.unit
        ),
    });
    let directions = id.unidentifiable.iter().map(|u| Undetermined {
        names: u.parameters.clone(),
        why: u.why.clone(),
    });
    combinations.chain(directions).collect()
}

/// The component errors without a curve of the runs' own: which of their coefficients the runs
/// do not determine.
fn open_components(
    components: &HashMap<String, (String, &'static str)>,
    curves: &[CurveEvidence],
    undetermined: &[Undetermined],
) -> Vec<Undetermined> {
    let mut names: Vec<&String> = components.keys().collect();
    names.sort();
    names
        .into_iter()
        .filter(|name| !curves.iter().any(|c| &c.name == *name))
        .map(|name| {
            let prefix = format!("{name}.");
            let mut open: Vec<&str> = undetermined
                .iter()
                .flat_map(|u| &u.names)
                .filter(|n| n.starts_with(&prefix))
                .map(String::as_str)
                .collect();
            open.sort_unstable();
            open.dedup();
            let why = if open.is_empty() {
                "not all of its coefficients are identified".to_string()
            } else {
                format!(
                    "its coefficients {} are not identifiable from these runs (see the \
                     identification)",
                    open.join(", ")
                )
            };
            Undetermined {
                names: vec![name.clone()],
                why,
            }
        })
        .collect()
}

/// Every component error of the model: its values' unit and its positions' (`mm`, `deg`).
fn components(study: &Study) -> HashMap<String, (String, &'static str)> {
    let machine = study.model.machine();
    study
        .model
        .errors()
        .params()
        .iter()
        .filter_map(|p| {
            let Role::Component { axis, .. } = &p.role else {
                return None;
            };
            let name = p.name.to_string();
            let unit = name.parse::<ParamName>().map_or("um", |n| n.unit());
            let position = match machine.axes()[*axis].kind() {
                AxisKind::Rotary => "deg",
                AxisKind::Linear => "mm",
            };
            Some((name, (unit.to_string(), position)))
        })
        .collect()
}

/// The unit of every name a tolerance file may give in `[parameters]` for `study`: every
/// parameter of the fit (machine coefficients, set-up parameters, effects), every component
/// error, and the parameters `base` holds.
pub fn model_units(study: &Study, base: Option<&BaseModel>) -> HashMap<String, String> {
    let mut units: HashMap<String, String> = (0..study.layout().n_x())
        .map(|i| {
            let info = study.param_info(i);
            (info.name, info.unit)
        })
        .collect();
    for (name, (unit, _)) in components(study) {
        units.insert(name, unit);
    }
    for h in base.iter().flat_map(|b| &b.held) {
        units.insert(h.name.clone(), h.unit.clone());
    }
    units
}
