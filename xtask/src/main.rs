//! The mtcal command line: `cargo xtask <command>`.
//!
//! Thin by design: it parses arguments, calls the library crates and prints. Exit codes: 0 ok,
//! 2 error (bad input or a failed command).

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use mtcal_kinematics::volmap::{Grid, MapMethod, MapOptions, volumetric_map};
use mtcal_kinematics::{AxisKind, Machine, MachineModel, ParamName, Side};
use mtcal_machine::topology::Reading;
use mtcal_machine::{LoadedMachine, load_machine};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod plan;
mod scale;
mod tolerance;

#[derive(Parser)]
#[command(name = "cargo xtask", about = "mtcal: machine-tool metrology", version)]
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
        /// Parameter file (TOML of ISO 230-1 names and values in µm / µrad).
        #[arg(long)]
        params: PathBuf,
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
        #[arg(long = "threshold")]
        thresholds: Vec<f64>,
    },
    /// Compensation files from identified parameters: a pitch table of one axis (`--axis`,
    /// LinuxCNC `COMP_FILE_TYPE = 1` or CSV), the machine's ISO 230-1 error parameters for a
    /// controller that models the machine (`--format isg` for Beckhoff TF5280 ISG_CSV, `etalon`
    /// for the Etalon Exchange Format), or else a 3-D grid of tool-point error vectors (CSV).
    /// Conventions and formats: crates/compensate (compensation = −error).
    Compensate {
        #[command(flatten)]
        machine: MachineArg,
        /// Parameter file (TOML of ISO 230-1 names and values in µm / µrad).
        #[arg(long)]
        params: PathBuf,
        /// The file to write.
        #[arg(long)]
        out: PathBuf,
        /// A pitch table of this linear axis (positioning along its own direction).
        #[arg(long)]
        axis: Option<char>,
        /// Node spacing, mm.
        #[arg(long, default_value_t = 25.0)]
        spacing_mm: f64,
        /// `csv` (pitch table with --axis, else 3-D grid), `linuxcnc` (pitch table), `isg` or
        /// `etalon` (error parameters of the whole machine), `linuxcnc-trt` (HAL settings of the
        /// rotary pivots of LinuxCNC's xyzac/xyzbc table-table kinematics).
        #[arg(long, default_value = "csv")]
        format: String,
        /// Error parameters: node spacing of rotary axes' tables, degrees.
        #[arg(long, default_value_t = 10.0)]
        spacing_deg: f64,
        /// Pitch tables: LinuxCNC's joint position minus mtcal's axis position, mm (when the
        /// controller's home puts the joint zero elsewhere); added to every node position.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        joint_offset_mm: f64,
        /// Pitch tables: the signed ISO 230-2 reversal value B = x̄↑ − x̄↓ in µm; writes a
        /// bidirectional table (reverse = forward + B).
        #[arg(long, allow_negative_numbers = true)]
        reversal_um: Option<f64>,
        /// Positions of the other axes, e.g. Y=0,Z=-270,A=0 (mm / degrees; default: linear axes
        /// mid-stroke, rotary axes 0).
        #[arg(long)]
        hold: Option<String>,
    },
    /// Correct an NC program for identified errors: every G0/G1 pose moved so the tool (point,
    /// and on five-axis machines its axis) lands where the program meant it (crates/ncprog).
    Correct {
        #[command(flatten)]
        machine: MachineArg,
        /// Parameter file (TOML of ISO 230-1 names and values in µm / µrad).
        #[arg(long)]
        params: PathBuf,
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
        /// Parameter file (TOML of ISO 230-1 names and values in µm / µrad).
        #[arg(long)]
        params: PathBuf,
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
        /// Parameter file (TOML of ISO 230-1 names and values in µm / µrad).
        #[arg(long)]
        params: PathBuf,
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
    Identify(IdentifyArgs),
    /// Simulate a measurement session from a machine, a truth parameter file and a test plan.
    Simulate {
        /// The test plan (TOML; see crates/identify/src/simulate.rs).
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away (`| head`): nothing more to say to it, and not a failure.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::from(2)
        }
    }
}

