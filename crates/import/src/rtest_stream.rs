//! `rtest-stream`: an R-test head's continuous stream, the NC program that drove the
//! measuring cycle and the context log into the per-visit session of docs/VOLUMETRIC.md
//! (source 000's TEVOR step).
//!
//! Steps, each refusing what does not fit with the file and the line, column or time at fault:
//! 1. the session (it must exist): its machine and its ball set-ups, every `[setup.<name>]`
//!    with `ball = [x, y, z]` (mm, workpiece frame) and optional `range_um` (the keys and the
//!    default range are the R-test plugin's, declared as `capability::PointVisits`);
//! 2. the program's dwells ([`crate::nc_dwells`]); each dwell's ball is the set-up whose ball
//!    the nominal tool point (`Machine::tool_in_workpiece` at the dwell's axes) is on, within
//!    [`BALL_MATCH_MM`];
//! 3. the stream `t,dx,dy,dz` cut into plateaus ([`crate::plateaus`]); plateau k is dwell
//!    k mod n (the stream starts at a cycle's first visit: a stream cut both before and after
//!    would shift every visit, which only unequal dwells or timing can show); refused: no
//!    plateau, a plateau shorter than [`SHORT_PLATEAU_SHARE`] of its dwell, a count that is
//!    not a whole number of cycles;
//! 4. the log `t[,S][,T_<name>…]` (any context column a run may hold) interpolated linearly to
//!    each visit's time, never extrapolated;
//! 5. one R-test run per ball (`setup = "<ball>"`, rows in time order: `t`, the machine's
//!    axes as commanded, `dx,dy,dz`, the log's columns), and for each cycle withheld one
//!    validation run per ball `<ball>-c<k>` (cycles numbered from 1), written with their
//!    `[[run]]` tables in one transaction.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use mtcal_kinematics::Machine;
use mtcal_located::{Located, Location};
use mtcal_plugins::capability::{PointVisits, declared_once};
use mtcal_session::{Manifest, ManifestRun, RunTable, RunUse, Session, SetupRef};

use crate::ImportError;
use crate::csv_rows::{HeaderProblem, Row, read_rows};
use crate::nc_dwells::{Dwell, Dwells, read_dwells};
use crate::plateaus::{
    BRIDGE_S, Cut, Cutter, MIN_PLATEAU_SAMPLES, Plateau, SETTLE_FLOOR_UM, SETTLE_SIGMAS,
};
use crate::session;

/// A dwell's nominal tool point lies within this of its ball (mm).
pub const BALL_MATCH_MM: f64 = 1.0;
/// A plateau shorter than this share of its dwell does not belong to it.
pub const SHORT_PLATEAU_SHARE: f64 = 0.5;
/// A gap between plateaus inside a cycle that differs from cycle 1's by more than this (s) and
/// this share marks where the cycles went out of step (for the message only).
const GAP_TOL_S: f64 = 0.5;
const GAP_TOL_SHARE: f64 = 0.25;

/// The stream's columns.
const STREAM_COLUMNS: [&str; 4] = ["t", "dx", "dy", "dz"];

/// What to import, and into which session.
#[derive(Debug, Clone)]
pub struct StreamOptions<'a> {
    /// The head's stream, CSV `t,dx,dy,dz` (s, µm).
    pub stream: &'a Path,
    /// The NC program that drove the cycle.
    pub program: &'a Path,
    /// The context log, CSV `t[,S][,T_<name>…]`; none: no context columns.
    pub log: Option<&'a Path>,
    /// The session folder; its `session.toml` declares the machine and the ball set-ups.
    pub session: &'a Path,
    /// Cycles (numbered from 1 in stream order) written as validation runs `<ball>-c<k>`.
    pub validate_cycles: &'a [usize],
    /// A prefix of the run names (`<prefix>-<ball>`); none: the set-up names.
    pub name: Option<&'a str>,
}

/// A ball set-up of the session.
#[derive(Debug, Clone, PartialEq)]
pub struct Ball {
    /// The set-up's name, `[setup.<name>]`.
    pub setup: String,
    /// `ball`, mm, workpiece frame.
    pub ball_mm: [f64; 3],
    /// `range_um`, µm.
    pub range_um: f64,
}

/// The ball a dwell visits: its index in the balls and the nominal tool point's distance from
/// its centre (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DwellBall {
    pub ball: usize,
    pub distance_mm: f64,
}

/// One visit: a plateau and the dwell it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Visit {
    /// 0-based cycle (the card and the run names count from 1).
    pub cycle: usize,
    /// Index of the program's dwell.
    pub dwell: usize,
    pub plateau: Plateau,
}

