//! The machine's ISO 230-1 error parameters for a controller that models the machine itself
//! (`isg`, `etalon`): written, read back and counted.

use crate::exported::{Checked, Exported, Written, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ParameterFormat, ParameterValue};
use mtcal_kinematics::MachineModel;
use std::path::Path;

/// A whole-machine file takes no `--axis`.
pub(super) fn accepts_axis(
    format: ParameterFormat,
    axis: Option<char>,
) -> Result<(), CompensateError> {
    super::no_axis(format.name(), "the error parameters of every axis", axis)
}

/// Writes every error parameter of `model` in `format`.
pub(super) fn write(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    format: ParameterFormat,
    settings: &Settings,
) -> Result<Exported, CompensateError> {
    let machine = model.machine();
    let params = crate::error_parameters(model, coeffs, settings.spacing_mm, settings.spacing_deg)?;
    crate::write_error_parameters(path, machine, &params, format, &settings.made_from)?;
    let tables = params
        .params
        .iter()
        .filter(|p| matches!(p.value, ParameterValue::Table { .. }))
        .count();
    let written = Written::Parameters {
        format,
        tables,
        locations: params.params.len() - tables,
    };
    Ok(Exported {
        written,
        card: made_from(crate::parameters::card(machine, format), settings),
        beside: Vec::new(),
    })
}

/// Reads the parameters back: one "table" per parameter, a constant one point.
pub(super) fn check(path: &Path, format: ParameterFormat) -> Result<Checked, CompensateError> {
    let params = crate::read_error_parameters(path, format)?;
    let points = params
        .params
        .iter()
        .map(|p| match &p.value {
            ParameterValue::Table { args, .. } => args.len(),
            ParameterValue::Constant(_) => 1,
        })
        .sum();
    Ok(Checked {
        tables: params.params.len(),
        points,
    })
}
