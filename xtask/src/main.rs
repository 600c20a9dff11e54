//! The mtcal command line: `cargo xtask <command>`.
//!
//! Thin by design: it parses arguments, calls the library crates and prints. Exit codes: 0 ok,
//! 2 error (bad input or a failed command).

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use mtcal_kinematics::volmap::{Grid, MapMethod, MapOptions, volumetric_map};
use mtcal_kinematics::{AxisKind, MachineModel};
use mtcal_located::Outputs;
use mtcal_machine::topology::Reading;
use mtcal_machine::{LoadedMachine, load_machine};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod compensate;
mod history;
mod identify;
mod import;
mod plan;
mod scale;
mod tolerance;
mod volumetric;

#[derive(Parser)]
#[command(
    name = "cargo xtask",
    about = "mtcal: machine-tool metrology",
    version,
    after_help = EXIT_CODES
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Describe a machine: branches, axes, strokes and its error model.
    Describe {
        #[command(flatten)]
        machine: MachineArg,
    },
    /// Volumetric error map of a machine for a parameter file.
    Map {
        #[command(flatten)]
        machine: MachineArg,
        #[command(flatten)]
        params: ParamsArg,
        /// Grid points per linear axis, e.g. 21x22x22 (source 004's 10,164 points, the default).
        #[arg(long)]
        grid: Option<String>,
        /// Rotary axis positions in degrees for the map, e.g. A=30,C=45 (default 0).
        #[arg(long, conflicts_with = "orientations")]
        at: Option<String>,
        /// An orientation grid for five-axis machines: the linear grid repeated at every
        /// combination of rotary positions, each axis as LETTER=FROM..TO/COUNT in degrees (ends
        /// included), e.g. A=-30..90/5,C=0..270/4; axes not named stay at 0.
        #[arg(long)]
        orientations: Option<String>,
        /// Use the exact model instead of the first-order one.
        #[arg(long)]
        exact: bool,
        /// Thresholds in µm for the share of points under them (repeatable).
        #[arg(long = "threshold", default_values_t = [5.0, 10.0, 20.0])]
        thresholds: Vec<f64>,
    },
    /// Compensation files from identified parameters, each with its convention card: pitch
    /// tables (LinuxCNC, CSV, Fanuc 3620–3627, SINUMERIK EEC), cross and sag tables (SINUMERIK
    /// CEC, Heidenhain .COM), error parameters for controls that model the machine (ISG, Etalon,
    /// Heidenhain KinematicsComp), five-axis pivots (LinuxCNC trt, SINUMERIK $TC_CARR) or a 3-D
    /// grid of tool-point errors (CSV). Conventions and formats: crates/compensate.
    Compensate(compensate::CompensateArgs),
    /// Read a compensation file back and check it against the control's limits before loading
    /// it (same --format, --axis and limit options as `compensate`).
    CheckCompensation(compensate::CheckArgs),
    /// Correct an NC program for identified errors: every G0/G1 pose moved so the tool (point,
    /// and on five-axis machines its axis) lands where the program meant it (crates/ncprog).
    Correct {
        #[command(flatten)]
        machine: MachineArg,
        #[command(flatten)]
        params: ParamsArg,
        /// The NC program to correct (read, never modified).
        #[arg(long)]
        program: PathBuf,
        /// The corrected program to write.
        #[arg(long)]
        out: PathBuf,
        /// Match the tool point only (rotary axes as commanded).
        #[arg(long)]
        position_only: bool,
    },
    /// The zero point of source 004: the constant offset that minimises the summed volumetric
    /// error over its 10,164-point grid; with --program, that program offset by it.
    ZeroPoint {
        #[command(flatten)]
        machine: MachineArg,
        #[command(flatten)]
        params: ParamsArg,
        /// An NC program to offset (read, never modified); needs --out.
        #[arg(long, requires = "out")]
        program: Option<PathBuf>,
        /// The offset program to write.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Predicted tool-tip error along CL data (CSV `x,y,z[,i,j,k]`: tool tip in the workpiece
    /// frame, mm, and tool axis; crates/ncprog/src/cl.rs): axis positions by the nominal inverse
    /// kinematics, then the identified errors at them.
    ClError {
        #[command(flatten)]
        machine: MachineArg,
        #[command(flatten)]
        params: ParamsArg,
        /// The CL data file (read, never modified).
        #[arg(long)]
        cl: PathBuf,
        /// Write every point's axis positions and predicted error to this CSV file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Plot the predicted tool-tip error (and tool-axis tilt) along the path to this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Identify a machine's errors from a measurement session (folder with session.toml).
    Identify(identify::IdentifyArgs),
    /// Import an instrument's own export (ecmc ISO 230-2 .dat, API XD .pos, Renishaw .rtx)
    /// as a laser run of a session: its CSV and its [[run]] in session.toml; Renishaw
    /// ball-bar .b5r files as ballbar runs, with a card of what was read and assumed; or an
    /// R-test head's continuous stream with its NC program and log as one rtest run per ball
    /// (rtest-stream, docs/VOLUMETRIC.md) (crates/import).
    Import(import::ImportArgs),
    /// The machine history: add a campaign (a session or an identify JSON), list machines,
    /// show a machine's campaigns, the trend of a parameter (drift, step, tolerance, next
    /// check), the fleet against its tolerances (SQLite file or PostgreSQL, crates/history).
    History(history::HistoryArgs),
    /// Evaluate a volumetric thermal test (rtest runs, ball on the table, one row per ball
    /// visit; docs/VOLUMETRIC.md): each point's deformation over time, the mean, standard
    /// deviation and max − min between points per cycle with their noise floors, and whether
    /// the deformation is uniform — ISO 230-3's single-point assumption (crates/volumetric).
    Volumetric(volumetric::VolumetricArgs),
    /// Simulate a measurement session from a machine, a truth parameter file and a test plan.
    Simulate {
        /// The test plan (TOML; see crates/simulate/src/lib.rs).
        plan: PathBuf,
        /// The session folder to write.
        #[arg(long)]
        out: PathBuf,
    },
    /// Plan a measurement: choose instrument positions for the wanted parameters, check every
    /// pose for collisions with the URDF's collision geometry, write the test plan, one NC
    /// program per run and a report (crates/plan, docs/PLANNING.md).
    Plan {
        /// The planning file (TOML; see docs/PLANNING.md).
        planning: PathBuf,
        /// The folder to write.
        #[arg(long)]
        out: PathBuf,
    },
    /// List the registered instrument plugins.
    Plugins,
    /// Tolerance analysis (source 001): random machines within the tolerances of a
    /// specification, the P90 of their maximum volumetric error, each tolerance's sensitivity
    /// (crates/tolerance, docs/TOLERANCE.md).
    Tolerance(tolerance::ToleranceArgs),
    /// How identification scales: simulate a session of N samples in a temporary folder,
    /// identify it in a child process and print the time and peak memory (xtask/src/scale.rs).
    ScaleBench(scale::ScaleArgs),
    /// Build the nominal machine of a topology code and write it as a URDF to edit.
    Topology {
        /// e.g. wCAFYXZt, CAFYXZ, ZFYX
        code: String,
        /// Read a bare code from the tool end (the rail paper's `ZFYX`).
        #[arg(long)]
        from_tool: bool,
        /// Output file (standard output if absent).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

#[derive(clap::Args)]
struct MachineArg {
    /// A URDF file, or a topology code such as wCAFYXZt / CAFYXZ.
    machine: String,
    /// Read a bare topology code from the tool end instead of the workpiece end.
    #[arg(long)]
    from_tool: bool,
}

impl MachineArg {
    fn load(&self) -> Result<LoadedMachine> {
        load_machine(&self.machine, reading(self.from_tool))
            .with_context(|| format!("cannot load machine `{}`", self.machine))
    }
}

fn reading(from_tool: bool) -> Reading {
    if from_tool {
        Reading::FromTool
    } else {
        Reading::FromWorkpiece
    }
}

/// What a script can read from the exit code (`--help` and the README say the same).
const EXIT_CODES: &str = "Exit codes: 0 done, and within every check asked for; 1 done, but a \
check failed or could not be decided (an acceptance that fails or cannot decide, a fit that did \
not converge or does not explain the recordings, a volumetric test not uniform under \
--require-uniform) — the outputs are written; 2 bad input or \
another error — nothing is written.";

/// The work is done and its outputs written, but a check asked of it is not met: exit 1.
#[derive(Debug)]
pub(crate) struct ChecksFailed(pub String);

impl std::fmt::Display for ChecksFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ChecksFailed {}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away (`| head`): nothing more to say to it, and not a failure.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<ChecksFailed>().is_some() => {
            eprintln!("check failed: {e}");
            ExitCode::from(1)
        }
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::from(2)
        }
    }
}