/// The error and its causes, each said once: the library errors already write their source
/// into their own message (`file: cannot read: <io error>`), so a cause whose text the message
/// so far contains is not repeated.
fn message(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let text = cause.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
    }
    msg
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
        Command::Identify(args) => identify(args, &mut stdout),
        Command::Simulate { plan, out } => {
            let sim = mtcal_identify::simulate::simulate(&plan, &out)?;
            writeln!(
                stdout,
                "wrote {} ({} runs, {} samples)",
                sim.manifest.display(),
                sim.runs,
                sim.samples
            )?;
            Ok(())
        }
        Command::Plan { planning, out } => plan::run(&planning, &out, &mut stdout),
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
            write!(stdout, "{}", describe(&loaded, &model))?;
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
            let coeffs = mtcal_machine::params::load_params(&params, model.errors())
                .with_context(|| format!("cannot read parameter file {}", params.display()))?;
            let mut grid = make_grid(model.machine(), grid.as_deref(), at.as_deref())?;
            if let Some(text) = orientations.as_deref() {
                let list = orientation_grid(model.machine(), text)?;
                grid = grid
                    .with_orientations(&list)
                    .context("cannot build the orientation grid")?;
            }
            let opts = MapOptions {
                method: if exact {
                    MapMethod::Exact
                } else {
                    MapMethod::FirstOrder
                },
                ..MapOptions::default()
            };
            let thresholds = if thresholds.is_empty() {
                vec![5.0, 10.0, 20.0]
            } else {
                thresholds
            };
            write!(stdout, "{}", describe(&loaded, &model))?;
            writeln!(stdout, "parameters  {}", params.display())?;
            let map = volumetric_map(&model, &coeffs, &grid, &opts);
            writeln!(stdout, "{}", map.summary(&thresholds))?;
            Ok(())
        }
        Command::Compensate {
            machine,
            params,
            out,
            axis,
            spacing_mm,
            format,
            spacing_deg,
            joint_offset_mm,
            reversal_um,
            hold,
        } => {
            let (model, coeffs) = model_and_coeffs(&machine, &params)?;
            let hold_q = hold_positions(model.machine(), hold.as_deref())?;
            let what = compensate(
                &model,
                &coeffs,
                &out,
                CompensateArgs {
                    axis,
                    spacing_mm,
                    spacing_deg,
                    joint_offset_mm,
                    format: &format,
                    reversal_um,
                    hold_q,
                },
            )?;
            writeln!(stdout, "wrote {} ({what})", out.display())?;
            Ok(())
        }
        Command::Correct {
            machine,
            params,
            program,
            out,
            position_only,
        } => {
            let (model, coeffs) = model_and_coeffs(&machine, &params)?;
            let nc = read_program(&program)?;
            let options = mtcal_ncprog::CorrectOptions {
                match_tool_axis: !position_only,
                ..Default::default()
            };
            let corrected = mtcal_ncprog::correct_program(&model, &coeffs, &nc, &options).map_err(
                |e| match e.location() {
                    // `prog.nc:5:4: …`, as every other located message.
                    Some((line, column)) => anyhow::anyhow!(
                        "{}:{line}{}: {}",
                        program.display(),
                        column.map_or(String::new(), |c| format!(":{c}")),
                        e.message()
                    ),
                    None => anyhow::anyhow!("cannot correct {}: {e}", program.display()),
                },
            )?;
            mtcal_machine::write_atomically(&out, corrected.text.as_bytes())
                .with_context(|| format!("cannot write {}", out.display()))?;
            writeln!(
                stdout,
                "wrote {} ({} poses corrected)",
                out.display(),
                corrected.poses.len()
            )?;
            Ok(())
        }
        Command::ZeroPoint {
            machine,
            params,
            program,
            out,
        } => {
            let (model, coeffs) = model_and_coeffs(&machine, &params)?;
            let grid =
                Grid::source004(model.machine()).context("cannot build source 004's grid")?;
            let z = mtcal_ncprog::model_zero_point(&model, &coeffs, &grid)
                .context("the grid has no points")?;
            let zp = &z.zero_point;
            let mm: Vec<String> = z
                .positions
                .iter()
                .zip(model.machine().axes())
                .map(|(v, a)| match a.kind() {
                    AxisKind::Linear => format!("{}={:.3}", a.letter().as_char(), v * 1e3),
                    AxisKind::Rotary => format!("{}={:.3}", a.letter().as_char(), v.to_degrees()),
                })
                .collect();
            writeln!(
                stdout,
                "zero point  {} of {} grid points",
                mm.join(" "),
                grid.len()
            )?;
            writeln!(
                stdout,
                "offset      [{:.3}, {:.3}, {:.3}] um",
                zp.offset_um[0], zp.offset_um[1], zp.offset_um[2]
            )?;
            writeln!(
                stdout,
                "sum |error| {:.1} um before, {:.1} um after (geometric median {:.1} um); max {:.3} um before, {:.3} um after",
                zp.sum_before_um,
                zp.sum_after_um,
                z.median.sum_um,
                zp.max_before_um,
                zp.max_after_um
            )?;
            if let (Some(program), Some(out)) = (program, out) {
                let nc = read_program(&program)?;
                let text = mtcal_ncprog::offset_program(
                    &nc,
                    zp.offset_um.map(|v| v * 1e-3),
                    mtcal_ncprog::Decimals::default(),
                )
                .with_context(|| format!("cannot offset {}", program.display()))?;
                mtcal_machine::write_atomically(&out, text.as_bytes())
                    .with_context(|| format!("cannot write {}", out.display()))?;
                writeln!(stdout, "wrote {}", out.display())?;
            }
            Ok(())
        }
        Command::ClError {
            machine,
            params,
            cl,
            out,
            plot,
        } => cl_error(
            &mut stdout,
            &machine,
            &params,
            &cl,
            out.as_deref(),
            plot.as_deref(),
        ),
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
                Some(path) => mtcal_machine::write_atomically(&path, text.as_bytes())
                    .with_context(|| format!("cannot write {}", path.display()))?,
                None => write!(stdout, "{text}")?,
            }
            Ok(())
        }
    }
}

