//! `cargo xtask import`: an instrument's own export into a session run (crates/import).

use anyhow::{Result, bail};
use clap::ValueEnum;
use mtcal_import::{B5rOptions, Format, ImportOptions, ReadingUnit, StreamOptions};
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
    /// Renishaw QC10/QC20 ball-bar runs (`.b5r`, XML; several files, e.g. the clockwise and
    /// counter-clockwise run of each plane): ballbar runs with a card of what was read and
    /// what was assumed (docs/FORMATS.md, "Imports").
    RenishawB5r,
    /// An R-test head's continuous stream (CSV t,dx,dy,dz) with the NC program that drove
    /// the cycle (--program) and the context log (--log): one rtest run per ball of the
    /// session (docs/VOLUMETRIC.md).
    RtestStream,
}

impl FormatArg {
    /// The laser export format, or `None` for the ball-bar files and the stream.
    fn laser_format(self) -> Option<Format> {
        match self {
            FormatArg::EcmcDat => Some(Format::EcmcDat),
            FormatArg::ApiPos => Some(Format::ApiPos),
            FormatArg::RenishawRtx => Some(Format::RenishawRtx),
            FormatArg::RenishawB5r | FormatArg::RtestStream => None,
        }
    }
}

#[derive(Debug, clap::Args)]
pub struct ImportArgs {
    /// The export's format.
    format: FormatArg,
    /// The instrument's file (read, never modified); for rtest-stream the stream CSV; for
    /// renishaw-b5r one or several .b5r files.
    #[arg(required = true, num_args = 1..)]
    files: Vec<PathBuf>,
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
    /// of the run names, `<name>-<ball>` (default: the set-up names); for renishaw-b5r a
    /// prefix, `<name>-<plane>-<cw|ccw>` (default: each file's stem, with -cw/-ccw when a
    /// file holds both runs).
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
    /// renishaw-b5r: the axis positions at the circle's centre, e.g. X=0,Y=0,Z=-200 (mm /
    /// degrees; default 0; rotary axes are held there).
    #[arg(long)]
    center: Option<String>,
    /// renishaw-b5r: the circle's radius = the bar's nominal length, mm (default: the file's
    /// NOMINAL_LENGTH).
    #[arg(long)]
    radius_mm: Option<f64>,
    /// renishaw-b5r: the unit of the raw readings, um, mm or nm (default: READINGS' DT
    /// attribute, else um).
    #[arg(long, value_parser = parse_unit)]
    reading_unit: Option<ReadingUnit>,
    /// renishaw-b5r: the angle of the first reading of the measured arc, degrees from +A
    /// towards +B (default 0).
    #[arg(long, allow_hyphen_values = true)]
    start_deg: Option<f64>,
    /// renishaw-b5r: the measured arc, degrees (default 360; a partial arc, e.g. 220).
    #[arg(long)]
    sweep_deg: Option<f64>,
    /// renishaw-b5r: the overshoot arcs the readings include before and after the measured
    /// arc, degrees (default 0).
    #[arg(long)]
    overshoot_deg: Option<f64>,
    /// renishaw-b5r: the angle between readings, degrees (default (sweep + 2 × overshoot) /
    /// number of readings).
    #[arg(long)]
    step_deg: Option<f64>,
    /// renishaw-b5r: the feed, mm/min (default: the file's PROGRAMMED_FEEDRATE; without one
    /// the readings are 1 s apart).
    #[arg(long)]
    feed: Option<f64>,
}

fn parse_unit(s: &str) -> Result<ReadingUnit, String> {
    ReadingUnit::parse(s).ok_or_else(|| format!("expected um, mm or nm, found `{s}`"))
}

/// Imports the file and prints what was read and the `[[run]]` written.
pub fn run(args: ImportArgs, stdout: &mut dyn Write) -> Result<()> {
    crate::check_paths(&[], &[&args.session])?;
    if args.format == FormatArg::RenishawB5r {
        return run_b5r(args, stdout);
    }
    refuse_unused(
        &args,
        &[
            ("--center", "", args.center.is_some()),
            ("--radius-mm", "", args.radius_mm.is_some()),
            ("--reading-unit", "", args.reading_unit.is_some()),
            ("--start-deg", "", args.start_deg.is_some()),
            ("--sweep-deg", "", args.sweep_deg.is_some()),
            ("--overshoot-deg", "", args.overshoot_deg.is_some()),
            ("--step-deg", "", args.step_deg.is_some()),
            ("--feed", "", args.feed.is_some()),
        ],
    )?;
    let file = match args.files.as_slice() {
        [file] => file.clone(),
        _ => {
            let format = format_name(&args);
            bail!("`import {format}` reads one file; give one at a time");
        }
    };
    let Some(format) = args.format.laser_format() else {
        return run_stream(args, &file, stdout);
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
        file: &file,
        session: &args.session,
        machine: args.machine.as_deref(),
        axis: args.axis,
        name: args.name.as_deref(),
        hold: args.hold.as_deref(),
    })?;
    write!(stdout, "{}", imported.summary())?;
    Ok(())
}

/// `renishaw-b5r`: ball-bar runs into the session; prints the card.
fn run_b5r(args: ImportArgs, stdout: &mut dyn Write) -> Result<()> {
    refuse_unused(
        &args,
        &[
            ("--axis", " (the file names its plane)", args.axis.is_some()),
            (
                "--hold",
                " (the axes follow the circle; give its centre with --center)",
                args.hold.is_some(),
            ),
            ("--program", "", args.program.is_some()),
            ("--log", "", args.log.is_some()),
            ("--validate-cycles", "", !args.validate_cycles.is_empty()),
        ],
    )?;
    let imported = mtcal_import::import_b5r(&B5rOptions {
        files: &args.files,
        session: &args.session,
        machine: args.machine.as_deref(),
        name: args.name.as_deref(),
        center: args.center.as_deref(),
        radius_mm: args.radius_mm,
        reading_unit: args.reading_unit,
        start_deg: args.start_deg,
        sweep_deg: args.sweep_deg,
        overshoot_deg: args.overshoot_deg,
        step_deg: args.step_deg,
        feed_mm_per_min: args.feed,
    })?;
    write!(stdout, "{}", imported.card())?;
    Ok(())
}

/// `rtest-stream`: the stream, the program and the log into per-ball runs; prints the card.
fn run_stream(args: ImportArgs, stream: &std::path::Path, stdout: &mut dyn Write) -> Result<()> {
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
        stream,
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
        let format = format_name(args);
        bail!("{option} does not apply to `import {format}`{why}");
    }
    Ok(())
}

/// The format as the command line names it.
fn format_name(args: &ImportArgs) -> String {
    args.format
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_string())
}
