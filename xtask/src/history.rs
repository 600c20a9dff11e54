//! `cargo xtask history`: every calibration of a machine kept ([`mtcal_history::Store`]) and
//! what the series say ([`mtcal_history::trend_view`], [`mtcal_history::fleet_view`]).

use anyhow::{Context, Result, bail};
use mtcal_history::{Campaign, CampaignId, Limits, Store, Timestamp};
use mtcal_identify::pipeline::{PipelineOptions, Prepared};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The history file when neither `--db` nor `MTCAL_HISTORY` names one.
const DEFAULT_DB: &str = "mtcal-history.sqlite";

/// The arguments of `history`.
#[derive(clap::Args)]
pub(crate) struct HistoryArgs {
    /// The history: an SQLite file (created when absent) or a postgres://… URL (default:
    /// $MTCAL_HISTORY, else ./mtcal-history.sqlite).
    #[arg(long, global = true)]
    db: Option<String>,
    /// JSON instead of text.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: HistoryCommand,
}

#[derive(clap::Subcommand)]
enum HistoryCommand {
    /// Add a campaign: a session folder (identified now) or an identify JSON result.
    Add {
        /// The session folder (or its session.toml), or a RESULT.json of `identify --json`.
        input: PathBuf,
        /// The machine's name in the history (yours: `mill-3`, a serial number…).
        #[arg(long)]
        machine: String,
        /// When the machine was measured, e.g. 2026-03-01 or 2026-03-01T14:30:00Z (default:
        /// the newest modification time of the session's files, or of the JSON).
        #[arg(long)]
        date: Option<String>,
        /// The machine's temperature during the campaign, °C.
        #[arg(long)]
        temperature_c: Option<f64>,
        /// A note kept with the campaign.
        #[arg(long)]
        note: Option<String>,
    },
    /// The machines and how many campaigns each has.
    List,
    /// A machine's campaigns.
    Show { machine: String },
    /// What a parameter's series says: changes between campaigns (E_n), drift rate, step,
    /// tolerance and next check; without --param, one line per parameter.
    Trend {
        machine: String,
        /// The parameter, e.g. EX0C or EXX.P1.
        #[arg(long)]
        param: Option<String>,
        /// Tolerances on parameters: the [parameters] table of an acceptance file
        /// (docs/ACCEPTANCE.md).
        #[arg(long)]
        tolerances: Option<PathBuf>,
        /// The longest interval between checks, days.
        #[arg(long, default_value_t = 365.0)]
        max_interval_days: f64,
    },
    /// The checks of one day as a warm-up trajectory (source 000): per parameter the time
    /// constant, the change still to come and the settled value, each ± u95, and with
    /// recorded temperatures (`add --temperature-c`) the sensitivity per kelvin.
    Thermal {
        machine: String,
        /// The parameter, e.g. EX0C (default: every parameter of the day's checks).
        #[arg(long)]
        param: Option<String>,
        /// The day, YYYY-MM-DD in UTC (default: the day of the latest campaign).
        #[arg(long)]
        day: Option<String>,
    },
    /// Every machine's latest campaign and the parameters beyond their tolerances.
    Fleet {
        #[arg(long)]
        tolerances: Option<PathBuf>,
    },
    /// The history page (OUT/index.html, self-contained): a machine's trend plots (values ±
    /// u95, drift line and band, tolerance lines) and its fleet row, or with --fleet the fleet
    /// table with the drift rates of the toleranced parameters.
    Report {
        /// The machine (omit with --fleet).
        machine: Option<String>,
        /// The whole fleet instead of one machine.
        #[arg(long, conflicts_with = "machine")]
        fleet: bool,
        /// The folder to write index.html into.
        #[arg(long)]
        out: PathBuf,
        /// Only these parameters (repeatable; default every parameter of the latest campaign,
        /// or with --fleet those the tolerances name).
        #[arg(long = "param")]
        params: Vec<String>,
        #[arg(long)]
        tolerances: Option<PathBuf>,
        #[arg(long, default_value_t = 365.0)]
        max_interval_days: f64,
    },
    /// Mark a campaign superseded by a later one of the same machine (both are kept).
    Supersede {
        id: i64,
        #[arg(long)]
        by: i64,
        #[arg(long)]
        reason: String,
    },
}

