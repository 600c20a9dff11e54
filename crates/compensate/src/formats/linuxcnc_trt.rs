//! `linuxcnc-trt`: HAL settings of the rotary pivots of LinuxCNC's xyzac/xyzbc table-table
//! kinematics, the errors they cannot hold listed in comments.

use crate::exported::{Checked, Exported, Written, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct LinuxCncTrt;

impl ControlFormat for LinuxCncTrt {
    fn name(&self) -> &'static str {
        "linuxcnc-trt"
    }

    fn about(&self) -> &'static str {
        "HAL settings of the rotary pivots of LinuxCNC's xyzac/xyzbc table-table kinematics \
         (no --axis)"
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        super::no_axis(self.name(), "the pivots of the rotary axes", axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let machine = model.machine();
        let pivots = crate::trt_pivots_with_nominal(model, coeffs)?;
        let kinematics = pivots.kind.name();
        let not_representable = pivots.not_representable.len();
        let card = made_from(
            crate::trt::card(machine, kinematics, not_representable),
            settings,
        );
        let mut text = crate::trt_hal_text(&pivots, machine.name());
        text.push_str(&card.file_lines("# "));
        mtcal_machine::write_atomically(path, text.as_bytes()).map_err(|source| {
            CompensateError::Write {
                path: path.to_path_buf(),
                source,
            }
        })?;
        let written = Written::TrtPivots {
            kinematics,
            not_representable,
        };
        Ok(Exported {
            written,
            card,
            beside: Vec::new(),
        })
    }

    fn check(
        &self,
        _: &Machine,
        _: &Path,
        _: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        Err(CompensateError::NoReader {
            format: "LinuxCNC HAL settings",
        })
    }
}

inventory::submit!(Registered(&LinuxCncTrt));
