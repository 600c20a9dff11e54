//! The test plan: read with located errors, its keys checked; the machine it names, the truth
//! and the session-wide settings.

use crate::SimulateError;
use crate::context::{Schedule, context_schedules};
use crate::keys::{PlanKeys, PlanMessages};
use crate::record::Record;
use mtcal_kinematics::MachineModel;
use mtcal_machine::{LoadError, LoadedMachine, load_machine, params, topology::Reading};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A test plan: its table, its keys as read, and the file that names it in messages.
/// Relative paths in it (machine, truth) start at that file's folder.
#[derive(Debug, Clone)]
pub struct Plan {
    pub table: toml::Table,
    pub file: PathBuf,
    keys: PlanKeys,
}

/// The machine of a plan: as loaded, and the files a session folder gets of it.
#[derive(Debug, Clone)]
pub struct PlanMachine {
    pub loaded: LoadedMachine,
    pub files: MachineFiles,
}

/// What a session's manifest names as its machine.
#[derive(Debug, Clone)]
pub enum MachineFiles {
    /// A topology code, named as it is; no file.
    Code(String),
    /// A URDF and its error configuration (`None`: the full ISO model), written into the
    /// session as `machine.urdf` and `machine.errors.toml`.
    Urdf {
        urdf: Vec<u8>,
        errors: Option<Vec<u8>>,
    },
}

/// The plan's session-wide settings (besides machine, truth and runs).
#[derive(Debug)]
pub(crate) struct Settings {
    /// Noise seed.
    pub seed: u64,
    /// Time between samples, s (a run may say its own).
    pub interval: f64,
    /// Time between runs, s.
    pub pause: f64,
    /// `[context]` columns' programmes over session time.
    pub schedules: Vec<(String, Schedule)>,
    pub record: Record,
    /// `[setup.<name>]` tables.
    pub setups: BTreeMap<String, toml::Table>,
    /// `[nuisance.<setup>]` tables: true nuisance values.
    pub nuisance: toml::Table,
}

impl Plan {
    /// Reads and parses the plan file at `path`.
    pub fn read(path: &Path) -> Result<Plan, SimulateError> {
        let text = std::fs::read_to_string(path).map_err(|e| SimulateError::Io {
            path: path.to_path_buf(),
            cause: e,
        })?;
        let table: toml::Table = toml::from_str(&text).map_err(|e| {
            let (line, col) = e.span().map(|s| line_col(&text, s.start)).unwrap_or((1, 1));
            plan_error(
                path,
                format!("{line}:{col}: not a valid plan: {}", e.message()),
            )
        })?;
        Plan::from_table(table, path)
    }

    /// A plan held in memory; `file` names it in messages.
    pub fn from_table(table: toml::Table, file: &Path) -> Result<Plan, SimulateError> {
        let keys = mtcal_located::toml::from_table(&table, &PlanMessages)
            .map_err(|p| plan_error(file, p.message))?;
        Ok(Plan {
            table,
            file: file.to_path_buf(),
            keys,
        })
    }

    /// Where the plan's relative paths start.
    fn base(&self) -> &Path {
        self.file.parent().unwrap_or(Path::new("."))
    }

    /// An error about the plan.
    pub(crate) fn error(&self, message: String) -> SimulateError {
        plan_error(&self.file, message)
    }

    /// An error about the plan's run `run`.
    pub(crate) fn run_error(&self, run: &str, message: String) -> SimulateError {
        SimulateError::Run {
            file: self.file.clone(),
            run: run.to_string(),
            message,
        }
    }

    /// The machine the plan names: a URDF relative to the plan (with the `.errors.toml` beside
    /// it) or a topology code.
    pub fn machine(&self) -> Result<PlanMachine, SimulateError> {
        let arg = self.keys.machine.as_deref().ok_or_else(|| {
            self.error("missing `machine = \"<file>.urdf\"` (or a topology code)".into())
        })?;
        let file = self.base().join(arg);
        let is_file = file.is_file();
        let loaded = load_machine(
            &if is_file {
                file.to_string_lossy().into_owned()
            } else {
                arg.to_string()
            },
            Reading::default(),
        )
        .map_err(|e| self.error(format!("machine: {e}")))?;
        let files = if is_file {
            machine_files(&file)?
        } else {
            MachineFiles::Code(arg.to_string())
        };
        Ok(PlanMachine { loaded, files })
    }

    /// The truth: its model (the session's, or `truth_errors`' richer one: a planted higher
    /// order) and its coefficients (`truth`, default zero).
    pub(crate) fn truth(
        &self,
        loaded: &LoadedMachine,
    ) -> Result<(MachineModel, Vec<f64>), SimulateError> {
        let config = match &self.keys.truth_errors {
            None => loaded.config.clone(),
            Some(f) => mtcal_machine::config::load_config(&self.base().join(f), &loaded.machine)
                .map_err(|e| self.error(format!("truth_errors: {e}")))?,
        };
        let model = MachineModel::new(loaded.machine.clone(), &config)
            .map_err(|e| self.error(format!("error model: {e}")))?;
        let truth = match &self.keys.truth {
            None => vec![0.0; model.n_coeffs()],
            Some(f) => params::load_params(&self.base().join(f), model.errors())
                .map_err(|e| self.error(format!("truth: {e}")))?,
        };
        Ok((model, truth))
    }