pub(crate) fn run(args: HistoryArgs, out: &mut impl Write) -> Result<()> {
    let db = args
        .db
        .or_else(|| std::env::var("MTCAL_HISTORY").ok())
        .unwrap_or_else(|| DEFAULT_DB.to_string());
    let json = args.json;
    match args.command {
        HistoryCommand::Add {
            input,
            machine,
            date,
            temperature_c,
            note,
        } => {
            // The date and the campaign first: a mistake in either opens no database.
            let date = date.map(|d| mtcal_history::parse_date(&d)).transpose()?;
            let mut campaign = campaign_of(&input, &machine, date)?;
            campaign.temperature_c = temperature_c;
            campaign.note = note;
            let mut store = Store::open(&db)?;
            let id = store.add(&campaign)?;
            if json {
                writeln!(out, "{}", serde_json::json!({ "added": id.0 }))?;
            } else {
                writeln!(
                    out,
                    "added campaign {} of {machine} ({}) to {}",
                    id.0,
                    campaign.date.strftime("%Y-%m-%d %H:%M:%S UTC"),
                    store.location()
                )?;
            }
        }
        HistoryCommand::List => {
            let machines = Store::open(&db)?.machines()?;
            if json {
                print_json(out, &machines)?;
            } else {
                writeln!(
                    out,
                    "{:<24} {:>9}  first       last",
                    "machine", "campaigns"
                )?;
                for m in &machines {
                    writeln!(
                        out,
                        "{:<24} {:>9}  {}  {}",
                        m.name,
                        m.campaigns,
                        m.first_date.strftime("%Y-%m-%d"),
                        m.last_date.strftime("%Y-%m-%d")
                    )?;
                }
            }
        }
        HistoryCommand::Show { machine } => show(&Store::open(&db)?, &machine, json, out)?,
        HistoryCommand::Trend {
            machine,
            param,
            tolerances,
            max_interval_days,
        } => {
            let store = Store::open(&db)?;
            let limits = limits(tolerances.as_deref())?;
            trend(
                &store,
                &machine,
                param.as_deref(),
                &limits,
                max_interval_days,
                json,
                out,
            )?
        }
        HistoryCommand::Thermal {
            machine,
            param,
            day,
        } => {
            let store = Store::open(&db)?;
            let names = match param {
                Some(p) => vec![p],
                None => mtcal_history::latest_parameters(&store, &machine)?,
            };
            let mut views = Vec::with_capacity(names.len());
            for name in &names {
                views.push(mtcal_history::thermal_view(
                    &store,
                    &machine,
                    name,
                    day.as_deref(),
                )?);
            }
            if json {
                print_json(out, &views)?;
            } else {
                for v in &views {
                    writeln!(out, "{v}")?;
                }
            }
        }
        HistoryCommand::Fleet { tolerances } => {
            let lines =
                mtcal_history::fleet_view(&Store::open(&db)?, &limits(tolerances.as_deref())?)?;
            if json {
                print_json(out, &lines)?;
            } else {
                write!(out, "{}", mtcal_history::fleet_text(&lines))?;
            }
        }
        HistoryCommand::Report {
            machine,
            fleet,
            out: dir,
            params,
            tolerances,
            max_interval_days,
        } => {
            let store = Store::open(&db)?;
            let limits = limits(tolerances.as_deref())?;
            let page = match (machine, fleet) {
                (Some(m), false) => machine_page(&store, &m, &params, &limits, max_interval_days)?,
                (None, true) => fleet_page(&store, &params, &limits, max_interval_days)?,
                _ => bail!("history report: name a machine, or give --fleet"),
            };
            let path = mtcal_report::write_history(&dir, &page)?;
            writeln!(out, "wrote {}", path.display())?;
        }
        HistoryCommand::Supersede { id, by, reason } => {
            let mut store = Store::open(&db)?;
            store.supersede(CampaignId(id), CampaignId(by), &reason)?;
            writeln!(
                out,
                "campaign {id} is superseded by campaign {by}: {reason}"
            )?;
        }
    }
    Ok(())
}

fn print_json(out: &mut impl Write, value: &impl serde::Serialize) -> Result<()> {
    writeln!(out, "{}", serde_json::to_string_pretty(value)?)?;
    Ok(())
}

/// The campaign of `input`: a session identified now (its files digested), or an identify
/// JSON (whose machine and session files the history cannot know).
fn campaign_of(input: &Path, machine: &str, date: Option<Timestamp>) -> Result<Campaign> {
    if input.extension().is_some_and(|e| e == "json") {
        let text = std::fs::read_to_string(input)
            .with_context(|| format!("cannot read {}", input.display()))?;
        let date = match date {
            Some(date) => date,
            None => mtcal_history::newest_modification(&[input])?,
        };
        return Ok(Campaign::from_identify_json(&text, machine, date)?);
    }
    let outcome =
        Prepared::load(input, PipelineOptions::default())?.run(&mut mtcal_solve::Silent)?;
    let session = &outcome.study.session;
    let mut session_files = vec![session.manifest.as_path()];
    session_files.extend(session.runs.iter().map(|r| r.file.as_path()));
    let provenance = mtcal_history::Provenance {
        session_files: &session_files,
        machine_source: &outcome.study.machine.source,
        error_model_source: &outcome.study.machine.config_source,
        mtcal_version: env!("CARGO_PKG_VERSION"),
    };
    Ok(Campaign::from_identified_session(
        &outcome.to_json(),
        machine,
        date,
        &provenance,
    )?)
}

