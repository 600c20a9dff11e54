//! One compensation file of an identified machine, as `mtcal compensate` writes it: which file
//! ([`Compensation`]), its settings ([`Settings`]) and what was written ([`Written`], whose
//! `Display` is the sentence the command prints).

use crate::parameters::{ParameterFormat, ParameterValue};
use crate::{CompensateError, GridSpec, PitchFormat};
use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use mtcal_machine::card::ConventionCard;
use std::fmt;
use std::path::{Path, PathBuf};

/// Which compensation file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compensation {
    /// A pitch table of one linear axis (positioning along its own direction).
    PitchTable { axis: char, format: PitchFormat },
    /// A 3-D grid of tool-point error vectors (CSV).
    Grid,
    /// The machine's ISO 230-1 error parameters, for a controller that models the machine.
    Parameters(ParameterFormat),
    /// HAL settings of the rotary pivots of LinuxCNC's xyzac/xyzbc table-table kinematics.
    TrtPivots,
    /// SINUMERIK 840D sl measuring-system error compensation (`%_N_AX_EEC_INI`): the table of
    /// linear axis `axis`, or of every linear axis.
    SiemensEec { axis: Option<char> },
    /// SINUMERIK 840D sl sag / cross-axis compensation (`%_N_NC_CEC_INI`): a table for every
    /// ordered pair of linear axes, or those whose input axis is `input`.
    SiemensCec { input: Option<char> },
    /// SINUMERIK 840D sl CYCLE800 swivel data (`$TC_CARR`) of a machine with two rotary axes.
    SiemensCarr,
    /// Fanuc pitch error compensation (3620–3627 and the pitch data) of axis `axis` or of every
    /// axis, with the values table beside it (`FILE.values.csv`, which holds the card).
    Fanuc { axis: Option<char> },
    /// Heidenhain nonlinear axis error compensation: the `.CMA` file at the path and its
    /// `.COM` tables beside it.
    HeidenhainCom,
    /// Heidenhain KinematicsComp: the listing (`.TAB`) at the path and its `.COM` tables.
    HeidenhainKinematicsComp,
}

impl Compensation {
    /// Whether the file can hold a reversal of linear axis `axis` (a bidirectional table of
    /// it: a pitch table of the axis, or Fanuc's of the axis or of every axis).
    pub fn holds_reversal_of(&self, axis: char) -> bool {
        match *self {
            Compensation::PitchTable { axis: a, .. } => a == axis,
            Compensation::Fanuc { axis: a } => a.is_none_or(|a| a == axis),
            _ => false,
        }
    }
}

/// The settings of a compensation file; each kind uses those it needs.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Node spacing of linear axes (pitch tables, grids, parameter tables), mm.
    pub spacing_mm: f64,
    /// Node spacing of rotary axes' parameter tables, degrees.
    pub spacing_deg: f64,
    /// Pitch tables: the controller's joint position minus mtcal's axis position, mm.
    pub joint_offset_mm: f64,
    /// Pitch tables: the signed ISO 230-2 reversal value B, µm (a bidirectional table), as the
    /// user gave it: it applies to the table's axis (Fanuc: every linear axis written) and
    /// takes the place of a reversal in `reversals`.
    pub reversal_um: Option<f64>,
    /// Reversals an identification found, per axis: each bidirectional pitch table (LinuxCNC,
    /// CSV, Fanuc) of such an axis holds its reversal, and its card says where it came from.
    pub reversals: Vec<crate::AxisReversal>,
    /// What the numbers were made from (an identification's account of what went in and what
    /// it left out), for every card: [`ConventionCard::made_from`].
    pub made_from: Vec<String>,
    /// Positions (SI) of the axes a pitch table or grid does not move ([`crate::default_hold`]
    /// with the user's changes).
    pub hold_q: Vec<f64>,
    /// SINUMERIK tables: the control's limits (MD38000, MD18342).
    pub siemens: crate::SiemensLimits,
    /// SINUMERIK EEC: the reference point where each linear axis' table is zero (mm, mtcal's
    /// axis coordinates; a rotary axis' table is zero at 0°), as K3 asks (no jump when the
    /// compensation starts).
    pub reference_mm: f64,
    /// Fanuc pitch error compensation: the series, increment system and limits.
    pub fanuc: crate::FanucControl,
    /// Heidenhain `.COM` tables: the control's limits (TNC 4xx or MANUALplus 620).
    pub heidenhain: crate::ComLimits,
}