/// The error and its causes, joined by ": ".
fn message(e: &anyhow::Error) -> String {
    // Every error in the chain says its own part once (libraries either show a cause or make it
    // the source, never both: tests/architecture.rs), so the chain joined is the message.
    format!("{e:#}")
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

fn run(cli: Cli) -> Result<()> {
    // Everything goes through one handle so that a closed pipe is an error to return, never a
    // panic (`println!` panics when standard output is gone).
    let mut stdout = std::io::stdout().lock();
    match cli.command {
        Command::Identify(args) => identify::run(args, &mut stdout),
        Command::Simulate { plan, out } => {
            check_paths(&[], &[&out])?;
            let sim = mtcal_simulate::simulate(&plan, &out)?;
            writeln!(
                stdout,
                "wrote {} ({} runs, {} samples)",
                sim.manifest.display(),
                sim.runs,
                sim.samples
            )?;
            Ok(())
        }
        Command::Import(args) => import::run(args, &mut stdout),
        Command::Volumetric(args) => volumetric::run(args, &mut stdout),
        Command::History(args) => history::run(args, &mut stdout),
        Command::Plan { planning, out } => {
            check_paths(&[], &[&out])?;
            plan::run(&planning, &out, &mut stdout)
        }
        Command::Plugins => {
            let plugins = mtcal_plugins::plugins();
            let width = plugins.iter().map(|p| p.name.len()).max().unwrap_or(0);
            for p in plugins {
                writeln!(stdout, "{:<width$} {}", p.name, p.about)?;
            }
            Ok(())
        }
        Command::Describe { machine } => {
            let loaded = machine.load()?;
            let model = build_model(&loaded)?;
            write!(stdout, "{}", mtcal_machine::describe(&loaded, &model))?;
            Ok(())
        }
        Command::Map {
            machine,
            params,
            grid,
            at,
            orientations,
            exact,
            thresholds,
        } => {
            let loaded = machine.load()?;
            let model = build_model(&loaded)?;
            let coeffs = load_params(&model, &params, &mut stdout)?;
            let grid = mtcal_machine::axis_text::map_grid(
                model.machine(),
                grid.as_deref(),
                at.as_deref(),
                orientations.as_deref(),
            )?;
            let method = if exact {
                MapMethod::Exact
            } else {
                MapMethod::FirstOrder
            };
            let opts = MapOptions {
                method,
                ..MapOptions::default()
            };
            write!(stdout, "{}", mtcal_machine::describe(&loaded, &model))?;
            writeln!(stdout, "parameters  {}", params.params.display())?;
            let map = volumetric_map(&model, &coeffs, &grid, &opts);
            writeln!(stdout, "{}", map.summary(&thresholds))?;
            Ok(())
        }
        Command::Compensate(args) => compensate::run(args, &mut stdout),
        Command::CheckCompensation(args) => compensate::check(args, &mut stdout),
        Command::Correct {
            machine,
            params,
            program,
            out,
            position_only,
        } => {
            check_paths(&[&out], &[])?;
            let (model, coeffs) = model_and_coeffs(&machine, &params, &mut stdout)?;
            let options = mtcal_ncprog::CorrectOptions {
                match_tool_axis: !position_only,
                ..Default::default()
            };
            let corrected = mtcal_ncprog::correct_file(&model, &coeffs, &program, &options)?;
            save(&out, &corrected.text)?;
            let poses = corrected.poses.len();
            writeln!(stdout, "wrote {} ({poses} poses corrected)", out.display())?;
            Ok(())
        }
        Command::ZeroPoint {
            machine,
            params,
            program,
            out,
        } => {
            check_paths(
                &[out.as_deref()].into_iter().flatten().collect::<Vec<_>>(),
                &[],
            )?;
            let (model, coeffs) = model_and_coeffs(&machine, &params, &mut stdout)?;
            let grid =
                Grid::source004(model.machine()).context("cannot build source 004's grid")?;
            let z = mtcal_ncprog::model_zero_point(&model, &coeffs, &grid)
                .context("the grid has no points")?;
            write!(stdout, "{}", z.report(model.machine(), grid.len()))?;
            if let (Some(program), Some(out)) = (program, out) {
                let offset_mm = z.zero_point.offset_um.map(|v| v * 1e-3);
                let text = mtcal_ncprog::offset_file(&program, offset_mm)?;
                write_file(&mut stdout, &out, &text)?;
            }
            Ok(())
        }
        Command::ClError {
            machine,
            params,
            cl,
            out,
            plot,
        } => {
            let outputs: Vec<&Path> = [out.as_deref(), plot.as_deref()]
                .into_iter()
                .flatten()
                .collect();
            check_paths(&outputs, &[])?;
            let (model, coeffs) = model_and_coeffs(&machine, &params, &mut stdout)?;
            let data = mtcal_ncprog::read_cl(&cl)?;
            let errors = mtcal_ncprog::PathErrors::new(&model, &coeffs, &data, &cl)?;
            write!(stdout, "{}", errors.report(&cl))?;
            // The plot is drawn before any file is written: a path it cannot draw (one point)
            // is refused with nothing half done.
            let svg = match &plot {
                Some(_) => Some(path_error_svg(&model, &data, &errors, &cl)?),
                None => None,
            };
            let mut files = Outputs::new();
            if let Some(out) = &out {
                files.file(out, errors.csv(model.machine(), &data));
            }
            if let (Some(plot), Some(svg)) = (&plot, svg) {
                files.file(plot, svg);
            }
            for path in files.commit()? {
                let rows = errors.errors.len();
                match Some(&path) == out.as_ref() {
                    true => writeln!(stdout, "wrote {} ({rows} rows)", path.display())?,
                    false => writeln!(stdout, "wrote {}", path.display())?,
                }
            }
            Ok(())
        }
        Command::Tolerance(args) => tolerance::run(args, &mut stdout),
        Command::ScaleBench(args) => scale::run(args, &mut stdout),
        Command::Topology {
            code,
            from_tool,
            out,
        } => {
            let parsed = mtcal_machine::topology::parse_code(&code, reading(from_tool))?;
            let machine = mtcal_machine::topology::nominal_machine(&parsed, &code)?;
            let comment = format!(
                "Nominal machine for topology code {parsed} (mtcal default geometry: see \
                 crates/machine/src/topology.rs). Edit the origins and limits to match the real machine."
            );
            let text = mtcal_machine::urdf::write_urdf(&machine, Some(&comment));
            match out {
                Some(path) => save(&path, &text)?,
                None => write!(stdout, "{text}")?,
            }
            Ok(())
        }
    }
}

/// Writes `text` to `path` atomically; errors name the file.
fn save(path: &Path, text: &str) -> Result<()> {
    mtcal_machine::write_atomically(path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))
}

