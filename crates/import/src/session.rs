//! A [`Recording`] into a session folder: the run CSV and its `[[run]]` in `session.toml`.

use std::path::{Component, Path, PathBuf};

use mtcal_kinematics::{AxisKind, Machine};
use mtcal_machine::topology::Reading;
use mtcal_plugins::capability::{PositioningRuns, declared_once};
use mtcal_session::{
    Manifest, ManifestRun, RunTable, RunUse, Session, SetupRef, run_text, session_text,
};

use crate::recording::Recording;
use crate::{ImportError, ImportOptions, Imported};

/// Positions may pass an axis limit by this much (mm), as the session reader allows.
pub(crate) const LIMIT_TOL_MM: f64 = 0.01;

/// The session as it is before the import: its manifest (or a new one) and its machine.
struct Target {
    manifest: Manifest,
    /// What `load_machine` is given: the manifest's machine resolved from the current folder.
    machine_arg: String,
    created: bool,
}

pub fn write(options: &ImportOptions<'_>, recording: Recording) -> Result<Imported, ImportError> {
    let instrument = declared_once::<PositioningRuns>()?;
    let target = target(options)?;
    let machine = load_machine(&target.machine_arg)?;
    let axis = axis(options, &recording, &machine)?;
    let name = run_name(options)?;
    let file = format!("{name}.csv");
    refuse_existing(options.session, &target.manifest, &name, &file)?;
    let table = run_table(
        options,
        &recording,
        &machine,
        axis,
        instrument.reading,
        &options.session.join(&file),
    )?;
    let run = manifest_run(instrument, &name, &file, axis);
    let entry = entry_text(&run);
    let mut manifest = target.manifest;
    manifest.runs.push(run);
    let manifest_path = write_both(options.session, &table, &manifest)?;
    Ok(Imported {
        recording,
        axis,
        run_name: name,
        run_file: table.path,
        manifest: manifest_path,
        created: target.created,
        entry,
    })
}

fn target(options: &ImportOptions<'_>) -> Result<Target, ImportError> {
    let dir = options.session;
    if dir.join(mtcal_session::MANIFEST_NAME).is_file() {
        if let Some(m) = options.machine {
            return Err(ImportError::Options(format!(
                "--machine {m}: the session {} names its machine already; leave --machine out",
                dir.display()
            )));
        }
        let session = mtcal_session::load_session_to_extend(dir)?;
        return Ok(Target {
            manifest: session.to_manifest(),
            machine_arg: machine_arg(&session),
            created: false,
        });
    }
    let Some(machine) = options.machine else {
        return Err(ImportError::Options(format!(
            "{} has no session.toml: give --machine (a URDF or a topology code) to create the \
             session",
            dir.display()
        )));
    };
    Ok(Target {
        manifest: Manifest {
            machine: machine_in_manifest(machine, dir),
            ..Manifest::default()
        },
        machine_arg: machine.to_string(),
        created: true,
    })
}

/// What `load_machine` is given for a session: its URDF resolved from the current folder, or
/// its topology code.
pub(crate) fn machine_arg(session: &Session) -> String {
    match &session.machine_path {
        Some(p) => p.to_string_lossy().into_owned(),
        None => session.machine.clone(),
    }
}

/// The nominal machine `arg` names (a URDF path or a topology code).
pub(crate) fn load_machine(arg: &str) -> Result<Machine, ImportError> {
    Ok(mtcal_machine::load_machine(arg, Reading::FromWorkpiece)
        .map_err(|cause| ImportError::Machine {
            machine: arg.to_string(),
            cause: Box::new(cause),
        })?
        .machine)
}

/// The manifest's `machine`: a URDF's path relative to the session folder, or the code.
pub(crate) fn machine_in_manifest(machine: &str, dir: &Path) -> String {
    let path = Path::new(machine);
    if !path.is_file() {
        return machine.to_string();
    }
    let (Ok(file), Ok(cwd)) = (path.canonicalize(), std::env::current_dir()) else {
        return machine.to_string();
    };
    let dir = absolute(&cwd.join(dir));
    relative(&file, &dir).to_string_lossy().replace('\\', "/")
}