/// The context log: its columns besides `t`, in file order, and their values by row.
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    pub path: PathBuf,
    pub names: Vec<String>,
    pub t_s: Vec<f64>,
    /// `columns[c][i]`: column `c` at row `i`.
    pub columns: Vec<Vec<f64>>,
}

/// A run written.
#[derive(Debug, Clone, PartialEq)]
pub struct WrittenRun {
    pub name: String,
    /// The ball's set-up.
    pub setup: String,
    pub file: PathBuf,
    pub use_: RunUse,
    pub rows: usize,
}

/// What [`import_stream`] read, assumed and wrote.
#[derive(Debug, Clone)]
pub struct StreamImported {
    pub program: PathBuf,
    pub dwells: Dwells,
    pub dwell_balls: Vec<DwellBall>,
    pub balls: Vec<Ball>,
    pub stream: PathBuf,
    pub cut: Cut,
    /// The range the stream was cut with (the smallest of the set-ups'), µm.
    pub range_um: f64,
    pub visits: Vec<Visit>,
    pub cycles: usize,
    /// Where the cycles' timing first departs from cycle 1's (s), if it does.
    pub timing_departs_s: Option<f64>,
    pub log: Option<Log>,
    pub validate_cycles: Vec<usize>,
    pub runs: Vec<WrittenRun>,
    pub manifest: PathBuf,
    /// The `[[run]]` entries appended, as TOML.
    pub entries: String,
    /// The instrument the runs are of.
    instrument: &'static str,
}

/// Reads the three files and writes the per-visit runs into the session.
pub fn import_stream(options: &StreamOptions<'_>) -> Result<StreamImported, ImportError> {
    let instrument = declared_once::<PointVisits>()?;
    let session = existing_session(options.session, instrument)?;
    let machine = session::load_machine(&session::machine_arg(&session))?;
    let balls = balls_of(&session, instrument)?;
    let letters: Vec<char> = machine.letters().chars().collect();
    let dwells = read_dwells(options.program, &letters)?;
    let dwell_balls = match_dwells(options.program, &dwells.dwells, &machine, &balls)?;
    let range_um = balls
        .iter()
        .map(|b| b.range_um)
        .fold(f64::INFINITY, f64::min);
    let cut = read_stream(options.stream, range_um)?;
    let visits = map_visits(options.stream, options.program, &cut, &dwells.dwells)?;
    let cycles = visits.len() / dwells.dwells.len();
    let validate_cycles = validation_cycles(options.validate_cycles, cycles)?;
    let log = options.log.map(read_log).transpose()?;
    let context = context_of(log.as_ref(), &visits)?;
    let plan = RunsPlan {
        options,
        instrument,
        machine: &machine,
        dwells: &dwells.dwells,
        dwell_balls: &dwell_balls,
        balls: &balls,
        visits: &visits,
        context: &context,
        log_names: log.as_ref().map_or(&[][..], |l| &l.names),
        validate: &validate_cycles,
    };
    let (runs, manifest_path, entries) = plan.write(&session)?;
    let timing_departs_s =
        timing_departure(&cut.plateaus, dwells.dwells.len()).map(|k| cut.plateaus[k].start_s);
    Ok(StreamImported {
        program: options.program.to_path_buf(),
        timing_departs_s,
        dwells,
        dwell_balls,
        balls,
        stream: options.stream.to_path_buf(),
        cut,
        range_um,
        visits,
        cycles,
        log,
        validate_cycles,
        runs,
        manifest: manifest_path,
        entries,
        instrument: instrument.instrument,
    })
}

fn existing_session(dir: &Path, instrument: &PointVisits) -> Result<Session, ImportError> {
    if !dir.join(mtcal_session::MANIFEST_NAME).is_file() {
        return Err(ImportError::Options(format!(
            "{} has no session.toml: rtest-stream adds to a session that declares the machine \
             and the balls ([setup.<ball>] with {} = [x, y, z])",
            dir.display(),
            instrument.point_key
        )));
    }
    Ok(mtcal_session::load_session_to_extend(dir)?)
}

// ---------------------------------------------------------------------------------------------
// The balls and the dwells

/// The session's ball set-ups: every `[setup.<name>]` with the instrument's point key
/// (`ball`), in name order.
pub fn balls_of(session: &Session, instrument: &PointVisits) -> Result<Vec<Ball>, ImportError> {
    let (point, range) = (instrument.point_key, instrument.range_key);
    let mut balls = Vec::new();
    for (name, table) in &session.setups {
        let Some(value) = table.get(point) else {
            continue;
        };
        let bad = |key: &str, message: String| setup_error(session, name, key, message);
        let ball_mm = three_numbers(value).ok_or_else(|| {
            bad(
                point,
                format!("expected {point} = [x, y, z] (mm, three numbers), found {value}"),
            )
        })?;
        let range_um = match table.get(range) {
            None => instrument.default_range_um,
            Some(v) => number(v)
                .filter(|r| *r > 0.0)
                .ok_or_else(|| bad(range, format!("expected {range} above 0 (µm), found {v}")))?,
        };
        balls.push(Ball {
            setup: name.clone(),
            ball_mm,
            range_um,
        });
    }
    if balls.is_empty() {
        return Err(ImportError::Options(format!(
            "{}: expected ball set-ups ([setup.<ball>] with {point} = [x, y, z]), found none",
            session.manifest.display()
        )));
    }
    Ok(balls)
}