impl Settings {
    /// The settings of a plain file of `machine`: nodes `spacing_mm` and `spacing_deg` apart,
    /// the other axes at [`crate::default_hold`], no joint offset and no reversal, nothing said
    /// of where the numbers came from, EEC tables zero at 0 mm, a Fanuc Series 30i with IS-C,
    /// a TNC 4xx and the SINUMERIK defaults. Change the fields a file needs.
    pub fn new(machine: &Machine, spacing_mm: f64, spacing_deg: f64) -> Self {
        Settings {
            spacing_mm,
            spacing_deg,
            joint_offset_mm: 0.0,
            reversal_um: None,
            reversals: Vec::new(),
            made_from: Vec::new(),
            hold_q: crate::default_hold(machine),
            siemens: crate::SiemensLimits::default(),
            reference_mm: 0.0,
            fanuc: crate::FanucControl::new(
                crate::FanucSeries::Series30i,
                crate::IncrementSystem::IsC,
            ),
            heidenhain: crate::ComLimits::tnc_4xx(),
        }
    }
}

/// What [`write_compensation`] wrote.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Written {
    PitchTable {
        format: PitchFormat,
        axis: char,
        nodes: usize,
        bidirectional: bool,
    },
    Grid {
        nodes: [usize; 3],
    },
    Parameters {
        format: ParameterFormat,
        /// Component errors written as tables.
        tables: usize,
        /// Location errors written as constants.
        locations: usize,
    },
    TrtPivots {
        /// The HAL component, e.g. `xyzac-trt-kins`.
        kinematics: &'static str,
        /// Identified errors these kinematics cannot hold (listed in the file).
        not_representable: usize,
    },
    /// Interpolation tables of a control (SINUMERIK EEC or CEC).
    ControlTables {
        /// The file's name on the control, e.g. `%_N_AX_EEC_INI`.
        file: &'static str,
        tables: usize,
        /// Interpolation points in all tables.
        points: usize,
    },
    /// A set of files: a control's assignment or listing file and its tables.
    ControlFiles {
        what: &'static str,
        /// Files written, the card's included.
        files: usize,
        tables: usize,
        points: usize,
    },
    /// A CYCLE800 swivel data record.
    SiemensCarr {
        /// The kinematics type letter (`T`, `P`, `M`).
        kind: char,
        /// Identified errors `$TC_CARR` cannot hold (listed in the file).
        not_representable: usize,
    },
}

impl fmt::Display for Written {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Written::PitchTable {
                format,
                axis,
                nodes,
                bidirectional,
            } => write!(
                f,
                "{} pitch table of {axis}, {nodes} nodes{}",
                format.name(),
                if bidirectional { ", bidirectional" } else { "" }
            ),
            Written::Grid { nodes: [x, y, z] } => {
                write!(f, "a {x} × {y} × {z} grid of tool-point errors")
            }
            Written::Parameters {
                format,
                tables,
                locations,
            } => write!(
                f,
                "{} error parameters: {tables} component-error tables, {locations} location errors",
                format.name()
            ),
            Written::TrtPivots {
                kinematics,
                not_representable,
            } => write!(
                f,
                "HAL settings of LinuxCNC's {kinematics}; {not_representable} identified errors \
                 it cannot hold are listed in it"
            ),
            Written::ControlTables {
                file,
                tables,
                points,
            } => write!(f, "{file}: {tables} tables, {points} points"),
            Written::ControlFiles {
                what,
                files,
                tables,
                points,
            } => write!(f, "{what}: {files} files, {tables} tables, {points} points"),
            Written::SiemensCarr {
                kind,
                not_representable,
            } => write!(
                f,
                "CYCLE800 swivel data, kinematics type {kind}; {not_representable} identified \
                 errors $TC_CARR cannot hold are listed in it"
            ),
        }
    }
}

