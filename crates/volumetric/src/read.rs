//! A session folder's runs of point visits (an R-test's, ball on the table) read into
//! [`Visits`]: every row a visit of its point. Which instruments' runs those are, their reading
//! columns and the set-up that reads along the machine's axes, their plugins declare
//! ([`PointVisits`]).

use std::collections::BTreeMap;
use std::path::Path;

use mtcal_plugins::capability::{PointVisits, declared_some};
use mtcal_session::{RunColumns, RunSpec, RunTable, RunUse, Session, SetupRef};

use crate::VolumetricError;
use crate::points::{Point, Visit, Visits, check_point};

/// The rotary axes, by the contract's letters.
const ROTARY: [char; 3] = ['A', 'B', 'C'];
/// Rotary positions are told apart to this many degrees.
const ROTARY_DECIMALS: i32 = 3;

/// One run's rows, with what names its point.
struct RunRows {
    spec: RunSpec,
    setup: String,
    table: RunTable,
}

/// Reads the session at `dir` (a folder or its `session.toml`): its machine's axes, every run
/// of point visits (ball on the table) row by row. Runs of other instruments are left out and
/// named in [`Visits::notes`].
pub fn read_session(dir: &Path) -> Result<Visits, VolumetricError> {
    let session = mtcal_session::load_session(dir)?;
    let axes = machine_axes(&session)?;
    let kinds = declared_some::<PointVisits>()?;
    let kind_of = |r: &RunSpec| kinds.iter().copied().find(|k| k.instrument == r.instrument);
    let (visited, others): (Vec<&RunSpec>, Vec<&RunSpec>) =
        session.runs.iter().partition(|r| kind_of(r).is_some());
    let instruments = kinds
        .iter()
        .map(|k| k.instrument)
        .collect::<Vec<_>>()
        .join(" or ");
    if visited.is_empty() {
        return Err(VolumetricError::invalid(
            session.manifest.display().to_string(),
            format!(
                "no {instruments} run (found {}): a volumetric thermal test is a session of \
                 {instruments} runs, ball on the table (docs/VOLUMETRIC.md)",
                describe_runs(&others)
            ),
        ));
    }
    let mut runs = Vec::with_capacity(visited.len());
    for spec in visited {
        let kind = kind_of(spec).expect("partitioned by it");
        runs.push(read_run(&session, spec, kind, &axes)?);
    }
    let varying = varying_rotary(&runs);
    let points = points_of(&runs, &varying)?;
    let mut notes = Vec::new();
    if !others.is_empty() {
        notes.push(format!(
            "left out: {} (only {instruments} runs are ball visits)",
            describe_runs(&others)
        ));
    }
    Ok(Visits {
        session: session.dir.clone(),
        machine: session.machine.clone(),
        points,
        stated_sigma_um: stated_sigma(&session, &runs),
        notes,
    })
}

fn describe_runs(runs: &[&RunSpec]) -> String {
    if runs.is_empty() {
        return "no run".into();
    }
    let names: Vec<String> = runs
        .iter()
        .take(4)
        .map(|r| format!("`{}` ({})", r.name, r.instrument))
        .collect();
    let more = runs.len().saturating_sub(4);
    match more {
        0 => names.join(", "),
        _ => format!("{} and {more} more", names.join(", ")),
    }
}

/// The machine's axis letters (the run files' position columns).
fn machine_axes(session: &Session) -> Result<Vec<char>, VolumetricError> {
    let arg = match &session.machine_path {
        Some(p) => p.to_string_lossy().into_owned(),
        None => session.machine.clone(),
    };
    let loaded = mtcal_machine::load_machine(&arg, mtcal_machine::topology::Reading::FromWorkpiece)
        .map_err(|cause| VolumetricError::Machine {
            manifest: session.manifest.clone(),
            machine: session.machine.clone(),
            cause: Box::new(cause),
        })?;
    Ok(loaded.machine.letters().chars().collect())
}

/// One run of point visits: its set-up (ball on the table) and its rows, every reading
/// present.
fn read_run(
    session: &Session,
    spec: &RunSpec,
    kind: &PointVisits,
    axes: &[char],
) -> Result<RunRows, VolumetricError> {
    let setup = match &spec.setup {
        SetupRef::Shared(name) => name.clone(),
        SetupRef::Own(_) => spec.name.clone(),
    };
    refuse_other_axes(session, spec, &setup, kind)?;
    let cols = RunColumns {
        axes,
        readings: &kind.readings,
        readings_optional: spec.use_ == RunUse::Validate,
        labels: &[],
    };
    let table = mtcal_session::read_run(&spec.file, &cols)?;
    if table.values.is_none() {
        return Err(VolumetricError::invalid(
            spec.file.display().to_string(),
            format!(
                "run `{}` has no readings ({}): every visit's reading is needed; leave the run \
                 out of the session or give its readings",
                spec.name,
                kind.readings.join(", ")
            ),
        ));
    }
    Ok(RunRows {
        spec: spec.clone(),
        setup,
        table,
    })
}