fn setup_error(session: &Session, setup: &str, key: &str, message: String) -> ImportError {
    match session.setup_location(setup, key) {
        Some(at) => ImportError::Invalid(Located {
            at: at.clone(),
            message: format!("[setup.{setup}] {message}"),
        }),
        None => ImportError::Options(format!(
            "{}: [setup.{setup}] {message}",
            session.manifest.display()
        )),
    }
}

fn number(v: &toml::Value) -> Option<f64> {
    let x = match v {
        toml::Value::Float(f) => *f,
        toml::Value::Integer(i) => *i as f64,
        _ => return None,
    };
    x.is_finite().then_some(x)
}

fn three_numbers(v: &toml::Value) -> Option<[f64; 3]> {
    let a = v.as_array()?;
    if a.len() != 3 {
        return None;
    }
    Some([number(&a[0])?, number(&a[1])?, number(&a[2])?])
}

/// Each dwell's ball: the nominal tool point at the dwell's axes within [`BALL_MATCH_MM`] of
/// exactly one set-up's ball, the axes within their limits; else an error at the `G4`.
pub fn match_dwells(
    program: &Path,
    dwells: &[Dwell],
    machine: &Machine,
    balls: &[Ball],
) -> Result<Vec<DwellBall>, ImportError> {
    dwells
        .iter()
        .map(|d| {
            let fail = |message: String| {
                ImportError::Invalid(Located {
                    at: Location::at(program, d.line, d.column),
                    message,
                })
            };
            check_limits(machine, &d.axes).map_err(&fail)?;
            ball_of(machine, &d.axes, balls).map_err(fail)
        })
        .collect()
}

fn check_limits(machine: &Machine, axes: &[f64]) -> Result<(), String> {
    for (a, &v) in machine.axes().iter().zip(axes) {
        let Some((lo, hi)) = a.limits() else { continue };
        let (lo, hi) = (a.kind().to_file(lo), a.kind().to_file(hi));
        if v < lo - session::LIMIT_TOL_MM || v > hi + session::LIMIT_TOL_MM {
            return Err(format!(
                "expected axis {} within its limits {lo} … {hi} at this dwell, found {v}",
                a.letter().as_char()
            ));
        }
    }
    Ok(())
}

fn ball_of(machine: &Machine, axes: &[f64], balls: &[Ball]) -> Result<DwellBall, String> {
    let q: Vec<f64> = machine
        .axes()
        .iter()
        .zip(axes)
        .map(|(a, &v)| a.kind().from_file(v))
        .collect();
    let p = machine.tool_in_workpiece(&q).t * 1e3;
    let distance = |b: &Ball| {
        let d = [p.x - b.ball_mm[0], p.y - b.ball_mm[1], p.z - b.ball_mm[2]];
        d.iter().map(|v| v * v).sum::<f64>().sqrt()
    };
    let mut by_distance: Vec<(f64, usize)> = balls
        .iter()
        .enumerate()
        .map(|(i, b)| (distance(b), i))
        .collect();
    by_distance.sort_by(|a, b| a.0.total_cmp(&b.0));
    let Some(&(d0, i0)) = by_distance.first() else {
        return Err("expected ball set-ups in the session, found none".to_string());
    };
    let point = format!("({:.3}, {:.3}, {:.3}) mm", p.x, p.y, p.z);
    if d0 > BALL_MATCH_MM {
        return Err(format!(
            "expected the nominal tool point on a set-up's ball (within {BALL_MATCH_MM} mm), \
             found it at {point} (workpiece frame), {d0:.3} mm from the nearest, `{}`",
            balls[i0].setup
        ));
    }
    if let Some(&(d1, i1)) = by_distance.get(1).filter(|(d, _)| *d <= BALL_MATCH_MM) {
        return Err(format!(
            "expected the nominal tool point on one set-up's ball, found it at {point} on \
             two: `{}` ({d0:.3} mm) and `{}` ({d1:.3} mm)",
            balls[i0].setup, balls[i1].setup
        ));
    }
    Ok(DwellBall {
        ball: i0,
        distance_mm: d0,
    })
}

