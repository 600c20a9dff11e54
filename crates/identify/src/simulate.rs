//! Simulated sessions: a machine, a truth parameter file and a test plan → a session folder
//! that `identify` reads like a real one.
//!
//! # Test plan (`plan.toml`)
//! ```toml
//! machine = "../machines/mcu630-cafyxz.urdf"  # relative to the plan, or a topology code
//! truth = "truth.params.toml"                 # optional (mtcal.params/1); default all zero
//! seed = 7                                    # noise seed (default 0)
//! interval_s = 0.5                            # time between samples (default 0.5 s)
//!
//! [identify]                                  # copied into the session manifest
//! parameters = ["EC0Y", "EB0Z", "EA0Z"]
//!
//! [setup.ball1]                               # shared set-ups, as in session.toml
//! ball = [150.0, 0.0, 100.0]
//!
//! [nuisance.ball1]                            # true nuisance values (their units, e.g. um)
//! ball_x = 3.0
//!
//! [[run]]
//! name = "xyc-a0"
//! instrument = "rtest"
//! setup = "ball1"                             # or an own [run.setup] table
//! use = "fit"                                 # or "validate"
//! path = { kind = "xyc", samples = 73 }       # the plugin's path keys
//! noise = 0.5                                 # σ of the reading noise (channel units);
//!                                             # default: the channel's σ; 0: noise-free
//! readings = true                             # false: a validation run without readings
//! feed_mm_min = 1000.0                        # feed written into the run's NC program
//! ```
//! Besides the session, every run's commanded path is written as a G-code program,
//! `programs/<run>.nc` (mm / degrees, `G90 G01`, the linear axes keeping the tool point where
//! the instrument needs it), for running the same test on the real machine.
//! Noise is Gaussian, from a ChaCha8 generator seeded with `seed` and the run's index, so a
//! plan gives byte-identical sessions on every machine.
//!
//! # Planting effects
//! [`simulate_with`] takes [`Plant`]s: each sees every sample (run, time, axis positions, tool
//! pose) and adds to the noise-free readings. The physics search plants thermal drift,
//! backlash, … this way.

use mtcal_instrument::{At, PathSpec, SetupContext};
use mtcal_kinematics::{AxisKind, MachineModel, Rigid};
use mtcal_machine::{load_machine, params, topology::Reading};
use mtcal_session::{Manifest, ManifestRun, RunTable, RunUse, SetupRef, write_run, write_session};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Keys of a plan's top level and of its runs.
const PLAN_KEYS: &[&str] = &[
    "machine",
    "truth",
    "seed",
    "interval_s",
    "identify",
    "setup",
    "nuisance",
    "run",
];
const RUN_KEYS: &[&str] = &[
    "name",
    "instrument",
    "setup",
    "use",
    "path",
    "noise",
    "readings",
    "interval_s",
    "feed_mm_min",
];

/// Why a plan could not be simulated; names the plan file and the key.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    #[error("{}: {message}", file.display())]
    Plan { file: PathBuf, message: String },
    #[error("{}: run `{run}`: {message}", file.display())]
    Run {
        file: PathBuf,
        run: String,
        message: String,
    },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// One sample as a [`Plant`] sees it.
#[derive(Debug, Clone, Copy)]
pub struct PlantSample<'a> {
    pub run: &'a str,
    pub instrument: &'a str,
    /// Index of the run in the plan.
    pub run_index: usize,
    pub sample: usize,
    pub t: f64,
    /// Axis positions, SI.
    pub q: &'a [f64],
    /// Actual tool pose in the workpiece frame.
    pub w_t_t: &'a Rigid,
}