/// What [`write_compensation`] wrote and what its numbers mean.
#[derive(Clone, Debug, PartialEq)]
pub struct Exported {
    pub written: Written,
    /// The file's convention card (also written in the file where the format has comments).
    pub card: ConventionCard,
    /// Files written beside the first (tables, or the card when the format takes no
    /// comments): where, and what each holds.
    pub beside: Vec<(PathBuf, &'static str)>,
}

/// Writes the compensation file `what` of `model` with coefficients `coeffs` to `path`
/// (atomically), its convention card in it or beside it; says what it wrote.
pub fn write_compensation(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    what: Compensation,
    settings: &Settings,
) -> Result<Exported, CompensateError> {
    let machine = model.machine();
    let mut beside = Vec::new();
    let (written, card) = match what {
        Compensation::PitchTable { axis, format } => {
            let (written, card) = write_pitch_table(model, coeffs, path, axis, format, settings)?;
            if format == PitchFormat::LinuxCnc {
                let what = "the convention card: the file takes no comments";
                beside.push((write_card_beside(path, &card)?, what));
            }
            (written, card)
        }
        Compensation::Grid => {
            let mut spec = GridSpec::new(machine, [settings.spacing_mm; 3]);
            spec.hold_q = settings.hold_q.clone();
            let mut grid = crate::error_grid(model, coeffs, &spec)?;
            let card = made_from(crate::grid::card(machine), settings);
            append_card(&mut grid.note, &card);
            crate::write_grid_csv(path, &grid)?;
            let nodes = [grid.x_mm.len(), grid.y_mm.len(), grid.z_mm.len()];
            (Written::Grid { nodes }, card)
        }
        Compensation::Parameters(format) => {
            let params =
                crate::error_parameters(model, coeffs, settings.spacing_mm, settings.spacing_deg)?;
            crate::write_error_parameters(path, machine, &params, format, &settings.made_from)?;
            let tables = params
                .params
                .iter()
                .filter(|p| matches!(p.value, ParameterValue::Table { .. }))
                .count();
            let written = Written::Parameters {
                format,
                tables,
                locations: params.params.len() - tables,
            };
            (
                written,
                made_from(crate::parameters::card(machine, format), settings),
            )
        }
        Compensation::TrtPivots => {
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
            (written, card)
        }
        Compensation::SiemensEec { axis } => {
            write_siemens_eec(model, coeffs, path, axis, settings)?
        }
        Compensation::SiemensCec { input } => {
            write_siemens_cec(model, coeffs, path, input, settings)?
        }
        Compensation::SiemensCarr => {
            let name: String = machine.name().chars().take(crate::CARR_MAX_NAME).collect();
            let data = crate::carr_data(model, coeffs, 1, &name)?;
            crate::write_carr(path, &data, machine.name(), &settings.made_from)?;
            let written = Written::SiemensCarr {
                kind: data.kind.letter(),
                not_representable: data.not_representable.len(),
            };
            (written, made_from(crate::carr_card(&data), settings))
        }
        Compensation::Fanuc { axis } => {
            let (written, card, values) = write_fanuc(model, coeffs, path, axis, settings)?;
            let what = "the values table and the convention card: the record takes no comments";
            beside.push((values, what));
            (written, card)
        }
        Compensation::HeidenhainCom => {
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
            beside.extend(heidenhain_beside(path, files));
            (
                written,
                made_from(crate::heidenhain_com_card(&set), settings),
            )
        }
        Compensation::HeidenhainKinematicsComp => {
            let (mm, deg) = (settings.spacing_mm, settings.spacing_deg);
            let kc = crate::kinematics_comp(model, coeffs, mm, deg)?;
            let files = crate::write_kinematics_comp(
                path,
                &kc,
                &crate::KcLimits::default(),
                &settings.made_from,
            )?;
            let written = Written::ControlFiles {
                what: "Heidenhain KinematicsComp listing and tables",
                files: files.len(),
                tables: kc.tables.len(),
                points: kc.tables.iter().map(|t| t.positions.len()).sum(),
            };
            beside.extend(heidenhain_beside(path, files));
            (
                written,
                made_from(crate::kinematics_comp_card(&kc), settings),
            )
        }
    };
    Ok(Exported {
        written,
        card,
        beside,
    })
}

/// The SINUMERIK EEC file of linear axis `axis` or of every linear axis.
fn write_siemens_eec(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    axis: Option<char>,
    settings: &Settings,
) -> Result<(Written, ConventionCard), CompensateError> {
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
    Ok((written, card))
}

/// The SINUMERIK CEC file: every ordered pair of linear axes, or those with input `input`,
/// numbered from 0.
fn write_siemens_cec(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    input: Option<char>,
    settings: &Settings,
) -> Result<(Written, ConventionCard), CompensateError> {
    let machine = model.machine();
    let names = crate::siemens_axis_names(machine);
    let hold = &settings.hold_q;
    let mut tables = crate::siemens_cec_tables(model, coeffs, settings.spacing_mm, hold, &names)?;
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
    Ok((written, card))
}

/// The Fanuc axes of `machine` (numbered X, Y, Z, then A, B, C, as present): all, or `axis`
/// alone with its number.
pub(crate) fn fanuc_axes(
    machine: &Machine,
    axis: Option<char>,
) -> Result<Vec<crate::FanucAxis>, CompensateError> {
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
        .map(|(number, (letter, rotary))| crate::FanucAxis::new(letter, number, rotary))
        .collect())
}

