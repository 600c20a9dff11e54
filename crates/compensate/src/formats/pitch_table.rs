//! A pitch table of one linear axis, as LinuxCNC's file or CSV (`linuxcnc`, `csv --axis`):
//! written with its reversal and joint offset, read back and checked.

use crate::exported::{Checked, Exported, Written, append_card, made_from, write_card_beside};
use crate::settings::Settings;
use crate::{CompensateError, LINUXCNC_MAX_TRIPLETS, PitchFormat};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

/// Writes the pitch table of `axis` in `format`; LinuxCNC's file takes no comments, so its
/// card is written beside it.
pub(super) fn write(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    axis: char,
    format: PitchFormat,
    settings: &Settings,
) -> Result<Exported, CompensateError> {
    let mut table = crate::pitch_table(model, coeffs, axis, settings.spacing_mm, &settings.hold_q)?;
    let reversal = settings.reversal_of(axis);
    if let Some((r, _)) = &reversal {
        table = table.with_reversal(r, crate::stroke_mm(model.machine(), axis)?);
    }
    table = table.shifted_mm(settings.joint_offset_mm);
    let card = made_from(
        crate::pitch::card(
            format,
            axis,
            settings.joint_offset_mm,
            reversal.as_ref().map(|(_, source)| source.as_str()),
        ),
        settings,
    );
    let mut beside = Vec::new();
    match format {
        PitchFormat::LinuxCnc => {
            crate::write_linuxcnc_comp(path, &table)?;
            let what = "the convention card: the file takes no comments";
            beside.push((write_card_beside(path, &card)?, what));
        }
        PitchFormat::Csv => {
            append_card(&mut table.note, &card);
            crate::write_pitch_csv(path, &table)?
        }
    }
    let written = Written::PitchTable {
        format,
        axis,
        nodes: table.len(),
        bidirectional: reversal.is_some(),
    };
    Ok(Exported {
        written,
        card,
        beside,
    })
}

/// Reads the pitch table of `axis` in `format` back; LinuxCNC's holds at most
/// [`LINUXCNC_MAX_TRIPLETS`] nodes.
pub(super) fn check(
    machine: &Machine,
    path: &Path,
    axis: char,
    format: PitchFormat,
) -> Result<Checked, CompensateError> {
    crate::linear_axis(machine, axis)?;
    let table = match format {
        PitchFormat::LinuxCnc => crate::read_linuxcnc_comp(path, axis)?,
        PitchFormat::Csv => crate::read_pitch_csv(path, axis)?,
    };
    if format == PitchFormat::LinuxCnc && table.len() > LINUXCNC_MAX_TRIPLETS {
        return Err(CompensateError::TooManyNodes {
            what: format!("LinuxCNC compensation file for axis {axis}"),
            nodes: table.len(),
            max: LINUXCNC_MAX_TRIPLETS,
        });
    }
    Ok(Checked {
        tables: 1,
        points: table.len(),
    })
}
