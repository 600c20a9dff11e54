//! What the history says, for a person and for the JSON: one parameter's trend
//! ([`trend_view`]) and the fleet against its tolerances ([`fleet_view`]). The statistics are
//! `mtcal-trend`'s; this module picks the series out of the store and words the result.

use crate::{Error, FleetRow, ParameterStatus, SeriesPoint, Store, Timestamp};
use mtcal_trend::{Conformity, NextCheckReason, Point, Tolerance, Trend, TrendOptions, Verdict};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::{self, Write as _};

/// Tolerances on identified parameters: the limit on `|value|` per parameter name, in the
/// parameter's own unit (µm, µrad), and whether ISO 14253-1's guard band applies.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Limits {
    pub limits: BTreeMap<String, f64>,
    pub guard_band: bool,
}

impl Limits {
    fn tolerance(&self, parameter: &str) -> Option<Tolerance> {
        self.limits.get(parameter).map(|&limit| Tolerance {
            limit,
            guard_band: self.guard_band,
        })
    }
}

/// The parameters of `machine`'s latest campaign, in its order.
pub fn latest_parameters(store: &Store, machine: &str) -> Result<Vec<String>, Error> {
    let row = store
        .fleet()?
        .into_iter()
        .find(|r| r.machine == machine)
        .ok_or_else(|| Error::UnknownMachine {
            location: store.location().to_string(),
            name: machine.to_string(),
        })?;
    Ok(row.parameters.into_iter().map(|p| p.name).collect())
}

/// The trends of `machine`'s `parameters` (none: those of its latest campaign) that have a
/// value in some campaign: what a machine's history page plots.
pub fn machine_trends(
    store: &Store,
    machine: &str,
    parameters: &[String],
    limits: &Limits,
    max_interval_days: f64,
) -> Result<Vec<TrendView>, Error> {
    let names = if parameters.is_empty() {
        latest_parameters(store, machine)?
    } else {
        parameters.to_vec()
    };
    let mut trends = Vec::with_capacity(names.len());
    for name in &names {
        let view = trend_view(store, machine, name, limits, max_interval_days)?;
        if view.points.iter().any(|p| p.value.is_some()) {
            trends.push(view);
        }
    }
    Ok(trends)
}

/// A machine and its drift rates as text: `(machine, [(parameter, rate)])`.
pub type MachineDrifts = (String, Vec<(String, String)>);

/// Per machine of `fleet`, the drift rate of each of `parameters` (none: those `limits`
/// names) as a line of text, `+0.0120 ± 0.0040 um/day (significant)`; a parameter a machine's
/// model does not have is left out of its list.
pub fn fleet_drift_rates(
    store: &Store,
    fleet: &[FleetLine],
    parameters: &[String],
    limits: &Limits,
    max_interval_days: f64,
) -> Result<Vec<MachineDrifts>, Error> {
    let names: Vec<String> = if parameters.is_empty() {
        limits.limits.keys().cloned().collect()
    } else {
        parameters.to_vec()
    };
    let mut drifts = Vec::with_capacity(fleet.len());
    for line in fleet {
        let mut rates = Vec::new();
        for name in &names {
            let view = match trend_view(store, &line.machine, name, limits, max_interval_days) {
                Err(Error::UnknownParameter { .. }) => continue,
                view => view?,
            };
            if let Some(t) = &view.trend {
                rates.push((name.clone(), drift_text(t, view.unit.as_deref())));
            }
        }
        drifts.push((line.machine.clone(), rates));
    }
    Ok(drifts)
}

/// A drift rate with its interval, per day, and whether it is significant.
fn drift_text(t: &Trend, unit: Option<&str>) -> String {
    let significant = if t.drift.significant {
        " (significant)"
    } else {
        ""
    };
    format!(
        "{:+.4} ± {:.4} {}/day{significant}",
        t.drift.rate_per_day,
        t.drift.rate_u95_per_day,
        unit.unwrap_or("")
    )
}

/// One parameter of one machine over its campaigns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrendView {
    pub machine: String,
    pub parameter: String,
    pub unit: Option<String>,
    /// Every campaign's entry, superseded and unidentifiable ones included, in date order.
    pub points: Vec<SeriesPoint>,
    /// The limit on `|value|`, when one is known.
    pub limit: Option<f64>,
    /// The analysis of the identified, not superseded values.
    pub trend: Option<Trend>,
    /// Why there is no analysis (too few values…).
    pub not_analysed: Option<String>,
}

