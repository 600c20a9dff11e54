//! `linuxcnc`: LinuxCNC's axis compensation file (`COMP_FILE_TYPE = 1`) of `--axis`, its card
//! beside it.

use crate::exported::{Checked, Exported};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, PitchFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct LinuxCnc;

impl LinuxCnc {
    /// The table's axis; the file is of one axis only.
    fn axis(axis: Option<char>) -> Result<char, CompensateError> {
        axis.ok_or_else(|| {
            CompensateError::AxisUse(
                "--format `linuxcnc` without --axis: expected csv (3-D grid), isg or etalon"
                    .to_string(),
            )
        })
    }
}

impl ControlFormat for LinuxCnc {
    fn name(&self) -> &'static str {
        "linuxcnc"
    }

    fn about(&self) -> &'static str {
        "LinuxCNC's axis compensation file (COMP_FILE_TYPE = 1) of linear axis --axis, its \
         convention card beside it"
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        Self::axis(axis).map(|_| ())
    }

    fn holds_reversal_of(&self, asked: Option<char>, axis: char) -> bool {
        asked == Some(axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        axis: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let axis = Self::axis(axis)?;
        super::pitch_table::write(model, coeffs, path, axis, PitchFormat::LinuxCnc, settings)
    }

    fn check(
        &self,
        machine: &Machine,
        path: &Path,
        axis: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        super::pitch_table::check(machine, path, Self::axis(axis)?, PitchFormat::LinuxCnc)
    }
}

inventory::submit!(Registered(&LinuxCnc));