/// The parameter limits of an acceptance file's `[parameters]` table.
fn limits(tolerances: Option<&Path>) -> Result<Limits> {
    let Some(path) = tolerances else {
        return Ok(Limits::default());
    };
    let t = mtcal_acceptance::Tolerances::read(path)?;
    Ok(Limits {
        limits: t
            .parameters
            .iter()
            .map(|p| (p.name.clone(), p.limit))
            .collect(),
        guard_band: t.rule == mtcal_acceptance::DecisionRule::Iso14253_1,
    })
}

/// One machine's page: its fleet row and a trend plot per parameter.
fn machine_page(
    store: &Store,
    machine: &str,
    params: &[String],
    limits: &Limits,
    max_interval_days: f64,
) -> Result<mtcal_report::HistoryPage> {
    Ok(mtcal_report::HistoryPage {
        title: format!("mtcal history — {machine}"),
        source: store.location().to_string(),
        trends: mtcal_history::machine_trends(store, machine, params, limits, max_interval_days)?
            .into_iter()
            .map(trend_plot)
            .collect(),
        fleet: mtcal_history::fleet_view(store, limits)?
            .iter()
            .filter(|l| l.machine == machine)
            .map(fleet_entry)
            .collect(),
        drifts: Vec::new(),
    })
}

/// The fleet page: every machine's row with the drift rates of `params` (default: the
/// parameters the tolerances name).
fn fleet_page(
    store: &Store,
    params: &[String],
    limits: &Limits,
    max_interval_days: f64,
) -> Result<mtcal_report::HistoryPage> {
    let fleet = mtcal_history::fleet_view(store, limits)?;
    Ok(mtcal_report::HistoryPage {
        title: "mtcal history — fleet".to_string(),
        source: store.location().to_string(),
        drifts: mtcal_history::fleet_drift_rates(store, &fleet, params, limits, max_interval_days)?,
        fleet: fleet.iter().map(fleet_entry).collect(),
        trends: Vec::new(),
    })
}

/// A fleet line as the history page shows it.
fn fleet_entry(line: &mtcal_history::FleetLine) -> mtcal_report::FleetEntry {
    mtcal_report::FleetEntry {
        machine: line.machine.clone(),
        campaigns: line.campaigns,
        last_check_day: line.last_check.strftime("%Y-%m-%d").to_string(),
        out_of_tolerance: line.out_of_tolerance.clone(),
        cannot_decide: line.cannot_decide.clone(),
    }
}

/// A parameter's trend as the history page plots it.
fn trend_plot(view: mtcal_history::TrendView) -> mtcal_report::TrendPlot {
    mtcal_report::TrendPlot {
        points: view
            .points
            .iter()
            .map(|p| mtcal_report::TrendPoint {
                time_s: p.date.as_second() as f64,
                value: p.value,
                u95: p.u95,
                superseded: p.superseded,
            })
            .collect(),
        machine: view.machine,
        parameter: view.parameter,
        unit: view.unit,
        limit: view.limit,
        trend: view.trend,
        not_analysed: view.not_analysed,
    }
}

fn show(store: &Store, machine: &str, json: bool, out: &mut impl Write) -> Result<()> {
    let campaigns = store.campaigns(machine)?;
    if campaigns.is_empty() {
        bail!("the history has no machine `{machine}` (`history list` names them)");
    }
    if json {
        return print_json(out, &campaigns);
    }
    writeln!(out, "{machine}: {} campaigns", campaigns.len())?;
    for c in &campaigns {
        let superseded = c
            .superseded
            .as_ref()
            .map(|s| format!("  superseded by {}: {}", s.by.0, s.reason))
            .unwrap_or_default();
        let converged = if c.fit.converged {
            ""
        } else {
            ", DID NOT CONVERGE"
        };
        writeln!(
            out,
            "  {:<5} {}  rms {:.3} um{converged}{superseded}",
            c.id.0,
            c.date.strftime("%Y-%m-%d %H:%M"),
            c.fit.rms_um,
        )?;
    }
    Ok(())
}

fn trend(
    store: &Store,
    machine: &str,
    param: Option<&str>,
    limits: &Limits,
    max_interval_days: f64,
    json: bool,
    out: &mut impl Write,
) -> Result<()> {
    let names: Vec<String> = match param {
        Some(p) => vec![p.to_string()],
        None => mtcal_history::latest_parameters(store, machine)?,
    };
    let mut views = Vec::with_capacity(names.len());
    for name in &names {
        views.push(mtcal_history::trend_view(
            store,
            machine,
            name,
            limits,
            max_interval_days,
        )?);
    }
    if json {
        return print_json(out, &views);
    }
    if param.is_some() {
        write!(out, "{}", views[0])?;
    } else {
        for v in &views {
            writeln!(out, "{}", v.one_line())?;
        }
    }
    Ok(())
}
