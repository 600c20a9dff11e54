//! `heidenhain-kinematicscomp`: the ISO 230-1 errors as Heidenhain KinematicsComp's listing
//! (`.TAB`) at the path and its tables beside it.

use crate::exported::{Checked, Exported, Written, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, KcLimits, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct HeidenhainKinematicsComp;

impl ControlFormat for HeidenhainKinematicsComp {
    fn name(&self) -> &'static str {
        "heidenhain-kinematicscomp"
    }

    fn about(&self) -> &'static str {
        "the ISO 230-1 errors as Heidenhain KinematicsComp's listing .TAB and its tables \
         (no --axis)"
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        super::no_axis(self.name(), "the errors of every axis", axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let (mm, deg) = (settings.spacing_mm, settings.spacing_deg);
        let kc = crate::kinematics_comp(model, coeffs, mm, deg)?;
        let files =
            crate::write_kinematics_comp(path, &kc, &KcLimits::default(), &settings.made_from)?;
        let written = Written::ControlFiles {
            what: "Heidenhain KinematicsComp listing and tables",
            files: files.len(),
            tables: kc.tables.len(),
            points: kc.tables.iter().map(|t| t.positions.len()).sum(),
        };
        Ok(Exported {
            written,
            card: made_from(crate::kinematics_comp_card(&kc), settings),
            beside: super::heidenhain_files::beside(path, files),
        })
    }

    fn check(
        &self,
        _: &Machine,
        path: &Path,
        _: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        let kc = crate::read_kinematics_comp(path)?;
        crate::validate_kinematics_comp(&kc, &KcLimits::default())?;
        Ok(Checked {
            tables: kc.tables.len(),
            points: kc.tables.iter().map(|t| t.positions.len()).sum(),
        })
    }
}

inventory::submit!(Registered(&HeidenhainKinematicsComp));