// ---------------------------------------------------------------------------------------------
// The stream

/// Where each of `t, dx, dy, dz` is in the stream's header.
fn stream_layout(names: &[String]) -> Result<[usize; 4], HeaderProblem> {
    let mut index = [usize::MAX; 4];
    for (k, name) in names.iter().enumerate() {
        let unknown = || {
            (
                k,
                format!("expected the columns t, dx, dy, dz (in any order), found \"{name}\""),
            )
        };
        let c = STREAM_COLUMNS
            .iter()
            .position(|s| s == name)
            .ok_or_else(unknown)?;
        if index[c] != usize::MAX {
            return Err((
                k,
                format!("expected each column once, found \"{name}\" twice"),
            ));
        }
        index[c] = k;
    }
    if let Some(c) = index.iter().position(|&i| i == usize::MAX) {
        return Err((
            usize::MAX,
            format!(
                "expected the columns t, dx, dy, dz, found no \"{}\"",
                STREAM_COLUMNS[c]
            ),
        ));
    }
    Ok(index)
}

/// Cuts the stream at `path` into plateaus, readings on the ball inside `±range_um`.
pub fn read_stream(path: &Path, range_um: f64) -> Result<Cut, ImportError> {
    let mut cutter = Cutter::new(range_um);
    let mut last_t: Option<f64> = None;
    let (_, rows) = read_rows(path, stream_layout, |index, row| {
        let t = increasing_time(row, index[0], last_t)?;
        last_t = Some(t);
        let reading = match [
            row.cells[index[1]],
            row.cells[index[2]],
            row.cells[index[3]],
        ] {
            [Some(dx), Some(dy), Some(dz)] => Some([dx, dy, dz]),
            // An empty cell: the sensor is off the ball.
            _ => None,
        };
        cutter.push(t, reading);
        Ok(())
    })?;
    if rows == 0 {
        return Err(crate::csv_rows::located(
            path,
            2,
            1,
            "expected samples after the header, found none",
        ));
    }
    Ok(cutter.finish())
}

/// The row's time in cell `k`: present and after `last`.
fn increasing_time(row: &Row<'_>, k: usize, last: Option<f64>) -> Result<f64, ImportError> {
    let t = row.cells[k]
        .ok_or_else(|| row.error(k, "column \"t\": expected a time in s, found an empty cell"))?;
    match last {
        Some(prev) if t <= prev => Err(row.error(
            k,
            format!(
                "column \"t\": expected a time after {prev} s (strictly increasing), found {t}"
            ),
        )),
        _ => Ok(t),
    }
}

/// Plateau k as dwell k mod n, refusing a stream that does not follow the program.
pub fn map_visits(
    stream: &Path,
    program: &Path,
    cut: &Cut,
    dwells: &[Dwell],
) -> Result<Vec<Visit>, ImportError> {
    let at = |t_s: f64, message: String| ImportError::AtTime {
        path: stream.to_path_buf(),
        t_s,
        message,
    };
    let n = dwells.len();
    let plateaus = &cut.plateaus;
    if plateaus.is_empty() {
        return Err(at(
            cut.first_s,
            format!(
                "expected plateaus (all three readings on the ball and settled) from here to \
                 t = {} s, found none in {} samples",
                cut.last_s, cut.samples
            ),
        ));
    }
    for (k, p) in plateaus.iter().enumerate() {
        let d = &dwells[k % n];
        if p.duration_s() < SHORT_PLATEAU_SHARE * d.dwell_s {
            return Err(at(
                p.start_s,
                format!(
                    "plateau {} (cycle {}, dwell {} of {n}) lasts {:.3} s, much shorter than its \
                     dwell of {} s ({}:{}): the plateaus do not follow the program (a visit \
                     missing before it, or a G4 P in ms?)",
                    k + 1,
                    k / n + 1,
                    k % n + 1,
                    p.duration_s(),
                    d.dwell_s,
                    program.display(),
                    d.line
                ),
            ));
        }
    }
    if plateaus.len() % n != 0 {
        return Err(incomplete_cycles(stream, plateaus, n));
    }
    Ok(plateaus
        .iter()
        .enumerate()
        .map(|(k, p)| Visit {
            cycle: k / n,
            dwell: k % n,
            plateau: p.clone(),
        })
        .collect())
}

