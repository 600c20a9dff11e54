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
//! [setup.ball1]                               # shared set-ups, as in session.toml: the
//! ball = [150.0, 0.0, 100.0]                  # plugin's keys, written into the session as
//! mount = "ball-on-table"                     # given (R-test: or "ball-in-spindle"; default
//!                                             # "ball-on-table", plugins/rtest)
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
//! # More plan keys
//! ```toml
//! truth_errors = "rich.errors.toml"  # error model of the truth only (a higher order than the
//!                                    # session's model: a planted `component-order` effect)
//! pause_s = 10.0                     # time between runs (default 10 s)
//!
//! [record]                           # optional: the files hold rounded numbers, as a controller
//! positions = 4                      # and an instrument write them: decimals of mm and degrees
//! readings = 4                       # (the machine moves to exactly the written positions),
//! time = 3                           # of each reading channel's unit, of seconds and of the
//! context = 3                        # context columns; default: every digit of the f64
//!
//! [context]                          # context columns written into every run, by session time
//! S = [[0.0, 0.0], [150.0, 4000.0]]  # spindle speed, rpm: steps (held until the next point)
//! T_bed = [[0.0, 20.5], [600.0, 21.5]]  # temperatures, °C: linear between points
//! P_air = [[0.0, 1013.0], [600.0, 1011.0]]  # air pressure, hPa, and H_<name> humidity, %:
//!                                    # linear between points
//!
//! [[effect]]                         # a planted effect (any number)
//! effect = "thermal-drift"           # a registered family (crates/effects)
//! axis = "Z"                         # its target: axis, channel (+ instrument) or setup + nuisance
//! amplitude_um = 3.0                 # every parameter, named with its unit
//! tau_s = 400.0
//! below_noise = 0.5                  # optional: scale the amplitudes so that the effect's
//!                                    # largest change of any reading is 0.5 × its noise
//! ```
//!
//! # Planting effects
//! A plan's `[[effect]]` tables are evaluated on the whole planned session (thermal states run
//! over all runs in time order) and applied exactly: an effect on an axis displaces the axis in
//! the truth model (the fit carries it through the axis Jacobian), one on a set-up parameter
//! moves the parameter, one on a reading (or its gain) changes the reading. Each family's keys:
//! `crates/effects/src/families/`.
//!
//! Concealing an effect: `below_noise` puts it under the single-sample noise; the rest is a
//! matter of the plan: a
//! timing that hides it in the fitted parameters (a drift with τ shorter than the first run
//! rises while C turns once and looks like C's location errors; a temperature that changes
//! during one XYC run); a larger effect of another class planted beside it. The planted-effect
//! tests (`crates/identify/tests/physics_search.rs`) do all three for every family.
//!
//! [`simulate_with`] also takes [`Plant`]s: each sees every sample (run, time, axis positions,
//! tool pose) and adds to the readings, for effects no family describes.

