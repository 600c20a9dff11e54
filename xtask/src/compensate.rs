//! `cargo xtask compensate`: one compensation file of an identified machine in a registered
//! control format ([`mtcal_compensate::Request::write`]); `--format` and `--axis` together say
//! which. `cargo xtask check-compensation`: a compensation file read back and checked against
//! the control's limits ([`mtcal_compensate::Request::check`]). The formats, their names and
//! their help come from the library's registry, not from here.

use anyhow::{Context, Result};
use clap::ValueEnum;
use clap::builder::{PossibleValue, TypedValueParser};
use mtcal_compensate::{ControlFormat, ControlOptions, Request, Settings};
use mtcal_located::Outputs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arguments of `compensate`.
#[derive(clap::Args)]
pub(crate) struct CompensateArgs {
    #[command(flatten)]
    machine: crate::MachineArg,
    #[command(flatten)]
    params: crate::ParamsArg,
    /// The file to write.
    #[arg(long)]
    out: PathBuf,
    /// Node spacing, mm.
    #[arg(long, default_value_t = 25.0)]
    spacing_mm: f64,
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
    /// SINUMERIK EEC: the axes' reference point, mm (mtcal's axis coordinates): each linear
    /// axis' table is made zero there, as the K3 manual asks (no jump when compensation
    /// starts); a rotary axis' table is zero at 0°. The card lists what each table removed.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    reference_mm: f64,
    #[command(flatten)]
    control: ControlArgs,
}

/// Which file, for which control: shared by `compensate` and `check-compensation`.
#[derive(clap::Args)]
pub(crate) struct ControlArgs {
    /// The axis of the file, where its format takes one (a pitch table's axis, a SINUMERIK
    /// or Fanuc file of one axis, the input axis of SINUMERIK CEC tables).
    #[arg(long)]
    axis: Option<char>,
    /// The control format, one of those registered (listed with what each writes under
    /// --help).
    #[arg(long, default_value = "csv", value_parser = FormatParser)]
    format: &'static dyn ControlFormat,
    /// A format's own setting, KEY=VALUE (repeat the flag for several): the keys a format
    /// takes are listed with it under --format; a key the format does not take is refused.
    #[arg(long = "control-option", value_name = "KEY=VALUE")]
    control_option: Vec<String>,
    /// SINUMERIK: most interpolation points per table, the machine's MD38000 (EEC) and
    /// MD18342 (CEC) (default 200, the smallest documented).
    #[arg(long)]
    max_points: Option<usize>,
    /// SINUMERIK CEC: how many tables the control provides (default 8).
    #[arg(long)]
    cec_tables: Option<usize>,
    /// Fanuc: the control series, `30i` (0i-D/F, 30i/31i/32i) or `16` (0i-A/B/C, 16/18,
    /// 16i/18i/21i).
    #[arg(long, default_value = "30i")]
    fanuc_series: FanucSeriesArg,
    /// Fanuc: the increment system, `is-b` (0.001 mm) or `is-c` (0.0001 mm).
    #[arg(long, default_value = "is-b")]
    increment: IncrementArg,
    /// Fanuc: most points of one axis from 3621 to 3622 (default 128, the limit a public
    /// summary gives; no Fanuc manual read states it: set your control's).
    #[arg(long)]
    fanuc_axis_points: Option<u32>,
    /// Heidenhain .COM tables: the control, `tnc4xx` (≤ 256 entries, spacing a power of two
    /// of 0.1 µm) or `manualplus620`.
    #[arg(long, default_value = "tnc4xx")]
    heidenhain_control: HeidenhainArg,
}

/// The arguments of `check-compensation`.
#[derive(clap::Args)]
pub(crate) struct CheckArgs {
    #[command(flatten)]
    machine: crate::MachineArg,
    /// The compensation file to read and check (the .CMA or .TAB of a Heidenhain set).
    file: PathBuf,
    #[command(flatten)]
    control: ControlArgs,
}

/// `--heidenhain-control`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum HeidenhainArg {
    Tnc4xx,
    Manualplus620,
}

/// `--fanuc-series`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum FanucSeriesArg {
    #[value(name = "30i")]
    Series30i,
    #[value(name = "16")]
    Series16,
}

/// `--increment`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum IncrementArg {
    IsB,
    IsC,
}

/// `--format`'s parser: a registered format by name; an unknown name is refused with every
/// registered one, and `--help` lists them with what each writes.
#[derive(Clone)]
struct FormatParser;

