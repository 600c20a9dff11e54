//! `isg` and `etalon`: the machine's ISO 230-1 error parameters for a control that models the
//! machine (the ISG kernel's volumetric compensation, Beckhoff TF5280) — one format type, two
//! registrations that differ only in the file's syntax ([`ParameterFormat`]).

use crate::exported::{Checked, Exported};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, ParameterFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

/// A parameter file in one syntax, with its `--help` line.
struct ParameterFile {
    format: ParameterFormat,
    about: &'static str,
}

impl ControlFormat for ParameterFile {
    fn name(&self) -> &'static str {
        self.format.name()
    }

    fn about(&self) -> &'static str {
        self.about
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        super::error_parameters::accepts_axis(self.format, axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        super::error_parameters::write(model, coeffs, path, self.format, settings)
    }

    fn check(
        &self,
        _: &Machine,
        path: &Path,
        _: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        super::error_parameters::check(path, self.format)
    }
}

static ISG: ParameterFile = ParameterFile {
    format: ParameterFormat::IsgCsv,
    about: "the machine's ISO 230-1 error parameters (every axis, no --axis) as ISG CSV, for the \
            ISG kernel's volumetric compensation (Beckhoff TF5280)",
};

static ETALON: ParameterFile = ParameterFile {
    format: ParameterFormat::Etalon,
    about: "the machine's ISO 230-1 error parameters (every axis, no --axis) as Etalon \
            Exchange, for the ISG kernel's volumetric compensation",
};

inventory::submit!(Registered(&ISG));
inventory::submit!(Registered(&ETALON));