/// The Fanuc record of axis `axis` or of every axis (numbered X, Y, Z, A, B, C as present),
/// and its values table beside it.
fn write_fanuc(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    axis: Option<char>,
    settings: &Settings,
) -> Result<(Written, ConventionCard, PathBuf), CompensateError> {
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
            reversal: reversal_of(settings, fanuc_axis.letter)
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
        c.reversal_source = reversal_of(settings, c.table.axis.letter).map(|(_, source)| source);
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
    Ok((written, card, values))
}

/// The files a Heidenhain writer wrote besides `path`, each said: a table or the card.
fn heidenhain_beside(path: &Path, files: Vec<PathBuf>) -> Vec<(PathBuf, &'static str)> {
    let card = crate::card_path(path);
    files
        .into_iter()
        .filter(|f| f != path)
        .map(|f| {
            let what = if f == card {
                "the convention card: Heidenhain tables take no comments"
            } else {
                "a table the first file names"
            };
            (f, what)
        })
        .collect()
}

/// `card` with what the numbers were made from ([`Settings::made_from`]).
fn made_from(card: ConventionCard, settings: &Settings) -> ConventionCard {
    ConventionCard {
        made_from: settings.made_from.clone(),
        ..card
    }
}

/// Adds `card` to a file's comment note (the writer prefixes each line).
fn append_card(note: &mut String, card: &ConventionCard) {
    note.push('\n');
    note.push_str(card.file_lines("").trim_end());
}

/// Writes `card` beside `path` (`PATH.card.txt`) for a format that takes no comments.
fn write_card_beside(path: &Path, card: &ConventionCard) -> Result<PathBuf, CompensateError> {
    let mut name = path.as_os_str().to_owned();
    name.push(".card.txt");
    let beside = PathBuf::from(name);
    // The file beside it by name: the pair moves together, a folder in the text would not.
    let text = format!(
        "# convention card of {}\n{}",
        path.file_name().unwrap_or_default().to_string_lossy(),
        card.file_lines("")
    );
    crate::write_file(&beside, &text)?;
    Ok(beside)
}

/// The reversal a bidirectional table of `axis` holds and where it comes from: the user's
/// `reversal_um`, else the one an identification found for the axis.
fn reversal_of(settings: &Settings, axis: char) -> Option<(crate::Reversal, String)> {
    if let Some(b) = settings.reversal_um {
        return Some((
            crate::Reversal::constant(b),
            format!("the reversal value given ({b:+} µm)"),
        ));
    }
    settings
        .reversals
        .iter()
        .find(|r| r.axis == axis)
        .map(|r| (r.reversal, r.source.clone()))
}

