//! `siemens-carr`: SINUMERIK CYCLE800 swivel data (`$TC_CARR`) of a five-axis machine.

use crate::exported::{Checked, Exported, Written, made_from};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

struct SiemensCarr;

impl ControlFormat for SiemensCarr {
    fn name(&self) -> &'static str {
        "siemens-carr"
    }

    fn about(&self) -> &'static str {
        "SINUMERIK CYCLE800 swivel data $TC_CARR of a five-axis machine (no --axis)"
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        super::no_axis(self.name(), "the swivel data of the rotary axes", axis)
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
        let name: String = machine.name().chars().take(crate::CARR_MAX_NAME).collect();
        let data = crate::carr_data(model, coeffs, 1, &name)?;
        crate::write_carr(path, &data, machine.name(), &settings.made_from)?;
        let written = Written::SiemensCarr {
            kind: data.kind.letter(),
            not_representable: data.not_representable.len(),
        };
        Ok(Exported {
            written,
            card: made_from(crate::carr_card(&data), settings),
            beside: Vec::new(),
        })
    }

    fn check(
        &self,
        _: &Machine,
        path: &Path,
        _: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        crate::read_carr(path)?;
        Ok(Checked {
            tables: 1,
            points: 0,
        })
    }
}

inventory::submit!(Registered(&SiemensCarr));
