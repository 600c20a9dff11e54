//! Instrument exports to mtcal session runs (`cargo xtask import FORMAT FILE --session DIR`).
//!
//! Each reader turns one third-party file into a [`Recording`]: the deviations of one linear
//! axis in the order they were recorded. [`import`] writes it as a run CSV of the session
//! (`t`, every machine axis, the reading in µm, context columns) and appends its `[[run]]` to
//! `session.toml` through `mtcal_session::write_session`, creating the session when it has no
//! manifest yet (then a machine is required). Nothing is written unless everything was read
//! and checked; a manifest that fails to write takes its new run file back out.
//!
//! No importer names an instrument: the plugin whose runs a format's files hold declares that
//! capability (`mtcal_instrument::capability`) with its name, set-up keys and reading columns,
//! and the importer asks for it — positioning runs here (the laser's `d`, its own set-up
//! `mode = "linear"`, `direction` = the axis), circle runs for `.b5r`, point visits for the
//! R-test stream.
//!
//! Formats (what is read, the sign and unit conventions, what is assumed: docs/FORMATS.md,
//! "Imports"):
//! - [`Format::EcmcDat`] — the EPICS ecmc ISO 230-2 input table (`ecmc`);
//! - [`Format::ApiPos`] — API XD laser linear data (`api_pos`);
//! - [`Format::RenishawRtx`] — Renishaw CARTO dynamic capture (`rtx`).
//!
//! [`import_b5r`] (`renishaw-b5r`, module `b5r`) reads Renishaw QC10/QC20 ball-bar runs
//! (`.b5r`, XML), several files at once, into ball-bar runs: the axes along the circle in the
//! plane the file names, `dr` in µm, a set-up per plane (pivot at the circle's centre, length =
//! radius), the software's `RENISHAW_DIAGNOSTICS` kept in each run's `[run.b5r]` table, and a
//! card of what was read and what was assumed ([`B5rImported::card`]).
//!
//! [`import_stream`] (`rtest-stream`) is of another kind: an R-test head's continuous stream,
//! the NC program that drove the measuring cycle and a context log become the per-visit
//! session of docs/VOLUMETRIC.md, one R-test run per ball (`rtest_stream`, with the program's
//! reader `nc_dwells` and the stream's cutting `plateaus`).
//!
//! Errors name the file, the line and column (text), the byte offset (binary) or the time (a
//! stream that does not follow its program) and what was expected; no reader panics or yields
//! a non-finite number.

mod api_pos;
mod b5r;
mod csv_rows;
mod ecmc;
pub mod nc_dwells;
pub mod plateaus;
mod recording;
pub mod rtest_stream;
mod rtx;
mod session;
mod text;

use std::path::{Path, PathBuf};

pub use api_pos::read_pos;
pub use b5r::{
    B5rFile, B5rImported, B5rOptions, B5rPlane, B5rRun, B5rWritten, Feature, FeatureValue,
    ReadingUnit, import_b5r, read_b5r,
};
pub use ecmc::read_dat;
pub use recording::Recording;
pub use rtest_stream::{StreamImported, StreamOptions, import_stream};
pub use rtx::read_rtx;

/// The instrument exports [`import`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// `ecmc-dat`: ISO 230-2 `KEY=VALUE` input tables of the EPICS ecmc test tools.
    EcmcDat,
    /// `api-pos`: API XD laser linear data `.pos` (tab-separated text).
    ApiPos,
    /// `renishaw-rtx`: Renishaw CARTO dynamic capture `.rtx` (binary samples).
    RenishawRtx,
}

impl Format {
    /// Every format, in the order the command line lists them.
    pub const ALL: [Format; 3] = [Format::EcmcDat, Format::ApiPos, Format::RenishawRtx];

