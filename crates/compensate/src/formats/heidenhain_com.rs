//! `heidenhain-com`: Heidenhain nonlinear axis error compensation, the `.CMA` file at the path
//! and its `.COM` tables beside it.

use crate::exported::{Checked, Exported, Written, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct HeidenhainCom;

impl ControlFormat for HeidenhainCom {
    fn name(&self) -> &'static str {
        "heidenhain-com"
    }

    fn about(&self) -> &'static str {
        "Heidenhain nonlinear axis error tables: the .CMA file and its .COM tables beside it \
         (no --axis)"
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        super::no_axis(self.name(), "the tables of every axis", axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let set = crate::heidenhain_com_set(
            model,
            coeffs,
            settings.spacing_mm,
            &settings.hold_q,
            &settings.heidenhain,
        )?;
        let files =
            crate::write_heidenhain_com(path, &set, &settings.heidenhain, &settings.made_from)?;
        let written = Written::ControlFiles {
            what: "Heidenhain .CMA and .COM tables",
            files: files.len(),
            tables: set.tables.len(),
            points: set.total_points(),
        };
        Ok(Exported {
            written,
            card: made_from(crate::heidenhain_com_card(&set), settings),
            beside: super::heidenhain_files::beside(path, files),
        })
    }

    fn check(
        &self,
        _: &Machine,
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Checked, CompensateError> {
        let set = crate::read_heidenhain_com(path)?;
        crate::validate_heidenhain_com(&set, &settings.heidenhain)?;
        Ok(Checked {
            tables: set.tables.len(),
            points: set.total_points(),
        })
    }
}

inventory::submit!(Registered(&HeidenhainCom));