impl TypedValueParser for FormatParser {
    type Value = &'static dyn ControlFormat;

    fn parse_ref(
        &self,
        _: &clap::Command,
        _: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<Self::Value, clap::Error> {
        mtcal_compensate::find_format(&value.to_string_lossy())
            .map_err(|e| clap::Error::raw(clap::error::ErrorKind::InvalidValue, format!("{e}\n")))
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(
            mtcal_compensate::control_formats()
                .into_iter()
                .map(|f| PossibleValue::new(f.name()).help(format_help(f))),
        ))
    }
}

/// A format's line under `--help`: what it writes and the options it takes.
fn format_help(format: &dyn ControlFormat) -> String {
    let options: Vec<String> = format
        .options()
        .iter()
        .map(|o| format!("{} ({})", o.key, o.about))
        .collect();
    if options.is_empty() {
        format.about().to_string()
    } else {
        format!(
            "{}; --control-option {}",
            format.about(),
            options.join(", ")
        )
    }
}

/// The SINUMERIK limits: the defaults with the user's machine data.
fn siemens_limits(args: &ControlArgs) -> mtcal_compensate::SiemensLimits {
    let mut limits = mtcal_compensate::SiemensLimits::default();
    if let Some(n) = args.max_points {
        limits.enc_comp_max_points = n;
        limits.cec_max_points = n;
    }
    if let Some(n) = args.cec_tables {
        limits.cec_max_tables = n;
    }
    limits
}

/// The Fanuc control of `--fanuc-series` and `--increment`, with its series' limits.
fn fanuc_control(args: &ControlArgs) -> mtcal_compensate::FanucControl {
    use mtcal_compensate::{FanucSeries, IncrementSystem};
    let series = match args.fanuc_series {
        FanucSeriesArg::Series30i => FanucSeries::Series30i,
        FanucSeriesArg::Series16 => FanucSeries::Series16,
    };
    let increment = match args.increment {
        IncrementArg::IsB => IncrementSystem::IsB,
        IncrementArg::IsC => IncrementSystem::IsC,
    };
    let mut control = mtcal_compensate::FanucControl::new(series, increment);
    if let Some(n) = args.fanuc_axis_points {
        control.axis_points = n;
    }
    control
}

impl ControlArgs {
    /// The file `--format` and `--axis` name.
    fn request(&self) -> Result<Request> {
        Ok(Request::of(self.format, self.axis)?)
    }

    /// The settings with the control's limits and the format's options; the rest as given.
    fn settings(
        &self,
        machine: &mtcal_kinematics::Machine,
        hold_q: Vec<f64>,
        spacing_mm: f64,
        spacing_deg: f64,
    ) -> Result<Settings> {
        let control_options =
            ControlOptions::from_pairs(self.control_option.iter().map(String::as_str))?;
        Ok(Settings {
            hold_q,
            siemens: siemens_limits(self),
            fanuc: fanuc_control(self),
            heidenhain: match self.heidenhain_control {
                HeidenhainArg::Tnc4xx => mtcal_compensate::ComLimits::tnc_4xx(),
                HeidenhainArg::Manualplus620 => mtcal_compensate::ComLimits::manualplus_620(),
            },
            control_options,
            ..Settings::new(machine, spacing_mm, spacing_deg)
        })
    }
}