    /// The name the command line uses.
    pub fn name(self) -> &'static str {
        match self {
            Format::EcmcDat => "ecmc-dat",
            Format::ApiPos => "api-pos",
            Format::RenishawRtx => "renishaw-rtx",
        }
    }

    /// Reads `file` in this format.
    pub fn read(self, file: &Path) -> Result<Recording, ImportError> {
        match self {
            Format::EcmcDat => read_dat(file),
            Format::ApiPos => read_pos(file),
            Format::RenishawRtx => read_rtx(file),
        }
    }
}

/// Why an import wrote nothing.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The text file could not be read, or is not UTF-8 (located).
    #[error(transparent)]
    Read(#[from] mtcal_located::ReadError),
    /// A binary file could not be read.
    #[error("{}: cannot read: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// Text contents wrong at a line and column: what was expected, what was found.
    #[error(transparent)]
    Invalid(#[from] mtcal_located::Located),
    /// A stream or log that does not fit the program or the session, at a time (s) on the
    /// session's clock: what was expected, what was found.
    #[error("{}: t = {t_s} s: {message}", path.display())]
    AtTime {
        path: PathBuf,
        t_s: f64,
        message: String,
    },
    /// Binary contents wrong at a byte offset (0-based).
    #[error("{}: byte {offset}: {message}", path.display())]
    Binary {
        path: PathBuf,
        offset: usize,
        message: String,
    },
    /// The session could not be read or the run not written.
    #[error(transparent)]
    Session(#[from] mtcal_session::SessionError),
    /// The machine the session names (or `--machine`) does not load.
    #[error("cannot load machine `{machine}`: {cause}")]
    Machine {
        machine: String,
        cause: Box<mtcal_machine::LoadError>,
    },
    /// The options do not fit the file or the session (an axis the machine lacks, a run
    /// that exists, no machine for a new session).
    #[error("{0}")]
    Options(String),
    /// The run and the manifest could not both be written; neither was.
    #[error(transparent)]
    Output(#[from] mtcal_located::OutputError),
    /// No linked instrument plugin (or more than one) records the runs the format holds.
    #[error(transparent)]
    Instrument(#[from] mtcal_plugins::capability::CapabilityError),
}

/// What to import, and into which session.
#[derive(Debug, Clone)]
pub struct ImportOptions<'a> {
    pub format: Format,
    pub file: &'a Path,
    /// The session folder; created with its manifest when it has no `session.toml`.
    pub session: &'a Path,
    /// A URDF path (relative to the current folder) or a topology code; required for a new
    /// session, refused for an existing one (its manifest names the machine).
    pub machine: Option<&'a str>,
    /// The measured axis; default the axis the file names.
    pub axis: Option<char>,
    /// The run's name (and CSV file stem); default the input's file stem.
    pub name: Option<&'a str>,
    /// The other axes' positions, `Y=0,Z=-200` (mm / degrees; default 0); for a capture
    /// without positions, also the measured axis' position.
    pub hold: Option<&'a str>,
}

/// What [`import`] read and wrote.
#[derive(Debug, Clone)]
pub struct Imported {
    pub recording: Recording,
    pub axis: char,
    pub run_name: String,
    pub run_file: PathBuf,
    pub manifest: PathBuf,
    /// Whether the session (its manifest) was created.
    pub created: bool,
    /// The `[[run]]` entry written, as TOML.
    pub entry: String,
}

impl Imported {
    /// A short summary for the command line: what was read and the entry written.
    pub fn summary(&self) -> String {
        let r = &self.recording;
        let mut out = format!(
            "read axis {}: {} targets, {} cycles, {} samples ({} in the file; written mm and um)\n",
            self.axis,
            r.targets,
            r.cycles,
            r.len(),
            r.unit
        );
        let verb = if self.created {
            "created"
        } else {
            "appended to"
        };
        out.push_str(&format!(
            "wrote {} and {verb} {}:\n{}",
            self.run_file.display(),
            self.manifest.display(),
            self.entry
        ));
        out
    }
}

/// Reads `options.file` and writes it into the session as one positioning run (a laser's).
pub fn import(options: &ImportOptions<'_>) -> Result<Imported, ImportError> {
    let recording = options.format.read(options.file)?;
    session::write(options, recording)
}