/// The output paths of a command checked before its work ([`Outputs::check`]): a folder where a
/// file goes, a file where a folder goes, a name too long, told at once.
fn check_paths(files: &[&Path], folders: &[&Path]) -> Result<()> {
    let mut outputs = Outputs::new();
    for f in files {
        outputs.file(f, Vec::new());
    }
    for d in folders {
        outputs.folder(d);
    }
    Ok(outputs.check()?)
}

/// Writes `files` as one transaction ([`Outputs`]) and says which.
fn commit(out: &mut impl Write, files: Outputs) -> Result<()> {
    for path in files.commit()? {
        writeln!(out, "wrote {}", path.display())?;
    }
    Ok(())
}

/// Writes `text` to `path` atomically and says so.
fn write_file(out: &mut impl Write, path: &Path, text: &str) -> Result<()> {
    save(path, text)?;
    writeln!(out, "wrote {}", path.display())?;
    Ok(())
}

fn build_model(loaded: &LoadedMachine) -> Result<MachineModel> {
    MachineModel::new(loaded.machine.clone(), &loaded.config)
        .context("the error-model configuration does not fit the machine")
}

/// The parameter file of a command that acts on identified errors.
#[derive(clap::Args)]
pub(crate) struct ParamsArg {
    /// Parameter file (TOML of ISO 230-1 names and values in µm / µrad), or the JSON of
    /// `identify --json` (what it identified goes in; what it could not determine stays zero).
    #[arg(long)]
    params: PathBuf,
    /// With an identify JSON: give each combination of machine parameters the session could
    /// not separate its minimum-norm split (the smallest members that reproduce it; a choice,
    /// not an identification, said on the screen and the card) instead of leaving its members
    /// at zero. A combination with a set-up member is never split.
    #[arg(long)]
    split_combinations: bool,
}