use mtcal_effects::{AxisView, PreparedEffects, RunView, SessionView, SetupView};
use mtcal_instrument::{At, PathSpec, SetupContext};
use mtcal_kinematics::{AxisKind, MachineModel, Rigid};
use mtcal_machine::{load_machine, params, topology::Reading};
use mtcal_session::{Manifest, ManifestRun, RunTable, RunUse, SetupRef, write_run, write_session};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Keys of a plan's top level and of its runs.
const PLAN_KEYS: &[&str] = &[
    "machine",
    "truth",
    "truth_errors",
    "pause_s",
    "record",
    "context",
    "effect",
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

/// One run of a plan, ready to be measured.
struct PlannedRun {
    name: String,
    instrument: String,
    setup_ref: SetupRef,
    /// Index into the plan's distinct set-ups.
    setup: usize,
    use_: RunUse,
    poses: Vec<Vec<f64>>,
    /// Each sample's label values (instruments with label columns), and their numbers.
    labels: Vec<Vec<String>>,
    label_numbers: Vec<u32>,
    t: Vec<f64>,
    /// Context columns sampled at `t` (file units).
    context: Vec<(String, Vec<f64>)>,
    noise: Vec<f64>,
    with_readings: bool,
    feed: f64,
}

/// One distinct set-up of a plan.
struct PlannedSetup {
    name: String,
    instrument: String,
    setup: Box<dyn mtcal_instrument::Setup>,
    /// True nuisance values (SI).
    nuis: Vec<f64>,
}

/// [`simulate`] with planted effects (besides the plan's own `[[effect]]` tables).
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
    // The truth may have a richer error model than the session's (a planted higher order).
    let truth_config = match plan.get("truth_errors") {
        None => loaded.config.clone(),
        Some(v) => {
            let f = v.as_str().ok_or_else(|| {
                plan_err(format!("`truth_errors` must be a file name, found {v}"))
            })?;
            mtcal_machine::config::load_config(&base.join(f), &loaded.machine)
                .map_err(|e| plan_err(format!("truth_errors: {e}")))?
        }
    };
    let model = MachineModel::new(loaded.machine.clone(), &truth_config)
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
    let pause = match plan.get("pause_s") {
        None => 10.0,
        Some(v) => v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| plan_err(format!("`pause_s` must be a number ≥ 0, found {v}")))?,
    };
    let schedules = context_schedules(&plan, plan_path)?;
    let record = Record::from_plan(&plan, plan_path)?;
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

    // Phase 1: every run's path, times and context.
    let mut planned: Vec<PlannedRun> = Vec::new();
    let mut distinct: Vec<PlannedSetup> = Vec::new();
    let mut t0 = 0.0;
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
        let plugin = mtcal_plugins::find(instrument).ok_or_else(|| {
            run_err(format!(
                "unknown instrument `{instrument}`; known: {}",
                mtcal_plugins::plugins()
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
        let poses = record.positions_of(model.machine(), poses);
        let labels = match plugin.path_labels {
            Some(f) => f(&PathSpec {
                path: path_table,
                setup: &setup_table,
                machine: model.machine(),
            })
            .map_err(|e| run_err(format!("path: {e}")))?,
            None => Vec::new(),
        };
        let label_numbers = labels
            .iter()
            .map(|values| {
                let refs: Vec<&str> = values.iter().map(String::as_str).collect();
                setup.resolve_label(&refs)
            })
            .collect::<Result<Vec<u32>, String>>()
            .map_err(|e| run_err(format!("path labels: {e}")))?;
        if !setup.label_columns().is_empty() && labels.len() != poses.len() {
            return Err(run_err(format!(
                "the path gives {} label sets for {} samples",
                labels.len(),
                poses.len()
            )));
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
        let feed = match run.get("feed_mm_min") {
            None => 1000.0,
            Some(v) => v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .filter(|x| x.is_finite() && *x > 0.0)
                .ok_or_else(|| run_err(format!("`feed_mm_min` must be > 0, found {v}")))?,
        };
        let n = poses.len();
        let t: Vec<f64> = (0..n)
            .map(|i| Record::round(t0 + i as f64 * dt, record.time))
            .collect();
        if t.windows(2).any(|w| w[1] <= w[0]) {
            return Err(run_err(format!(
                "[record] time = {}: samples {dt} s apart need more decimals",
                record.time.unwrap_or(0)
            )));
        }
        t0 += n as f64 * dt + pause;
        let context = schedules
            .iter()
            .map(|(name, schedule)| {
                let values = t
                    .iter()
                    .map(|&ti| Record::round(schedule.at(ti), record.context))
                    .collect();
                (name.clone(), values)
            })
            .collect();
        let setup_index = match distinct.iter().position(|d| d.name == setup_name) {
            Some(i) => i,
            None => {
                distinct.push(PlannedSetup {
                    name: setup_name.clone(),
                    instrument: instrument.to_string(),
                    setup,
                    nuis,
                });
                distinct.len() - 1
            }
        };
        planned.push(PlannedRun {
            name,
            instrument: instrument.to_string(),
            setup_ref,
            setup: setup_index,
            use_,
            poses,
            labels,
            label_numbers,
            t,
            context,
            noise,
            with_readings,
            feed,
        });
    }

    // Phase 2: the plan's planted effects, on the whole session.
    let effects = planted_effects(&plan, plan_path, &model, &truth, &distinct, &planned)?;

    // Phase 3: the readings.
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
    let mut total = 0;
    for (ri, run) in planned.iter().enumerate() {
        let run_err = |message: String| SimulateError::Run {
            file: plan_path.to_path_buf(),
            run: run.name.clone(),
            message,
        };
        let PlannedSetup { setup, nuis, .. } = &distinct[run.setup];
        let channels = setup.channels();
        let nch = channels.len();
        let mut rng =
            rand_chacha::ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1_000_003) + ri as u64);
        let n = run.poses.len();
        let mut positions = Vec::with_capacity(n * run.poses[0].len());
        let mut values = Vec::with_capacity(n * nch);
        let mut pred = vec![0.0; nch];
        let mut fx = effects.as_ref().map(|(prepared, params)| {
            let max_nuis = distinct.iter().map(|d| d.nuis.len()).max().unwrap_or(0);
            let max_ch = distinct
                .iter()
                .map(|d| d.setup.channels().len())
                .max()
                .unwrap_or(0);
            (
                prepared,
                params,
                prepared.scratch(model.machine().n_axes(), max_nuis, max_ch),
            )
        });
        let mut shifted_q = vec![0.0; model.machine().n_axes()];
        let mut shifted_nuis = nuis.clone();
        for (i, q) in run.poses.iter().enumerate() {
            let ti = run.t[i];
            let mut pose = model.tool_pose(q, &truth, &mut ws);
            let mut current_nuis: &[f64] = nuis;
            if let Some((prepared, params, out)) = fx.as_mut() {
                // Planted effects act exactly: the axes really are elsewhere, the set-up's
                // parameters really have moved.
                prepared.sample(ri, run.setup, i, params, out);
                for ((s, &qi), d) in shifted_q.iter_mut().zip(q).zip(&out.dq) {
                    *s = qi + d;
                }
                for ((s, &v), d) in shifted_nuis.iter_mut().zip(nuis).zip(&out.dn) {
                    *s = v + d;
                }
                pose = model.tool_pose(&shifted_q, &truth, &mut ws);
                current_nuis = &shifted_nuis;
            }
            setup.predict(
                &At {
                    q,
                    t: ti,
                    w_t_t: &pose,
                    label: run.label_numbers.get(i).copied().unwrap_or(0),
                },
                current_nuis,
                &mut pred,
            );
            if let Some((_, _, out)) = fx.as_ref() {
                for (c, p) in pred.iter_mut().enumerate() {
                    *p = *p * (1.0 + out.gain[c]) + out.dr[c];
                }
            }
            let sample = PlantSample {
                run: &run.name,
                instrument: &run.instrument,
                run_index: ri,
                sample: i,
                t: ti,
                q,
                w_t_t: &pose,
            };
            for p in plants {
                p.apply(&sample, &mut pred);
            }
            for (c, p) in pred.iter().enumerate() {
                let e = if run.noise[c] > 0.0 {
                    Normal::new(0.0, run.noise[c])
                        .expect("finite positive σ")
                        .sample(&mut rng)
                } else {
                    0.0
                };
                values.push(p + e);
            }
            for (v, ax) in q.iter().zip(model.machine().axes()) {
                let file = ax.kind().to_file(*v);
                // The pose was rounded in file units already: this gives the same digits.
                positions.push(Record::round(file, record.positions));
            }
        }
        // The instrument's own form of the readings (an artefact's measured centres, a laser's
        // uncompensated lengths), then file units.
        let q_si: Vec<f64> = run.poses.concat();
        setup
            .record_readings(
                &mtcal_instrument::RunData {
                    q: &q_si,
                    t: &run.t,
                    context: &run.context,
                },
                &mut values,
            )
            .map_err(|e| run_err(format!("recording the readings: {e}")))?;
        for row in values.chunks_exact_mut(nch) {
            for (v, ch) in row.iter_mut().zip(channels) {
                *v = Record::round(*v * ch.unit.per_si(), record.readings);
            }
        }
        let program = mtcal_instrument::program::nc_program(
            model.machine(),
            &run.poses,
            run.feed,
            &format!("mtcal {} run {}", run.instrument, run.name),
        );
        let programs = out.join("programs");
        std::fs::create_dir_all(&programs).map_err(|e| SimulateError::Io {
            path: programs.clone(),
            source: e,
        })?;
        let nc = programs.join(format!("{}.nc", run.name));
        mtcal_machine::write_atomically(&nc, program.as_bytes()).map_err(|e| {
            SimulateError::Io {
                path: nc,
                source: e,
            }
        })?;
        total += n;
        let axes: Vec<char> = model
            .machine()
            .axes()
            .iter()
            .map(|a| a.letter().as_char())
            .collect();
        let readings: Vec<String> = channels.iter().map(|c| c.name.clone()).collect();
        let table = RunTable {
            path: out.join(format!("{}.csv", run.name)),
            columns: Vec::new(),
            t: run.t.clone(),
            axes,
            positions,
            readings: if run.with_readings {
                readings
            } else {
                Vec::new()
            },
            values: run.with_readings.then_some(values),
            context: run.context.clone(),
            labels: setup
                .label_columns()
                .iter()
                .enumerate()
                .map(|(k, name)| {
                    let column = run.labels.iter().map(|v| v[k].clone()).collect();
                    (name.to_string(), column)
                })
                .collect(),
        };
        write_run(&out.join(format!("{}.csv", run.name)), &table)
            .map_err(|e| run_err(e.to_string()))?;
        manifest_runs.push(ManifestRun {
            name: run.name.clone(),
            instrument: run.instrument.clone(),
            file: format!("{}.csv", run.name),
            use_: run.use_,
            setup: run.setup_ref.clone(),
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

/// A context column's programme over session time.
#[derive(Debug, Clone)]
struct Schedule {
    /// `(time s, value)`, increasing in time.
    points: Vec<(f64, f64)>,
    /// Steps (spindle speed, feed: the value holds until the next point) or linear
    /// interpolation (temperatures).
    steps: bool,
}

impl Schedule {
    fn at(&self, t: f64) -> f64 {
        let p = &self.points;
        let k = p.partition_point(|(ti, _)| *ti <= t);
        if k == 0 {
            return p[0].1;
        }
        if self.steps || k == p.len() {
            return p[k - 1].1;
        }
        let ((t0, v0), (t1, v1)) = (p[k - 1], p[k]);
        v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    }
}

/// The plan's `[context]` table: per column a list of `[time_s, value]` points.
fn context_schedules(
    plan: &toml::Table,
    file: &Path,
) -> Result<Vec<(String, Schedule)>, SimulateError> {
    let err = |message: String| SimulateError::Plan {
        file: file.to_path_buf(),
        message,
    };
    let Some(v) = plan.get("context") else {
        return Ok(Vec::new());
    };
    let table = v
        .as_table()
        .ok_or_else(|| err("`context` must be a table of columns".into()))?;
    let mut out = Vec::new();
    for (name, v) in table {
        let steps = match name.as_str() {
            "S" | "F" => true,
            n if ["T_", "P_", "H_"].iter().any(|p| n.starts_with(p)) && n.len() > 2 => false,
            _ => {
                return Err(err(format!(
                    "[context] `{name}`: context columns are S, F, T_<name> (°C), P_<name> \
                     (hPa) and H_<name> (% RH)"
                )));
            }
        };
        let bad = || {
            err(format!(
                "[context] `{name}` must be a list of [time_s, value] pairs, increasing in time"
            ))
        };
        let list = v.as_array().ok_or_else(bad)?;
        let mut points = Vec::with_capacity(list.len());
        for item in list {
            let pair = item.as_array().filter(|a| a.len() == 2).ok_or_else(bad)?;
            let num = |x: &toml::Value| {
                x.as_float()
                    .or_else(|| x.as_integer().map(|i| i as f64))
                    .filter(|x| x.is_finite())
            };
            let (t, value) = (
                num(&pair[0]).ok_or_else(bad)?,
                num(&pair[1]).ok_or_else(bad)?,
            );
            if points.last().is_some_and(|(tp, _): &(f64, f64)| *tp >= t) {
                return Err(bad());
            }
            points.push((t, value));
        }
        if points.is_empty() {
            return Err(bad());
        }
        out.push((name.clone(), Schedule { points, steps }));
    }
    Ok(out)
}

/// The plan's `[[effect]]` tables, prepared on the planned session.
fn planted_effects(
    plan: &toml::Table,
    file: &Path,
    model: &MachineModel,
    truth: &[f64],
    setups: &[PlannedSetup],
    runs: &[PlannedRun],
) -> Result<Option<(PreparedEffects, Vec<f64>)>, SimulateError> {
    let Some(v) = plan.get("effect") else {
        return Ok(None);
    };
    let err = |message: String| SimulateError::Plan {
        file: file.to_path_buf(),
        message,
    };
    let list = v
        .as_array()
        .ok_or_else(|| err("`effect` must be a list of [[effect]] tables".into()))?;
    let machine = model.machine();
    let view = Arc::new(SessionView::new(
        machine
            .axes()
            .iter()
            .enumerate()
            .map(|(a, ax)| AxisView {
                letter: ax.letter().as_char(),
                rotary: ax.kind() == AxisKind::Rotary,
                stroke: ax
                    .limits()
                    .filter(|(lo, hi)| hi > lo)
                    .unwrap_or_else(|| mtcal_kinematics::model::default_stroke(machine, a)),
            })
            .collect(),
        setups
            .iter()
            .map(|s| SetupView {
                name: s.name.clone(),
                instrument: s.instrument.clone(),
                channels: s.setup.channels().to_vec(),
                reads_pose: (0..s.setup.channels().len())
                    .map(|c| s.setup.reads_pose(c))
                    .collect(),
                nuisance: s.setup.nuisance().to_vec(),
            })
            .collect(),
        runs.iter()
            .map(|r| {
                let q: Vec<f64> = r.poses.iter().flat_map(|q| q.iter().copied()).collect();
                RunView::from_vectors(
                    r.name.clone(),
                    r.setup,
                    r.use_ == RunUse::Fit,
                    &r.t,
                    &q,
                    &r.context,
                )
            })
            .collect(),
        Vec::new(),
    ));
    let mut effects: Vec<Arc<dyn mtcal_effects::Effect>> = Vec::new();
    let mut values = Vec::new();
    for (k, item) in list.iter().enumerate() {
        let mut table = item
            .as_table()
            .ok_or_else(|| err(format!("effect {} is not a table", k + 1)))?
            .clone();
        // `below_noise = f`: the amplitudes are scaled so that the effect's largest change of
        // any reading is f times that reading's noise.
        let below = match table.remove("below_noise") {
            None => None,
            Some(v) => Some(
                v.as_float()
                    .or_else(|| v.as_integer().map(|i| i as f64))
                    .filter(|f| f.is_finite() && *f > 0.0)
                    .ok_or_else(|| {
                        err(format!(
                            "[[effect]] {}: `below_noise` must be a positive number, found {v}",
                            k + 1
                        ))
                    })?,
            ),
        };
        let (effect, mut v) = mtcal_effects::plant(&table, &view)
            .map_err(|m| err(format!("[[effect]] {}: {m}", k + 1)))?;
        if let Some(fraction) = below {
            let single = PreparedEffects::new(std::slice::from_ref(&effect), &view, &v);
            let largest = largest_change(model, truth, &single, &v, setups, runs);
            if largest.is_nan() || largest <= 0.0 {
                return Err(err(format!(
                    "[[effect]] {}: `below_noise`: the effect changes no reading of this plan",
                    k + 1
                )));
            }
            for (x, p) in v.iter_mut().zip(effect.params()) {
                if p.kind == mtcal_effects::ParamKind::Amplitude {
                    *x *= fraction / largest;
                }
            }
        }
        effects.push(effect);
        values.extend(v);
    }
    Ok(Some((
        PreparedEffects::new(&effects, &view, &values),
        values,
    )))
}

/// The largest change an effect makes to any reading of the plan, in units of that reading's
/// noise (its channel's σ where the run is noise-free).
fn largest_change(
    model: &MachineModel,
    truth: &[f64],
    effect: &PreparedEffects,
    values: &[f64],
    setups: &[PlannedSetup],
    runs: &[PlannedRun],
) -> f64 {
    let mut ws = model.workspace();
    let na = model.machine().n_axes();
    let max_nuis = setups.iter().map(|d| d.nuis.len()).max().unwrap_or(0);
    let max_ch = setups
        .iter()
        .map(|d| d.setup.channels().len())
        .max()
        .unwrap_or(0);
    let mut out = effect.scratch(na, max_nuis, max_ch);
    let mut largest: f64 = 0.0;
    for (r, run) in runs.iter().enumerate() {
        let PlannedSetup { setup, nuis, .. } = &setups[run.setup];
        let channels = setup.channels();
        let (mut plain, mut with) = (vec![0.0; channels.len()], vec![0.0; channels.len()]);
        let mut q2 = vec![0.0; na];
        let mut n2 = nuis.clone();
        for (i, q) in run.poses.iter().enumerate() {
            let t = run.t[i];
            let pose = model.tool_pose(q, truth, &mut ws);
            setup.predict(
                &At {
                    q,
                    t,
                    w_t_t: &pose,
                    label: 0,
                },
                nuis,
                &mut plain,
            );
            effect.sample(r, run.setup, i, values, &mut out);
            for ((s, &a), d) in q2.iter_mut().zip(q).zip(&out.dq) {
                *s = a + d;
            }
            for ((s, &a), d) in n2.iter_mut().zip(nuis).zip(&out.dn) {
                *s = a + d;
            }
            let pose = model.tool_pose(&q2, truth, &mut ws);
            setup.predict(
                &At {
                    q,
                    t,
                    w_t_t: &pose,
                    label: 0,
                },
                &n2,
                &mut with,
            );
            for (c, ch) in channels.iter().enumerate() {
                let changed = with[c] * (1.0 + out.gain[c]) + out.dr[c];
                let sigma = if run.noise[c] > 0.0 {
                    run.noise[c]
                } else {
                    ch.sigma
                };
                largest = largest.max((changed - plain[c]).abs() / sigma);
            }
        }
    }
    largest
}

/// Copies a URDF (and its `.errors.toml`, if any) into the session as `machine.urdf`.
/// `[record]`: how many decimals the files hold (`None`: every digit).
#[derive(Clone, Copy, Debug, Default)]
struct Record {
    positions: Option<usize>,
    readings: Option<usize>,
    time: Option<usize>,
    context: Option<usize>,
}

impl Record {
    const KEYS: [&str; 4] = ["positions", "readings", "time", "context"];

    fn from_plan(plan: &toml::Table, file: &Path) -> Result<Record, SimulateError> {
        let err = |message: String| SimulateError::Plan {
            file: file.to_path_buf(),
            message,
        };
        let Some(v) = plan.get("record") else {
            return Ok(Record::default());
        };
        let table = v
            .as_table()
            .ok_or_else(|| err(format!("`record` must be a table, found {v}")))?;
        let mut record = Record::default();
        for (k, v) in table {
            let decimals = v
                .as_integer()
                .filter(|d| (0..=9).contains(d))
                .ok_or_else(|| {
                    err(format!(
                        "[record] `{k}` must be a number of decimals from 0 to 9, found {v}"
                    ))
                })? as usize;
            match k.as_str() {
                "positions" => record.positions = Some(decimals),
                "readings" => record.readings = Some(decimals),
                "time" => record.time = Some(decimals),
                "context" => record.context = Some(decimals),
                _ => {
                    return Err(err(format!(
                        "[record] unknown key `{k}`; it has {}",
                        Record::KEYS.join(", ")
                    )));
                }
            }
        }
        Ok(record)
    }

    /// `v` as written with `decimals` and read back (a written `-0.000` reads as 0).
    fn round(v: f64, decimals: Option<usize>) -> f64 {
        match decimals {
            None => v,
            Some(d) => {
                let r: f64 = format!("{v:.d$}").parse().expect("a formatted f64 parses");
                if r == 0.0 { 0.0 } else { r }
            }
        }
    }

    /// The poses the controller is given: each axis rounded in its file unit (mm, degrees),
    /// then converted back as `identify` converts the file.
    fn positions_of(
        &self,
        machine: &mtcal_kinematics::Machine,
        mut poses: Vec<Vec<f64>>,
    ) -> Vec<Vec<f64>> {
        if self.positions.is_none() {
            return poses;
        }
        for q in &mut poses {
            for (v, ax) in q.iter_mut().zip(machine.axes()) {
                *v = match ax.kind() {
                    AxisKind::Linear => Record::round(*v * 1e3, self.positions) * 1e-3,
                    AxisKind::Rotary => Record::round(v.to_degrees(), self.positions).to_radians(),
                };
            }
        }
        poses
    }
}

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
