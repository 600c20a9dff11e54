//! The planning pipeline: candidates → reach and fixture limits → collisions → information →
//! choice → plan, programs and report.

use crate::PlanError;
use crate::geometry::MachineGeometry;
use crate::info::{self, Choice, Informations};
use crate::run_keys;
use crate::scene::{Hit, Scene, bodies_of};
use crate::spec::{Group, Source, Wanted};
use crate::tooled::tooled_machine;
use mtcal_identify::Study;
use mtcal_instrument::{InstrumentPlugin, PathSpec, Setup, SetupContext};
use mtcal_kinematics::{AxisKind, Machine};
use mtcal_located::Location;
use mtcal_machine::{LoadedMachine, load_machine, topology::Reading};
use mtcal_simulate::{Plan, PlanMachine};
use nalgebra::DMatrix;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One run of the plan, with its commanded poses.
#[derive(Clone, Debug)]
pub struct PlannedRun {
    pub name: String,
    pub instrument: String,
    /// The shared set-up's name.
    pub setup_name: String,
    pub setup: toml::Table,
    /// The set-up as its plugin loaded it on the plan's machine (tool length added): what the
    /// path and the collision bodies are made from.
    pub loaded: Arc<dyn Setup>,
    pub path: toml::Table,
    /// `fit` or `validate`.
    pub use_: String,
    pub feed_mm_min: f64,
    /// SI, canonical axis order.
    pub poses: Vec<Vec<f64>>,
    /// Each sample's first label (artefact: `placement/feature`), or empty.
    pub labels: Vec<String>,
}

/// A set-up as the plan uses it, loaded once for all its runs ([`Ctx::planned_setup`]).
struct PlannedSetup {
    plugin: &'static InstrumentPlugin,
    name: String,
    /// Its table with the keys the planner writes out.
    table: toml::Table,
    loaded: Arc<dyn Setup>,
}

/// The collision check of one run.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct RunCheck {
    pub run: String,
    pub poses: usize,
    /// Poses closer than the clearance.
    pub colliding_poses: usize,
    /// Sampled points of the moves between poses closer than the clearance.
    pub colliding_moves: usize,
    /// The first colliding pose (0-based).
    pub first_pose: Option<usize>,
    /// The deepest collision of the run.
    pub worst: Option<Hit>,
    /// The instrument has no collision geometry here: only the machine was checked.
    pub instrument_unchecked: bool,
}

impl RunCheck {
    pub fn collides(&self) -> bool {
        self.colliding_poses + self.colliding_moves > 0
    }
}

/// A fixed run: kept, or given up for a collision.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FixedReport {
    pub check: RunCheck,
    pub kept: bool,
}

/// One candidate position.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CandidateReport {
    pub group: String,
    /// The set-up name it gets (`rtest-03`).
    pub name: String,
    pub position_mm: [f64; 3],
    /// `ok`, `collides`, `unreachable` or `fixture limits`.
    pub status: String,
    pub reason: Option<String>,
    pub runs: Vec<RunCheck>,
    pub chosen: bool,
    /// Chosen if collisions were ignored.
    pub chosen_ignoring_collisions: bool,
}

/// D-criteria (`log det` of the wanted parameters' covariance; lower is better).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Criteria {
    pub fixed_only: f64,
    pub chosen: f64,
    pub ignoring_collisions: f64,
    pub random_best: Option<f64>,
    pub random_median: Option<f64>,
    pub hand: Option<f64>,
}

/// The 95 % half-widths of one parameter under each plan (`None`: not identified).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct IntervalRow {
    pub name: String,
    pub unit: String,
    pub wanted: bool,
    pub fixed_only: Option<f64>,
    pub chosen: Option<f64>,
    pub ignoring_collisions: Option<f64>,
    pub random_median: Option<f64>,
    pub hand: Option<f64>,
}

/// Everything the planner found (`report.json`).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Report {
    pub schema: String,
    pub planning: String,
    pub machine: String,
    pub tool_length_mm: f64,
    pub clearance_mm: f64,
    pub wanted: Vec<String>,
    pub unsupported_geometry: Vec<String>,
    pub fixed_runs: Vec<FixedReport>,
    pub candidates: Vec<CandidateReport>,
    pub criteria: Criteria,
    pub intervals: Vec<IntervalRow>,
    /// Sentences: what collisions and limits made the plan give up, and what it cost.
    pub given_up: Vec<String>,
}

/// A finished plan, ready to be written.
#[derive(Debug)]
pub struct Planned {
    pub report: Report,
    /// The test plan (`plan.toml`).
    pub plan: toml::Table,
    /// Its runs in plan order.
    pub runs: Vec<PlannedRun>,
    /// The plan's machine (tool length added) and its URDF text, error configuration text.
    pub tooled: Machine,
    pub urdf: String,
    pub errors_toml: Option<String>,
}

struct Ctx<'a> {
    src: &'a Source,
    loaded: LoadedMachine,
    tooled: Machine,
    geometry: MachineGeometry,
    tool_length: f64,
    clearance: f64,
    move_step: f64,
    feed: f64,
}

/// Plans from a planning file.
pub fn plan(path: &Path) -> Result<Planned, PlanError> {
    plan_source(&Source::read(path)?)
}