/// `p` with `.` and `..` resolved lexically (the session folder may not exist yet); the
/// existing part resolved through links.
fn absolute(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    let mut existing = out.clone();
    let mut rest = Vec::new();
    while !existing.exists() {
        match existing.file_name() {
            Some(n) => rest.push(n.to_os_string()),
            None => break,
        }
        existing.pop();
    }
    let mut base = existing.canonicalize().unwrap_or(existing);
    base.extend(rest.iter().rev());
    base
}

/// `file` relative to the folder `dir` (both absolute).
fn relative(file: &Path, dir: &Path) -> PathBuf {
    let f: Vec<_> = file.components().collect();
    let d: Vec<_> = dir.components().collect();
    let common = f.iter().zip(&d).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..d.len() {
        out.push("..");
    }
    out.extend(&f[common..]);
    out
}

/// The measured axis: `--axis`, else the file's; a linear axis of the machine.
fn axis(
    options: &ImportOptions<'_>,
    rec: &Recording,
    machine: &Machine,
) -> Result<char, ImportError> {
    let letter = match (options.axis, rec.axis) {
        (Some(a), Some(f)) if a != f => {
            return Err(ImportError::Options(format!(
                "--axis {a}: {} says it measured axis {f}",
                options.file.display()
            )));
        }
        (Some(a), _) | (None, Some(a)) => a,
        (None, None) => {
            return Err(ImportError::Options(format!(
                "{} does not name its axis: give --axis (X, Y, Z…)",
                options.file.display()
            )));
        }
    };
    match machine.axis_index(letter) {
        Some(k) if machine.axes()[k].kind() == AxisKind::Linear => Ok(letter),
        Some(_) => Err(ImportError::Options(format!(
            "axis {letter} is rotary: the imports are linear positioning runs"
        ))),
        None => Err(ImportError::Options(format!(
            "the machine has no axis {letter} (axes {})",
            machine.letters()
        ))),
    }
}

/// `raw` as a run name and CSV stem: anything but letters, digits, `-`, `_` and `.` replaced by
/// `-`, no leading `.`.
pub(crate) fn file_safe(raw: &str) -> String {
    let name: String = raw
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '-'
            }
        })
        .collect();
    name.trim_start_matches('.').to_string()
}

/// `--name`, else the input's file stem with anything but letters, digits, `-`, `_` and `.`
/// replaced by `-`.
fn run_name(options: &ImportOptions<'_>) -> Result<String, ImportError> {
    let raw = match options.name {
        Some(n) => n.to_string(),
        None => options
            .file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    let name = file_safe(&raw);
    if name.is_empty() || (options.name.is_some() && name != raw) {
        return Err(ImportError::Options(format!(
            "run name `{raw}`: expected letters, digits, `-`, `_` and `.` (it names the CSV file)"
        )));
    }
    Ok(name)
}

/// Whether `name` can name a run and its CSV file: letters, digits, `-`, `_`, `.`, not
/// starting with `.`.
pub(crate) fn is_run_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
}

/// Refuses a run name the session has, or a run file that exists.
pub(crate) fn refuse_existing(
    dir: &Path,
    manifest: &Manifest,
    name: &str,
    file: &str,
) -> Result<(), ImportError> {
    if manifest.runs.iter().any(|r| r.name == name) {
        return Err(ImportError::Options(format!(
            "the session {} has a run `{name}` already: give another --name",
            dir.display()
        )));
    }
    if dir.join(file).exists() {
        return Err(ImportError::Options(format!(
            "{} exists already: give another --name",
            dir.join(file).display()
        )));
    }
    Ok(())
}