/// The arguments of `identify`.
#[derive(clap::Args)]
struct IdentifyArgs {
    /// The session folder (or its session.toml).
    session: PathBuf,
    /// Write the result as JSON (schema mtcal.identify/1) to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write every validation run's predicted readings to DIR/<run>.csv.
    #[arg(long)]
    predict: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Everything on the screen (the whole information account; otherwise its first
    /// lines, and all of it in the JSON).
    #[arg(long)]
    verbose: bool,
    /// Worker threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Run the physics search: find the effects the model left out (thermal drift,
    /// backlash, cyclic errors, omitted parameters…), add those that improve held-out
    /// prediction, and report them as discoveries.
    #[arg(long)]
    search: bool,
    /// Another session (planned, moved or extra runs, e.g. from `simulate`): print what
    /// adding its runs would do to every interval, without refitting.
    #[arg(long, value_name = "SESSION")]
    what_if: Option<PathBuf>,
    /// Write an HTML report (DIR/index.html, self-contained, SVG plots): ball-bar polar
    /// plots, residuals along time and temperatures, component errors, volumetric map,
    /// parameters, what the data cannot separate, discoveries.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Write the error model these runs identify (an .errors.toml to keep beside the
    /// URDF): the parameters they determine, without those they cannot.
    #[arg(long, value_name = "FILE")]
    suggest_model: Option<PathBuf>,
}

/// `identify`: what was loaded, then (after the fit or the search) the summary and the
/// information account, what another session would add, and the files asked for.
fn identify(args: IdentifyArgs, out: &mut impl Write) -> Result<()> {
    let options = mtcal_identify::pipeline::PipelineOptions {
        solver: mtcal_solve::Options {
            threads: args.threads,
            ..Default::default()
        },
        search: args.search,
    };
    let prepared = mtcal_identify::pipeline::Prepared::load(&args.session, options)?;
    write!(out, "{}", prepared.header())?;
    let mut progress = Progress::new(args.quiet);
    let outcome = prepared.run(&mut progress);
    progress.finish();
    let outcome = outcome?;
    write!(out, "{}", outcome.screen(args.verbose))?;
    if let Some(dir) = &args.what_if {
        write!(out, "\n{}", outcome.what_if(dir)?)?;
    }
    if let Some(path) = &args.suggest_model {
        write_file(out, path, &outcome.suggested_model())?;
    }
    if let Some(path) = &args.json {
        write_file(out, path, &outcome.identification.to_json())?;
    }
    if let Some(dir) = &args.predict {
        for f in outcome.write_predictions(dir)? {
            writeln!(out, "wrote {}", f.display())?;
        }
    }
    if let Some(dir) = &args.report {
        let path = outcome.write_report(dir)?;
        writeln!(out, "wrote {}", path.display())?;
    }
    Ok(())
}

/// Writes `text` to `path` (atomically) and says so.
fn write_file(out: &mut impl Write, path: &Path, text: &str) -> Result<()> {
    mtcal_machine::write_atomically(path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    writeln!(out, "wrote {}", path.display())?;
    Ok(())
}

/// A progress bar on standard error for long fits (hidden when quiet or not a terminal).
struct Progress {
    bar: Option<indicatif::ProgressBar>,
}

impl Progress {
    fn new(quiet: bool) -> Self {
        let bar = (!quiet).then(|| {
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} iteration {prefix} [{bar:30}] {pos}/{len} blocks {msg}",
                )
                .expect("valid template"),
            );
            bar
        });
        Self { bar }
    }
    fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

