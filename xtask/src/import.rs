//! `cargo xtask import`: an instrument's own export into a session run (crates/import).

use anyhow::{Result, bail};
use clap::ValueEnum;
use mtcal_import::{Format, ImportOptions, StreamOptions};
use std::io::Write;
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// ISO 230-2 KEY=VALUE tables of the EPICS ecmc test tools (`*_ISO230.dat`).
    EcmcDat,
    /// API XD laser linear data (`.pos`, tab-separated).
    ApiPos,
    /// Renishaw CARTO dynamic capture (`.rtx`).
    RenishawRtx,
    /// An R-test head's continuous stream (CSV t,dx,dy,dz) with the NC program that drove
    /// the cycle (--program) and the context log (--log): one rtest run per ball of the
    /// session (docs/VOLUMETRIC.md).
    RtestStream,
}

impl FormatArg {
    /// The laser export format, or `None` for the stream.
    fn laser_format(self) -> Option<Format> {
        match self {
            FormatArg::EcmcDat => Some(Format::EcmcDat),
            FormatArg::ApiPos => Some(Format::ApiPos),
            FormatArg::RenishawRtx => Some(Format::RenishawRtx),
            FormatArg::RtestStream => None,
        }
    }
}

#[derive(Debug, clap::Args)]
pub struct ImportArgs {
    /// The export's format.
    format: FormatArg,
    /// The instrument's file (read, never modified); for rtest-stream the stream CSV.
    file: PathBuf,
    /// The session folder; created with its session.toml when it has none (rtest-stream:
    /// it must exist and declare the machine and the balls).
    #[arg(long)]
    session: PathBuf,
    /// The machine of a new session: a URDF file or a topology code.
    #[arg(long)]
    machine: Option<String>,
    /// The measured linear axis (default: the axis the file names).
    #[arg(long)]
    axis: Option<char>,
    /// The run's name and CSV file stem (default: the file's stem); for rtest-stream a prefix
    /// of the run names, `<name>-<ball>` (default: the set-up names).
    #[arg(long)]
    name: Option<String>,
    /// The other axes' positions, e.g. Y=0,Z=-200 (mm / degrees; default 0).
    #[arg(long)]
    hold: Option<String>,
    /// rtest-stream: the NC program that drove the measuring cycle (G-code).
    #[arg(long)]
    program: Option<PathBuf>,
    /// rtest-stream: the context log, CSV t[,S][,T_<name>…] (default: no context columns).
    #[arg(long)]
    log: Option<PathBuf>,
    /// rtest-stream: cycles (numbered from 1) written as validation runs <ball>-c<k>, e.g. 3,7.
    #[arg(long, value_delimiter = ',')]
    validate_cycles: Vec<usize>,
}

/// Imports the file and prints what was read and the `[[run]]` written.
pub fn run(args: ImportArgs, stdout: &mut dyn Write) -> Result<()> {
    crate::check_paths(&[], &[&args.session])?;
    let Some(format) = args.format.laser_format() else {
        return run_stream(args, stdout);
    };
    refuse_unused(
        &args,
        &[
            ("--program", "", args.program.is_some()),
            ("--log", "", args.log.is_some()),
            ("--validate-cycles", "", !args.validate_cycles.is_empty()),
        ],
    )?;
    let imported = mtcal_import::import(&ImportOptions {
        format,
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

/// `rtest-stream`: the stream, the program and the log into per-ball runs; prints the card.
fn run_stream(args: ImportArgs, stdout: &mut dyn Write) -> Result<()> {
    refuse_unused(
        &args,
        &[
            (
                "--machine",
                " (the session names it)",
                args.machine.is_some(),
            ),
            ("--axis", "", args.axis.is_some()),
            (
                "--hold",
                " (the program commands the axes)",
                args.hold.is_some(),
            ),
        ],
    )?;
    let Some(program) = &args.program else {
        bail!("rtest-stream needs --program: the NC program that drove the measuring cycle");
    };
    let imported = mtcal_import::import_stream(&StreamOptions {
        stream: &args.file,
        program,
        log: args.log.as_deref(),
        session: &args.session,
        validate_cycles: &args.validate_cycles,
        name: args.name.as_deref(),
    })?;
    write!(stdout, "{}", imported.card())?;
    Ok(())
}

/// Refuses the options given that the format does not use: `(option, why, given)`.
fn refuse_unused(args: &ImportArgs, options: &[(&str, &str, bool)]) -> Result<()> {
    if let Some((option, why, _)) = options.iter().find(|(_, _, given)| *given) {
        let format = args
            .format
            .to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_string());
        bail!("{option} does not apply to `import {format}`{why}");
    }
    Ok(())
}