/// The error for a plateau count that is not a whole number of cycles, at the first plateau
/// whose timing departs from cycle 1's, else at the start of the incomplete cycle.
fn incomplete_cycles(stream: &Path, plateaus: &[Plateau], n: usize) -> ImportError {
    let m = plateaus.len();
    let head = format!(
        "expected a whole number of cycles of {n} dwells, found {m} plateaus ({} cycles and {} \
         over)",
        m / n,
        m % n
    );
    let (t_s, message) = match timing_departure(plateaus, n) {
        Some(k) => (
            plateaus[k].start_s,
            format!(
                "{head}; the gap before this plateau differs from cycle 1's: a visit missing or \
                 extra near here?"
            ),
        ),
        None => (
            plateaus[m - m % n].start_s,
            format!("{head}; the incomplete cycle starts here"),
        ),
    };
    ImportError::AtTime {
        path: stream.to_path_buf(),
        t_s,
        message,
    }
}

/// The first plateau (after cycle 1) whose gap to the plateau before it, inside a cycle,
/// differs from the same gap in cycle 1 by more than [`GAP_TOL_S`] and [`GAP_TOL_SHARE`]:
/// the moves between two dwells take the same time in every cycle.
fn timing_departure(plateaus: &[Plateau], n: usize) -> Option<usize> {
    let gap = |k: usize| plateaus[k].start_s - plateaus[k - 1].end_s;
    (n..plateaus.len()).filter(|k| k % n != 0).find(|&k| {
        let reference = gap(k % n);
        (gap(k) - reference).abs() > GAP_TOL_S.max(GAP_TOL_SHARE * reference)
    })
}

// ---------------------------------------------------------------------------------------------
// The log

/// Reads the context log: `t` and context columns (`S`, `F`, `T_<name>`, `P_<name>`,
/// `H_<name>`), every cell a number, `t` strictly increasing.
pub fn read_log(path: &Path) -> Result<Log, ImportError> {
    let mut t_s = Vec::new();
    let mut columns: Vec<Vec<f64>> = Vec::new();
    let ((_, names), rows) = read_rows(path, log_layout, |(t_at, names), row| {
        let t = increasing_time(row, *t_at, t_s.last().copied())?;
        t_s.push(t);
        columns.resize(names.len(), Vec::new());
        let others = (0..row.cells.len()).filter(|k| k != t_at);
        for (c, k) in others.enumerate() {
            let v = row.cells[k].ok_or_else(|| {
                row.error(
                    k,
                    format!(
                        "column \"{}\": expected a number, found an empty cell",
                        names[c]
                    ),
                )
            })?;
            columns[c].push(v);
        }
        Ok(())
    })?;
    if rows == 0 {
        return Err(crate::csv_rows::located(
            path,
            2,
            1,
            "expected rows after the header, found none",
        ));
    }
    columns.resize(names.len(), Vec::new());
    Ok(Log {
        path: path.to_path_buf(),
        names,
        t_s,
        columns,
    })
}

/// Where `t` is in the log's header, and the other columns' names in order.
fn log_layout(names: &[String]) -> Result<(usize, Vec<String>), HeaderProblem> {
    let mut t_at = None;
    let mut others: Vec<String> = Vec::new();
    for (k, name) in names.iter().enumerate() {
        if name == "t" && t_at.is_none() {
            t_at = Some(k);
        } else if name == "t" || others.contains(name) {
            return Err((
                k,
                format!("expected each column once, found \"{name}\" twice"),
            ));
        } else if is_context(name) {
            others.push(name.clone());
        } else {
            return Err((
                k,
                format!(
                    "expected t and context columns (S rpm, F mm/min, T_<name> °C, P_<name> \
                     hPa, H_<name> %), found \"{name}\""
                ),
            ));
        }
    }
    let t_at = t_at.ok_or((
        usize::MAX,
        "expected a column \"t\", found none".to_string(),
    ))?;
    Ok((t_at, others))
}

/// A column name a run file accepts as context (as `mtcal-session` reads them).
fn is_context(name: &str) -> bool {
    let prefixed = ["T_", "P_", "H_"]
        .iter()
        .any(|p| name.starts_with(p) && name.len() > 2);
    prefixed || mtcal_session::CONTEXT_COLUMNS.contains(&name)
}

impl Log {
    /// Every column linearly interpolated to `t_s` (a visit of 0-based `cycle`); a time outside
    /// the log is refused, not extrapolated.
    pub fn at(&self, t_s: f64, cycle: usize) -> Result<Vec<f64>, ImportError> {
        let (first, last) = min_max(self.t_s.iter().copied());
        if !(first..=last).contains(&t_s) {
            return Err(ImportError::AtTime {
                path: self.path.clone(),
                t_s,
                message: format!(
                    "expected the log to cover every visit, found it from t = {first} to {last} \
                     s and a visit (cycle {}) at this time",
                    cycle + 1
                ),
            });
        }
        // The last row at or before t_s.
        let i = self.t_s.partition_point(|&t| t <= t_s) - 1;
        Ok(self
            .columns
            .iter()
            .map(|c| match self.t_s.get(i + 1) {
                Some(&t1) if t_s > self.t_s[i] => {
                    let w = (t_s - self.t_s[i]) / (t1 - self.t_s[i]);
                    c[i] + w * (c[i + 1] - c[i])
                }
                _ => c[i],
            })
            .collect())
    }
}