impl mtcal_solve::Observer for Progress {
    fn iteration(&mut self, it: usize, cost: f64, _lambda: f64) {
        if let Some(bar) = &self.bar {
            bar.set_prefix(it.to_string());
            bar.set_message(format!("cost {cost:.4e}"));
        }
    }
    fn rows(&mut self, done: usize, total: usize) {
        if let Some(bar) = &self.bar {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
    }
}

fn build_model(loaded: &LoadedMachine) -> Result<MachineModel> {
    MachineModel::new(loaded.machine.clone(), &loaded.config)
        .context("the error-model configuration does not fit the machine")
}

/// The machine's model and the coefficients of a parameter file.
fn model_and_coeffs(
    machine: &MachineArg,
    params: &std::path::Path,
) -> Result<(MachineModel, Vec<f64>)> {
    let loaded = machine.load()?;
    let model = build_model(&loaded)?;
    let coeffs = mtcal_machine::params::load_params(params, model.errors())
        .with_context(|| format!("cannot read parameter file {}", params.display()))?;
    Ok((model, coeffs))
}

/// An NC program, parsed (errors name the file, line and column).
fn read_program(path: &std::path::Path) -> Result<mtcal_ncprog::Program> {
    let text = read_text(path, "NC program")?;
    mtcal_ncprog::Program::parse(&text)
        .map_err(|e| located(path, e.line, e.column, e.expected, &e.found))
}

/// CL data, parsed (errors name the file, line and column).
fn read_cl(path: &std::path::Path) -> Result<mtcal_ncprog::ClData> {
    let text = read_text(path, "CL data")?;
    mtcal_ncprog::ClData::parse(&text)
        .map_err(|e| located(path, e.line, e.column, e.expected, &e.found))
}

fn read_text(path: &std::path::Path, what: &str) -> Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("cannot read {what} {}", path.display()))
}