    /// The session-wide settings, checked in the order the plan format lists them.
    pub(crate) fn settings(&self) -> Result<Settings, SimulateError> {
        let keys = &self.keys;
        let nuisance = match &keys.nuisance {
            Some(toml::Value::Table(t)) => t.clone(),
            _ => toml::Table::new(),
        };
        Ok(Settings {
            seed: self.seed()?,
            interval: self.interval()?,
            pause: self.pause()?,
            schedules: context_schedules(keys.context.as_ref(), &self.file)?,
            record: Record::from_plan(keys.record.as_ref(), &self.file)?,
            setups: keys.setup.clone().unwrap_or_default(),
            nuisance,
        })
    }

    /// `seed`: the noise seed (default 0).
    fn seed(&self) -> Result<u64, SimulateError> {
        match self.keys.seed {
            None => Ok(0),
            Some(i) => u64::try_from(i).map_err(|_| {
                self.error(format!("`seed` must be a non-negative integer, found {i}"))
            }),
        }
    }

    /// `interval_s`: time between samples (default 0.5 s).
    fn interval(&self) -> Result<f64, SimulateError> {
        match self.keys.interval_s {
            None => Ok(0.5),
            Some(n) if n.value.is_finite() && n.value > 0.0 => Ok(n.value),
            Some(n) => {
                Err(self.error(format!("`interval_s` must be a positive number, found {n}")))
            }
        }
    }

    /// `pause_s`: time between runs (default 10 s).
    fn pause(&self) -> Result<f64, SimulateError> {
        match self.keys.pause_s {
            None => Ok(10.0),
            Some(n) if n.value.is_finite() && n.value >= 0.0 => Ok(n.value),
            Some(n) => Err(self.error(format!("`pause_s` must be a number ≥ 0, found {n}"))),
        }
    }

    /// The `[[run]]` tables.
    pub(crate) fn runs(&self) -> Result<&[toml::Table], SimulateError> {
        self.keys
            .run
            .as_deref()
            .ok_or_else(|| self.error("no [[run]]".into()))
    }

    /// The `[[effect]]` tables (`None` without the key).
    pub(crate) fn effects(&self) -> Option<&[toml::Table]> {
        self.keys.effect.as_deref()
    }

    /// `[identify]`, copied into the session's manifest.
    pub(crate) fn identify(&self) -> toml::Table {
        match &self.keys.identify {
            Some(toml::Value::Table(t)) => t.clone(),
            _ => toml::Table::new(),
        }
    }
}

impl PlanMachine {
    /// A machine given as URDF text and its error configuration's text (`None`: the full ISO
    /// model), read as the files `machine.urdf` and `machine.errors.toml` of a session folder
    /// would be.
    pub fn from_urdf(urdf: String, errors: Option<String>) -> Result<PlanMachine, LoadError> {
        let urdf_file = Path::new("machine.urdf");
        let machine = mtcal_machine::urdf::load_urdf_str(&urdf, urdf_file)?;
        let config_file = mtcal_machine::config::config_path_for(urdf_file);
        let config = match &errors {
            Some(text) => mtcal_machine::config::parse_config(text, &config_file, &machine)?,
            None => mtcal_machine::config::default_config(&machine),
        };
        let loaded = LoadedMachine {
            machine,
            config,
            source: urdf_file.display().to_string(),
            config_source: config_source(errors.is_some(), &config_file),
        };
        Ok(PlanMachine {
            loaded,
            files: MachineFiles::Urdf {
                urdf: urdf.into_bytes(),
                errors: errors.map(String::into_bytes),
            },
        })
    }
}

/// What [`load_machine`] says a URDF's error model came from: its `.errors.toml`, or the
/// default.
pub(crate) fn config_source(has_file: bool, file: &Path) -> String {
    if has_file {
        file.display().to_string()
    } else {
        "full ISO model: no .errors.toml beside the URDF".to_string()
    }
}

/// The URDF file's bytes and those of the `.errors.toml` beside it, if there is one.
fn machine_files(urdf: &Path) -> Result<MachineFiles, SimulateError> {
    let read = |path: &Path| {
        std::fs::read(path).map_err(|e| SimulateError::Io {
            path: path.to_path_buf(),
            cause: e,
        })
    };
    let config = mtcal_machine::config::config_path_for(urdf);
    Ok(MachineFiles::Urdf {
        urdf: read(urdf)?,
        errors: config.is_file().then(|| read(&config)).transpose()?,
    })
}

fn plan_error(file: &Path, message: String) -> SimulateError {
    SimulateError::Plan {
        file: file.to_path_buf(),
        message,
    }
}

