//! `fanuc`: Fanuc pitch error compensation (3620–3627 and the pitch data) of `--axis` or of
//! every axis, with the values table beside it (`FILE.values.csv`, which holds the card).

use crate::exported::{Checked, Exported, Written};
use crate::settings::Settings;
use crate::{CompensateError, ControlFormat, FanucAxis, Registered};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::{Path, PathBuf};

struct Fanuc;

impl ControlFormat for Fanuc {
    fn name(&self) -> &'static str {
        "fanuc"
    }

    fn about(&self) -> &'static str {
        "Fanuc pitch error compensation 3620–3627 and pitch data of --axis or of every axis, \
         with a values table FILE.values.csv"
    }

    fn holds_reversal_of(&self, asked: Option<char>, axis: char) -> bool {
        asked.is_none_or(|a| a == axis)
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        axis: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let requests: Vec<crate::FanucRequest> = fanuc_axes(model.machine(), axis)?
            .into_iter()
            .map(|fanuc_axis| crate::FanucRequest {
                axis: fanuc_axis,
                interval: if fanuc_axis.rotary {
                    settings.spacing_deg
                } else {
                    settings.spacing_mm
                },
                layout: crate::FanucLayout::default(),
                reversal: settings
                    .reversal_of(fanuc_axis.letter)
                    .map(|(r, _)| r)
                    .filter(|_| !fanuc_axis.rotary),
            })
            .collect();
        let mut conversions =
            crate::fanuc_export(model, coeffs, &requests, &settings.fanuc, &settings.hold_q)?;
        for c in conversions
            .iter_mut()
            .filter(|c| c.table.is_bidirectional())
        {
            c.reversal_source = settings
                .reversal_of(c.table.axis.letter)
                .map(|(_, source)| source);
        }
        let mut name = path.as_os_str().to_owned();
        name.push(".values.csv");
        let values = PathBuf::from(name);
        let card = crate::write_fanuc(
            path,
            &values,
            &settings.fanuc,
            &conversions,
            &settings.made_from,
        )?;
        let written = Written::ControlTables {
            file: "Fanuc pitch error compensation record",
            tables: conversions.len(),
            points: conversions
                .iter()
                .map(|c| c.table.node_points().count())
                .sum(),
        };
        let what = "the values table and the convention card: the record takes no comments";
        Ok(Exported {
            written,
            card,
            beside: vec![(values, what)],
        })
    }

    fn check(
        &self,
        machine: &Machine,
        path: &Path,
        axis: Option<char>,
        settings: &Settings,
    ) -> Result<Checked, CompensateError> {
        let axes = fanuc_axes(machine, axis)?;
        let tables = crate::read_fanuc_parameters(path, &settings.fanuc, &axes)?;
        crate::validate_fanuc(&settings.fanuc, &tables)?;
        let points = tables.iter().map(|t| t.node_points().count()).sum();
        Ok(Checked {
            tables: tables.len(),
            points,
        })
    }
}

inventory::submit!(Registered(&Fanuc));

/// The Fanuc axes of `machine` (numbered X, Y, Z, then A, B, C, as present): all, or `axis`
/// alone with its number.
fn fanuc_axes(machine: &Machine, axis: Option<char>) -> Result<Vec<FanucAxis>, CompensateError> {
    if let Some(letter) = axis
        && machine.axis_index(letter).is_none()
    {
        return Err(CompensateError::NoSuchAxis {
            letter,
            letters: machine.letters(),
        });
    }
    let mut letters: Vec<(char, bool)> = machine
        .axes()
        .iter()
        .map(|a| (a.letter().as_char(), a.letter().is_rotary()))
        .collect();
    letters.sort_by_key(|&(c, rotary)| (rotary, c));
    Ok((1u32..)
        .zip(letters)
        .filter(|(_, (c, _))| axis.is_none_or(|a| a == *c))
        .map(|(number, (letter, rotary))| FanucAxis::new(letter, number, rotary))
        .collect())
}