/// `file:line:column: expected …, found …`.
fn located(
    path: &std::path::Path,
    line: usize,
    column: usize,
    expected: &str,
    found: &str,
) -> anyhow::Error {
    anyhow::anyhow!(
        "{}:{line}:{column}: expected {expected}, found {found}",
        path.display()
    )
}

/// `cl-error`: the summary of the predicted errors along a CL path, and with `out` the CSV of
/// every point.
fn cl_error(
    stdout: &mut impl std::io::Write,
    machine: &MachineArg,
    params: &std::path::Path,
    cl_path: &std::path::Path,
    out: Option<&std::path::Path>,
    plot: Option<&std::path::Path>,
) -> Result<()> {
    use std::fmt::Write as _;
    let (model, coeffs) = model_and_coeffs(machine, params)?;
    let cl = read_cl(cl_path)?;
    mtcal_ncprog::check_units(model.machine(), &cl)
        .map_err(|e| located(cl_path, e.line, e.column, e.expected, &e.found))?;
    let points =
        mtcal_ncprog::all_axis_positions(model.machine(), &cl, &mtcal_ncprog::ClOptions::default())
            .map_err(|e| anyhow::anyhow!("{}: {e}", cl_path.display()))?;
    let qs: Vec<Vec<f64>> = points.iter().map(|p| p.q.clone()).collect();
    let errors = mtcal_ncprog::predicted_errors(&model, &coeffs, &qs);
    let s = mtcal_ncprog::summarize(&errors).context("the CL data has no points")?;
    let singular = points.iter().filter(|p| p.singular.is_some()).count();
    writeln!(
        stdout,
        "cl data     {}: {} points{}",
        cl_path.display(),
        s.points,
        if singular > 0 {
            format!(" ({singular} singular: free rotary axis held at the previous position)")
        } else {
            String::new()
        }
    )?;
    writeln!(
        stdout,
        "|error|     max {:.3} um at line {}, RMS {:.3} um, P90 {:.3} um; tool-axis tilt max {:.3} urad",
        s.max_um, points[s.max_index].line, s.rms_um, s.p90_um, s.max_tilt_urad
    )?;
    // The plot is drawn before any file is written: a path it cannot draw (one point) is
    // refused with nothing half done.
    let svg = if plot.is_some() {
        let five_axis = model
            .machine()
            .axes()
            .iter()
            .any(|a| a.kind() == AxisKind::Rotary);
        let mut along_mm = 0.0;
        let path: Vec<mtcal_report::PathPoint> = cl
            .points
            .iter()
            .enumerate()
            .zip(&errors)
            .map(|((k, p), e)| {
                if k > 0 {
                    along_mm += (p.tip_mm - cl.points[k - 1].tip_mm).norm();
                }
                mtcal_report::PathPoint {
                    along_mm,
                    error_um: e.magnitude_um,
                    tilt_urad: five_axis.then_some(e.tilt_urad),
                }
            })
            .collect();
        let title = format!("predicted error along {}", cl_path.display());
        Some(mtcal_report::path_error_svg(&title, &path)?)
    } else {
        None
    };
    if let Some(out) = out {
        let axes = model.machine().axes();
        let mut csv = String::from("x,y,z");
        for a in axes {
            let unit = match a.kind() {
                AxisKind::Linear => "mm",
                AxisKind::Rotary => "deg",
            };
            let _ = write!(csv, ",{}_{unit}", a.letter().as_char());
        }
        csv.push_str(",dx_um,dy_um,dz_um,e_um,tilt_urad\n");
        for ((p, ap), e) in cl.points.iter().zip(&points).zip(&errors) {
            let _ = write!(csv, "{},{},{}", p.tip_mm.x, p.tip_mm.y, p.tip_mm.z);
            for (a, &q) in axes.iter().zip(&ap.q) {
                let v = a.kind().to_file(q);
                let _ = write!(csv, ",{v:.6}");
            }
            let t = e.translation_um;
            let _ = writeln!(
                csv,
                ",{:.4},{:.4},{:.4},{:.4},{:.3}",
                t.x, t.y, t.z, e.magnitude_um, e.tilt_urad
            );
        }
        mtcal_machine::write_atomically(out, csv.as_bytes())
            .with_context(|| format!("cannot write {}", out.display()))?;
        writeln!(stdout, "wrote {} ({} rows)", out.display(), errors.len())?;
    }
    if let (Some(plot), Some(svg)) = (plot, svg) {
        mtcal_machine::write_atomically(plot, svg.as_bytes())
            .with_context(|| format!("cannot write {}", plot.display()))?;
        writeln!(stdout, "wrote {}", plot.display())?;
    }
    Ok(())
}