/// The trend of `parameter` of `machine`: its series and what `mtcal-trend` says of the values
/// that count (identified, not superseded).
pub fn trend_view(
    store: &Store,
    machine: &str,
    parameter: &str,
    limits: &Limits,
    max_interval_days: f64,
) -> Result<TrendView, Error> {
    let points = store.series(machine, parameter)?;
    let counted = counted_points(&points);
    let options = TrendOptions {
        tolerance: limits.tolerance(parameter),
        max_interval_days,
        ..TrendOptions::default()
    };
    let (trend, not_analysed) = match mtcal_trend::analyse(&counted, &options) {
        Ok(trend) => (Some(trend), None),
        Err(e) => (None, Some(e.to_string())),
    };
    Ok(TrendView {
        machine: machine.to_string(),
        parameter: parameter.to_string(),
        unit: points.iter().find_map(|p| p.unit.clone()),
        limit: limits.limits.get(parameter).copied(),
        points,
        trend,
        not_analysed,
    })
}

impl TrendView {
    /// One line: the parameter, its latest value, the drift and the verdict.
    pub fn one_line(&self) -> String {
        let unit = self.unit.as_deref().unwrap_or("");
        let latest = self
            .points
            .iter()
            .rev()
            .find(|p| !p.superseded && p.verdict.is_none())
            .map_or_else(
                || "no campaign".to_string(),
                |p| match (p.value, p.u95) {
                    (Some(v), Some(u)) => format!("{v:.3} ± {u:.3} {unit}"),
                    _ => status_words(p.status).to_string(),
                },
            );
        let said = match (&self.trend, &self.not_analysed) {
            (Some(t), _) => {
                let verdict = match t.verdict {
                    Verdict::NoChange => "no change",
                    Verdict::Drift => "DRIFT",
                    Verdict::Step => "STEP",
                };
                format!(
                    "drift {:+.4} ± {:.4} {unit}/day: {verdict}",
                    t.drift.rate_per_day, t.drift.rate_u95_per_day
                )
            }
            (None, Some(why)) => format!("no trend ({why})"),
            (None, None) => String::new(),
        };
        format!("{:<12} latest {latest:<24} {said}", self.parameter)
    }
}

/// The values that count ([`SeriesPoint::counts`]): identified, from a fit that is a
/// calibration, not superseded.
fn counted_points(points: &[SeriesPoint]) -> Vec<Point> {
    points
        .iter()
        .filter(|p| p.counts())
        .filter_map(|p| Some(Point::new(p.date.as_second() as f64, p.value?, p.u95?)))
        .collect()
}

impl fmt::Display for TrendView {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let unit = self.unit.as_deref().unwrap_or("");
        writeln!(
            f,
            "{} of {}: {} campaigns, {} with a value",
            self.parameter,
            self.machine,
            self.points.len(),
            self.points.iter().filter(|p| p.value.is_some()).count()
        )?;
        let not_calibrations = self.points.iter().filter(|p| p.verdict.is_some()).count();
        if not_calibrations > 0 {
            writeln!(
                f,
                "{not_calibrations} campaign(s) not counted: their fit is not a calibration \
                 (did not converge, or the model does not explain the recordings)"
            )?;
        }
        if let Some(t) = &self.trend {
            writeln!(f, "{}", verdict_text(t, unit))?;
        }
        if let Some(why) = &self.not_analysed {
            writeln!(f, "no trend: {why}")?;
        }
        if let (Some(limit), Some(t)) = (self.limit, &self.trend) {
            writeln!(f, "{}", tolerance_text(t, limit, unit))?;
        }
        writeln!(f)?;
        let mut significant = self
            .trend
            .iter()
            .flat_map(|t| &t.changes)
            .filter(|c| c.significant)
            .map(|c| c.to);
        let mut next_significant = significant.next();
        let mut counted = 0;
        for p in &self.points {
            let counts = p.counts();
            let mark = if counts && next_significant == Some(counted) {
                next_significant = significant.next();
                "  changed from the one before (E_n > 1)"
            } else {
                ""
            };
            if counts {
                counted += 1;
            }
            writeln!(f, "  {}{mark}", point_text(p, unit))?;
        }
        Ok(())
    }
}

/// `2026-03-01  campaign 12  12.300 ± 1.100 µm` (or why there is no value).
fn point_text(p: &SeriesPoint, unit: &str) -> String {
    let value = match (p.status, p.value, p.u95) {
        (_, Some(v), Some(u)) => format!("{v:>10.3} ± {u:.3} {unit}"),
        (status, _, _) => format!("{:>10}", status_words(status)),
    };
    let superseded = if p.superseded { "  (superseded)" } else { "" };
    let not_counted = if p.verdict.is_some() {
        "  (not counted: the fit is not a calibration)"
    } else {
        ""
    };
    format!(
        "{}  campaign {:<5} {value}{superseded}{not_counted}",
        day(p.date),
        p.campaign.0
    )
}

