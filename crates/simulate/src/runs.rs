//! The plan's runs before any reading: each run's set-up, commanded path, labels, times and
//! context, and the distinct set-ups with their true nuisance values.

use crate::SimulateError;
use crate::keys::{RunKeys, RunMessages, RunName, SetupKey};
use crate::plan::{Plan, Settings};
use crate::record::Record;
use mtcal_instrument::{Channel, InstrumentPlugin, PathSpec, Setup, SetupContext};
use mtcal_kinematics::MachineModel;
use mtcal_located::toml::{SerdeMessages, from_table};
use mtcal_session::{RunUse, SetupRef};

/// One run of a plan, ready to be measured.
pub(crate) struct PlannedRun {
    pub name: String,
    pub instrument: String,
    pub setup_ref: SetupRef,
    /// Index into the plan's distinct set-ups.
    pub setup: usize,
    pub use_: RunUse,
    pub poses: Vec<Vec<f64>>,
    /// Each sample's label values (instruments with label columns), and their numbers.
    pub labels: Vec<Vec<String>>,
    pub label_numbers: Vec<u32>,
    pub t: Vec<f64>,
    /// Context columns sampled at `t` (file units).
    pub context: Vec<(String, Vec<f64>)>,
    /// σ of each channel's noise, SI (0: noise-free).
    pub noise: Vec<f64>,
    pub with_readings: bool,
    pub feed: f64,
}

/// One distinct set-up of a plan.
pub(crate) struct PlannedSetup {
    pub name: String,
    pub instrument: String,
    pub setup: Box<dyn Setup>,
    /// True nuisance values (SI).
    pub nuis: Vec<f64>,
}

/// A run's set-up as the plan gives it.
struct SetupChoice {
    reference: SetupRef,
    /// The shared set-up's name, or the run's own name.
    name: String,
    table: toml::Table,
}

/// Every run of the plan in order, and the distinct set-ups they use. The runs follow each
/// other in session time, the plan's pause between them.
pub(crate) fn plan_runs(
    plan: &Plan,
    settings: &Settings,
    model: &MachineModel,
) -> Result<(Vec<PlannedRun>, Vec<PlannedSetup>), SimulateError> {
    let mut runs = Vec::new();
    let mut setups: Vec<PlannedSetup> = Vec::new();
    let mut t0 = 0.0;
    for (ri, table) in plan.runs()?.iter().enumerate() {
        let name = from_table::<RunName>(table, &SerdeMessages)
            .ok()
            .and_then(|n| n.name)
            .ok_or_else(|| plan.error(format!("run {} has no `name`", ri + 1)))?;
        let name = name.as_str();
        let (mut run, setup, end) = from_table::<RunKeys>(table, &RunMessages)
            .map_err(|p| p.message)
            .and_then(|keys| plan_run(&keys, name, settings, model, t0))
            .map_err(|message| plan.run_error(name, message))?;
        t0 = end;
        run.setup = match setups.iter().position(|d| d.name == setup.name) {
            Some(i) => i,
            None => {
                setups.push(setup);
                setups.len() - 1
            }
        };
        runs.push(run);
    }
    Ok((runs, setups))
}

/// Run `name` (its plan table `run`) starting at session time `t0`: the run (its set-up
/// index not yet set), its set-up as loaded and the time the next run starts; or what is
/// wrong with it.
fn plan_run(
    run: &RunKeys,
    name: &str,
    settings: &Settings,
    model: &MachineModel,
    t0: f64,
) -> Result<(PlannedRun, PlannedSetup, f64), String> {
    let (instrument, plugin) = plugin_of(run)?;
    let choice = setup_choice(run, name, settings)?;
    let use_ = run_use(run)?;
    let empty = toml::Table::new();
    let path_table = run.path.as_ref().unwrap_or(&empty);
    let ctx = SetupContext {
        machine: model.machine(),
    };
    let setup = (plugin.load_setup)(&choice.table, &ctx).map_err(|e| format!("set-up: {e}"))?;
    let spec = PathSpec {
        path: path_table,
        setup: &*setup,
        machine: model.machine(),
    };
    let poses = commanded_poses(plugin, &spec, &settings.record, model)?;
    let (labels, label_numbers) = path_labels(plugin, &spec, &*setup, poses.len())?;
    let nuis = true_nuisance(&*setup, &choice.name, &settings.nuisance)?;
    let noise = run_noise(run, setup.channels())?;
    let with_readings = with_readings(run);
    let dt = interval(run, settings.interval)?;
    let feed = feed(run)?;
    let t = sample_times(t0, dt, poses.len(), &settings.record)?;
    let end = t0 + (poses.len() as f64 * dt + settings.pause);
    let context = context_columns(&t, settings);
    let planned = PlannedRun {
        name: name.to_string(),
        instrument: instrument.to_string(),
        setup_ref: choice.reference,
        setup: 0,
        use_,
        poses,
        labels,
        label_numbers,
        t,
        context,
        noise,
        with_readings,
        feed,
    };
    let setup = PlannedSetup {
        name: choice.name,
        instrument: instrument.to_string(),
        setup,
        nuis,
    };
    Ok((planned, setup, end))
}