/// The coefficients of the parameter file `params` for `model`.
fn load_params(model: &MachineModel, params: &ParamsArg, out: &mut impl Write) -> Result<Vec<f64>> {
    Ok(load_identified(model, params, out)?.coeffs)
}

/// A parameter file read, and what an identification behind it says.
struct Identified {
    coeffs: Vec<f64>,
    /// The identification, when the file is its JSON.
    from: Option<mtcal_machine::from_identify::FromIdentify>,
    /// Its account of what went in and what was left out, for the cards: from the JSON, or
    /// the header `identify --params-out` gave the parameter file (empty without one).
    account: Vec<String>,
}

/// The coefficients of the parameter file `params` for `model`, and, when an identification
/// gave them, what it gave (a JSON's account of what went in said on `out`).
fn load_identified(
    model: &MachineModel,
    arg: &ParamsArg,
    out: &mut impl Write,
) -> Result<Identified> {
    use mtcal_machine::from_identify as fi;
    let params = arg.params.as_path();
    let context = || format!("cannot read parameter file {}", params.display());
    let text = std::fs::read_to_string(params).with_context(context)?;
    if !fi::is_json(&text) {
        if arg.split_combinations {
            anyhow::bail!(
                "--split-combinations needs the identify JSON: {} is a parameter file, whose \
                 values are all given",
                params.display()
            );
        }
        let coeffs = mtcal_machine::params::parse_params(&text, params, model.errors())
            .with_context(context)?;
        return Ok(Identified {
            coeffs,
            from: None,
            account: fi::account_in_header(&text),
        });
    }
    // An identify JSON: what the identification gave a number, said on the screen.
    let mut from = fi::read_identify_json(&text, params, model.errors()).with_context(context)?;
    if arg.split_combinations {
        from.split_combinations(model.errors());
    }
    for line in from.account(&params.display().to_string()) {
        writeln!(out, "{line}")?;
    }
    Ok(Identified {
        coeffs: from.coeffs.clone(),
        account: from.account(""),
        from: Some(from),
    })
}

