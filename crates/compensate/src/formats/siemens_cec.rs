//! `siemens-cec`: SINUMERIK 840D sl sag / cross-axis compensation (`%_N_NC_CEC_INI`): a table
//! for every ordered pair of linear axes, or those whose input axis is `--axis`.

use crate::exported::{Checked, Exported, Written, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct SiemensCec;

impl ControlFormat for SiemensCec {
    fn name(&self) -> &'static str {
        "siemens-cec"
    }

    fn about(&self) -> &'static str {
        "SINUMERIK sag/cross tables, %_N_NC_CEC_INI: every pair of linear axes, or those with \
         input --axis"
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        input: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let machine = model.machine();
        let names = crate::siemens_axis_names(machine);
        let hold = &settings.hold_q;
        let mut tables =
            crate::siemens_cec_tables(model, coeffs, settings.spacing_mm, hold, &names)?;
        if let Some(letter) = input {
            crate::linear_axis(machine, letter)?;
            let control = format!("{letter}1");
            tables.retain(|t| t.input_axis == control);
            for (k, t) in tables.iter_mut().enumerate() {
                t.index = k;
            }
        }
        let card = made_from(crate::cec_card(&tables, &names), settings);
        let note = crate::siemens_note(machine, hold);
        crate::write_siemens_cec(path, &tables, &card, &note, &settings.siemens)?;
        let written = Written::ControlTables {
            file: crate::CEC_FILE_NAME,
            tables: tables.len(),
            points: tables.iter().map(|t| t.positions.len()).sum(),
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
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Checked, CompensateError> {
        let tables = crate::read_siemens_cec(path, &settings.siemens)?;
        let points = tables.iter().map(|t| t.positions.len()).sum();
        Ok(Checked {
            tables: tables.len(),
            points,
        })
    }
}

inventory::submit!(Registered(&SiemensCec));