/// Plans from a read planning file.
pub fn plan_source(src: &Source) -> Result<Planned, PlanError> {
    let f = &src.file;
    let machine_arg = f.machine.get_ref();
    let machine_file = src.base().join(machine_arg);
    let arg = if machine_file.is_file() {
        machine_file.to_string_lossy().into_owned()
    } else {
        machine_arg.clone()
    };
    let loaded = load_machine(&arg, Reading::default())
        .map_err(|e| src.at(&f.machine, format!("machine: {e}")))?;
    let tool_length = f.tool_length_mm.as_ref().map_or(100.0, |v| *v.get_ref()) * 1e-3;
    let tooled = tooled_machine(&loaded.machine, tool_length)
        .map_err(|e| src.at(&f.machine, format!("machine with the tool length: {e}")))?;
    let geometry = if machine_file.is_file() {
        MachineGeometry::from_urdf_file(&machine_file, &loaded.machine)?
    } else {
        MachineGeometry {
            bodies: Vec::new(),
            unsupported: vec![format!(
                "`{machine_arg}` is a topology code: the machine has no collision geometry"
            )],
        }
    };
    if let Wanted::Names(names) = f.wanted.get_ref() {
        for name in names {
            let base = name.split('.').next().unwrap_or(name);
            if base.parse::<mtcal_kinematics::ParamName>().is_err() {
                return Err(src.at(
                    &f.wanted,
                    format!(
                        "wanted `{name}` is not an estimated parameter: not an ISO 230-1 name \
                         (EXX, EX0C, EC0Y…; docs/FORMATS.md)"
                    ),
                ));
            }
        }
    }
    let ctx = Ctx {
        src,
        loaded,
        tooled,
        geometry,
        tool_length,
        clearance: f.clearance_mm.as_ref().map_or(1.0, |v| *v.get_ref()) * 1e-3,
        move_step: f.move_step.as_ref().map_or(5.0, |v| *v.get_ref()),
        feed: f.feed_mm_min.as_ref().map_or(1000.0, |v| *v.get_ref()),
    };
    ctx.run()
}

/// One candidate while it is being planned.
struct Cand {
    report: CandidateReport,
    setup: toml::Table,
    runs: Vec<PlannedRun>,
}