/// Refuses a set-up whose readings are not along the machine's axes (an R-test's nest on the
/// table turns with it): the deformation is read in machine directions.
fn refuse_other_axes(
    session: &Session,
    spec: &RunSpec,
    setup: &str,
    kind: &PointVisits,
) -> Result<(), VolumetricError> {
    let machine = &kind.machine_axes;
    let value = session.setup_of(spec).get(machine.key);
    let Some(value) = value.filter(|v| v.as_str() != Some(machine.value)) else {
        return Ok(());
    };
    let at = session
        .setup_location(setup, machine.key)
        .map_or_else(|| spec.location.to_string(), ToString::to_string);
    Err(VolumetricError::invalid(
        at,
        format!(
            "run `{}`: {key} = {value}: the volumetric evaluation reads {} ({key} = \"{}\"), whose \
             axes are the machine's",
            spec.name,
            machine.words,
            machine.value,
            key = machine.key,
        ),
    ))
}

/// The rotary axes whose commanded position is not the same in every row: what tells the
/// points of one ball apart.
fn varying_rotary(runs: &[RunRows]) -> Vec<(char, usize)> {
    let Some(first) = runs.first() else {
        return Vec::new();
    };
    first
        .table
        .axes
        .iter()
        .enumerate()
        .filter(|(_, a)| ROTARY.contains(a))
        .filter(|&(i, _)| {
            let mut values = runs
                .iter()
                .flat_map(|r| (0..r.table.len()).map(move |k| rounded(r.table.q_row(k)[i])));
            let v0 = values.next();
            values.any(|v| Some(v) != v0)
        })
        .map(|(i, &a)| (a, i))
        .collect()
}

/// Degrees rounded to [`ROTARY_DECIMALS`], as an integer key (thousandths).
fn rounded(deg: f64) -> i64 {
    (deg * 10f64.powi(ROTARY_DECIMALS)).round() as i64
}

fn point_name(setup: &str, rotary: &[(char, f64)]) -> String {
    let mut name = setup.to_string();
    for (k, (axis, deg)) in rotary.iter().enumerate() {
        name.push(if k == 0 { '@' } else { ',' });
        name.push(*axis);
        name.push_str(&format!("{deg}"));
    }
    name
}

/// Every row a visit of its point (set-up, rotary positions); the points' visits in time
/// order, checked; points ordered by their first visit.
fn points_of(runs: &[RunRows], varying: &[(char, usize)]) -> Result<Vec<Point>, VolumetricError> {
    type Key = (String, Vec<i64>);
    let mut by_key: BTreeMap<Key, (Vec<Visit>, Vec<[f64; 3]>)> = BTreeMap::new();
    let xyz: Vec<Option<usize>> = ['X', 'Y', 'Z']
        .iter()
        .map(|l| runs[0].table.axes.iter().position(|a| a == l))
        .collect();
    for run in runs {
        let table = &run.table;
        for k in 0..table.len() {
            let q = table.q_row(k);
            let key = (
                run.setup.clone(),
                varying.iter().map(|&(_, i)| rounded(q[i])).collect(),
            );
            let reading = table.reading_row(k).unwrap_or(&[0.0; 3]);
            let entry = by_key.entry(key).or_default();
            entry.0.push(Visit {
                t_s: table.t[k],
                reading_um: [reading[0], reading[1], reading[2]],
                run: run.spec.name.clone(),
                row: k,
            });
            entry
                .1
                .push([0, 1, 2].map(|c| xyz[c].map_or(0.0, |i| q[i])));
        }
    }
    let mut points = Vec::with_capacity(by_key.len());
    for ((setup, rot), (mut visits, positions)) in by_key {
        visits.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        let rotary_deg: Vec<(char, f64)> = varying
            .iter()
            .zip(&rot)
            .map(|(&(axis, _), &r)| (axis, r as f64 / 10f64.powi(ROTARY_DECIMALS)))
            .collect();
        let n = positions.len() as f64;
        let position_mm = [0, 1, 2].map(|c| positions.iter().map(|p| p[c]).sum::<f64>() / n);
        let point = Point {
            name: point_name(&setup, &rotary_deg),
            setup,
            rotary_deg,
            position_mm,
            visits,
        };
        check_point(&point).map_err(|e| locate(e, runs))?;
        points.push(point);
    }
    points.sort_by(|a, b| a.visits[0].t_s.total_cmp(&b.visits[0].t_s));
    Ok(points)
}

/// A point's error with `run \`r\` row k` replaced by the file and its line.
fn locate(e: VolumetricError, runs: &[RunRows]) -> VolumetricError {
    let VolumetricError::Invalid { at, message } = e else {
        return e;
    };
    let located = runs.iter().find_map(|r| {
        let prefix = format!("run `{}` row ", r.spec.name);
        let row: usize = at.strip_prefix(&prefix)?.parse().ok()?;
        Some(file_line(&r.spec.file, row - 1))
    });
    VolumetricError::Invalid {
        at: located.unwrap_or(at),
        message,
    }
}

/// `file:line` of data row `row`.
fn file_line(file: &Path, row: usize) -> String {
    match mtcal_session::row_line(file, row) {
        Some(line) => format!("{}:{line}", file.display()),
        None => file.display().to_string(),
    }
}

/// The smallest and largest `sigma_um` the runs' set-ups state.
fn stated_sigma(session: &Session, runs: &[RunRows]) -> Option<(f64, f64)> {
    let values: Vec<f64> = runs
        .iter()
        .filter_map(|r| {
            let v = session.setup_of(&r.spec).get("sigma_um")?;
            v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
        })
        .filter(|v| v.is_finite())
        .collect();
    let lo = values.iter().copied().reduce(f64::min)?;
    let hi = values.iter().copied().reduce(f64::max)?;
    Some((lo, hi))
}
