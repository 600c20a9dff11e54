//! `etalon`: the machine's ISO 230-1 error parameters as Etalon Exchange.

use crate::exported::{Checked, Exported};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, ParameterFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct Etalon;

impl ControlFormat for Etalon {
    fn name(&self) -> &'static str {
        ParameterFormat::Etalon.name()
    }

    fn about(&self) -> &'static str {
        "the machine's ISO 230-1 error parameters (every axis, no --axis) as Etalon \
         Exchange, for the ISG kernel's volumetric compensation"
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        super::error_parameters::accepts_axis(ParameterFormat::Etalon, axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        super::error_parameters::write(model, coeffs, path, ParameterFormat::Etalon, settings)
    }

    fn check(
        &self,
        _: &Machine,
        path: &Path,
        _: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        super::error_parameters::check(path, ParameterFormat::Etalon)
    }
}

inventory::submit!(Registered(&Etalon));