/// The log's columns at each visit (none without a log).
fn context_of(log: Option<&Log>, visits: &[Visit]) -> Result<Vec<Vec<f64>>, ImportError> {
    match log {
        Some(log) => visits
            .iter()
            .map(|v| log.at(v.plateau.t_s, v.cycle))
            .collect(),
        None => Ok(vec![Vec::new(); visits.len()]),
    }
}

// ---------------------------------------------------------------------------------------------
// The runs

/// The cycles to withhold, sorted: numbered from 1, within the stream, leaving one to fit.
fn validation_cycles(asked: &[usize], cycles: usize) -> Result<Vec<usize>, ImportError> {
    let set: BTreeSet<usize> = asked.iter().copied().collect();
    if let Some(&k) = set.iter().find(|&&k| k == 0 || k > cycles) {
        return Err(ImportError::Options(format!(
            "--validate-cycles {k}: the stream has {cycles} cycles, numbered 1 … {cycles}"
        )));
    }
    if !set.is_empty() && set.len() >= cycles {
        return Err(ImportError::Options(format!(
            "--validate-cycles leaves none of the {cycles} cycles to fit"
        )));
    }
    Ok(set.into_iter().collect())
}

/// Everything the runs are built from.
struct RunsPlan<'a> {
    options: &'a StreamOptions<'a>,
    /// The instrument whose runs are point visits.
    instrument: &'a PointVisits,
    machine: &'a Machine,
    dwells: &'a [Dwell],
    dwell_balls: &'a [DwellBall],
    balls: &'a [Ball],
    visits: &'a [Visit],
    /// The log's values at each visit.
    context: &'a [Vec<f64>],
    log_names: &'a [String],
    validate: &'a [usize],
}

impl RunsPlan<'_> {
    /// Builds the runs and writes them with the session's manifest extended by their
    /// `[[run]]`s, all or nothing; returns what was written, the manifest and the entries.
    fn write(&self, session: &Session) -> Result<(Vec<WrittenRun>, PathBuf, String), ImportError> {
        let (tables, runs) = self.build()?;
        let mut manifest = session.to_manifest();
        let written = check_new_runs(self.options.session, &manifest, &runs, &tables)?;
        let entries = runs.iter().map(session::entry_text).collect::<String>();
        manifest.runs.extend(runs);
        let path = session::write_all(self.options.session, &tables, &manifest)?;
        Ok((written, path, entries))
    }

    /// The run tables and their `[[run]]`s: per ball (in the order the program first visits
    /// them) the fitted cycles, then per withheld cycle each ball.
    fn build(&self) -> Result<(Vec<RunTable>, Vec<ManifestRun>), ImportError> {
        let mut order: Vec<usize> = Vec::new();
        for db in self.dwell_balls {
            if !order.contains(&db.ball) {
                order.push(db.ball);
            }
        }
        let mut tables = Vec::new();
        let mut runs = Vec::new();
        for &b in &order {
            let name = self.base_name(b)?;
            let fit = |v: &Visit| !self.validate.contains(&(v.cycle + 1));
            self.push_run(&mut tables, &mut runs, b, name, RunUse::Fit, fit);
        }
        for &k in self.validate {
            for &b in &order {
                let name = format!("{}-c{k}", self.base_name(b)?);
                let of_cycle = |v: &Visit| v.cycle + 1 == k;
                self.push_run(&mut tables, &mut runs, b, name, RunUse::Validate, of_cycle);
            }
        }
        Ok((tables, runs))
    }

    fn base_name(&self, ball: usize) -> Result<String, ImportError> {
        let setup = &self.balls[ball].setup;
        let name = match self.options.name {
            Some(prefix) => format!("{prefix}-{setup}"),
            None => setup.clone(),
        };
        if !session::is_run_name(&name) {
            return Err(ImportError::Options(format!(
                "run name `{name}` (from set-up `{setup}`): expected letters, digits, `-`, `_` \
                 and `.` (it names the CSV file); give --name or rename the set-up"
            )));
        }
        Ok(name)
    }

    fn push_run(
        &self,
        tables: &mut Vec<RunTable>,
        runs: &mut Vec<ManifestRun>,
        ball: usize,
        name: String,
        use_: RunUse,
        keep: impl Fn(&Visit) -> bool,
    ) {
        let rows: Vec<usize> = (0..self.visits.len())
            .filter(|&i| {
                self.dwell_balls[self.visits[i].dwell].ball == ball && keep(&self.visits[i])
            })
            .collect();
        let file = format!("{name}.csv");
        tables.push(self.table(&rows, self.options.session.join(&file)));
        runs.push(ManifestRun {
            name,
            instrument: self.instrument.instrument.to_string(),
            file,
            use_,
            setup: SetupRef::Shared(self.balls[ball].setup.clone()),
            extra: toml::Table::new(),
        });
    }

    /// The table of the visits `rows` (indices into the visits, in time order).
    fn table(&self, rows: &[usize], path: PathBuf) -> RunTable {
        let mut positions = Vec::new();
        let mut values = Vec::new();
        for &i in rows {
            let v = &self.visits[i];
            positions.extend_from_slice(&self.dwells[v.dwell].axes);
            values.extend_from_slice(&v.plateau.reading_um);
        }
        let context = self
            .log_names
            .iter()
            .enumerate()
            .map(|(c, name)| {
                (
                    name.clone(),
                    rows.iter().map(|&i| self.context[i][c]).collect(),
                )
            })
            .collect();
        RunTable {
            path,
            columns: Vec::new(),
            t: rows.iter().map(|&i| self.visits[i].plateau.t_s).collect(),
            axes: self.machine.letters().chars().collect(),
            positions,
            readings: self.instrument.readings.map(String::from).to_vec(),
            values: Some(values),
            context,
            labels: Vec::new(),
        }
    }
}