/// Line and column (1-based, in characters) of byte `offset` of `text`.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::keys::PLAN_KEYS;

    fn machines() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../machines")
    }

    #[test]
    fn a_plan_that_is_not_toml_is_located_by_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plan.toml");
        std::fs::write(&path, "seed = 1\nmachine = [\n").unwrap();
        let e = Plan::read(&path).unwrap_err().to_string();
        let at = format!("{}: 2:12: not a valid plan: unclosed array", path.display());
        assert!(e.starts_with(&at), "{e}");
    }

    #[test]
    fn a_plan_in_memory_is_checked_like_a_file() {
        let mut table = toml::Table::new();
        table.insert("machin".into(), "m.urdf".into());
        let e = Plan::from_table(table, Path::new("p.toml")).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "p.toml: unknown key `machin`; a plan has {}",
                PLAN_KEYS.join(", ")
            )
        );
    }

    /// The message of `text` read as a plan, or of its settings.
    fn problem(text: &str) -> String {
        let table: toml::Table = toml::from_str(text).unwrap();
        let plan = Plan::from_table(table, Path::new("p.toml"));
        let e = match plan {
            Ok(plan) => plan.settings().expect_err(text),
            Err(e) => e,
        };
        e.to_string().strip_prefix("p.toml: ").unwrap().to_string()
    }

    #[test]
    fn every_top_level_problem_is_worded_as_the_plan_format_words_it() {
        let cases = [
            (
                "machine = 3",
                "missing `machine = \"<file>.urdf\"` (or a topology code)",
            ),
            ("truth = 3", "`truth` must be a file name, found 3"),
            (
                "truth_errors = [1]",
                "`truth_errors` must be a file name, found [1]",
            ),
            (
                "seed = 1.5",
                "`seed` must be a non-negative integer, found 1.5",
            ),
            (
                "seed = -1",
                "`seed` must be a non-negative integer, found -1",
            ),
            (
                "interval_s = \"x\"",
                "`interval_s` must be a positive number, found \"x\"",
            ),
            (
                "interval_s = 0",
                "`interval_s` must be a positive number, found 0",
            ),
            (
                "pause_s = -1.0",
                "`pause_s` must be a number ≥ 0, found -1.0",
            ),
            ("pause_s = nan", "`pause_s` must be a number ≥ 0, found nan"),
            ("record = 3", "`record` must be a table, found 3"),
            ("context = 3", "`context` must be a table of columns"),
            ("effect = 3", "`effect` must be a list of [[effect]] tables"),
            ("effect = [{}, 3]", "effect 2 is not a table"),
            ("setup = 3", "`setup` must be a table of set-ups"),
            ("setup = { a = 3 }", "`setup.a` must be a table"),
            ("run = 3", "no [[run]]"),
            ("run = [1]", "run 1 is not a table"),
        ];
        for (text, message) in cases {
            assert_eq!(problem(text), message, "{text}");
        }
    }

    #[test]
    fn record_decimals_are_checked_in_the_order_of_their_names() {
        let decimals = "must be a number of decimals from 0 to 9";
        let cases = [
            (
                "positions = 1.5",
                format!("[record] `positions` {decimals}, found 1.5"),
            ),
            ("time = 10", format!("[record] `time` {decimals}, found 10")),
            (
                "time = 10\ncontext = -1",
                format!("[record] `context` {decimals}, found -1"),
            ),
            (
                "angles = 3",
                "[record] unknown key `angles`; it has positions, readings, time, context".into(),
            ),
        ];
        for (text, message) in cases {
            assert_eq!(problem(&format!("[record]\n{text}")), message, "{text}");
        }
    }

    #[test]
    fn identify_and_nuisance_that_are_not_tables_count_as_none() {
        let table: toml::Table = toml::from_str("identify = 3\nnuisance = 3").unwrap();
        let plan = Plan::from_table(table, Path::new("p.toml")).unwrap();
        assert!(plan.identify().is_empty());
        assert!(plan.settings().unwrap().nuisance.is_empty());
    }

    #[test]
    fn a_machine_from_text_is_the_machine_from_its_files() {
        let urdf = machines().join("mcu630-cafyxz.urdf");
        let errors = mtcal_machine::config::config_path_for(&urdf);
        let files = load_machine(&urdf.display().to_string(), Reading::default()).unwrap();
        let text = |p: &Path| std::fs::read_to_string(p).unwrap();
        let memory = PlanMachine::from_urdf(text(&urdf), Some(text(&errors))).unwrap();
        assert_eq!(
            format!("{:?}", (&files.machine, &files.config)),
            format!("{:?}", (&memory.loaded.machine, &memory.loaded.config))
        );
        assert_eq!(memory.loaded.source, "machine.urdf");
        assert_eq!(memory.loaded.config_source, "machine.errors.toml");
        let MachineFiles::Urdf {
            urdf: bytes,
            errors,
        } = memory.files
        else {
            panic!("a URDF")
        };
        assert_eq!(bytes, std::fs::read(&urdf).unwrap());
        assert!(errors.is_some());
    }
}
