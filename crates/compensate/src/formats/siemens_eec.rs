//! `siemens-eec`: SINUMERIK 840D sl leadscrew/encoder compensation (`%_N_AX_EEC_INI`) of
//! `--axis` or of every axis, rotary axes without limits as modulo tables.

use crate::exported::{Checked, Exported, Written, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, Registered};
use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use std::path::Path;

struct SiemensEec;

impl ControlFormat for SiemensEec {
    fn name(&self) -> &'static str {
        "siemens-eec"
    }

    fn about(&self) -> &'static str {
        "SINUMERIK leadscrew tables, %_N_AX_EEC_INI: of --axis or of every axis, rotary axes \
         without limits as modulo tables"
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        axis: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let machine = model.machine();
        let names = crate::siemens_axis_names(machine);
        let (spacing, hold) = (settings.spacing_mm, &settings.hold_q);
        let rotary = |a: char| {
            let deg = settings.spacing_deg;
            crate::siemens_eec_rotary_table(model, coeffs, a, deg, hold, &names)
        };
        let is_rotary = |a: char| {
            machine
                .axis_index(a)
                .is_some_and(|i| machine.axes()[i].kind() == AxisKind::Rotary)
        };
        let linear = |a: char| {
            crate::siemens_eec_table(model, coeffs, a, spacing, hold, &names)
                .map(|t| t.relative_to(settings.reference_mm))
        };
        let rotary = |a: char| rotary(a).map(|t| t.relative_to(0.0));
        let tables = match axis {
            Some(a) if is_rotary(a) => vec![rotary(a)?],
            Some(a) => vec![linear(a)?],
            None => machine
                .axes()
                .iter()
                .filter(|a| a.kind() == AxisKind::Linear)
                .chain(
                    machine
                        .axes()
                        .iter()
                        .filter(|a| a.kind() == AxisKind::Rotary),
                )
                .map(|a| match a.kind() {
                    AxisKind::Rotary => rotary(a.letter().as_char()),
                    _ => linear(a.letter().as_char()),
                })
                .collect::<Result<_, _>>()?,
        };
        let card = made_from(crate::eec_card(&tables, &names), settings);
        let note = crate::siemens_note(machine, hold);
        crate::write_siemens_eec(path, &tables, &card, &note, &settings.siemens)?;
        let written = Written::ControlTables {
            file: crate::EEC_FILE_NAME,
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
        let tables = crate::read_siemens_eec(path, &settings.siemens)?;
        let points = tables.iter().map(|t| t.positions.len()).sum();
        Ok(Checked {
            tables: tables.len(),
            points,
        })
    }
}

inventory::submit!(Registered(&SiemensEec));