/// What `compensate` writes.
struct CompensateArgs<'a> {
    axis: Option<char>,
    spacing_mm: f64,
    spacing_deg: f64,
    joint_offset_mm: f64,
    format: &'a str,
    reversal_um: Option<f64>,
    hold_q: Vec<f64>,
}

/// Writes the compensation file of `mtcal compensate`; says what it wrote.
fn compensate(
    model: &MachineModel,
    coeffs: &[f64],
    out: &std::path::Path,
    args: CompensateArgs<'_>,
) -> Result<String> {
    use mtcal_compensate as comp;
    let parameter_format = match args.format {
        "isg" => Some(comp::ParameterFormat::IsgCsv),
        "etalon" => Some(comp::ParameterFormat::Etalon),
        _ => None,
    };
    if args.format == "linuxcnc-trt" {
        let pivots = comp::trt_pivots_with_nominal(model, coeffs)?;
        let text = comp::trt_hal_text(&pivots, model.machine().name());
        mtcal_machine::write_atomically(out, text.as_bytes())
            .with_context(|| format!("cannot write {}", out.display()))?;
        return Ok(format!(
            "HAL settings of LinuxCNC's {}; {} identified errors it cannot hold are listed in it",
            pivots.kind.name(),
            pivots.not_representable.len()
        ));
    }
    if let Some(format) = parameter_format {
        if let Some(axis) = args.axis {
            bail!(
                "--format {} writes the error parameters of every axis; drop --axis {axis}",
                args.format
            );
        }
        let params = comp::error_parameters(model, coeffs, args.spacing_mm, args.spacing_deg)?;
        comp::write_error_parameters(out, model.machine(), &params, format)?;
        let tables = params
            .params
            .iter()
            .filter(|p| matches!(p.value, comp::ParameterValue::Table { .. }))
            .count();
        return Ok(format!(
            "{} error parameters: {tables} component-error tables, {} location errors",
            args.format,
            params.params.len() - tables
        ));
    }
    let Some(axis) = args.axis else {
        if args.format != "csv" {
            bail!(
                "--format `{}` without --axis: expected csv (3-D grid), isg or etalon",
                args.format
            );
        }
        let mut spec = comp::GridSpec::new(model.machine(), [args.spacing_mm; 3]);
        spec.hold_q = args.hold_q;
        let grid = comp::error_grid(model, coeffs, &spec)?;
        comp::write_grid_csv(out, &grid)?;
        return Ok(format!(
            "a {} × {} × {} grid of tool-point errors",
            grid.x_mm.len(),
            grid.y_mm.len(),
            grid.z_mm.len()
        ));
    };
    let mut table = comp::pitch_table(model, coeffs, axis, args.spacing_mm, &args.hold_q)?;
    if let Some(b) = args.reversal_um {
        table = table.with_reversal_um(b);
    }
    table = table.shifted_mm(args.joint_offset_mm);
    match args.format {
        "linuxcnc" => comp::write_linuxcnc_comp(out, &table)?,
        "csv" => comp::write_pitch_csv(out, &table)?,
        other => bail!("--format `{other}`: expected linuxcnc, csv, isg, etalon or linuxcnc-trt"),
    }
    Ok(format!(
        "{} pitch table of {axis}, {} nodes{}",
        args.format,
        table.len(),
        if table.reverse_um.is_some() {
            ", bidirectional"
        } else {
            ""
        }
    ))
}