fn status_words(status: ParameterStatus) -> &'static str {
    match status {
        ParameterStatus::NotIdentifiable => "not identifiable",
        ParameterStatus::Combination => "only in a combination",
        _ => "no value",
    }
}

/// The date of `t`, `2026-03-01`.
fn day(t: Timestamp) -> String {
    t.strftime("%Y-%m-%d").to_string()
}

fn day_of_s(time_s: f64) -> String {
    Timestamp::from_second(time_s.round() as i64).map_or_else(|_| format!("{time_s} s"), day)
}

/// The drift, the step and which the data prefer, in words.
fn verdict_text(t: &Trend, unit: &str) -> String {
    let d = &t.drift;
    let mut s = format!(
        "drift {:+.4} ± {:.4} {unit}/day{} (χ²/dof {:.2}{})",
        d.rate_per_day,
        d.rate_u95_per_day,
        if d.significant { ", significant" } else { "" },
        d.scatter.chi2 / (d.scatter.dof.max(1) as f64),
        if d.scatter.inflated {
            ": scatter beyond the stated u95, interval widened"
        } else {
            ""
        },
    );
    if let Some(step) = &t.step {
        let _ = write!(
            s,
            "\nbest step between {} and {}: {:+.3} ± {:.3} {unit} (p = {:.3})",
            day_of_s(step.time_before_s),
            day_of_s(step.time_after_s),
            step.shift,
            step.shift_u95,
            step.p_value
        );
    }
    let verdict = match t.verdict {
        Verdict::NoChange => "no significant change".to_string(),
        Verdict::Drift => "a steady drift (the data prefer it to a step)".to_string(),
        Verdict::Step => "a step change (the data prefer it to a drift)".to_string(),
    };
    let _ = write!(s, "\nverdict: {verdict}");
    s
}

/// The tolerance and the next check, in words.
fn tolerance_text(t: &Trend, limit: f64, unit: &str) -> String {
    let mut s = format!("tolerance |value| ≤ {limit} {unit}: ");
    match &t.tolerance {
        Some(status) if status.first_out.is_some() => s.push_str("crossed"),
        Some(status) if status.first_undecided.is_some() => {
            s.push_str("within, but some results cannot be decided (inside by less than U)")
        }
        _ => s.push_str("within"),
    }
    if let Some(next) = &t.next_check {
        let why = match next.reason {
            NextCheckReason::NoSignificantDrift => "no significant drift: the maximum interval",
            NextCheckReason::DriftReachesLimit => {
                "when the drift (at its upper 95 % bound) reaches the limit"
            }
            NextCheckReason::CappedByMaximumInterval { .. } => {
                "the maximum interval, before the drift reaches the limit"
            }
            NextCheckReason::AlreadyAtLimit => "now: the latest result is at the limit",
        };
        let _ = write!(
            s,
            "; next check {} (in {:.0} days: {why})",
            day_of_s(next.time_s),
            next.interval_days
        );
    }
    s
}

/// A machine of the fleet and its parameters beyond their tolerances at its latest campaign.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FleetLine {
    pub machine: String,
    pub campaigns: u64,
    pub last_check: Timestamp,
    /// Parameters of the latest campaign proven beyond their limit.
    pub out_of_tolerance: Vec<String>,
    /// Parameters of the latest campaign within their limit by less than U (guard band).
    pub cannot_decide: Vec<String>,
}

/// The fleet: every machine's latest campaign against `limits`, in machine order.
pub fn fleet_view(store: &Store, limits: &Limits) -> Result<Vec<FleetLine>, Error> {
    Ok(store
        .fleet()?
        .into_iter()
        .map(|row| fleet_line(row, limits))
        .collect())
}

fn fleet_line(row: FleetRow, limits: &Limits) -> FleetLine {
    let mut out_of_tolerance = Vec::new();
    let mut cannot_decide = Vec::new();
    for p in &row.parameters {
        let (Some(tolerance), Some(value), Some(u95)) = (limits.tolerance(&p.name), p.value, p.u95)
        else {
            continue;
        };
        let point = Point::new(
            row.latest.date.as_second() as f64,
            value,
            u95.max(f64::MIN_POSITIVE),
        );
        match mtcal_trend::conformity(&point, &tolerance) {
            Ok(Conformity::OutOfTolerance) => out_of_tolerance.push(p.name.clone()),
            Ok(Conformity::CannotDecide) => cannot_decide.push(p.name.clone()),
            _ => {}
        }
    }
    FleetLine {
        machine: row.machine,
        campaigns: row.campaigns,
        last_check: row.latest.date,
        out_of_tolerance,
        cannot_decide,
    }
}