pub(crate) fn run(args: CompensateArgs, out: &mut impl Write) -> Result<()> {
    let model = crate::build_model(&args.machine.load()?)?;
    let crate::Identified {
        coeffs,
        from: identified,
        account,
    } = crate::load_identified(&model, &args.params, out)?;
    let defaults = mtcal_compensate::default_hold(model.machine());
    let hold = args.hold.as_deref().unwrap_or("");
    let hold_q = mtcal_machine::axis_text::held_positions(model.machine(), defaults, hold)?;
    let what = args.control.request()?;
    let control =
        args.control
            .settings(model.machine(), hold_q, args.spacing_mm, args.spacing_deg)?;
    // What the identification gave and what became of it: on the screen (its account above,
    // the reversals here) and on the card.
    let mut made_from = account;
    let reversals = match &identified {
        Some(from) => {
            let (reversals, said) = found_reversals(from, what, args.reversal_um);
            for line in &said {
                writeln!(out, "{line}")?;
            }
            made_from.extend(said);
            reversals
        }
        None => Vec::new(),
    };
    let settings = Settings {
        joint_offset_mm: args.joint_offset_mm,
        reversal_um: args.reversal_um,
        reversals,
        made_from,
        reference_mm: args.reference_mm,
        ..control
    };
    // The file and those beside it (tables, a card) written into a private folder, then
    // into place together: an error in any leaves none of them.
    let name = args
        .out
        .file_name()
        .with_context(|| format!("{}: not a file name", args.out.display()))?;
    let target = args
        .out
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut files = Outputs::new();
    files.file(&args.out, Vec::new());
    files.check()?;
    let (exported, staging) = mtcal_located::staged(|dir| {
        what.write(&model, &coeffs, &dir.join(name), &settings)
            // A message names the file where the user will find it, not the private folder.
            .map_err(|e| {
                let shown = target.display().to_string();
                anyhow::anyhow!(e.to_string().replace(&dir.display().to_string(), &shown))
            })
    })??;
    let mut files = Outputs::new();
    files.files_of(staging.path(), target)?;
    files.commit()?;
    writeln!(out, "wrote {} ({})", args.out.display(), exported.written)?;
    for (beside, what) in &exported.beside {
        let beside = target.join(beside.strip_prefix(staging.path()).unwrap_or(beside));
        writeln!(out, "wrote {} ({what})", beside.display())?;
    }
    write!(out, "{}", exported.card.lines("  "))?;
    Ok(())
}

/// The reversals of linear axes an identification found that the file `what` can hold
/// (bidirectional tables), and a line for each saying what becomes of it: held, left out
/// because the identification did not determine it, given by `--reversal-um` instead, or not
/// held by this format. A reversal whose backlash is within its interval of zero is left out;
/// a change along the stroke within its interval of zero is left out of one that is put in.
fn found_reversals(
    from: &mtcal_machine::from_identify::FromIdentify,
    what: Request,
    reversal_um: Option<f64>,
) -> (Vec<mtcal_compensate::AxisReversal>, Vec<String>) {
    let mut kept = Vec::new();
    let mut said = Vec::new();
    for r in &from.reversals {
        let words = r.words();
        if !what.holds_reversal_of(r.axis) {
            said.push(format!(
                "  {words}: not in this file (no bidirectional table of axis {} in it)",
                r.axis
            ));
            continue;
        }
        if reversal_um.is_some() {
            said.push(format!("  {words}: not used, --reversal-um given"));
            continue;
        }
        if !r.determined() {
            said.push(format!(
                "  {words}: left out, the identification did not determine it (zero is within \
                 its interval)"
            ));
            continue;
        }
        let change_um = if r.change_determined() {
            -r.change_um
        } else {
            if r.change_um != 0.0 {
                said.push(format!(
                    "  {}: its change along the stroke is within its interval of zero and left \
                     out",
                    r.label
                ));
            }
            0.0
        };
        // The axis lags behind the command: x̄↑ = −B/2, x̄↓ = +B/2, ISO 230-2's B = −backlash.
        let reversal = mtcal_compensate::Reversal {
            middle_um: -r.backlash_um,
            change_um,
            span_mm: r.span_mm,
        };
        let beyond = match r.span_mm {
            Some((lo, hi)) if change_um != 0.0 => {
                format!("; beyond the measured {lo} … {hi} mm it holds its value at the nearer end")
            }
            _ => String::new(),
        };
        let at = match r.span_mm {
            Some((lo, hi)) => format!("at {} mm", 0.5 * (lo + hi)),
            None => "at mid-stroke".into(),
        };
        said.push(format!(
            "  {words}: in the reverse table of axis {} (ISO 230-2 reversal value B = {:+.1} µm \
             {at}{beyond})",
            r.axis, reversal.middle_um
        ));
        kept.push(mtcal_compensate::AxisReversal {
            axis: r.axis,
            reversal,
            source: words,
        });
    }
    (kept, said)
}

/// `check-compensation`: reads the file back, checks it against the control's limits and
/// says what it holds.
pub(crate) fn check(args: CheckArgs, out: &mut impl Write) -> Result<()> {
    let loaded = args.machine.load()?;
    let machine = &loaded.machine;
    let what = args.control.request()?;
    // The spacings only make tables; a check reads them from the file.
    let settings =
        args.control
            .settings(machine, mtcal_compensate::default_hold(machine), 1.0, 1.0)?;
    let checked = what.check(machine, &args.file, &settings)?;
    writeln!(
        out,
        "{}: reads back and is within the control's limits: {checked}",
        args.file.display()
    )?;
    Ok(())
}