/// The run's instrument and its plugin.
fn plugin_of(run: &RunKeys) -> Result<(&str, &'static InstrumentPlugin), String> {
    let instrument = run
        .instrument
        .as_deref()
        .ok_or_else(|| "missing `instrument`".to_string())?;
    let plugin =
        mtcal_plugins::find(instrument).ok_or_else(|| mtcal_plugins::unknown(instrument))?;
    Ok((instrument, plugin))
}

/// `setup = "<name>"` (a shared `[setup.<name>]`), an own table, or none (an empty own one).
fn setup_choice(run: &RunKeys, name: &str, settings: &Settings) -> Result<SetupChoice, String> {
    let (reference, name, table) = match &run.setup {
        Some(SetupKey::Shared(s)) => {
            let t = settings
                .setups
                .get(s)
                .ok_or_else(|| format!("no [setup.{s}] in the plan"))?;
            (SetupRef::Shared(s.clone()), s.clone(), t.clone())
        }
        Some(SetupKey::Own(t)) => (SetupRef::Own(t.clone()), name.to_string(), t.clone()),
        None => (
            SetupRef::Own(toml::Table::new()),
            name.to_string(),
            toml::Table::new(),
        ),
    };
    Ok(SetupChoice {
        reference,
        name,
        table,
    })
}

/// `use = "fit"` (the default) or `"validate"`.
fn run_use(run: &RunKeys) -> Result<RunUse, String> {
    match run.use_.as_ref().and_then(|v| v.as_str()) {
        None | Some("fit") => Ok(RunUse::Fit),
        Some("validate") => Ok(RunUse::Validate),
        Some(other) => Err(format!(
            "`use` must be \"fit\" or \"validate\", found \"{other}\""
        )),
    }
}

/// The plugin's path for `spec`, as the controller is given it (`[record] positions`).
fn commanded_poses(
    plugin: &InstrumentPlugin,
    spec: &PathSpec<'_>,
    record: &Record,
    model: &MachineModel,
) -> Result<Vec<Vec<f64>>, String> {
    let poses = (plugin.path)(spec).map_err(|e| format!("path: {e}"))?;
    if poses.is_empty() {
        return Err("the path has no samples".into());
    }
    Ok(record.positions_of(model.machine(), poses))
}

/// Each sample's label values and their numbers (empty for an instrument without labels).
fn path_labels(
    plugin: &InstrumentPlugin,
    spec: &PathSpec<'_>,
    setup: &dyn Setup,
    samples: usize,
) -> Result<(Vec<Vec<String>>, Vec<u32>), String> {
    let labels = match plugin.path_labels {
        Some(f) => f(spec).map_err(|e| format!("path: {e}"))?,
        None => Vec::new(),
    };
    let numbers = labels
        .iter()
        .map(|values| {
            let refs: Vec<&str> = values.iter().map(String::as_str).collect();
            setup.resolve_label(&refs)
        })
        .collect::<Result<Vec<u32>, _>>()
        .map_err(|e| format!("path labels: {e}"))?;
    if !setup.label_columns().is_empty() && labels.len() != samples {
        return Err(format!(
            "the path gives {} label sets for {samples} samples",
            labels.len()
        ));
    }
    Ok((labels, numbers))
}