/// Refuses names the session has, files that exist and names repeated among the new runs;
/// returns what will be written.
fn check_new_runs(
    dir: &Path,
    manifest: &Manifest,
    runs: &[ManifestRun],
    tables: &[RunTable],
) -> Result<Vec<WrittenRun>, ImportError> {
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    for (run, table) in runs.iter().zip(tables) {
        if !seen.insert(run.name.as_str()) {
            return Err(ImportError::Options(format!(
                "two new runs would be called `{}`: rename a set-up or give --name",
                run.name
            )));
        }
        session::refuse_existing(dir, manifest, &run.name, &run.file)?;
        let setup = match &run.setup {
            SetupRef::Shared(name) => name.clone(),
            SetupRef::Own(_) => String::new(),
        };
        out.push(WrittenRun {
            name: run.name.clone(),
            setup,
            file: dir.join(&run.file),
            use_: run.use_,
            rows: table.len(),
        });
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// The card

impl StreamImported {
    /// What was read, written and assumed, for the command line.
    pub fn card(&self) -> String {
        let mut out = String::new();
        out.push_str(&self.program_line());
        out.push_str(&self.stream_lines());
        out.push_str(&self.log_line());
        out.push_str(&self.written_lines());
        out.push_str(&self.assumptions());
        out
    }

    fn program_line(&self) -> String {
        let d = &self.dwells.dwells;
        let (lo, hi) = min_max(d.iter().map(|d| d.dwell_s));
        let mut line = format!(
            "read {}: {} dwells (lines {} … {}) of {lo} … {hi} s on {} balls",
            self.program.display(),
            d.len(),
            d.first().map_or(0, |d| d.line),
            d.last().map_or(0, |d| d.line),
            self.balls_visited().len()
        );
        if !self.dwells.never_commanded.is_empty() {
            let axes: String = self.dwells.never_commanded.iter().collect();
            line.push_str(&format!("; axes {axes} never commanded: held at 0"));
        }
        if self.dwells.merged > 0 {
            line.push_str(&format!(
                "; {} dwells with no move before them merged into the one before",
                self.dwells.merged
            ));
        }
        line + "\n"
    }

    fn stream_lines(&self) -> String {
        let c = &self.cut;
        let n = self.dwells.dwells.len();
        let mut out = format!(
            "read {}: {} samples, t = {} … {} s; {} plateaus = {} cycles of {n} dwells",
            self.stream.display(),
            c.samples,
            c.first_s,
            c.last_s,
            c.plateaus.len(),
            self.cycles
        );
        if c.passages_without_plateau > 0 {
            out.push_str(&format!(
                "; {} passages on a ball without a plateau (not visits)",
                c.passages_without_plateau
            ));
        }
        let mut durations: Vec<f64> = c.plateaus.iter().map(Plateau::duration_s).collect();
        durations.sort_by(f64::total_cmp);
        let averaged = min_max(c.plateaus.iter().map(|p| p.averaged as f64));
        let shortest = durations.first().copied().unwrap_or(0.0);
        let median = durations
            .get(durations.len().saturating_sub(1) / 2)
            .copied()
            .unwrap_or(0.0);
        out.push_str(&format!(
            "\nplateaus: shortest {shortest:.3} s, median {median:.3} s; {} … {} samples \
             averaged each\n",
            averaged.0, averaged.1
        ));
        let per_ball: Vec<String> = self
            .balls_visited()
            .iter()
            .map(|&b| {
                let visits = self
                    .visits
                    .iter()
                    .filter(|v| self.dwell_balls[v.dwell].ball == b)
                    .count();
                format!("{} {visits}", self.balls[b].setup)
            })
            .collect();
        out.push_str(&format!("visits per ball: {}\n", per_ball.join(", ")));
        if let Some(t) = self.timing_departs_s {
            out.push_str(&format!(
                "note: at t = {t} s the gap between plateaus differs from cycle 1's (check the \
                 visits there)\n"
            ));
        }
        out
    }

    fn log_line(&self) -> String {
        match &self.log {
            Some(log) => format!(
                "read {}: {} rows, t = {} … {} s, columns {}\n",
                log.path.display(),
                log.t_s.len(),
                min_max(log.t_s.iter().copied()).0,
                min_max(log.t_s.iter().copied()).1,
                if log.names.is_empty() {
                    "none but t".to_string()
                } else {
                    log.names.join(", ")
                }
            ),
            None => "no log: the runs have no context columns\n".to_string(),
        }
    }

    fn written_lines(&self) -> String {
        let validate = self
            .runs
            .iter()
            .filter(|r| r.use_ == RunUse::Validate)
            .count();
        let mut out = format!(
            "wrote {} runs ({} fit, {validate} validate) and appended to {}:\n",
            self.runs.len(),
            self.runs.len() - validate,
            self.manifest.display()
        );
        // One line per run: a volumetric test writes one per ball and withheld cycle, too many
        // for their whole TOML entries.
        for r in self.runs.iter() {
            out.push_str(&format!(
                "  {}: {} run {}, setup {}, {}, {} visit{}\n",
                r.file.display(),
                self.instrument,
                r.name,
                r.setup,
                r.use_.as_str(),
                r.rows,
                if r.rows == 1 { "" } else { "s" }
            ));
        }
        out
    }

    fn assumptions(&self) -> String {
        let (far, far_dwell) = self
            .dwell_balls
            .iter()
            .enumerate()
            .map(|(i, d)| (d.distance_mm, i))
            .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
        let ranges: BTreeSet<u64> = self.balls.iter().map(|b| b.range_um.to_bits()).collect();
        let range_note = if ranges.len() > 1 {
            " (the smallest of the set-ups' range_um)"
        } else {
            " (the set-ups' range_um)"
        };
        let validate = if self.validate_cycles.is_empty() {
            "none withheld".to_string()
        } else {
            let k: Vec<String> = self.validate_cycles.iter().map(|k| k.to_string()).collect();
            format!(
                "cycles {} withheld as validation runs <ball>-c<k>",
                k.join(", ")
            )
        };
        let lines = [
            "G4 P and G4 X are seconds (a Fanuc P in ms must be converted); positions absolute \
             (G90) and the machine's axis positions (work offsets G54…G59 and G43 as zero)"
                .to_string(),
            format!(
                "a dwell's ball: the set-up whose ball the nominal tool point is on, within \
                 {BALL_MATCH_MM} mm (farthest {far:.3} mm, {}:{})",
                self.program.display(),
                self.dwells.dwells.get(far_dwell).map_or(0, |d| d.line)
            ),
            format!(
                "off a ball: an empty cell or a reading at or beyond ±{} µm{range_note}",
                self.range_um
            ),
            format!(
                "settled: each reading within max({SETTLE_FLOOR_UM} µm, {SETTLE_SIGMAS} σ) of its \
                 passage's median (σ from consecutive differences), gaps up to {BRIDGE_S} s \
                 bridged, at least {MIN_PLATEAU_SAMPLES} samples"
            ),
            format!(
                "the stream starts at a cycle's first visit: plateau k is dwell k mod {}; a \
                 plateau shorter than {SHORT_PLATEAU_SHARE} of its dwell is refused",
                self.dwells.dwells.len()
            ),
            "a visit's reading: the mean of the settled samples in the middle half of its \
             plateau (both ends included); its time: the plateau's midpoint"
                .to_string(),
            "the log interpolated linearly to each visit's time, never extrapolated".to_string(),
            format!("cycles numbered from 1 in stream order; {validate}"),
        ];
        let mut out = "assumed:\n".to_string();
        for l in lines {
            out.push_str(&format!("- {l}\n"));
        }
        out
    }

    /// The balls the program visits, in the order it first visits them.
    fn balls_visited(&self) -> Vec<usize> {
        let mut order = Vec::new();
        for d in &self.dwell_balls {
            if !order.contains(&d.ball) {
                order.push(d.ball);
            }
        }
        order
    }
}

fn min_max(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    })
}