/// The run's table: `t`, every machine axis (file units), the deviation along `axis` in the
/// column `reading` (µm), the context columns.
fn run_table(
    options: &ImportOptions<'_>,
    rec: &Recording,
    machine: &Machine,
    axis: char,
    reading: &str,
    path: &Path,
) -> Result<RunTable, ImportError> {
    let held_si = match options.hold {
        Some(text) => {
            mtcal_machine::axis_text::held_positions(machine, vec![0.0; machine.n_axes()], text)
                .map_err(|e| ImportError::Options(e.to_string()))?
        }
        None => vec![0.0; machine.n_axes()],
    };
    let held: Vec<f64> = machine
        .axes()
        .iter()
        .zip(&held_si)
        .map(|(a, &q)| a.kind().to_file(q))
        .collect();
    let k = machine.axis_index(axis).expect("checked by axis()");
    let n = rec.len();
    let mut positions = Vec::with_capacity(n * held.len());
    for s in 0..n {
        let mut row = held.clone();
        if let Some(p) = &rec.positions_mm {
            row[k] = p[s];
        }
        positions.extend_from_slice(&row);
    }
    check_limits(machine, &positions)?;
    let t = rec
        .t_s
        .clone()
        .unwrap_or_else(|| (0..n).map(|s| s as f64).collect());
    Ok(RunTable {
        path: path.to_path_buf(),
        columns: Vec::new(),
        t,
        axes: machine
            .axes()
            .iter()
            .map(|a| a.letter().as_char())
            .collect(),
        positions,
        readings: vec![reading.to_string()],
        values: Some(rec.deviations_um.clone()),
        context: rec.context.clone(),
        labels: Vec::new(),
    })
}

/// Every position within its axis' limits (the session reader would refuse the run).
pub(crate) fn check_limits(machine: &Machine, positions: &[f64]) -> Result<(), ImportError> {
    let n_axes = machine.n_axes();
    for (k, a) in machine.axes().iter().enumerate() {
        let Some((lo, hi)) = a.limits() else { continue };
        let (lo, hi) = (a.kind().to_file(lo), a.kind().to_file(hi));
        let beyond = positions
            .iter()
            .skip(k)
            .step_by(n_axes)
            .find(|&&p| p < lo - LIMIT_TOL_MM || p > hi + LIMIT_TOL_MM);
        if let Some(p) = beyond {
            let letter = a.letter().as_char();
            return Err(ImportError::Options(format!(
                "axis {letter} at {p} is beyond its limits {lo} … {hi}: give the positions \
                 the axis had (--hold {letter}=…) or a machine whose stroke holds them"
            )));
        }
    }
    Ok(())
}

/// The run's `[[run]]`: the positioning instrument's, with its own set-up along `axis`.
fn manifest_run(instrument: &PositioningRuns, name: &str, file: &str, axis: char) -> ManifestRun {
    ManifestRun {
        name: name.to_string(),
        instrument: instrument.instrument.to_string(),
        file: file.to_string(),
        use_: RunUse::Fit,
        setup: SetupRef::Own((instrument.setup)(axis)),
        extra: toml::Table::new(),
    }
}

/// The entry as the manifest writes it, for the summary.
pub(crate) fn entry_text(run: &ManifestRun) -> String {
    let only = Manifest {
        machine: String::new(),
        runs: vec![run.clone()],
        ..Manifest::default()
    };
    let text = only.render().unwrap_or_default();
    text.split_once("[[run]]")
        .map(|(_, rest)| format!("[[run]]{rest}"))
        .unwrap_or(text)
}

/// The run file and the manifest written together ([`write_all`]).
fn write_both(dir: &Path, table: &RunTable, manifest: &Manifest) -> Result<PathBuf, ImportError> {
    write_all(dir, std::slice::from_ref(table), manifest)
}

/// The run files and the manifest written together ([`mtcal_located::Outputs`]): an error
/// leaves none of them (nor a session folder it created).
pub(crate) fn write_all(
    dir: &Path,
    tables: &[RunTable],
    manifest: &Manifest,
) -> Result<PathBuf, ImportError> {
    let mut files = mtcal_located::Outputs::new();
    files.folder(dir);
    for table in tables {
        files.file(&table.path, run_text(&table.path, table)?);
    }
    let (path, text) = session_text(dir, manifest)?;
    files.file(&path, text);
    files.commit()?;
    Ok(path)
}