impl Ctx<'_> {
    fn run(&self) -> Result<Planned, PlanError> {
        let f = &self.src.file;
        // Fixed runs.
        let mut fixed: Vec<(PlannedRun, RunCheck)> = Vec::new();
        for r in &f.run {
            let run = self.fixed_run(r)?;
            let check = self.check_run(&run)?;
            fixed.push((run, check));
        }
        // Candidates.
        let mut cands: Vec<Cand> = Vec::new();
        let mut budgets = Vec::new();
        let mut group_of = Vec::new();
        for (g, group) in f.candidates.iter().enumerate() {
            budgets.push(*group.get_ref().choose.get_ref());
            for c in self.group_candidates(group)? {
                group_of.push(g);
                cands.push(c);
            }
        }
        let mut seen = std::collections::BTreeSet::new();
        for r in fixed
            .iter()
            .map(|(r, _)| r)
            .chain(cands.iter().flat_map(|c| &c.runs))
        {
            if !seen.insert(r.name.clone()) {
                return Err(PlanError::Spec {
                    at: Location::at(&self.src.path, 1, 1),
                    message: format!("two runs would be named `{}`; rename one", r.name),
                });
            }
        }
        // Information of every unit.
        let reachable: Vec<usize> = (0..cands.len())
            .filter(|&c| matches!(cands[c].report.status.as_str(), "ok" | "collides"))
            .collect();
        let (infos, fixed_kept, fixed_lost, cand_info) =
            self.information(&fixed, &cands, &reachable)?;
        let wanted = self.wanted(&infos)?;
        let m = infos.names.len();
        let zero = DMatrix::zeros(m, m);
        let mut all_fixed = fixed_kept.clone();
        for l in &fixed_lost {
            all_fixed += l;
        }
        let mut choice = Choice {
            base: &fixed_kept,
            candidates: reachable
                .iter()
                .zip(&cand_info)
                .map(|(&c, i)| (group_of[c], i))
                .collect(),
            budget: budgets.clone(),
            excluded: reachable
                .iter()
                .map(|&c| cands[c].report.status != "ok")
                .collect(),
            wanted: &wanted,
        };
        let chosen = choice.choose();
        let chosen_value = choice.value(&chosen);
        let randoms = self.random_values(&choice);
        // As if nothing collided: fixed runs all kept, every reachable candidate allowed.
        let free_choice = Choice {
            base: &all_fixed,
            excluded: vec![false; reachable.len()],
            ..choice.clone()
        };
        let ideal = free_choice.choose();
        let ideal_value = free_choice.value(&ideal);
        for &k in &chosen {
            cands[reachable[k]].report.chosen = true;
        }
        for &k in &ideal {
            cands[reachable[k]].report.chosen_ignoring_collisions = true;
        }
        let hand = self.hand_information(&infos)?;
        choice.excluded = vec![true; reachable.len()];
        let fixed_value = choice.value(&[]);
        let pick =
            |sel: &[usize]| -> Vec<&DMatrix<f64>> { sel.iter().map(|&k| &cand_info[k]).collect() };
        let iv_chosen = info::intervals(&infos, &fixed_kept, &pick(&chosen));
        let iv_ideal = info::intervals(&infos, &all_fixed, &pick(&ideal));
        let iv_fixed = info::intervals(&infos, &fixed_kept, &[]);
        let iv_hand = hand.as_ref().map(|h| info::intervals(&infos, &zero, &[h]));
        let iv_random = randoms.as_ref().map(|(_, sels)| {
            let per: Vec<Vec<Option<f64>>> = sels
                .iter()
                .map(|s| info::intervals(&infos, &fixed_kept, &pick(s)))
                .collect();
            (0..m)
                .map(|k| median(per.iter().map(|v| v[k].unwrap_or(f64::INFINITY)).collect()))
                .map(|v| v.filter(|x| x.is_finite()))
                .collect::<Vec<_>>()
        });
        let intervals: Vec<IntervalRow> = (0..m)
            .map(|k| IntervalRow {
                name: infos.names[k].clone(),
                unit: infos.units[k].0.clone(),
                wanted: wanted.contains(&k),
                fixed_only: iv_fixed[k],
                chosen: iv_chosen[k],
                ignoring_collisions: iv_ideal[k],
                random_median: iv_random.as_ref().and_then(|v| v[k]),
                hand: iv_hand.as_ref().and_then(|v| v[k]),
            })
            .collect();
        let criteria = Criteria {
            fixed_only: fixed_value,
            chosen: chosen_value,
            ignoring_collisions: ideal_value,
            random_best: randoms
                .as_ref()
                .and_then(|(v, _)| v.iter().copied().reduce(f64::min)),
            random_median: randoms.as_ref().and_then(|(v, _)| median(v.clone())),
            hand: hand.as_ref().map(|h| info::criterion(&zero, &[h], &wanted)),
        };
        let given_up = given_up(&fixed, &cands, &intervals);
        // The plan: fixed runs kept, then the chosen candidates' runs.
        let mut runs: Vec<PlannedRun> = fixed
            .iter()
            .filter(|(_, c)| !c.collides())
            .map(|(r, _)| r.clone())
            .collect();
        let mut setups: Vec<(String, toml::Table)> = Vec::new();
        for r in &runs {
            if !setups.iter().any(|(n, _)| *n == r.setup_name) {
                setups.push((r.setup_name.clone(), r.setup.clone()));
            }
        }
        for &k in &chosen {
            let c = &cands[reachable[k]];
            setups.push((c.report.name.clone(), c.setup.clone()));
            runs.extend(c.runs.iter().cloned());
        }
        let plan = self.plan_table(&runs, &setups, &infos);
        let (urdf, errors_toml) = self.machine_files()?;
        let report = Report {
            schema: "mtcal.plan/1".into(),
            planning: self.src.path.display().to_string(),
            machine: self.loaded.source.clone(),
            tool_length_mm: self.tool_length * 1e3,
            clearance_mm: self.clearance * 1e3,
            wanted: wanted.iter().map(|&k| infos.names[k].clone()).collect(),
            unsupported_geometry: self.geometry.unsupported.clone(),
            fixed_runs: fixed
                .iter()
                .map(|(_, c)| FixedReport {
                    check: c.clone(),
                    kept: !c.collides(),
                })
                .collect(),
            candidates: cands.into_iter().map(|c| c.report).collect(),
            criteria,
            intervals,
            given_up,
        };
        Ok(Planned {
            report,
            plan,
            runs,
            tooled: self.tooled.clone(),
            urdf,
            errors_toml,
        })
    }

    /// A `[[run]]` of the planning file, its set-up loaded and its path generated.
    fn fixed_run(&self, r: &toml::Spanned<toml::Table>) -> Result<PlannedRun, PlanError> {
        let err = |m: String| self.src.at(r, m);
        let keys = run_keys::read(r.get_ref()).map_err(err)?;
        let name = keys.name;
        let instrument = keys
            .instrument
            .ok_or_else(|| err(format!("run `{name}`: missing `instrument`")))?;
        let (setup_name, setup) = match keys.setup {
            Some(toml::Value::String(s)) => {
                let table = self
                    .src
                    .file
                    .setup
                    .get(&s)
                    .and_then(|v| v.as_table())
                    .ok_or_else(|| err(format!("run `{name}`: no [setup.{s}] in the file")))?;
                (s, table.clone())
            }
            Some(toml::Value::Table(tb)) => (name.clone(), tb),
            _ => {
                return Err(err(format!(
                    "run `{name}`: `setup` must name a [setup.<name>] or be a table"
                )));
            }
        };
        let feed = keys.feed_mm_min.unwrap_or(self.feed);
        self.planned_setup(&instrument, &setup_name, &setup)
            .and_then(|setup| self.make_run(&name, &setup, &keys.path, &keys.use_, feed))
            .map_err(|m| err(format!("run `{name}`: {m}")))
    }

    /// The set-up `table` of `instrument` loaded by its plugin on the plan's machine, once for
    /// every run that shares it, with the keys the instrument has the planner write out
    /// ([`Planning::written_out`](mtcal_instrument::collision::Planning::written_out), an
    /// R-test's `mount`) taken from the loaded set-up where they are left to the plugin's
    /// default, so that the plan — and the session simulated from it — says what it was planned
    /// and collision-checked for. `Err` says why it does not load.
    fn planned_setup(
        &self,
        instrument: &str,
        name: &str,
        table: &toml::Table,
    ) -> Result<PlannedSetup, String> {
        let plugin =
            mtcal_plugins::find(instrument).ok_or_else(|| mtcal_plugins::unknown(instrument))?;
        let ctx = SetupContext {
            machine: &self.tooled,
        };
        let loaded: Arc<dyn Setup> = (plugin.load_setup)(table, &ctx)
            .map_err(|e| format!("set-up: {e}"))?
            .into();
        Ok(PlannedSetup {
            plugin,
            name: name.to_string(),
            table: Self::with_defaults_written_out(plugin, table, &*loaded),
            loaded,
        })
    }

    /// `setup` with the keys the planner writes out taken from `loaded` ([`Self::planned_setup`]).
    fn with_defaults_written_out(
        plugin: &InstrumentPlugin,
        setup: &toml::Table,
        loaded: &dyn Setup,
    ) -> toml::Table {
        let mut out = setup.clone();
        let keys = plugin.planning.map_or(&[][..], |p| p.written_out);
        if keys.iter().all(|k| setup.contains_key(*k)) {
            return out;
        }
        let loaded = loaded.to_toml();
        for key in keys.iter().filter(|k| !setup.contains_key(**k)) {
            if let Some(value) = loaded.get(*key) {
                out.insert((*key).into(), value.clone());
            }
        }
        out
    }

    /// The run `name` of a planned set-up: its path generated; `Err` says why not.
    fn make_run(
        &self,
        name: &str,
        setup: &PlannedSetup,
        path: &toml::Table,
        use_: &str,
        feed: f64,
    ) -> Result<PlannedRun, String> {
        let plugin = setup.plugin;
        let spec = PathSpec {
            path,
            setup: &*setup.loaded,
            machine: &self.tooled,
        };
        let poses = (plugin.path)(&spec).map_err(|e| format!("path: {e}"))?;
        if poses.is_empty() {
            return Err("the path has no samples".into());
        }
        let labels = match plugin.path_labels {
            Some(f) => f(&spec)
                .map_err(|e| format!("path: {e}"))?
                .into_iter()
                .map(|v| v.into_iter().next().unwrap_or_default())
                .collect(),
            None => Vec::new(),
        };
        Ok(PlannedRun {
            name: name.to_string(),
            instrument: plugin.name.to_string(),
            setup_name: setup.name.clone(),
            setup: setup.table.clone(),
            loaded: setup.loaded.clone(),
            path: path.clone(),
            use_: use_.to_string(),
            feed_mm_min: feed,
            poses,
            labels,
        })
    }

    /// Checks every pose of a run and, with `move_step`, the moves between them.
    fn check_run(&self, run: &PlannedRun) -> Result<RunCheck, PlanError> {
        let geo_err = |m: String| PlanError::Geometry {
            file: self.src.path.clone(),
            message: format!("run `{}`: {m}", run.name),
        };
        let plugin = mtcal_plugins::find(&run.instrument)
            .ok_or_else(|| geo_err(mtcal_plugins::unknown(&run.instrument)))?;
        let bodies = bodies_of(
            plugin,
            &*run.loaded,
            &run.setup,
            self.tool_length,
            &self.loaded.machine,
            &self.src.geometry,
        )
        .map_err(geo_err)?;
        let unchecked = bodies.is_none();
        let (bodies, allowed) = bodies.unwrap_or_default();
        let scene = Scene::new(
            &self.loaded.machine,
            &self.tooled,
            &self.geometry,
            bodies,
            allowed,
            self.clearance,
        );
        let mut out = RunCheck {
            run: run.name.clone(),
            poses: run.poses.len(),
            colliding_poses: 0,
            colliding_moves: 0,
            first_pose: None,
            worst: None,
            instrument_unchecked: unchecked,
        };
        let note = |hits: Vec<Hit>, out: &mut RunCheck| {
            for h in hits {
                if out
                    .worst
                    .as_ref()
                    .is_none_or(|w| h.distance_mm < w.distance_mm)
                {
                    out.worst = Some(h);
                }
            }
        };
        for (i, q) in run.poses.iter().enumerate() {
            let label = run.labels.get(i).map(String::as_str);
            let hits = scene.check(q, label).map_err(geo_err)?;
            if !hits.is_empty() {
                out.colliding_poses += 1;
                out.first_pose.get_or_insert(i);
                note(hits, &mut out);
            }
            if self.move_step <= 0.0 || i + 1 == run.poses.len() {
                continue;
            }
            let next = &run.poses[i + 1];
            let steps = self
                .tooled
                .axes()
                .iter()
                .zip(q.iter().zip(next))
                .map(|(a, (x, y))| {
                    let d = (y - x).abs();
                    match a.kind() {
                        AxisKind::Linear => d * 1e3 / self.move_step,
                        AxisKind::Rotary => d.to_degrees() / self.move_step,
                    }
                })
                .fold(0.0, f64::max)
                .ceil() as usize;
            for s in 1..steps.min(10_000) {
                let t = s as f64 / steps as f64;
                let mid: Vec<f64> = q.iter().zip(next).map(|(x, y)| x + t * (y - x)).collect();
                let hits = scene.check(&mid, label).map_err(geo_err)?;
                if !hits.is_empty() {
                    out.colliding_moves += 1;
                    note(hits, &mut out);
                }
            }
        }
        Ok(out)
    }

    /// A group's candidates: fixture limits, reach (the plugin's path), collisions.
    fn group_candidates(&self, group: &toml::Spanned<Group>) -> Result<Vec<Cand>, PlanError> {
        let g = group.get_ref();
        let instrument = g.instrument.get_ref();
        if mtcal_plugins::find(instrument).is_none() {
            return Err(self.src.at(
                &g.instrument,
                format!(
                    "unknown instrument `{instrument}`; known: {}",
                    mtcal_plugins::plugins()
                        .iter()
                        .map(|p| p.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        let key = match &g.position {
            Some(k) => k.get_ref().clone(),
            None => match mtcal_plugins::find(instrument)
                .and_then(|p| p.planning)
                .and_then(|p| p.position_key)
            {
                Some(k) => k.to_string(),
                None => {
                    return Err(self.src.at(
                        &g.instrument,
                        format!("instrument `{instrument}`: say which set-up key takes the position (`position = \"…\"`)"),
                    ));
                }
            },
        };
        let table_z = self.src.geometry.table_z_mm();
        let mut out = Vec::new();
        for (k, pos) in g.positions().into_iter().enumerate() {
            let name = format!("{}-{:02}", g.name.get_ref(), k + 1);
            let mut setup = g.setup.clone();
            setup.insert(
                key.clone(),
                toml::Value::Array(pos.iter().map(|&v| toml::Value::Float(v)).collect()),
            );
            let planned = self.planned_setup(instrument, &name, &setup);
            let setup = planned.as_ref().map_or(setup, |p| p.table.clone());
            let mut report = CandidateReport {
                group: g.name.get_ref().clone(),
                name: name.clone(),
                position_mm: pos,
                status: "ok".into(),
                reason: None,
                runs: Vec::new(),
                chosen: false,
                chosen_ignoring_collisions: false,
            };
            let radius = pos[0].hypot(pos[1]);
            let limit = if let Some(r) = g.max_radius_mm.as_ref().filter(|r| radius > *r.get_ref())
            {
                Some(format!(
                    "{radius:.1} mm from the workpiece origin, beyond max_radius_mm = {}",
                    r.get_ref()
                ))
            } else if let Some(h) = g.height_mm.as_ref() {
                let [lo, hi] = *h.get_ref();
                let height = pos[2] - table_z;
                (height < lo || height > hi).then(|| {
                    format!("{height:.1} mm above the table top, outside height_mm = [{lo}, {hi}]")
                })
            } else {
                None
            };
            if let Some(reason) = limit {
                report.status = "fixture limits".into();
                report.reason = Some(reason);
                out.push(Cand {
                    report,
                    setup,
                    runs: Vec::new(),
                });
                continue;
            }
            let mut runs = Vec::new();
            for r in g.runs.get_ref() {
                let feed = r.feed_mm_min.as_ref().map_or(self.feed, |f| *f.get_ref());
                let use_ = r
                    .use_
                    .as_ref()
                    .map_or("fit".to_string(), |u| u.get_ref().clone());
                let run_name = format!("{name}-{}", r.name.get_ref());
                let made = planned
                    .as_ref()
                    .map_err(Clone::clone)
                    .and_then(|p| self.make_run(&run_name, p, &r.path, &use_, feed));
                match made {
                    Ok(run) => runs.push(run),
                    Err(m) if m.starts_with("unknown instrument") || m.starts_with("set-up") => {
                        return Err(self
                            .src
                            .at(group, format!("group `{}`: {m}", g.name.get_ref())));
                    }
                    Err(m) => {
                        report.status = "unreachable".into();
                        report.reason = Some(format!("run `{}`: {m}", r.name.get_ref()));
                        break;
                    }
                }
            }
            if report.status == "ok" {
                for run in &runs {
                    let check = self.check_run(run)?;
                    if check.collides() {
                        report.status = "collides".into();
                    }
                    report.runs.push(check);
                }
            }
            if report.status == "unreachable" {
                runs.clear();
            }
            out.push(Cand {
                report,
                setup,
                runs,
            });
        }
        Ok(out)
    }

    /// Simulates every fixed run and reachable candidate once (noise-free), and linearises:
    /// the kept fixed runs' information, each colliding fixed run's, each candidate's.
    #[allow(clippy::type_complexity)]
    fn information(
        &self,
        fixed: &[(PlannedRun, RunCheck)],
        cands: &[Cand],
        reachable: &[usize],
    ) -> Result<
        (
            Informations,
            DMatrix<f64>,
            Vec<DMatrix<f64>>,
            Vec<DMatrix<f64>>,
        ),
        PlanError,
    > {
        let mut runs: Vec<PlannedRun> = fixed.iter().map(|(r, _)| r.clone()).collect();
        let mut setups: Vec<(String, toml::Table)> = Vec::new();
        for (r, _) in fixed {
            if !setups.iter().any(|(n, _)| *n == r.setup_name) {
                setups.push((r.setup_name.clone(), r.setup.clone()));
            }
        }
        for &c in reachable {
            setups.push((cands[c].report.name.clone(), cands[c].setup.clone()));
            runs.extend(cands[c].runs.iter().cloned());
        }
        if runs.iter().all(|r| r.use_ != "fit") {
            return Err(PlanError::Spec {
                at: Location::at(&self.src.path, 1, 1),
                message: "nothing to plan: no fixed run and no reachable candidate is fitted"
                    .into(),
            });
        }
        let infos_err = |e: String| PlanError::Information(e);
        let table = self.plan_table(
            &runs,
            &setups,
            &Informations {
                names: Vec::new(),
                units: Vec::new(),
                units_info: Vec::new(),
            },
        );
        let study = self.simulated_study(table)?;
        let index = |name: &str| study.runs.iter().position(|r| r.name == name && r.fit);
        let mut units: Vec<Vec<usize>> = Vec::new();
        units.push(
            fixed
                .iter()
                .filter(|(_, c)| !c.collides())
                .filter_map(|(r, _)| index(&r.name))
                .collect(),
        );
        let lost: Vec<&PlannedRun> = fixed
            .iter()
            .filter(|(_, c)| c.collides())
            .map(|(r, _)| r)
            .collect();
        for r in &lost {
            units.push(index(&r.name).into_iter().collect());
        }
        for &c in reachable {
            units.push(
                cands[c]
                    .runs
                    .iter()
                    .filter_map(|r| index(&r.name))
                    .collect(),
            );
        }
        let nonempty: Vec<Vec<usize>> = units.iter().filter(|u| !u.is_empty()).cloned().collect();
        let computed =
            info::unit_information(&study, &nonempty).map_err(|e| infos_err(e.to_string()))?;
        let m = computed.names.len();
        let mut it = computed.units_info.clone().into_iter();
        let mut mats: Vec<DMatrix<f64>> = units
            .iter()
            .map(|u| {
                if u.is_empty() {
                    DMatrix::zeros(m, m)
                } else {
                    it.next().unwrap_or_else(|| DMatrix::zeros(m, m))
                }
            })
            .collect();
        let cand_info = mats.split_off(1 + lost.len());
        let lost_info = mats.split_off(1);
        let kept = mats.pop().unwrap_or_else(|| DMatrix::zeros(m, m));
        Ok((computed, kept, lost_info, cand_info))
    }

    /// The study of the plan `table` on the plan's machine, simulated noise-free in memory.
    fn simulated_study(&self, mut table: toml::Table) -> Result<Study, PlanError> {
        let info = |e: String| PlanError::Information(e);
        let (urdf, errors) = self.machine_files()?;
        let machine = PlanMachine::from_urdf(urdf, errors).map_err(|e| info(e.to_string()))?;
        noise_free(&mut table);
        let plan = Plan::from_table(table, &self.src.path).map_err(|e| info(e.to_string()))?;
        simulated_study(&plan, machine, self.src.base()).map_err(info)
    }

    /// The wanted parameters as indices into the machine parameters.
    fn wanted(&self, infos: &Informations) -> Result<Vec<usize>, PlanError> {
        let w = &self.src.file.wanted;
        match w.get_ref() {
            Wanted::All(_) => Ok((0..infos.names.len()).collect()),
            Wanted::Names(names) => {
                let mut out = Vec::new();
                for name in names {
                    let hits: Vec<usize> = (0..infos.names.len())
                        .filter(|&k| {
                            let l = &infos.names[k];
                            l == name
                                || l.strip_prefix(name.as_str())
                                    .is_some_and(|r| r.starts_with('.'))
                        })
                        .collect();
                    if hits.is_empty() {
                        return Err(self.src.at(
                            w,
                            format!(
                                "wanted `{name}` is not an estimated parameter; estimated: {} (set \
                                 [identify] parameters)",
                                infos.names.join(", ")
                            ),
                        ));
                    }
                    out.extend(
                        hits.into_iter()
                            .filter(|k| !out.contains(k))
                            .collect::<Vec<_>>(),
                    );
                }
                Ok(out)
            }
        }
    }

    /// The hand-written plan's information on our machine parameters (by name).
    fn hand_information(&self, infos: &Informations) -> Result<Option<DMatrix<f64>>, PlanError> {
        let Some(c) = &self.src.file.compare else {
            return Ok(None);
        };
        let path = self.src.base().join(c.get_ref());
        let text = std::fs::read_to_string(&path)
            .map_err(|e| self.src.at(c, format!("compare: {}: {e}", path.display())))?;
        let mut table: toml::Table = toml::from_str(&text).map_err(|e| {
            self.src
                .at(c, format!("compare: {}: {}", path.display(), e.message()))
        })?;
        for k in ["truth", "truth_errors", "effect", "context", "nuisance"] {
            table.remove(k);
        }
        let mut identify = table
            .get("identify")
            .and_then(|v| v.as_table())
            .cloned()
            .unwrap_or_default();
        identify.insert("parameters".into(), self.estimated_names(infos).into());
        table.insert("identify".into(), identify.into());
        noise_free(&mut table);
        let compare = |e: String| self.src.at(c, format!("compare: {e}"));
        // Read as the file it came from: its machine and paths relative to its folder.
        let plan = Plan::from_table(table, &path).map_err(|e| compare(e.to_string()))?;
        let machine = plan.machine().map_err(|e| compare(e.to_string()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let study = simulated_study(&plan, machine, base).map_err(compare)?;
        let fit: Vec<usize> = (0..study.runs.len())
            .filter(|&r| study.runs[r].fit)
            .collect();
        let theirs = info::unit_information(&study, &[fit])?;
        let m = infos.names.len();
        let map: Vec<Option<usize>> = theirs
            .names
            .iter()
            .map(|n| infos.names.iter().position(|o| o == n))
            .collect();
        let mut out = DMatrix::zeros(m, m);
        let t = &theirs.units_info[0];
        for (a, ma) in map.iter().enumerate() {
            for (b, mb) in map.iter().enumerate() {
                if let (Some(i), Some(j)) = (ma, mb) {
                    out[(*i, *j)] = t[(a, b)];
                }
            }
        }
        Ok(Some(out))
    }

    /// `[identify] parameters`: the file's, else the wanted names, else the estimated labels.
    fn estimated_names(&self, infos: &Informations) -> Vec<toml::Value> {
        if let Some(p) = self
            .src
            .file
            .identify
            .get("parameters")
            .and_then(|v| v.as_array())
        {
            return p.clone();
        }
        match self.src.file.wanted.get_ref() {
            Wanted::Names(n) => n.iter().map(|s| s.clone().into()).collect(),
            Wanted::All(_) => infos.names.iter().map(|s| s.clone().into()).collect(),
        }
    }

    /// Random selections within the budgets (their criteria and the selections).
    #[allow(clippy::type_complexity)]
    fn random_values(&self, choice: &Choice<'_>) -> Option<(Vec<f64>, Vec<Vec<usize>>)> {
        let trials = self.src.file.random_trials.unwrap_or(20);
        if trials == 0 {
            return None;
        }
        let budget = choice.effective_budget();
        let mut state = self.src.file.seed.unwrap_or(1);
        let mut next = move || {
            // splitmix64
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        let (mut values, mut sels) = (Vec::new(), Vec::new());
        for _ in 0..trials {
            let mut sel = Vec::new();
            for (g, &k) in budget.iter().enumerate() {
                let mut pool: Vec<usize> = (0..choice.candidates.len())
                    .filter(|&c| choice.candidates[c].0 == g && !choice.excluded[c])
                    .collect();
                for _ in 0..k {
                    let i = (next() % pool.len() as u64) as usize;
                    sel.push(pool.swap_remove(i));
                }
            }
            sel.sort_unstable();
            values.push(choice.value(&sel));
            sels.push(sel);
        }
        Some((values, sels))
    }

    /// The test plan of `runs`.
    fn plan_table(
        &self,
        runs: &[PlannedRun],
        setups: &[(String, toml::Table)],
        infos: &Informations,
    ) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert("machine".into(), "machine.urdf".into());
        let mut identify = self.src.file.identify.clone();
        if !identify.contains_key("parameters") {
            let names = self.estimated_names(infos);
            if !names.is_empty() {
                identify.insert("parameters".into(), names.into());
            }
        }
        if !identify.is_empty() {
            t.insert("identify".into(), identify.into());
        }
        let mut st = toml::Table::new();
        for (n, s) in setups {
            st.insert(n.clone(), s.clone().into());
        }
        t.insert("setup".into(), st.into());
        let list: Vec<toml::Value> = runs
            .iter()
            .map(|r| {
                let mut x = toml::Table::new();
                x.insert("name".into(), r.name.clone().into());
                x.insert("instrument".into(), r.instrument.clone().into());
                x.insert("setup".into(), r.setup_name.clone().into());
                x.insert("use".into(), r.use_.clone().into());
                x.insert("path".into(), r.path.clone().into());
                x.insert("feed_mm_min".into(), r.feed_mm_min.into());
                x.into()
            })
            .collect();
        t.insert("run".into(), list.into());
        t
    }

    /// The plan's machine: the URDF (the original text when the tool length is 0, else the
    /// tooled machine written out) and the error configuration's text.
    fn machine_files(&self) -> Result<(String, Option<String>), PlanError> {
        let src = Path::new(&self.loaded.source);
        let urdf = if self.tool_length == 0.0 && src.is_file() {
            std::fs::read_to_string(src).map_err(|e| PlanError::Io {
                path: src.to_path_buf(),
                cause: e,
            })?
        } else {
            let comment = format!(
                "{} with the tool point {:.3} mm down the tool axis (mtcal plan: the R-test ball, \
                 ball-bar ball or probe centre). Collision geometry is in the original file.",
                self.loaded.source,
                self.tool_length * 1e3
            );
            mtcal_machine::urdf::write_urdf(&self.tooled, Some(&comment))
        };
        let cfg = Path::new(&self.loaded.config_source);
        let errors = if cfg.is_file() {
            Some(std::fs::read_to_string(cfg).map_err(|e| PlanError::Io {
                path: cfg.to_path_buf(),
                cause: e,
            })?)
        } else {
            None
        };
        Ok((urdf, errors))
    }
}

/// Every run of a test plan noise-free: the information of the runs, not of one noise draw.
fn noise_free(plan: &mut toml::Table) {
    if let Some(toml::Value::Array(runs)) = plan.get_mut("run") {
        for r in runs.iter_mut().filter_map(|r| r.as_table_mut()) {
            r.insert("noise".into(), toml::Value::Float(0.0));
        }
    }
}

/// `plan` simulated on `machine` in memory and made a study, as if its session were the
/// folder `dir`; or why not.
fn simulated_study(plan: &Plan, machine: PlanMachine, dir: &Path) -> Result<Study, String> {
    let session =
        mtcal_simulate::simulate_session(plan, machine, &[], dir).map_err(|e| e.to_string())?;
    let (session, machine, tables) = session.into_parts();
    Study::from_parts(session, machine, tables).map_err(|e| e.to_string())
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Sentences on what was given up and its cost.
fn given_up(
    fixed: &[(PlannedRun, RunCheck)],
    cands: &[Cand],
    intervals: &[IntervalRow],
) -> Vec<String> {
    let mut out = Vec::new();
    let describe = |c: &RunCheck| {
        let w = c.worst.as_ref().map_or(String::new(), |h| {
            format!(", worst {} vs {} at {:.1} mm", h.a, h.b, h.distance_mm)
        });
        format!(
            "{} of {} poses and {} move samples collide (first at pose {}){w}",
            c.colliding_poses,
            c.poses,
            c.colliding_moves,
            c.first_pose.map_or("-".into(), |p| p.to_string())
        )
    };
    for (r, c) in fixed {
        if c.collides() {
            out.push(format!("fixed run `{}` given up: {}", r.name, describe(c)));
        }
    }
    for c in cands {
        let r = &c.report;
        if r.status == "collides" {
            let runs: Vec<String> = r
                .runs
                .iter()
                .filter(|x| x.collides())
                .map(|x| format!("`{}`: {}", x.run, describe(x)))
                .collect();
            let lost = if r.chosen_ignoring_collisions {
                " (it would have been chosen)"
            } else {
                ""
            };
            out.push(format!(
                "position {} {:?} mm given up{lost}: {}",
                r.name,
                r.position_mm,
                runs.join("; ")
            ));
        }
    }
    let costs: Vec<String> = intervals
        .iter()
        .filter(|i| i.wanted)
        .filter_map(|i| match (i.chosen, i.ignoring_collisions) {
            (Some(a), Some(b)) if a > b * 1.005 => {
                Some(format!("{} ±{:.3} → ±{:.3} {}", i.name, b, a, i.unit))
            }
            (None, Some(b)) => Some(format!("{} ±{:.3} {} → not identified", i.name, b, i.unit)),
            _ => None,
        })
        .collect();
    if !costs.is_empty() {
        out.push(format!(
            "cost of the collisions (intervals without → with them): {}",
            costs.join(", ")
        ));
    } else if out.iter().any(|s| s.contains("given up")) {
        out.push("the collisions cost nothing in the wanted intervals (within 0.5 %)".into());
    }
    out
}

impl Planned {
    /// Writes `plan.toml`, the machine, one NC program per run, `report.json` and
    /// `report.txt` into `dir` (created if needed). Returns the files written.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, PlanError> {
        // Every file at once ([`mtcal_located::Outputs`]): an error leaves none behind.
        let mut files = mtcal_located::Outputs::new();
        files.folder(dir);
        let programs = dir.join("programs");
        let header = format!(
            "# Test plan written by `cargo xtask plan` from {} (see report.txt).\n# Simulate it with \
             `cargo xtask simulate plan.toml --out session`; run programs/<run>.nc on the machine.\n",
            self.report.planning
        );
        let body =
            toml::to_string(&self.plan).map_err(|e| PlanError::Information(e.to_string()))?;
        files.file(dir.join("plan.toml"), format!("{header}{body}"));
        files.file(dir.join("machine.urdf"), self.urdf.clone());
        if let Some(e) = &self.errors_toml {
            files.file(dir.join("machine.errors.toml"), e.clone());
        }
        for r in self.runs.iter() {
            let text = mtcal_instrument::program::nc_program(
                &self.tooled,
                &r.poses,
                r.feed_mm_min,
                &format!("mtcal {} run {}", r.instrument, r.name),
            );
            files.file(programs.join(format!("{}.nc", r.name)), text);
        }
        let json = serde_json::to_string_pretty(&self.report)
            .map_err(|e| PlanError::Information(e.to_string()))?;
        files.file(dir.join("report.json"), json);
        files.file(dir.join("report.txt"), self.report.summary());
        Ok(files.commit()?)
    }
}

impl Report {
    /// A plain-text account: the chosen positions, what collided, the intervals.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "measurement plan for {} (tool length {:.1} mm, clearance {:.1} mm)",
            self.machine, self.tool_length_mm, self.clearance_mm
        );
        let _ = writeln!(s, "wanted: {}", self.wanted.join(", "));
        for u in &self.unsupported_geometry {
            let _ = writeln!(s, "note: {u}");
        }
        for f in &self.fixed_runs {
            let _ = writeln!(
                s,
                "fixed run {:<28} {}",
                f.check.run,
                if f.kept {
                    "kept"
                } else {
                    "GIVEN UP (collision)"
                }
            );
        }
        let _ = writeln!(s, "candidates:");
        for c in &self.candidates {
            let mark = if c.chosen { "*" } else { " " };
            let why = c
                .reason
                .as_deref()
                .map_or(String::new(), |r| format!(": {r}"));
            let _ = writeln!(
                s,
                " {mark} {:<14} [{:>7.1} {:>7.1} {:>7.1}] {}{why}",
                c.name, c.position_mm[0], c.position_mm[1], c.position_mm[2], c.status
            );
        }
        let c = &self.criteria;
        let opt = |v: Option<f64>| v.map_or("-".into(), |x| format!("{x:.2}"));
        let _ = writeln!(
            s,
            "D-criterion (log det of the wanted covariance / prior², lower is better): fixed runs \
             only {:.2}, chosen {:.2}, ignoring collisions {:.2}, random best {} median {}, hand \
             plan {}",
            c.fixed_only,
            c.chosen,
            c.ignoring_collisions,
            opt(c.random_best),
            opt(c.random_median),
            opt(c.hand)
        );
        let _ = writeln!(
            s,
            "95 % intervals (- = not identified):\n  {:<16} {:<5} {:>11} {:>11} {:>11} {:>11} {:>11}",
            "parameter", "unit", "fixed only", "chosen", "no-collide", "random med", "hand plan"
        );
        let cell = |v: Option<f64>| v.map_or("-".into(), |x| format!("±{x:.4}"));
        for r in self.intervals.iter().filter(|r| r.wanted) {
            let _ = writeln!(
                s,
                "  {:<16} {:<5} {:>11} {:>11} {:>11} {:>11} {:>11}",
                r.name,
                r.unit,
                cell(r.fixed_only),
                cell(r.chosen),
                cell(r.ignoring_collisions),
                cell(r.random_median),
                cell(r.hand)
            );
        }
        for g in &self.given_up {
            let _ = writeln!(s, "given up: {g}");
        }
        s
    }
}

/// Positions and statuses for tests and callers: the chosen candidates' names.
impl Report {
    pub fn chosen(&self) -> Vec<&str> {
        self.candidates
            .iter()
            .filter(|c| c.chosen)
            .map(|c| c.name.as_str())
            .collect()
    }
}