/// The axis positions (SI) of `--hold Y=0,Z=-270,A=0`: the crate's defaults (linear axes
/// mid-stroke, rotary axes 0) with the given ones replaced (mm / degrees).
fn hold_positions(machine: &Machine, hold: Option<&str>) -> Result<Vec<f64>> {
    let mut q = mtcal_compensate::default_hold(machine);
    for item in hold
        .unwrap_or("")
        .split(',')
        .filter(|s| !s.trim().is_empty())
    {
        let (letter, value) = item
            .split_once('=')
            .with_context(|| format!("--hold `{item}`: expected LETTER=VALUE, e.g. Z=-270"))?;
        let letter = letter.trim().chars().next().unwrap_or('?');
        let v: f64 = value
            .trim()
            .parse()
            .with_context(|| format!("--hold `{item}`: `{value}` is not a number"))?;
        let k = machine
            .axis_index(letter)
            .with_context(|| format!("--hold `{item}`: the machine has no axis {letter}"))?;
        q[k] = machine.axes()[k].kind().from_file(v);
    }
    Ok(q)
}

/// Parses `21x22x22` and `A=30,C=45` into a grid over the linear axes.
/// The rotary positions (rad, canonical order) of `--orientations A=-30..90/5,C=0..270/4`:
/// every combination, axes not named at 0.
fn orientation_grid(machine: &Machine, text: &str) -> Result<Vec<Vec<f64>>> {
    let rotary: Vec<char> = machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Rotary)
        .map(|a| a.letter().as_char())
        .collect();
    if rotary.is_empty() {
        bail!("--orientations: the machine has no rotary axis");
    }
    let mut values = vec![vec![0.0]; rotary.len()];
    for item in text.split(',').filter(|s| !s.trim().is_empty()) {
        let bad = || {
            format!(
                "--orientations `{item}`: expected LETTER=FROM..TO/COUNT in degrees, e.g. C=0..270/4"
            )
        };
        let (letter, range) = item.split_once('=').with_context(bad)?;
        let letter = letter.trim().chars().next().unwrap_or('?');
        let slot = rotary.iter().position(|&c| c == letter).with_context(|| {
            format!("--orientations `{item}`: the machine has no rotary axis {letter}")
        })?;
        let (span, count) = range.split_once('/').with_context(bad)?;
        let (from, to) = span.split_once("..").with_context(bad)?;
        let number = |t: &str| t.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let (Some(from), Some(to)) = (number(from), number(to)) else {
            bail!(bad());
        };
        let count: usize = count
            .trim()
            .parse()
            .ok()
            .filter(|&n| n >= 1)
            .with_context(bad)?;
        values[slot] = (0..count)
            .map(|i| {
                let t = if count == 1 {
                    0.0
                } else {
                    i as f64 / (count - 1) as f64
                };
                (from + t * (to - from)).to_radians()
            })
            .collect();
    }
    // Every combination, the first axis slowest.
    let mut out: Vec<Vec<f64>> = vec![Vec::new()];
    for axis_values in &values {
        out = out
            .iter()
            .flat_map(|prefix| {
                axis_values.iter().map(move |&v| {
                    let mut o = prefix.clone();
                    o.push(v);
                    o
                })
            })
            .collect();
    }
    Ok(out)
}

