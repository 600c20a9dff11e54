//! A new instrument is placed by the planner with no line changed elsewhere: an instrument
//! written in this file alone — a tool-point tracker anchored on the table, its own position
//! key (`anchor`), its own collision bodies and `[geometry]` size, a set-up key the plan writes
//! out — is planned from a planning file: its candidate positions go into `anchor`, the one
//! whose probe dives into the table is found colliding by exactly the depth its own size says
//! and given up, the clear one is chosen and written with the key filled in. If the planner
//! named its instruments (a match on the name, a size in a struct of its own), this test could
//! not be written.

use mtcal_instrument::collision::{
    Bodies, BodySpec, InstrumentBody, Mount, Planning, Primitive, SizeKey, at,
    tool_ball_stem_holder,
};
use mtcal_instrument::{
    At, Channel, Fixture, InstrumentPlugin, Nuisance, PathSpec, Setup, SetupContext, SetupError,
    SetupFormat, Unit,
};
use mtcal_kinematics::Machine;
use mtcal_testkit::repo;
use nalgebra::Vector3;

/// The instrument's name in planning files.
const NAME: &str = "stub-anchor";

/// The probe on the tool: its own `[geometry]` key.
const PROBE_DIAMETER: SizeKey = SizeKey::positive("stub_probe_diameter_mm", 10.0);

/// A loaded set-up: where the anchor stands (workpiece frame, mm), the reading noise, and the
/// machine it computes the commanded tool point on.
#[derive(Debug)]
struct Anchor {
    anchor_mm: [f64; 3],
    sigma_um: f64,
    machine: Machine,
    channels: Vec<Channel>,
    nuisance: Vec<Nuisance>,
}

impl SetupFormat for Anchor {
    fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        let anchor = self.anchor_mm.iter().map(|&v| toml::Value::Float(v));
        t.insert("anchor".into(), toml::Value::Array(anchor.collect()));
        t.insert("sigma_um".into(), self.sigma_um.into());
        t
    }
}

impl Setup for Anchor {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }

    /// The tool point's deviation from where it was commanded, plus the tracker's own zero.
    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let nominal = self.machine.tool_in_workpiece(at.q);
        for k in 0..3 {
            out[k] = at.w_t_t.t[k] - nominal.t[k] + nuis[k];
        }
    }
}

/// How many times the planner had the stub load a set-up; the tests that plan hold `ONE_PLAN`
/// so that each counts its own.
static LOADS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
static ONE_PLAN: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn load(table: &toml::Table, ctx: &SetupContext<'_>) -> Result<Box<dyn Setup>, SetupError> {
    LOADS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
    let anchor: Vec<f64> = table
        .get("anchor")
        .and_then(|v| v.as_array())
        .map(|a| a.iter().filter_map(number).collect())
        .filter(|a: &Vec<f64>| a.len() == 3)
        .ok_or_else(|| SetupError::new("anchor", "expected [x, y, z] in mm"))?;
    let sigma_um = match table.get("sigma_um") {
        None => 0.5,
        Some(v) => number(v)
            .filter(|s| *s > 0.0)
            .ok_or_else(|| SetupError::new("sigma_um", "expected a positive number (µm)"))?,
    };
    if let Some(key) = table
        .keys()
        .find(|k| !["anchor", "sigma_um"].contains(&k.as_str()))
    {
        return Err(SetupError::new(key, "not a key of the anchor's set-up"));
    }
    let channels = ["dx", "dy", "dz"]
        .map(|name| Channel {
            name: name.into(),
            unit: Unit::Um,
            sigma: sigma_um * 1e-6,
        })
        .to_vec();
    let nuisance = ["zero_x", "zero_y", "zero_z"]
        .map(|name| Nuisance {
            name: name.into(),
            unit: Unit::Um,
            free: true,
            prior_sigma: None,
        })
        .to_vec();
    Ok(Box::new(Anchor {
        anchor_mm: [anchor[0], anchor[1], anchor[2]],
        sigma_um,
        machine: ctx.machine.clone(),
        channels,
        nuisance,
    }))
}

/// C turned once round with the linear axes keeping the tool point on the anchor.
fn path(spec: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    let machine = spec.machine;
    let setup: &Anchor = spec.own_setup()?;
    let tip = Vector3::from(setup.anchor_mm) * 1e-3;
    let c = machine
        .axis_index('C')
        .ok_or_else(|| SetupError::new("path", "the machine has no C axis"))?;
    let samples = 13;
    (0..samples)
        .map(|i| {
            let mut q = vec![0.0; machine.n_axes()];
            q[c] = std::f64::consts::TAU * i as f64 / (samples - 1) as f64;
            mtcal_kinematics::ik::follow_point(machine, &mut q, &tip)
                .map_err(|e| SetupError::new("anchor", e.to_string()))?;
            if !machine.within_limits(&q, 1e-9) {
                return Err(SetupError::new("anchor", "out of the axes' reach"));
            }
            Ok(q)
        })
        .collect()
}

/// Not for the conformance harness here: the planner needs none.
fn fixture(_: &Machine, _: u64) -> Option<Fixture> {
    None
}

