//! `csv`: a CSV pitch table of `--axis`, or without one the 3-D grid of tool-point errors.

use crate::exported::{Checked, Exported, Written, append_card, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, GridSpec, PitchFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct Csv;

impl ControlFormat for Csv {
    fn name(&self) -> &'static str {
        "csv"
    }

    fn about(&self) -> &'static str {
        "CSV: the pitch table of linear axis --axis (corrections along its own direction), or \
         without --axis the 3-D grid of tool-point errors over X, Y, Z"
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
        if let Some(axis) = axis {
            return super::pitch_table::write(
                model,
                coeffs,
                path,
                axis,
                PitchFormat::Csv,
                settings,
            );
        }
        let machine = model.machine();
        let mut spec = GridSpec::new(machine, [settings.spacing_mm; 3]);
        spec.hold_q = settings.hold_q.clone();
        let mut grid = crate::error_grid(model, coeffs, &spec)?;
        let card = made_from(crate::grid::card(machine), settings);
        append_card(&mut grid.note, &card);
        crate::write_grid_csv(path, &grid)?;
        let nodes = [grid.x_mm.len(), grid.y_mm.len(), grid.z_mm.len()];
        Ok(Exported {
            written: Written::Grid { nodes },
            card,
            beside: Vec::new(),
        })
    }

    fn check(
        &self,
        machine: &Machine,
        path: &Path,
        axis: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        match axis {
            Some(axis) => super::pitch_table::check(machine, path, axis, PitchFormat::Csv),
            None => Ok(Checked {
                tables: 1,
                points: crate::read_grid_csv(path)?.error_um.len(),
            }),
        }
    }
}

inventory::submit!(Registered(&Csv));
