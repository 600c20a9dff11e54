//! Measurement sessions: the `session.toml` manifest and the run CSV files (FORMATS.md,
//! "Measurement session", contract v1).
//!
//! This crate reads and writes the files and checks everything that can be checked without
//! knowing an instrument's physics or the machine's kinematics. Callers say which reading
//! columns an instrument has ([`RunColumns`]); the instrument plugins interpret set-ups and
//! readings.
//!
//! # The session folder
//!
//! A folder with `session.toml` and one CSV file per run:
//!
//! ```toml
//! machine = "machine.urdf"     # relative to session.toml, or a topology code ("wCAFYXZt")
//!
//! [setup.ball1]                # a shared set-up; keys are the instrument's
//! ball = [150.0, 0.0, 50.0]
//!
//! [[run]]
//! name = "rtest-xyc-a0"        # unique; also a file name, so no '/', '\' or leading '.'
//! instrument = "rtest"         # plugin name
//! file = "rtest-xyc-a0.csv"    # relative to the folder, inside it
//! use = "fit"                  # "fit" (default) or "validate"
//! setup = "ball1"              # a shared set-up, or instead its own table:
//! # [run.setup]
//! # ball = [250.0, 0.0, 100.0]
//! sigma_um = 0.5               # any other key is kept in `RunSpec::extra` for the plugin
//! ```
//!
//! The manifest has the top-level keys `machine` (required), `setup` (optional, a table of
//! named set-up tables) and `run` (at least one `[[run]]`); any other top-level key is an error,
//! so a misspelt key never passes silently. A run has `name`, `instrument` and `file`
//! (required, non-empty strings), `use` and either `setup = "<name>"` naming a `[setup.<name>]`
//! or its own `[run.setup]` table (or neither: an empty set-up), never both. Run names are
//! unique. A run's `file` is a relative path without `..` components, and after resolving
//! symbolic links it must lie inside the session folder; it must exist. `machine` is resolved
//! relative to the manifest when it names an existing file or ends in `.urdf`
//! ([`Session::machine_path`]); otherwise it is taken as a topology code.
//!
//! # Run files
//!
//! ```text
//! t,X,Y,Z,C,dx,dy,dz,T_spindle
//! 0.0,250.0,0.0,100.0,0.0,0.12,-0.4,1.03,21.5
//! 0.5,249.9,7.85,100.0,1.8,0.10,-0.38,1.01,21.5
//! ```
//!
//! - A header row, then at least one row. `,` separates fields, `.` is the decimal separator;
//!   fields may be quoted and are trimmed of surrounding blanks.
//! - Columns, in any order, each at most once: `t` (seconds since the session started, strictly
//!   increasing), one column per machine axis letter (mm for `X Y Z U V W`, degrees for
//!   `A B C`), the instrument's reading columns (µm or µrad as the instrument documents), and
//!   optional context columns `T_<name>` (°C), `S` (rpm), `F` (mm/min). Any other column is an
//!   error that lists the allowed ones.
//! - A fitted run has all of its instrument's reading columns. A validation run
//!   ([`RunColumns::readings_optional`]) has all of them or none ([`RunTable::values`] is then
//!   `None`), never some.
//! - Every field is a finite number. `NaN` and infinities are rejected ("NaN is not a
//!   measurement; leave the row out"), as are decimal commas (`"1,5"`) and files separated by
//!   `;`.
//! - Accepted quietly: a UTF-8 byte-order mark (stripped), CRLF line ends, blank lines
//!   (skipped, e.g. at the end of the file).
//!
//! [`write_run`] writes the same format (`\n` line ends, the shortest decimal that reads back to
//! the same `f64`, exponent form for very small and very large magnitudes), so reading a
//! written table gives it back bit for bit. Both writers replace files atomically (a temporary
//! file in the same folder, then a rename) and refuse to write what the readers would reject.
//!
//! # Errors
//!
//! Every [`SessionError`] about a file's contents starts with `path:line:column:`, then says what
//! was expected and what was found, and [`SessionError::location`] returns the position. Lines
//! and columns are 1-based. In `session.toml` the column counts characters; a problem with a
//! run as a whole (a missing key, a missing file) points at its value or its `[[run]]` header.
//! In a run file the column is the field number and the message names the column by its header
//! (`run1.csv:17:3: column "Y": expected a position in mm, found "1,5" with a decimal comma`);
//! problems with the header as a whole point at line 1, column 1. A byte that is not UTF-8
//! is located by its character column in either file. Nothing here panics on bad input.

mod column;
mod error;
mod manifest;
mod run;

pub use column::{Column, Columns, Scale, Storage};
pub use error::{Location, SessionError};
pub use manifest::{
    MANIFEST_NAME, Manifest, ManifestRun, RUN_KEYS, RunSpec, RunUse, Session, SetupRef, TOP_KEYS,
    load_session, load_session_to_extend, session_text, write_session,
};
pub use run::{
    CONTEXT_COLUMNS, RunColumns, RunTable, parse_run, read_run, row_line, run_text, write_run,
};

use std::path::Path;

/// The UTF-8 text of a file, without a leading byte-order mark.
fn text_of(path: &Path, bytes: Vec<u8>) -> Result<String, SessionError> {
    match mtcal_located::Source::from_bytes(path, bytes) {
        Ok(source) => Ok(source.text),
        Err(mtcal_located::ReadError::NotText(e)) => Err(SessionError::invalid(e.at, e.message)),
        Err(mtcal_located::ReadError::Io {
            path,
            cause: source,
        }) => Err(SessionError::read(&path, source)),
    }
}