fn write_pitch_table(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    axis: char,
    format: PitchFormat,
    settings: &Settings,
) -> Result<(Written, ConventionCard), CompensateError> {
    let mut table = crate::pitch_table(model, coeffs, axis, settings.spacing_mm, &settings.hold_q)?;
    let reversal = reversal_of(settings, axis);
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
    match format {
        PitchFormat::LinuxCnc => crate::write_linuxcnc_comp(path, &table)?,
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
    Ok((written, card))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_machine::topology::Reading;

    /// The nominal machine of a topology code, its full ISO error model, coefficients zero.
    fn model(code: &str) -> (MachineModel, Vec<f64>) {
        let m = mtcal_machine::load_machine(code, Reading::FromWorkpiece).unwrap();
        let model = MachineModel::new(m.machine, &m.config).unwrap();
        let coeffs = vec![0.0; model.n_coeffs()];
        (model, coeffs)
    }

    fn settings(model: &MachineModel) -> Settings {
        Settings::new(model.machine(), 100.0, 30.0)
    }

    /// The file at `path` is ASCII and holds the card line `line` (the readers skip it).
    fn assert_card_in(path: &Path, line: &str) {
        let text = std::fs::read_to_string(path).unwrap();
        assert!(text.is_ascii(), "{text}");
        assert!(text.lines().any(|l| l.starts_with(line)), "{line}\n{text}");
    }

    #[test]
    fn what_was_written_is_said_in_one_sentence() {
        let said = |w: Written| w.to_string();
        assert_eq!(
            said(Written::PitchTable {
                format: PitchFormat::LinuxCnc,
                axis: 'X',
                nodes: 13,
                bidirectional: true
            }),
            "linuxcnc pitch table of X, 13 nodes, bidirectional"
        );
        assert_eq!(
            said(Written::Grid { nodes: [5, 4, 3] }),
            "a 5 × 4 × 3 grid of tool-point errors"
        );
        assert_eq!(
            said(Written::Parameters {
                format: ParameterFormat::Etalon,
                tables: 18,
                locations: 3
            }),
            "etalon error parameters: 18 component-error tables, 3 location errors"
        );
        assert_eq!(
            said(Written::TrtPivots {
                kinematics: "xyzac-trt-kins",
                not_representable: 2
            }),
            "HAL settings of LinuxCNC's xyzac-trt-kins; 2 identified errors it cannot hold are \
             listed in it"
        );
    }

    #[test]
    fn each_kind_writes_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let mut s = settings(&model);
        let path = dir.path().join("x.csv");
        let what = Compensation::PitchTable {
            axis: 'X',
            format: PitchFormat::Csv,
        };
        let w = write_compensation(&model, &coeffs, &path, what, &s)
            .unwrap()
            .written;
        let table = crate::read_pitch_csv(&path, 'X').unwrap();
        assert_card_in(&path, "# values are              corrections (-error)");
        assert_eq!(
            w,
            Written::PitchTable {
                format: PitchFormat::Csv,
                axis: 'X',
                nodes: table.len(),
                bidirectional: false
            }
        );
        // A reversal value makes the table bidirectional.
        s.reversal_um = Some(-2.0);
        let path = dir.path().join("x.comp");
        let what = Compensation::PitchTable {
            axis: 'X',
            format: PitchFormat::LinuxCnc,
        };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let w = exported.written;
        // LinuxCNC's file takes no comments: the card is beside it.
        let (beside, _) = exported
            .beside
            .first()
            .cloned()
            .expect("a card file beside the LinuxCNC file");
        let card_text = std::fs::read_to_string(&beside).unwrap();
        assert!(card_text.contains("COMP_FILE_TYPE = 1"), "{card_text}");
        assert!(
            matches!(
                w,
                Written::PitchTable {
                    bidirectional: true,
                    ..
                }
            ),
            "{w:?}"
        );
        assert!(crate::read_linuxcnc_comp(&path, 'X').is_ok());

        let path = dir.path().join("g.csv");
        let w = write_compensation(&model, &coeffs, &path, Compensation::Grid, &s)
            .unwrap()
            .written;
        let grid = crate::read_grid_csv(&path).unwrap();
        assert_card_in(&path, "# values are              errors (actual - nominal)");
        assert_eq!(
            w,
            Written::Grid {
                nodes: [grid.x_mm.len(), grid.y_mm.len(), grid.z_mm.len()]
            }
        );

        let path = dir.path().join("p.txt");
        let what = Compensation::Parameters(ParameterFormat::Etalon);
        let w = write_compensation(&model, &coeffs, &path, what, &s)
            .unwrap()
            .written;
        let read = crate::read_error_parameters(&path, ParameterFormat::Etalon).unwrap();
        assert_card_in(
            &path,
            "// squareness              C0Y > 0 rotates Y's motion",
        );
        let Written::Parameters {
            tables, locations, ..
        } = w
        else {
            panic!("{w:?}")
        };
        assert_eq!(tables + locations, read.params.len());
        assert!(tables > 0);
    }

    #[test]
    fn siemens_files_hold_every_axis_or_the_one_asked_for() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let s = settings(&model);
        let path = dir.path().join("eec.ini");
        let what = Compensation::SiemensEec { axis: None };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let eec = crate::read_siemens_eec(&path, &s.siemens).unwrap();
        let names: Vec<&str> = eec.iter().map(|t| t.axis.as_str()).collect();
        assert_eq!(names, ["X1", "Y1", "Z1"]);
        let expected = Written::ControlTables {
            file: crate::EEC_FILE_NAME,
            tables: 3,
            points: eec.iter().map(|t| t.positions.len()).sum(),
        };
        assert_eq!(exported.written, expected);
        assert_card_in(&path, "; values are");

        let path = dir.path().join("cec.ini");
        let what = Compensation::SiemensCec { input: Some('Y') };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let cec = crate::read_siemens_cec(&path, &s.siemens).unwrap();
        let inputs: Vec<(usize, &str)> = cec
            .iter()
            .map(|t| (t.index, t.input_axis.as_str()))
            .collect();
        assert_eq!(inputs, [(0, "Y1"), (1, "Y1")]);
        assert!(matches!(
            exported.written,
            Written::ControlTables { tables: 2, .. }
        ));
    }

    /// A rotary axis without limits gets a modulo table over 0…360° whose ends are one value;
    /// a limited one a plain table.
    #[test]
    fn siemens_rotary_axes_get_their_positioning_tables() {
        let dir = tempfile::tempdir().unwrap();
        let (model, mut coeffs) = model("CAFYXZ");
        for (k, c) in coeffs.iter_mut().enumerate() {
            *c = 2e-6 * ((k as f64) * 1.3).sin();
        }
        let mut s = settings(&model);
        s.spacing_deg = 25.0;
        let path = dir.path().join("eec.ini");
        let what = Compensation::SiemensEec { axis: None };
        write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let eec = crate::read_siemens_eec(&path, &s.siemens).unwrap();
        let c = eec.iter().find(|t| t.axis == "C1").expect("a table of C");
        assert!(c.is_modulo);
        assert_eq!(c.positions.first(), Some(&0.0));
        assert_eq!(c.positions.last(), Some(&360.0));
        assert_eq!(c.values.first(), c.values.last());
        assert!(c.values.iter().any(|v| v.abs() > 1e-6), "{:?}", c.values);
        let a = eec.iter().find(|t| t.axis == "A1").expect("a table of A");
        assert!(!a.is_modulo);
        // The value is the error: the control's correction −value turns C onto the command;
        // zero at 0° (K3's reference point).
        let table = crate::rotary_table(&model, &coeffs, 'C', 360.0 / 15.0, &s.hold_q).unwrap();
        let error_deg = |p: f64| (-table.correction_at_urad(p) * 1e-6).to_degrees();
        for (p, v) in c.positions.iter().zip(&c.values) {
            let expected_deg = error_deg(*p) - error_deg(0.0);
            assert!(
                (v - expected_deg).abs() < 1e-6,
                "{p}: {v} vs {expected_deg}"
            );
        }
    }

    /// K3 asks for the value 0 at the reference point: each linear axis' table is the
    /// absolute error less its value at `reference_mm` (a constant shift the work offset
    /// absorbs), zero there as the control interpolates it, and the card says where and how
    /// much was removed.
    #[test]
    fn siemens_eec_tables_are_zero_at_the_reference_point() {
        let dir = tempfile::tempdir().unwrap();
        let (model, mut coeffs) = model("ZFYX");
        for (k, c) in coeffs.iter_mut().enumerate() {
            *c = 3e-6 * ((k as f64) * 0.9).cos();
        }
        let mut s = settings(&model);
        s.spacing_mm = 40.0;
        let names = crate::siemens_axis_names(model.machine());
        let absolute =
            crate::siemens_eec_table(&model, &coeffs, 'X', s.spacing_mm, &s.hold_q, &names)
                .unwrap();
        let reference_mm = absolute.positions[1] + 13.0;
        let at = absolute.value_at(reference_mm);
        assert!(
            at.abs() > 1e-4,
            "an error to remove at the reference: {at} mm"
        );
        s.reference_mm = reference_mm;
        let path = dir.path().join("eec.ini");
        let what = Compensation::SiemensEec { axis: Some('X') };
        write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let read = crate::read_siemens_eec(&path, &s.siemens).unwrap();
        assert_eq!(read[0].positions, absolute.positions);
        for (v, a) in read[0].values.iter().zip(&absolute.values) {
            assert!((v - (a - at)).abs() <= 1e-6, "{v} vs {a} − {at}");
        }
        assert!(read[0].value_at(reference_mm).abs() <= 1e-6);
        let text = std::fs::read_to_string(&path).unwrap();
        let said = format!(
            "$AA_ENC_COMP[0,N,X1] zero at {reference_mm} mm ({:+.3} um removed)",
            at * 1e3
        );
        assert!(text.contains(&said), "{said}\n{text}");
    }

    #[test]
    fn a_five_axis_machine_gets_its_swivel_data() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("CAFYXZ");
        let path = dir.path().join("carr.mpf");
        let exported = write_compensation(
            &model,
            &coeffs,
            &path,
            Compensation::SiemensCarr,
            &settings(&model),
        )
        .unwrap();
        let data = crate::read_carr(&path).unwrap();
        assert_eq!(
            exported.written,
            Written::SiemensCarr {
                kind: data.kind.letter(),
                not_representable: 0
            }
        );
        assert_eq!(exported.card.quantity, crate::Quantity::Geometry);
    }

    #[test]
    fn a_fanuc_record_holds_every_axis_numbered_x_y_z_then_rotary() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("CAFYXZ");
        let s = settings(&model);
        let path = dir.path().join("pitch.txt");
        let what = Compensation::Fanuc { axis: None };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let axes: Vec<crate::FanucAxis> = [('X', false), ('Y', false), ('Z', false)]
            .into_iter()
            .chain([('A', true), ('C', true)])
            .zip(1..)
            .map(|((letter, rotary), n)| crate::FanucAxis::new(letter, n, rotary))
            .collect();
        let tables = crate::read_fanuc_parameters(&path, &s.fanuc, &axes).unwrap();
        assert_eq!(tables.len(), 5);
        let (values, _) = exported.beside[0].clone();
        assert_card_in(&values, "# values are");
        let Written::ControlTables { tables: n, .. } = exported.written else {
            panic!("{:?}", exported.written)
        };
        assert_eq!(n, 5);
        // One axis alone keeps its number.
        let what = Compensation::Fanuc { axis: Some('Z') };
        write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let z = crate::read_fanuc_parameters(&path, &s.fanuc, &axes[2..3]).unwrap();
        assert_eq!(z[0].axis.number, 3);
    }

    #[test]
    fn heidenhain_files_come_as_a_set_with_their_card() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let s = settings(&model);
        let path = dir.path().join("CONFIG.CMA");
        let exported =
            write_compensation(&model, &coeffs, &path, Compensation::HeidenhainCom, &s).unwrap();
        let set = crate::read_heidenhain_com(&path).unwrap();
        let names: Vec<String> = exported
            .beside
            .iter()
            .map(|(p, _)| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["X.COM", "Y.COM", "Z.COM", "CONFIG.CMA.card.txt"]);
        assert_eq!(
            exported.written,
            Written::ControlFiles {
                what: "Heidenhain .CMA and .COM tables",
                files: 5,
                tables: set.tables.len(),
                points: set.total_points()
            }
        );

        let (five_axis, coeffs) = self::model("CAFYXZ");
        let path = dir.path().join("KC.TAB");
        let what = Compensation::HeidenhainKinematicsComp;
        let s = settings(&five_axis);
        let exported = write_compensation(&five_axis, &coeffs, &path, what, &s).unwrap();
        let kc = crate::read_kinematics_comp(&path).unwrap();
        let Written::ControlFiles { tables, .. } = exported.written else {
            panic!("{:?}", exported.written)
        };
        assert_eq!(tables, kc.tables.len());
        assert!(
            exported
                .beside
                .iter()
                .any(|(p, _)| p.ends_with("KC.TAB.card.txt"))
        );
    }

    #[test]
    fn a_machine_without_table_table_kinematics_has_no_pivots_and_nothing_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let path = dir.path().join("pivots.hal");
        let w = write_compensation(
            &model,
            &coeffs,
            &path,
            Compensation::TrtPivots,
            &settings(&model),
        );
        assert!(w.is_err(), "{w:?}");
        assert!(!path.exists());
    }

    #[test]
    fn a_rotary_axis_has_no_pitch_table() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("CAFYXZ");
        let what = Compensation::PitchTable {
            axis: 'C',
            format: PitchFormat::Csv,
        };
        let path = dir.path().join("c.csv");
        let e = write_compensation(&model, &coeffs, &path, what, &settings(&model)).unwrap_err();
        assert!(
            matches!(e, CompensateError::NotLinear { letter: 'C' }),
            "{e}"
        );
        assert!(!path.exists());
    }
}