/// The machine's model and the coefficients of a parameter file (a TOML parameter file or an
/// identify JSON, whose account goes to `out`).
fn model_and_coeffs(
    machine: &MachineArg,
    params: &ParamsArg,
    out: &mut impl Write,
) -> Result<(MachineModel, Vec<f64>)> {
    let model = build_model(&machine.load()?)?;
    let coeffs = load_params(&model, params, out)?;
    Ok((model, coeffs))
}

/// The SVG of `cl-error --plot`: the predicted tool-tip error (and on five-axis machines the
/// tool-axis tilt) against the distance along the path of the CL file `path`.
fn path_error_svg(
    model: &MachineModel,
    cl: &mtcal_ncprog::ClData,
    errors: &mtcal_ncprog::PathErrors,
    path: &Path,
) -> Result<String> {
    let five_axis = model
        .machine()
        .axes()
        .iter()
        .any(|a| a.kind() == AxisKind::Rotary);
    let points: Vec<mtcal_report::PathPoint> = mtcal_ncprog::along_mm(cl)
        .into_iter()
        .zip(&errors.errors)
        .map(|(along_mm, e)| mtcal_report::PathPoint {
            along_mm,
            error_um: e.magnitude_um,
            tilt_urad: five_axis.then_some(e.tilt_urad),
        })
        .collect();
    let title = format!("predicted error along {}", path.display());
    Ok(mtcal_report::path_error_svg(&title, &points)?)
}
