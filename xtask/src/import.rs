//! `cargo xtask import`: an instrument's own export into a session run (crates/import).

use anyhow::Result;
use clap::ValueEnum;
use mtcal_import::{Format, ImportOptions};
use std::io::Write;
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum FormatArg {
    /// ISO 230-2 KEY=VALUE tables of the EPICS ecmc test tools (`*_ISO230.dat`).
    EcmcDat,
    /// API XD laser linear data (`.pos`, tab-separated).
    ApiPos,
    /// Renishaw CARTO dynamic capture (`.rtx`).
    RenishawRtx,
}

impl From<FormatArg> for Format {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::EcmcDat => Format::EcmcDat,
            FormatArg::ApiPos => Format::ApiPos,
            FormatArg::RenishawRtx => Format::RenishawRtx,
        }
    }
}

#[derive(Debug, clap::Args)]
pub struct ImportArgs {
    /// The export's format.
    format: FormatArg,
    /// The instrument's file (read, never modified).
    file: PathBuf,
    /// The session folder; created with its session.toml when it has none.
    #[arg(long)]
    session: PathBuf,
    /// The machine of a new session: a URDF file or a topology code.
    #[arg(long)]
    machine: Option<String>,
    /// The measured linear axis (default: the axis the file names).
    #[arg(long)]
    axis: Option<char>,
    /// The run's name and CSV file stem (default: the file's stem).
    #[arg(long)]
    name: Option<String>,
    /// The other axes' positions, e.g. Y=0,Z=-200 (mm / degrees; default 0).
    #[arg(long)]
    hold: Option<String>,
}

/// Imports the file and prints what was read and the `[[run]]` written.
pub fn run(args: ImportArgs, stdout: &mut dyn Write) -> Result<()> {
    crate::check_paths(&[], &[&args.session])?;
    let imported = mtcal_import::import(&ImportOptions {
        format: args.format.into(),
        file: &args.file,
        session: &args.session,
        machine: args.machine.as_deref(),
        axis: args.axis,
        name: args.name.as_deref(),
        hold: args.hold.as_deref(),
    })?;
    write!(stdout, "{}", imported.summary())?;
    Ok(())
}