/// The set-up's true nuisance values (SI) from `[nuisance.<setup>]` (the parameters' units).
fn true_nuisance(
    setup: &dyn Setup,
    setup_name: &str,
    nuisance: &toml::Table,
) -> Result<Vec<f64>, String> {
    let params = setup.nuisance();
    let mut nuis = vec![0.0; params.len()];
    let Some(toml::Value::Table(t)) = nuisance.get(setup_name) else {
        return Ok(nuis);
    };
    for (k, v) in t {
        let j = params.iter().position(|n| &n.name == k).ok_or_else(|| {
            format!(
                "[nuisance.{setup_name}] `{k}`: the set-up has {}",
                params
                    .iter()
                    .map(|n| n.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        let x = v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .ok_or_else(|| format!("[nuisance.{setup_name}] `{k}` must be a number"))?;
        nuis[j] = x / params[j].unit.per_si();
    }
    Ok(nuis)
}

/// σ of each channel's noise (SI): `noise` in the channels' units, default their own σ.
fn run_noise(run: &RunKeys, channels: &[Channel]) -> Result<Vec<f64>, String> {
    let Some(n) = run.noise else {
        return Ok(channels.iter().map(|c| c.sigma).collect());
    };
    if !(n.value.is_finite() && n.value >= 0.0) {
        return Err(format!("`noise` must be a number ≥ 0, found {n}"));
    }
    Ok(channels.iter().map(|c| n.value / c.unit.per_si()).collect())
}

/// `readings = false`: a validation run written without readings.
fn with_readings(run: &RunKeys) -> bool {
    run.readings.unwrap_or(true)
}

/// `interval_s`: the run's time between samples (default the plan's). Only a float: an
/// integer has always been refused here.
fn interval(run: &RunKeys, default: f64) -> Result<f64, String> {
    match run.interval_s {
        None => Ok(default),
        Some(n) if !n.integer && n.value > 0.0 => Ok(n.value),
        Some(n) => Err(format!("`interval_s` must be > 0, found {n}")),
    }
}

/// `feed_mm_min`, the NC program's feed (default 1000 mm/min).
fn feed(run: &RunKeys) -> Result<f64, String> {
    match run.feed_mm_min {
        None => Ok(1000.0),
        Some(n) if n.value.is_finite() && n.value > 0.0 => Ok(n.value),
        Some(n) => Err(format!("`feed_mm_min` must be > 0, found {n}")),
    }
}

/// `n` sample times `dt` apart from `t0`, as the file holds them (`[record] time`).
fn sample_times(t0: f64, dt: f64, n: usize, record: &Record) -> Result<Vec<f64>, String> {
    let t: Vec<f64> = (0..n)
        .map(|i| Record::round(t0 + i as f64 * dt, record.time))
        .collect();
    if t.windows(2).any(|w| w[1] <= w[0]) {
        return Err(format!(
            "[record] time = {}: samples {dt} s apart need more decimals",
            record.time.unwrap_or(0)
        ));
    }
    Ok(t)
}

/// The context columns at times `t`, as the file holds them (`[record] context`).
fn context_columns(t: &[f64], settings: &Settings) -> Vec<(String, Vec<f64>)> {
    settings
        .schedules
        .iter()
        .map(|(name, schedule)| {
            let values = t
                .iter()
                .map(|&ti| Record::round(schedule.at(ti), settings.record.context))
                .collect();
            (name.clone(), values)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::keys::RUN_KEYS;

    fn keys(text: &str) -> Result<RunKeys, String> {
        let table: toml::Table = toml::from_str(&format!("name = \"r\"\n{text}")).unwrap();
        from_table::<RunKeys>(&table, &RunMessages).map_err(|p| p.message)
    }

    #[test]
    fn a_runs_keys_are_worded_as_the_plan_format_words_them() {
        let cases = [
            (
                "bogus = 1",
                format!(
                    "unknown key `bogus`; a plan run has {}",
                    RUN_KEYS.join(", ")
                ),
            ),
            ("instrument = 3", "missing `instrument`".into()),
            (
                "setup = 3",
                "`setup` must be a name or a table, found 3".into(),
            ),
            ("path = 3", "`path` must be a table, found 3".into()),
            (
                "noise = \"x\"",
                "`noise` must be a number ≥ 0, found \"x\"".into(),
            ),
            (
                "readings = 1",
                "`readings` must be true or false, found 1".into(),
            ),
            (
                "interval_s = \"x\"",
                "`interval_s` must be > 0, found \"x\"".into(),
            ),
            (
                "feed_mm_min = true",
                "`feed_mm_min` must be > 0, found true".into(),
            ),
        ];
        for (text, message) in cases {
            assert_eq!(keys(text).unwrap_err(), message, "{text}");
        }
    }

    #[test]
    fn a_runs_values_are_checked_as_before() {
        let run = keys("interval_s = 1\nnoise = -1\nfeed_mm_min = 0.0\nuse = 3").unwrap();
        assert_eq!(
            interval(&run, 0.5).unwrap_err(),
            "`interval_s` must be > 0, found 1"
        );
        assert_eq!(
            run_noise(&run, &[]).unwrap_err(),
            "`noise` must be a number ≥ 0, found -1"
        );
        assert_eq!(
            feed(&run).unwrap_err(),
            "`feed_mm_min` must be > 0, found 0.0"
        );
        // A `use` that is not a string has always meant a fitted run.
        assert!(run_use(&run).unwrap() == RunUse::Fit);
        let run = keys("interval_s = 0.25\nsetup = { a = 1 }").unwrap();
        assert_eq!(interval(&run, 0.5).unwrap(), 0.25);
        assert!(matches!(run.setup, Some(SetupKey::Own(t)) if t["a"].as_integer() == Some(1)));
        let run = keys("setup = \"ball1\"").unwrap();
        assert!(matches!(run.setup, Some(SetupKey::Shared(s)) if s == "ball1"));
    }
}