/// An effect planted into simulated readings.
pub trait Plant: Sync + std::fmt::Debug {
    /// Adds the effect (SI) to the noise-free `readings` of one sample.
    fn apply(&self, sample: &PlantSample<'_>, readings: &mut [f64]);
}

/// What a simulation wrote.
#[derive(Debug, Clone)]
pub struct Simulated {
    pub manifest: PathBuf,
    pub runs: usize,
    pub samples: usize,
}

/// Simulates `plan` into the folder `out` (created if needed).
pub fn simulate(plan: &Path, out: &Path) -> Result<Simulated, SimulateError> {
    simulate_with(plan, out, &[])
}

/// [`simulate`] with planted effects.
pub fn simulate_with(
    plan_path: &Path,
    out: &Path,
    plants: &[&dyn Plant],
) -> Result<Simulated, SimulateError> {
    let plan_err = |message: String| SimulateError::Plan {
        file: plan_path.to_path_buf(),
        message,
    };
    let text = std::fs::read_to_string(plan_path).map_err(|e| SimulateError::Io {
        path: plan_path.to_path_buf(),
        source: e,
    })?;
    let plan: toml::Table = toml::from_str(&text).map_err(|e| {
        let (line, col) = e.span().map(|s| line_col(&text, s.start)).unwrap_or((1, 1));
        plan_err(format!("{line}:{col}: not a valid plan: {}", e.message()))
    })?;
    if let Some(k) = plan.keys().find(|k| !PLAN_KEYS.contains(&k.as_str())) {
        return Err(plan_err(format!(
            "unknown key `{k}`; a plan has {}",
            PLAN_KEYS.join(", ")
        )));
    }
    let base = plan_path.parent().unwrap_or(Path::new("."));
    let machine_arg = plan
        .get("machine")
        .and_then(|v| v.as_str())
        .ok_or_else(|| {
            plan_err("missing `machine = \"<file>.urdf\"` (or a topology code)".into())
        })?;
    let machine_file = base.join(machine_arg);
    let is_file = machine_file.is_file();
    let loaded = load_machine(
        &if is_file {
            machine_file.to_string_lossy().into_owned()
        } else {
            machine_arg.to_string()
        },
        Reading::default(),
    )
    .map_err(|e| plan_err(format!("machine: {e}")))?;
    let model = MachineModel::new(loaded.machine.clone(), &loaded.config)
        .map_err(|e| plan_err(format!("error model: {e}")))?;
    let truth = match plan.get("truth") {
        None => vec![0.0; model.n_coeffs()],
        Some(v) => {
            let f = v
                .as_str()
                .ok_or_else(|| plan_err(format!("`truth` must be a file name, found {v}")))?;
            params::load_params(&base.join(f), model.errors())
                .map_err(|e| plan_err(format!("truth: {e}")))?
        }
    };
    let seed = int_key(&plan, "seed", plan_path)?.unwrap_or(0);
    let interval = float_key(&plan, "interval_s", plan_path)?.unwrap_or(0.5);
    let setups: BTreeMap<String, toml::Table> = match plan.get("setup") {
        None => BTreeMap::new(),
        Some(toml::Value::Table(t)) => t
            .iter()
            .map(|(k, v)| match v {
                toml::Value::Table(t) => Ok((k.clone(), t.clone())),
                _ => Err(plan_err(format!("`setup.{k}` must be a table"))),
            })
            .collect::<Result<_, _>>()?,
        Some(_) => return Err(plan_err("`setup` must be a table of set-ups".into())),
    };
    let nuisance_truth = plan
        .get("nuisance")
        .and_then(|v| v.as_table())
        .cloned()
        .unwrap_or_default();
    let runs = plan
        .get("run")
        .and_then(|v| v.as_array())
        .ok_or_else(|| plan_err("no [[run]]".into()))?;

    std::fs::create_dir_all(out).map_err(|e| SimulateError::Io {
        path: out.to_path_buf(),
        source: e,
    })?;
    let machine_in_session = if is_file {
        copy_machine(&machine_file, out)?;
        "machine.urdf".to_string()
    } else {
        machine_arg.to_string()
    };

    let mut ws = model.workspace();
    let mut manifest_runs = Vec::new();
    let mut t0 = 0.0;
    let mut total = 0;
    for (ri, run) in runs.iter().enumerate() {
        let run = run
            .as_table()
            .ok_or_else(|| plan_err(format!("run {} is not a table", ri + 1)))?;
        let name = run
            .get("name")
            .and_then(|v| v.as_str())
            .ok_or_else(|| plan_err(format!("run {} has no `name`", ri + 1)))?
            .to_string();
        let run_err = |message: String| SimulateError::Run {
            file: plan_path.to_path_buf(),
            run: name.clone(),
            message,
        };
        if let Some(k) = run.keys().find(|k| !RUN_KEYS.contains(&k.as_str())) {
            return Err(run_err(format!(
                "unknown key `{k}`; a plan run has {}",
                RUN_KEYS.join(", ")
            )));
        }
        let instrument = run
            .get("instrument")
            .and_then(|v| v.as_str())
            .ok_or_else(|| run_err("missing `instrument`".into()))?;
        let plugin = mtcal_instrument::find(instrument).ok_or_else(|| {
            run_err(format!(
                "unknown instrument `{instrument}`; known: {}",
                mtcal_instrument::plugins()
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?;
        let (setup_ref, setup_name, setup_table) = match run.get("setup") {
            Some(toml::Value::String(s)) => {
                let t = setups
                    .get(s)
                    .ok_or_else(|| run_err(format!("no [setup.{s}] in the plan")))?;
                (SetupRef::Shared(s.clone()), s.clone(), t.clone())
            }
            Some(toml::Value::Table(t)) => (SetupRef::Own(t.clone()), name.clone(), t.clone()),
            None => (
                SetupRef::Own(toml::Table::new()),
                name.clone(),
                toml::Table::new(),
            ),
            Some(v) => {
                return Err(run_err(format!(
                    "`setup` must be a name or a table, found {v}"
                )));
            }
        };
        let use_ = match run.get("use").and_then(|v| v.as_str()) {
            None | Some("fit") => RunUse::Fit,
            Some("validate") => RunUse::Validate,
            Some(other) => {
                return Err(run_err(format!(
                    "`use` must be \"fit\" or \"validate\", found \"{other}\""
                )));
            }
        };
        let empty = toml::Table::new();
        let path_table = match run.get("path") {
            Some(toml::Value::Table(t)) => t,
            None => &empty,
            Some(v) => return Err(run_err(format!("`path` must be a table, found {v}"))),
        };
        let ctx = SetupContext {
            machine: model.machine(),
        };
        let setup =
            (plugin.load_setup)(&setup_table, &ctx).map_err(|e| run_err(format!("set-up: {e}")))?;
        let poses = (plugin.path)(&PathSpec {
            path: path_table,
            setup: &setup_table,
            machine: model.machine(),
        })
        .map_err(|e| run_err(format!("path: {e}")))?;
        if poses.is_empty() {
            return Err(run_err("the path has no samples".into()));
        }
        // True nuisance values, given in the nuisance parameters' units.
        let mut nuis = vec![0.0; setup.nuisance().len()];
        if let Some(toml::Value::Table(t)) = nuisance_truth.get(&setup_name) {
            for (k, v) in t {
                let j = setup
                    .nuisance()
                    .iter()
                    .position(|n| &n.name == k)
                    .ok_or_else(|| {
                        run_err(format!(
                            "[nuisance.{setup_name}] `{k}`: the set-up has {}",
                            setup
                                .nuisance()
                                .iter()
                                .map(|n| n.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ))
                    })?;
                let x = v
                    .as_float()
                    .or_else(|| v.as_integer().map(|i| i as f64))
                    .ok_or_else(|| {
                        run_err(format!("[nuisance.{setup_name}] `{k}` must be a number"))
                    })?;
                nuis[j] = x / setup.nuisance()[j].unit.per_si();
            }
        }
        let channels = setup.channels();
        let noise: Vec<f64> = match run.get("noise") {
            None => channels.iter().map(|c| c.sigma).collect(),
            Some(v) => {
                let x = v
                    .as_float()
                    .or_else(|| v.as_integer().map(|i| i as f64))
                    .filter(|x| x.is_finite() && *x >= 0.0)
                    .ok_or_else(|| run_err(format!("`noise` must be a number ≥ 0, found {v}")))?;
                channels.iter().map(|c| x / c.unit.per_si()).collect()
            }
        };
        let with_readings = run
            .get("readings")
            .map(|v| {
                v.as_bool()
                    .ok_or_else(|| run_err(format!("`readings` must be true or false, found {v}")))
            })
            .transpose()?
            .unwrap_or(true);
        let dt = match run.get("interval_s") {
            Some(v) => v
                .as_float()
                .filter(|x| *x > 0.0)
                .ok_or_else(|| run_err(format!("`interval_s` must be > 0, found {v}")))?,
            None => interval,
        };
        let mut rng =
            rand_chacha::ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1_000_003) + ri as u64);
        let n = poses.len();
        let nch = channels.len();
        let mut t = Vec::with_capacity(n);
        let mut positions = Vec::with_capacity(n * poses[0].len());
        let mut values = Vec::with_capacity(n * nch);
        let mut pred = vec![0.0; nch];
        for (i, q) in poses.iter().enumerate() {
            let ti = t0 + i as f64 * dt;
            let pose = model.tool_pose(q, &truth, &mut ws);
            setup.predict(
                &At {
                    q,
                    t: ti,
                    w_t_t: &pose,
                },
                &nuis,
                &mut pred,
            );
            let sample = PlantSample {
                run: &name,
                instrument,
                run_index: ri,
                sample: i,
                t: ti,
                q,
                w_t_t: &pose,
            };
            for p in plants {
                p.apply(&sample, &mut pred);
            }
            for (c, ch) in channels.iter().enumerate() {
                let e = if noise[c] > 0.0 {
                    Normal::new(0.0, noise[c])
                        .expect("finite positive σ")
                        .sample(&mut rng)
                } else {
                    0.0
                };
                values.push((pred[c] + e) * ch.unit.per_si());
            }
            t.push(ti);
            for (v, ax) in q.iter().zip(model.machine().axes()) {
                positions.push(match ax.kind() {
                    AxisKind::Linear => v * 1e3,
                    AxisKind::Rotary => v.to_degrees(),
                });
            }
        }
        let feed = match run.get("feed_mm_min") {
            None => 1000.0,
            Some(v) => v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .filter(|x| x.is_finite() && *x > 0.0)
                .ok_or_else(|| run_err(format!("`feed_mm_min` must be > 0, found {v}")))?,
        };
        let program = mtcal_instrument::program::nc_program(
            model.machine(),
            &poses,
            feed,
            &format!("mtcal {instrument} run {name}"),
        );
        let programs = out.join("programs");
        std::fs::create_dir_all(&programs).map_err(|e| SimulateError::Io {
            path: programs.clone(),
            source: e,
        })?;
        let nc = programs.join(format!("{name}.nc"));
        mtcal_machine::write_atomically(&nc, program.as_bytes()).map_err(|e| {
            SimulateError::Io {
                path: nc,
                source: e,
            }
        })?;
        t0 += n as f64 * dt + 10.0;
        total += n;
        let axes: Vec<char> = model
            .machine()
            .axes()
            .iter()
            .map(|a| a.letter().as_char())
            .collect();
        let readings: Vec<String> = channels.iter().map(|c| c.name.clone()).collect();
        let table = RunTable {
            path: out.join(format!("{name}.csv")),
            columns: Vec::new(),
            t,
            axes,
            positions,
            readings: if with_readings { readings } else { Vec::new() },
            values: with_readings.then_some(values),
            context: Vec::new(),
        };
        write_run(&out.join(format!("{name}.csv")), &table).map_err(|e| run_err(e.to_string()))?;
        manifest_runs.push(ManifestRun {
            name: name.clone(),
            instrument: instrument.to_string(),
            file: format!("{name}.csv"),
            use_,
            setup: setup_ref,
            extra: toml::Table::new(),
        });
    }
    let manifest = Manifest {
        machine: machine_in_session,
        setups,
        runs: manifest_runs,
        identify: plan
            .get("identify")
            .and_then(|v| v.as_table())
            .cloned()
            .unwrap_or_default(),
    };
    let path = write_session(out, &manifest).map_err(|e| plan_err(e.to_string()))?;
    Ok(Simulated {
        manifest: path,
        runs: runs.len(),
        samples: total,
    })
}

/// Copies a URDF (and its `.errors.toml`, if any) into the session as `machine.urdf`.
fn copy_machine(urdf: &Path, out: &Path) -> Result<(), SimulateError> {
    let copy = |from: &Path, to: &Path| -> Result<(), SimulateError> {
        let bytes = std::fs::read(from).map_err(|e| SimulateError::Io {
            path: from.to_path_buf(),
            source: e,
        })?;
        mtcal_machine::write_atomically(to, &bytes).map_err(|e| SimulateError::Io {
            path: to.to_path_buf(),
            source: e,
        })
    };
    copy(urdf, &out.join("machine.urdf"))?;
    let cfg = mtcal_machine::config::config_path_for(urdf);
    if cfg.is_file() {
        copy(&cfg, &out.join("machine.errors.toml"))?;
    }
    Ok(())
}

fn int_key(t: &toml::Table, key: &str, file: &Path) -> Result<Option<u64>, SimulateError> {
    match t.get(key) {
        None => Ok(None),
        Some(toml::Value::Integer(i)) if *i >= 0 => Ok(Some(*i as u64)),
        Some(v) => Err(SimulateError::Plan {
            file: file.to_path_buf(),
            message: format!("`{key}` must be a non-negative integer, found {v}"),
        }),
    }
}

fn float_key(t: &toml::Table, key: &str, file: &Path) -> Result<Option<f64>, SimulateError> {
    match t.get(key) {
        None => Ok(None),
        Some(v) => v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .filter(|x| x.is_finite() && *x > 0.0)
            .map(Some)
            .ok_or_else(|| SimulateError::Plan {
                file: file.to_path_buf(),
                message: format!("`{key}` must be a positive number, found {v}"),
            }),
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}