fn make_grid(machine: &Machine, grid: Option<&str>, at: Option<&str>) -> Result<Grid> {
    let n_linear = machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Linear)
        .count();
    let counts: Vec<usize> = match grid {
        None => vec![21, 22, 22, 21, 21, 21][..n_linear].to_vec(),
        Some(text) => text
            .split('x')
            .map(|s| s.trim().parse::<usize>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("--grid `{text}`: expected counts like 21x22x22"))?,
    };
    if counts.len() != n_linear || counts.iter().any(|&n| n < 1) {
        bail!(
            "--grid needs one count ≥ 1 per linear axis ({n_linear} here), e.g. {}",
            vec!["11"; n_linear].join("x")
        );
    }
    let rotary_letters: Vec<char> = machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Rotary)
        .map(|a| a.letter().as_char())
        .collect();
    let mut rotary = vec![0.0; rotary_letters.len()];
    for item in at.unwrap_or("").split(',').filter(|s| !s.trim().is_empty()) {
        let (letter, value) = item
            .split_once('=')
            .with_context(|| format!("--at `{item}`: expected LETTER=DEGREES, e.g. C=45"))?;
        let letter = letter.trim().chars().next().unwrap_or('?');
        let deg: f64 = value
            .trim()
            .parse()
            .with_context(|| format!("--at `{item}`: `{value}` is not a number of degrees"))?;
        let slot = rotary_letters
            .iter()
            .position(|&c| c == letter)
            .with_context(|| format!("--at `{item}`: the machine has no rotary axis {letter}"))?;
        rotary[slot] = deg.to_radians();
    }
    Grid::with_counts(machine, &counts)
        .and_then(|g| g.with_rotary(&rotary))
        .context("cannot build the map grid")
}

/// A readable description of the machine and its error model.
fn describe(loaded: &LoadedMachine, model: &MachineModel) -> String {
    use std::fmt::Write;
    let m = &loaded.machine;
    let mut s = String::new();
    let _ = writeln!(s, "machine     {} ({})", m.name(), loaded.source);
    let _ = writeln!(s, "topology    {}", m.topology_code());
    let _ = writeln!(
        s,
        "axis  kind     branch     stroke                      direction"
    );
    for ax in m.axes() {
        let (unit, scale) = match ax.kind() {
            AxisKind::Linear => ("mm", 1e3),
            AxisKind::Rotary => ("deg", 180.0 / std::f64::consts::PI),
        };
        let stroke = match ax.limits() {
            Some((lo, hi)) => format!("{:9.3} … {:9.3} {unit}", lo * scale, hi * scale),
            None => "unlimited".to_string(),
        };
        let branch = match ax.side() {
            Side::Workpiece => "workpiece",
            Side::Tool => "tool",
        };
        let kind = match ax.kind() {
            AxisKind::Linear => "linear",
            AxisKind::Rotary => "rotary",
        };
        let d = ax.zero_rotation() * ax.direction();
        let _ = writeln!(
            s,
            "{:<5} {kind:<8} {branch:<10} {stroke:<27} ({:+.3}, {:+.3}, {:+.3})",
            ax.letter().to_string(),
            d.x,
            d.y,
            d.z
        );
    }
    let params = model.errors().params();
    let count = |f: &dyn Fn(&ParamName) -> bool| params.iter().filter(|p| f(&p.name)).count();
    let rotary = |n: &ParamName| n.axis().is_some_and(|a| a.is_rotary());
    let _ = writeln!(
        s,
        "errors      {} parameters, {} coefficients ({}): {} component, {} rotary location, {} squareness, {} set-up",
        params.len(),
        model.n_coeffs(),
        loaded.config_source,
        count(&|n| matches!(n, ParamName::Component { .. })),
        count(&|n| matches!(n, ParamName::Location { .. }) && rotary(n)),
        count(&|n| matches!(n, ParamName::Location { .. }) && !rotary(n)),
        count(&|n| matches!(n, ParamName::Setup(_))),
    );
    s
}
