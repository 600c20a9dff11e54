//! A new instrument is one registration: an instrument written in this file alone — an ideal
//! tool-point tracker, three readings (the tool point's deviation from where it was commanded,
//! in the workpiece frame) and a zero of its own — reaches every part of mtcal that works per
//! instrument without a line changed anywhere else: the conformance harness checks its
//! derivatives, the simulator writes a session measured with it, the identification loads its
//! set-ups and recovers the trunnion's eleven location and squareness errors from it, and the
//! registry lists it. Nothing of this file is known to any library: if adding an instrument
//! needed a change outside its own folder (a name listed in a library, a match on the
//! instrument), this test could not be written.

use mtcal_identify::{Study, identify_with_solution};
use mtcal_instrument::{
    At, Channel, Fixture, InstrumentPlugin, Nuisance, PathSpec, Setup, SetupContext, SetupError,
    SetupFormat, Unit,
};
use mtcal_kinematics::Machine;
use mtcal_simulate::simulate;
use mtcal_solve::Silent;
use mtcal_testkit::plans::Run;
use mtcal_testkit::{ELEVEN, FIVE_AXIS_TRUTH, TRUNNION, five_axis_truth_file, machine_file};

/// The tracker's name in session manifests.
const NAME: &str = "stub-tracker";

/// A loaded tracker set-up: its noise, and the machine it computes the commanded tool point
/// on (the nominal pose; the actual one comes from the core with every error inserted).
#[derive(Debug)]
struct Tracker {
    machine: Machine,
    sigma_um: f64,
    channels: Vec<Channel>,
    nuisance: Vec<Nuisance>,
}

impl Tracker {
    fn new(machine: &Machine, sigma_um: f64) -> Self {
        let channels = ["dx", "dy", "dz"]
            .map(|name| Channel {
                name: name.into(),
                unit: Unit::Um,
                sigma: sigma_um * 1e-6,
            })
            .to_vec();
        // Where the tracker reads zero is not known: its zero is estimated with the machine.
        let nuisance = ["zero_x", "zero_y", "zero_z"]
            .map(|name| Nuisance {
                name: name.into(),
                unit: Unit::Um,
                free: true,
                prior_sigma: None,
            })
            .to_vec();
        Tracker {
            machine: machine.clone(),
            sigma_um,
            channels,
            nuisance,
        }
    }
}

impl SetupFormat for Tracker {
    fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert("sigma_um".into(), self.sigma_um.into());
        t
    }
}

impl Setup for Tracker {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let nominal = self.machine.tool_in_workpiece(at.q);
        for k in 0..3 {
            out[k] = at.w_t_t.t[k] - nominal.t[k] + nuis[k];
        }
    }

    fn derivatives(
        &self,
        _at: &At<'_>,
        _nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        // The tool point is the pose's origin: a turn about it does not move it.
        d_pose.fill(0.0);
        d_nuis.fill(0.0);
        for k in 0..3 {
            d_pose[6 * k + k] = 1.0;
            d_nuis[3 * k + k] = 1.0;
        }
        true
    }
}

fn load(table: &toml::Table, ctx: &SetupContext<'_>) -> Result<Box<dyn Setup>, SetupError> {
    let sigma_um = match table.get("sigma_um") {
        None => 0.5,
        Some(v) => v
            .as_float()
            .filter(|s| *s > 0.0)
            .ok_or_else(|| SetupError::new("sigma_um", "expected a positive number (µm)"))?,
    };
    if let Some(key) = table.keys().find(|k| *k != "sigma_um") {
        return Err(SetupError::new(key, "not a key of the tracker's set-up"));
    }
    Ok(Box::new(Tracker::new(ctx.machine, sigma_um)))
}

/// Positions (mm, degrees) of the axes named in `table`, SI, over the machine's axes.
fn positions(
    machine: &Machine,
    table: Option<&toml::Value>,
    key: &str,
) -> Result<Vec<Option<f64>>, SetupError> {
    let mut out = vec![None; machine.n_axes()];
    let Some(table) = table else { return Ok(out) };
    let table = table
        .as_table()
        .ok_or_else(|| SetupError::new(key, "expected a table of axis positions"))?;
    for (letter, value) in table {
        let axis = letter
            .chars()
            .next()
            .and_then(|c| machine.axis_index(c))
            .ok_or_else(|| SetupError::new(key, format!("no axis {letter}")))?;
        let value = value
            .as_float()
            .ok_or_else(|| SetupError::new(key, format!("{letter}: expected a number")))?;
        out[axis] = Some(machine.axes()[axis].kind().from_file(value));
    }
    Ok(out)
}

/// A straight line in axis space: `from` → `to` (the axes they name), the others at `hold`
/// (or 0), `samples` evenly spaced.
fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let machine = spec.machine;
    let from = positions(machine, spec.path.get("from"), "from")?;
    let to = positions(machine, spec.path.get("to"), "to")?;
    let hold = positions(machine, spec.path.get("hold"), "hold")?;
    let samples = spec
        .path
        .get("samples")
        .and_then(|v| v.as_integer())
        .filter(|n| *n >= 2)
        .ok_or_else(|| SetupError::new("samples", "expected an integer of at least 2"))?
        as usize;
    Ok((0..samples)
        .map(|i| {
            let s = i as f64 / (samples - 1) as f64;
            (0..machine.n_axes())
                .map(|a| match (from[a], to[a]) {
                    (Some(f), Some(t)) => f + s * (t - f),
                    (Some(f), None) => f,
                    _ => hold[a].unwrap_or(0.0),
                })
                .collect()
        })
        .collect())
}

