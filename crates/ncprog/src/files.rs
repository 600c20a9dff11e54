//! NC programs and CL data read from files, and what goes wrong with them named by the file:
//! `prog.nc:5:4: expected …, found …`, as every located message of mtcal.

use crate::cl::{AxisPositionsError, ClData};
use crate::correct::{CorrectError, CorrectOptions, Correction, correct_program};
use crate::gcode::{Decimals, Program};
use crate::offset::{OffsetError, offset_program};
use mtcal_kinematics::MachineModel;
use std::path::{Path, PathBuf};

/// What went wrong with an NC program or CL data file.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// `what`: `NC program` or `CL data`.
    #[error("cannot read {what} {}", path.display())]
    Read {
        what: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}:{column}: expected {expected}, found {found}", path.display())]
    At {
        path: PathBuf,
        line: usize,
        column: usize,
        expected: &'static str,
        found: String,
    },
    /// A correction refused at one place of the program; `message` without its location.
    #[error(
        "{}:{line}{}: {message}",
        path.display(),
        column.map_or(String::new(), |c| format!(":{c}"))
    )]
    CorrectAt {
        path: PathBuf,
        line: usize,
        column: Option<usize>,
        message: String,
    },
    /// A correction refused for the whole program.
    #[error("cannot correct {}: {error}", path.display())]
    Correct { path: PathBuf, error: CorrectError },
    #[error("cannot offset {}", path.display())]
    Offset {
        path: PathBuf,
        #[source]
        source: OffsetError,
    },
    #[error("{}: {failures}", path.display())]
    NoAxisPositions {
        path: PathBuf,
        failures: AxisPositionsError,
    },
    #[error("the CL data has no points")]
    NoPoints,
}

impl FileError {
    /// The error at `line`, `column` of the file `path`.
    pub(crate) fn at(
        path: &Path,
        line: usize,
        column: usize,
        expected: &'static str,
        found: &str,
    ) -> Self {
        FileError::At {
            path: path.to_path_buf(),
            line,
            column,
            expected,
            found: found.to_string(),
        }
    }

    /// `error` of correcting the program `path`: located in the file when it is about one
    /// place.
    fn correct(path: &Path, error: CorrectError) -> Self {
        match error.location() {
            Some((line, column)) => FileError::CorrectAt {
                path: path.to_path_buf(),
                line,
                column,
                message: error.message(),
            },
            None => FileError::Correct {
                path: path.to_path_buf(),
                error,
            },
        }
    }
}

fn read_text(path: &Path, what: &'static str) -> Result<String, FileError> {
    std::fs::read_to_string(path).map_err(|source| FileError::Read {
        what,
        path: path.to_path_buf(),
        source,
    })
}

/// The NC program in the file `path`, parsed.
pub fn read_program(path: &Path) -> Result<Program, FileError> {
    let text = read_text(path, "NC program")?;
    Program::parse(&text).map_err(|e| FileError::at(path, e.line, e.column, e.expected, &e.found))
}

/// The CL data in the file `path`, parsed.
pub fn read_cl(path: &Path) -> Result<ClData, FileError> {
    let text = read_text(path, "CL data")?;
    ClData::parse(&text).map_err(|e| FileError::at(path, e.line, e.column, e.expected, &e.found))
}

/// The program in the file `path` corrected ([`correct_program`]).
pub fn correct_file(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    options: &CorrectOptions,
) -> Result<Correction, FileError> {
    let program = read_program(path)?;
    correct_program(model, coeffs, &program, options).map_err(|e| FileError::correct(path, e))
}

/// The text of the program in the file `path` offset by `offset_mm` ([`offset_program`]).
pub fn offset_file(path: &Path, offset_mm: [f64; 3]) -> Result<String, FileError> {
    let program = read_program(path)?;
    offset_program(&program, offset_mm, Decimals::default()).map_err(|source| FileError::Offset {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The message with its causes, as the command line prints it.
    fn said(e: &dyn std::error::Error) -> String {
        let mut s = e.to_string();
        let mut cause = e.source();
        while let Some(c) = cause {
            s.push_str(&format!(": {c}"));
            cause = c.source();
        }
        s
    }

    #[test]
    fn files_are_read_and_their_errors_located() {
        let dir = tempfile::tempdir().unwrap();
        let nc = dir.path().join("p.nc");
        std::fs::write(&nc, "G90 G21\nG1 X1 Y2 Z3\n").unwrap();
        assert_eq!(read_program(&nc).unwrap().lines.len(), 2);
        std::fs::write(&nc, "G90\nG1 X1 Y2 Z3 &\n").unwrap();
        let e = read_program(&nc).unwrap_err();
        let FileError::At { line, column, .. } = &e else {
            panic!("{e}")
        };
        assert_eq!((*line, *column), (2, 13));
        assert!(
            said(&e).starts_with(&format!("{}:2:13: expected ", nc.display())),
            "{e}"
        );

        let cl = dir.path().join("path.csv");
        std::fs::write(&cl, "x,y,z\n1,2,3\n4,5,6\n").unwrap();
        assert_eq!(read_cl(&cl).unwrap().points.len(), 2);
        std::fs::write(&cl, "x,y,z\n1,2\n").unwrap();
        let e = read_cl(&cl).unwrap_err();
        assert!(said(&e).starts_with(&format!("{}:2:", cl.display())), "{e}");

        let missing = dir.path().join("none.nc");
        let e = read_program(&missing).unwrap_err();
        let text = said(&e);
        assert!(
            text.starts_with(&format!("cannot read NC program {}: ", missing.display())),
            "{text}"
        );
        assert!(said(&read_cl(&missing).unwrap_err()).starts_with("cannot read CL data "));
    }

    #[test]
    fn correction_errors_are_located_in_the_file_when_they_are_about_one_place() {
        let path = Path::new("dir/p.nc");
        let at = FileError::correct(path, CorrectError::Arc { line: 7 });
        assert_eq!(
            at.to_string(),
            "dir/p.nc:7: arcs (G2/G3) are not corrected; linearise them into G1 moves"
        );
        let e = CorrectError::BeyondLimit {
            line: 3,
            column: 4,
            letter: 'X',
            value: 900.0,
            lo: -300.0,
            hi: 300.0,
            unit: "mm",
        };
        assert!(
            FileError::correct(path, e)
                .to_string()
                .starts_with("dir/p.nc:3:4: expected X within the axis limits"),
        );
        assert_eq!(
            FileError::correct(path, CorrectError::NoMotion).to_string(),
            "cannot correct dir/p.nc: the program has no motion: expected G0/G1 lines with axis \
             words"
        );
    }
}
