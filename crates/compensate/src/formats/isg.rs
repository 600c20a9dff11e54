//! `isg`: the machine's ISO 230-1 error parameters as ISG CSV (Beckhoff TF5280 volumetric compensation).

use crate::exported::{Checked, Exported};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, ParameterFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct Isg;

impl ControlFormat for Isg {
    fn name(&self) -> &'static str {
        ParameterFormat::IsgCsv.name()
    }

    fn about(&self) -> &'static str {
        "the machine's ISO 230-1 error parameters (every axis, no --axis) as ISG CSV, for the \
         ISG kernel's volumetric compensation (Beckhoff TF5280)"
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        super::error_parameters::accepts_axis(ParameterFormat::IsgCsv, axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        super::error_parameters::write(model, coeffs, path, ParameterFormat::IsgCsv, settings)
    }

    fn check(
        &self,
        _: &Machine,
        path: &Path,
        _: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        super::error_parameters::check(path, ParameterFormat::IsgCsv)
    }
}

inventory::submit!(Registered(&Isg));