/// The probe ball (its own size), stem and holder on the tool; the anchor, a small ball on the
/// table that the probe touches by design.
fn bodies(spec: &BodySpec<'_>) -> Result<Option<Bodies>, SetupError> {
    let setup: &Anchor = spec.own_setup()?;
    let r = 0.5 * spec.size_m(&PROBE_DIAMETER);
    let mut bodies = tool_ball_stem_holder("stub probe", r, spec.tool_length, spec.tool_side);
    bodies.push(InstrumentBody {
        name: "stub anchor".into(),
        mount: Mount::Workpiece,
        offset: at(Vector3::from(setup.anchor_mm) * 1e-3),
        primitive: Primitive::Sphere { radius: 0.002 },
        only_label: None,
    });
    Ok(Some((
        bodies,
        vec![("stub probe".into(), "stub anchor".into())],
    )))
}

inventory::submit! {
    InstrumentPlugin {
        name: NAME,
        about: "a tool-point tracker anchored on the table (a test's)",
        load_setup: load,
        fixture,
        path,
        path_labels: None,
        evaluate: None,
        polar_view: None,
        diagnose: None,
        planning: Some(Planning {
            position_key: Some("anchor"),
            written_out: &["sigma_um"],
            sizes: &[PROBE_DIAMETER],
            bodies: Some(bodies),
        }),
    }
}

/// A planning file for the stub: a clear position 150 mm above the table and one whose probe
/// ball centre is 10 mm under the table top; `geometry` is the `[geometry]` table's body.
fn planning(dir: &std::path::Path, geometry: &str) -> std::path::PathBuf {
    let machine = repo().join("machines/mcu630-cafyxz.urdf");
    let text = format!(
        "machine = {machine:?}\nwanted = [\"EX0C\", \"EY0C\"]\ntool_length_mm = 120.0\n\
         move_step = 0.0\nrandom_trials = 2\n\
         [geometry]\n{geometry}\n\
         [[candidates]]\nname = \"anchor\"\ninstrument = \"{NAME}\"\nchoose = 1\n\
         points = [[0.0, 0.0, 150.0], [0.0, 0.0, -10.0]]\nruns = [{{ name = \"c\" }}]\n"
    );
    let p = dir.join("planning.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn an_instrument_registered_in_a_test_is_placed_and_collision_checked() {
    let _one = ONE_PLAN.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let before = LOADS.load(std::sync::atomic::Ordering::SeqCst);
    let planned = mtcal_plan::plan(&planning(dir.path(), "stub_probe_diameter_mm = 12.0")).unwrap();
    // Each candidate's set-up is loaded once to plan it (the keys written out, its run's path
    // and collision bodies), then once to simulate its run and once for the study of what it
    // tells: two candidates, six loads (twelve when every step loaded its own).
    let loads = LOADS.load(std::sync::atomic::Ordering::SeqCst) - before;
    assert_eq!(loads, 6, "set-ups loaded");
    let r = &planned.report;
    let cand = |n: &str| r.candidates.iter().find(|c| c.name == n).unwrap();
    assert_eq!(cand("anchor-01").status, "ok", "{:?}", cand("anchor-01"));
    assert_eq!(
        cand("anchor-02").status,
        "collides",
        "{:?}",
        cand("anchor-02")
    );
    assert_eq!(r.chosen(), ["anchor-01"]);
    // Its bodies were checked (not just the machine), the probe ball by its own size: centre
    // 10 mm under the table top, radius 6 mm.
    let check = &cand("anchor-02").runs[0];
    assert!(!check.instrument_unchecked);
    let worst = check.worst.as_ref().expect("a collision");
    assert_eq!(worst.a, "stub probe", "{worst:?}");
    assert!((worst.distance_mm + 16.0).abs() < 0.1, "{worst:?}");
    // The clear position is clear with the probe against its anchor (touching by design).
    assert!(cand("anchor-01").runs.iter().all(|c| !c.collides()));
    // The position went into `anchor`, and `sigma_um`, left to its default, is written out.
    let setup = &planned.plan["setup"]["anchor-01"];
    assert_eq!(
        setup["anchor"].as_array().unwrap(),
        &[0.0, 0.0, 150.0].map(toml::Value::Float)
    );
    assert_eq!(setup["sigma_um"].as_float(), Some(0.5));
}

#[test]
fn the_stub_s_geometry_key_is_checked_and_a_key_nobody_declares_is_refused() {
    let _one = ONE_PLAN.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    for (geometry, expect) in [
        (
            "stub_probe_diameter_mm = -1.0",
            "`stub_probe_diameter_mm` must be > 0",
        ),
        ("stub_bogus_mm = 1.0", "unknown field `stub_bogus_mm`"),
    ] {
        let p = planning(dir.path(), geometry);
        let e = mtcal_plan::plan(&p).expect_err(geometry).to_string();
        let at = format!("{}:7:", p.display());
        assert!(e.starts_with(&at) && e.contains(expect), "{geometry}: {e}");
    }
}