/// The fleet table, one line per machine.
pub fn fleet_text(lines: &[FleetLine]) -> String {
    let mut s = format!(
        "{:<24} {:>9}  {:<10}  {}\n",
        "machine", "campaigns", "last check", "beyond tolerance (cannot decide)"
    );
    for l in lines {
        let mut beyond = l.out_of_tolerance.join(", ");
        if !l.cannot_decide.is_empty() {
            let _ = write!(beyond, " ({})", l.cannot_decide.join(", "));
        }
        let _ = writeln!(
            s,
            "{:<24} {:>9}  {:<10}  {}",
            l.machine,
            l.campaigns,
            day(l.last_check),
            if beyond.is_empty() {
                "-"
            } else {
                beyond.trim()
            }
        );
    }
    s
}

/// One parameter over the checks of one day (source 000: repeated quick R-tests while the
/// machine warms up): the first-order trajectory and, with recorded temperatures, the
/// parameter's sensitivity to temperature.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ThermalView {
    pub machine: String,
    pub parameter: String,
    pub unit: Option<String>,
    /// The day, `2026-03-01` (UTC).
    pub day: String,
    /// The checks of that day that count (identified, not superseded), in time order.
    pub checks: usize,
    pub trajectory: Option<mtcal_trend::Trajectory>,
    /// Why there is no trajectory.
    pub not_determined: Option<String>,
    pub sensitivity: Option<mtcal_trend::Sensitivity>,
}

/// The same-day trajectory of `parameter` of `machine` on `day` (`YYYY-MM-DD`, UTC; default
/// the day of its latest campaign).
pub fn thermal_view(
    store: &Store,
    machine: &str,
    parameter: &str,
    day: Option<&str>,
) -> Result<ThermalView, Error> {
    let series = store.series(machine, parameter)?;
    let temperatures: BTreeMap<i64, f64> = store
        .campaigns(machine)?
        .iter()
        .filter_map(|c| c.temperature_c.map(|t| (c.id.0, t)))
        .collect();
    let day = match day {
        Some(d) => d.to_string(),
        None => series
            .last()
            .map_or_else(String::new, |p| self::day(p.date)),
    };
    let points: Vec<Point> = series
        .iter()
        .filter(|p| p.counts() && self::day(p.date) == day)
        .filter_map(|p| {
            let point = Point::new(p.date.as_second() as f64, p.value?, p.u95?);
            Some(match temperatures.get(&p.campaign.0) {
                Some(&t) => point.with_temperature_c(t),
                None => point,
            })
        })
        .collect();
    let (trajectory, not_determined) =
        match mtcal_trend::fit_thermal(&points, &mtcal_trend::ThermalOptions::default()) {
            Ok(mtcal_trend::ThermalFit::Determined(t)) => (Some(t), None),
            Ok(mtcal_trend::ThermalFit::NotDetermined(why)) => (None, Some(why.to_string())),
            Err(e) => (None, Some(e.to_string())),
        };
    let all_have_temperature =
        !points.is_empty() && points.iter().all(|p| p.temperature_c.is_some());
    let sensitivity = if all_have_temperature {
        mtcal_trend::temperature_sensitivity(&points).ok().flatten()
    } else {
        None
    };
    Ok(ThermalView {
        machine: machine.to_string(),
        parameter: parameter.to_string(),
        unit: series.iter().find_map(|p| p.unit.clone()),
        day,
        checks: points.len(),
        trajectory,
        not_determined,
        sensitivity,
    })
}

impl fmt::Display for ThermalView {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let unit = self.unit.as_deref().unwrap_or("");
        write!(
            f,
            "{} of {} on {}: {} checks",
            self.parameter, self.machine, self.day, self.checks
        )?;
        match (&self.trajectory, &self.not_determined) {
            (Some(t), _) => write!(
                f,
                "; time constant {:.1} min ({:.1}…{:.1}), still to come at the first check \
                 {:+.3} ± {:.3} {unit}, settles at {:.3} ± {:.3} {unit}",
                t.tau_min,
                t.tau_low_min,
                t.tau_high_min,
                t.amplitude,
                t.amplitude_u95,
                t.settled_value,
                t.settled_value_u95
            )?,
            (None, Some(why)) => write!(f, "; {why}")?,
            (None, None) => {}
        }
        if let Some(s) = &self.sensitivity {
            write!(
                f,
                "; {:+.3} ± {:.3} {unit}/K with the recorded temperature",
                s.per_kelvin, s.u95_per_kelvin
            )?;
        }
        Ok(())
    }
}