/// Poses spread over the strokes for the conformance harness.
fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    let poses = (0..12)
        .map(|i| {
            machine
                .axes()
                .iter()
                .enumerate()
                .map(|(a, axis)| {
                    let (lo, hi) = axis.limits().unwrap_or((-3.0, 3.0));
                    let t = ((i as u64 * (a as u64 + 3) * 37 + seed * 11) % 101) as f64 / 100.0;
                    lo + (hi - lo) * t
                })
                .collect()
        })
        .collect();
    let mut setup = toml::Table::new();
    setup.insert("sigma_um".into(), (0.2 + 0.1 * seed as f64).into());
    Some(Fixture {
        setup,
        poses,
        labels: Vec::new(),
    })
}

inventory::submit! {
    InstrumentPlugin {
        name: NAME,
        about: "an ideal tool-point tracker: dx, dy, dz (um) from the commanded point (a test's)",
        load_setup: load,
        fixture,
        path,
        path_labels: None,
        evaluate: None,
        polar_view: None,
        diagnose: None,
        planning: None,
    }
}

/// The runs: C turns at three A tilts, an A sweep, and diagonals of the linear axes.
fn runs() -> String {
    let paths = [
        (
            "c-a0",
            "{ from = { C = 0.0 }, to = { C = 360.0 }, samples = 37, hold = { X = 150.0, Z = -200.0 } }",
        ),
        (
            "c-a30",
            "{ from = { C = 0.0 }, to = { C = 360.0 }, samples = 37, hold = { A = 30.0, X = 150.0, Z = -200.0 } }",
        ),
        (
            "c-a60",
            "{ from = { C = 0.0 }, to = { C = 360.0 }, samples = 37, hold = { A = 60.0, Y = 100.0, Z = -200.0 } }",
        ),
        (
            "a-sweep",
            "{ from = { A = -30.0 }, to = { A = 90.0 }, samples = 25, hold = { Y = 100.0, Z = -250.0 } }",
        ),
        (
            "a-sweep-c90",
            "{ from = { A = -30.0 }, to = { A = 90.0 }, samples = 25, hold = { C = 90.0, Y = 100.0, Z = -250.0 } }",
        ),
        (
            "xy",
            "{ from = { X = -300.0, Y = -300.0 }, to = { X = 300.0, Y = 300.0 }, samples = 21, hold = { Z = -250.0 } }",
        ),
        (
            "yz",
            "{ from = { Y = -300.0, Z = -500.0 }, to = { Y = 300.0, Z = -50.0 }, samples = 21 }",
        ),
        (
            "zx",
            "{ from = { X = -300.0, Z = -500.0 }, to = { X = 300.0, Z = -50.0 }, samples = 21 }",
        ),
    ];
    paths
        .iter()
        .map(|(name, path)| Run::new(name, NAME, "tracker").noise("0.3").path(path))
        .collect()
}

#[test]
fn the_conformance_harness_checks_the_stub_instrument() {
    let report = mtcal_conformance::try_check_plugin(NAME, 3).unwrap_or_else(|f| panic!("{f}"));
    assert!(
        report.fixtures > 0 && report.without_analytic == 0,
        "{report:?}"
    );
    assert!(mtcal_instrument::plugins().iter().any(|p| p.name == NAME));
}

#[test]
fn a_session_measured_with_the_stub_instrument_identifies_the_machine() {
    let dir = tempfile::tempdir().unwrap();
    let plan = format!(
        "machine = {machine:?}\ntruth = {truth:?}\nseed = 5\ninterval_s = 0.5\n\
         [identify]\nparameters = {eleven}\n[setup.tracker]\nsigma_um = 0.3\n{runs}",
        machine = machine_file(TRUNNION),
        truth = five_axis_truth_file(),
        eleven = mtcal_testkit::params::toml_list(&ELEVEN),
        runs = runs(),
    );
    let plan_file = dir.path().join("plan.toml");
    std::fs::write(&plan_file, plan).unwrap();
    let session = dir.path().join("session");
    simulate(&plan_file, &session).unwrap();
    let manifest = std::fs::read_to_string(session.join("session.toml")).unwrap();
    assert!(
        manifest.contains(&format!("instrument = \"{NAME}\"")),
        "{manifest}"
    );

    let study = Study::load(&session).unwrap();
    let (id, _) = identify_with_solution(&study, &Default::default(), &mut Silent).unwrap();
    assert!(id.solver.converged, "{:?}", id.solver);
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    for (name, truth) in FIVE_AXIS_TRUTH {
        let p = id
            .parameters
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("{name} not estimated"));
        // Within its interval, and the interval a real identification (µm, µrad).
        assert!(
            (p.value - truth).abs() <= p.u95 && p.u95 < 2.0,
            "{name}: {} ± {} for {truth}",
            p.value,
            p.u95
        );
    }
}
