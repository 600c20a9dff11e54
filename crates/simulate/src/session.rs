//! A simulated session held in memory: what it writes into a session folder, and the session
//! as loading that folder would give it.

use crate::plan::{MachineFiles, Plan, PlanMachine, Settings, config_source};
use crate::{SimulateError, Simulated};
use mtcal_machine::LoadedMachine;
use mtcal_session::{
    Location, MANIFEST_NAME, Manifest, ManifestRun, RunSpec, RunTable, RunUse, Session, SetupRef,
    run_text, session_text,
};
use std::path::{Path, PathBuf};

/// A simulated session: the manifest, the machine and every run's table, for the folder
/// [`dir`](Self::dir).
#[derive(Debug)]
pub struct SimulatedSession {
    /// The session folder: where the run tables say they are and [`write`](Self::write)
    /// puts them.
    pub dir: PathBuf,
    pub manifest: Manifest,
    pub machine: PlanMachine,
    /// The runs in plan order.
    pub runs: Vec<SimulatedRun>,
    /// The plan it was simulated from, which messages about writing it name.
    pub plan: PathBuf,
}

/// One simulated run.
#[derive(Debug)]
pub struct SimulatedRun {
    pub name: String,
    pub instrument: String,
    pub use_: RunUse,
    pub setup: SetupRef,
    /// The run file's table as reading the written file gives it back (file units, its path
    /// in the session folder).
    pub table: RunTable,
    /// The commanded poses, SI, row-major: what its NC program moves through.
    pub poses: Vec<f64>,
    pub feed_mm_min: f64,
}

impl SimulatedSession {
    pub(crate) fn new(
        plan: &Plan,
        settings: &Settings,
        machine: PlanMachine,
        runs: Vec<SimulatedRun>,
        dir: &Path,
    ) -> SimulatedSession {
        let manifest_runs = runs
            .iter()
            .map(|run| ManifestRun {
                name: run.name.clone(),
                instrument: run.instrument.clone(),
                file: format!("{}.csv", run.name),
                use_: run.use_,
                setup: run.setup.clone(),
                extra: toml::Table::new(),
            })
            .collect();
        let manifest = Manifest {
            machine: match &machine.files {
                MachineFiles::Code(code) => code.clone(),
                MachineFiles::Urdf { .. } => "machine.urdf".to_string(),
            },
            setups: settings.setups.clone(),
            runs: manifest_runs,
            identify: plan.identify(),
        };
        SimulatedSession {
            dir: dir.to_path_buf(),
            manifest,
            machine,
            runs,
            plan: plan.file.clone(),
        }
    }

    /// Samples over every run.
    pub fn samples(&self) -> usize {
        self.runs.iter().map(|r| r.table.len()).sum()
    }

    /// Writes the session folder: the machine's files, each run's NC program
    /// (`programs/<run>.nc`) and CSV file, and `session.toml`; all at once
    /// ([`mtcal_machine::Outputs`]): an error leaves none of them behind.
    pub fn write(&self) -> Result<Simulated, SimulateError> {
        let mut files = mtcal_machine::Outputs::new();
        files.folder(&self.dir);
        if let MachineFiles::Urdf { urdf, errors } = &self.machine.files {
            files.file(self.dir.join("machine.urdf"), urdf.clone());
            if let Some(errors) = errors {
                files.file(self.dir.join("machine.errors.toml"), errors.clone());
            }
        }
        let programs = self.dir.join("programs");
        for run in self.runs.iter() {
            let nc = programs.join(format!("{}.nc", run.name));
            files.file(nc, run.program(&self.machine.loaded.machine));
            let text = run_text(&run.table.path, &run.table).map_err(|e| SimulateError::Run {
                file: self.plan.clone(),
                run: run.name.clone(),
                message: e.to_string(),
            })?;
            files.file(&run.table.path, text);
        }
        let (path, text) =
            session_text(&self.dir, &self.manifest).map_err(|e| SimulateError::Plan {
                file: self.plan.clone(),
                message: e.to_string(),
            })?;
        files.file(path, text);
        files.commit()?;
        let manifest = self.dir.join(MANIFEST_NAME);
        Ok(Simulated {
            manifest,
            runs: self.runs.len(),
            samples: self.samples(),
        })
    }

    /// The session as loading the written folder gives it (`mtcal_session::load_session`),
    /// the machine as loading it gives it, and every run's table: what
    /// `mtcal_identify::Study::from_parts` takes. A session in memory has no manifest text:
    /// its locations (`machine_at`, each run's `location`) are the first line of the manifest
    /// it would be written as, and it names no `[identify]` key's place.
    pub fn into_parts(self) -> (Session, LoadedMachine, Vec<RunTable>) {
        let session = self.session();
        let machine = self.session_machine();
        let tables = self.runs.into_iter().map(|r| r.table).collect();
        (session, machine, tables)
    }

    fn session(&self) -> Session {
        let manifest = self.dir.join(MANIFEST_NAME);
        let at = Location {
            file: manifest.clone(),
            line: 1,
            column: 1,
        };
        let runs = self
            .manifest
            .runs
            .iter()
            .map(|r| RunSpec {
                name: r.name.clone(),
                instrument: r.instrument.clone(),
                file: self.dir.join(&r.file),
                file_as_written: r.file.clone(),
                use_: r.use_,
                setup: r.setup.clone(),
                extra: r.extra.clone(),
                location: at.clone(),
            })
            .collect();
        Session {
            dir: self.dir.clone(),
            manifest,
            machine: self.manifest.machine.clone(),
            machine_at: at,
            machine_path: match self.machine.files {
                MachineFiles::Urdf { .. } => Some(self.dir.join(&self.manifest.machine)),
                MachineFiles::Code(_) => None,
            },
            setups: self.manifest.setups.clone(),
            runs,
            identify: self.manifest.identify.clone(),
            identify_at: Default::default(),
            setup_at: Default::default(),
        }
    }

    /// The machine as loading the session folder gives it: its files are the session's.
    fn session_machine(&self) -> LoadedMachine {
        let mut loaded = self.machine.loaded.clone();
        if let MachineFiles::Urdf { errors, .. } = &self.machine.files {
            let urdf = self.dir.join("machine.urdf");
            let config = mtcal_machine::config::config_path_for(&urdf);
            loaded.source = urdf.display().to_string();
            loaded.config_source = config_source(errors.is_some(), &config);
        }
        loaded
    }
}

impl SimulatedRun {
    /// The run's NC program (G-code: mm, degrees, `G90 G01` at the run's feed).
    pub fn program(&self, machine: &mtcal_kinematics::Machine) -> String {
        let poses: Vec<Vec<f64>> = self
            .poses
            .chunks_exact(machine.n_axes())
            .map(<[f64]>::to_vec)
            .collect();
        mtcal_instrument::program::nc_program(
            machine,
            &poses,
            self.feed_mm_min,
            &format!("mtcal {} run {}", self.instrument, self.name),
        )
    }
}
