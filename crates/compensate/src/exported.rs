//! What writing or checking a compensation file gives back: what was written ([`Written`],
//! whose `Display` is the sentence the command prints), the convention card and the files
//! beside it ([`Exported`]), what a checked file holds ([`Checked`]); and the card helpers the
//! formats share.

use crate::parameters::ParameterFormat;
use crate::settings::Settings;
use crate::{CompensateError, PitchFormat};
use mtcal_machine::card::ConventionCard;
use std::fmt;
use std::path::{Path, PathBuf};

/// What a format wrote, in one sentence (its `Display`, which the command prints). The
/// built-in files have their own variants; any other format says what it wrote with
/// [`Written::ControlTables`] (one file) or [`Written::ControlFiles`] (a set), so a new format
/// needs no variant here.
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

/// What a format wrote ([`crate::Request::write`]) and what its numbers mean.
#[derive(Clone, Debug, PartialEq)]
pub struct Exported {
    pub written: Written,
    /// The file's convention card (also written in the file where the format has comments).
    pub card: ConventionCard,
    /// Files written beside the first (tables, or the card when the format takes no
    /// comments): where, and what each holds.
    pub beside: Vec<(PathBuf, &'static str)>,
}

/// What a file that passed its checks holds ([`crate::Request::check`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Checked {
    /// Tables (or parameters for a parameter file, records for swivel data).
    pub tables: usize,
    /// Interpolation points in all tables.
    pub points: usize,
}

impl fmt::Display for Checked {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} tables, {} points", self.tables, self.points)
    }
}

/// `card` with what the numbers were made from ([`Settings::made_from`]).
pub(crate) fn made_from(card: ConventionCard, settings: &Settings) -> ConventionCard {
    ConventionCard {
        made_from: settings.made_from.clone(),
        ..card
    }
}

/// Adds `card` to a file's comment note (the writer prefixes each line).
pub(crate) fn append_card(note: &mut String, card: &ConventionCard) {
    note.push('\n');
    note.push_str(card.file_lines("").trim_end());
}

/// Writes `card` beside `path` (`PATH.card.txt`) for a format that takes no comments.
pub(crate) fn write_card_beside(
    path: &Path,
    card: &ConventionCard,
) -> Result<PathBuf, CompensateError> {
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
