//! The measurement model against independent computations: a machine error reads as its
//! projection on the line of sight, a station shift and a dead path as the documented changes.

use mtcal_instrument::{At, PathSpec, Setup, SetupContext};
use mtcal_kinematics::{Machine, MachineModel, Rigid};
use mtcal_machine::topology::Reading;
use mtcal_tracer::{TracerSetup, nuis};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

fn zfyx_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../machines/mcv754-zfyx.urdf")
}

fn zfyx() -> mtcal_machine::LoadedMachine {
    mtcal_machine::load_machine(zfyx_path().to_str().unwrap(), Reading::default()).unwrap()
}

fn setup(machine: &Machine, station: [f64; 3], reflector: [f64; 3]) -> (TracerSetup, toml::Table) {
    let text = format!("station = {station:?}\nreflector = {reflector:?}\n");
    let table: toml::Table = toml::from_str(&text).unwrap();
    let s = mtcal_tracer::load(&table, &SetupContext { machine }).unwrap();
    (s, table)
}

fn grid(machine: &Machine, table: &toml::Table) -> Vec<Vec<f64>> {
    let p: toml::Table = toml::from_str("kind = \"grid\"\ncounts = [3, 3, 3]").unwrap();
    let loaded = mtcal_tracer::load(table, &SetupContext { machine }).unwrap();
    mtcal_tracer::path(&PathSpec {
        path: &p,
        setup: &loaded,
        machine,
    })
    .unwrap()
}

fn read(s: &TracerSetup, q: &[f64], pose: &Rigid, nuisance: &[f64]) -> f64 {
    let mut out = [f64::NAN];
    s.predict(
        &At {
            q,
            t: 0.0,
            w_t_t: pose,
            label: 0,
        },
        nuisance,
        &mut out,
    );
    out[0]
}

#[test]
fn a_positioning_error_of_x_reads_as_its_projection_on_the_line_of_sight() {
    let loaded = zfyx();
    let machine = loaded.machine.clone();
    let model = MachineModel::new(machine.clone(), &loaded.config).unwrap();
    let params = "[component.EXX]\ncoefficients = [4.0, -1.5, 0.7]\n";
    let coeffs =
        mtcal_machine::params::parse_params(params, Path::new("t.params.toml"), model.errors())
            .unwrap();
    let mut ws = model.workspace();
    let station = [450.0, -300.0, 50.0];
    let (s, table) = setup(&machine, station, [30.0, 20.0, 150.0]);
    let zero = [0.0; nuis::COUNT];
    let mut seen = 0.0_f64;
    for q in grid(&machine, &table) {
        let nominal = machine.tool_in_workpiece(&q);
        let actual = model.tool_pose(&q, &coeffs, &mut ws);
        let moved = actual.t - nominal.t;
        // EXX moves the tool along X only and does not turn it.
        assert!(moved.y.abs() < 1e-15 && moved.z.abs() < 1e-15, "{moved:?}");
        assert!((actual.r - nominal.r).norm() < 1e-15);
        let x0 = nominal.t + nominal.r * Vector3::new(0.03, 0.02, 0.15);
        let line = x0 - Vector3::from(station) * 1e-3;
        let u = line.normalize();
        let d = read(&s, &q, &actual, &zero);
        // Exactly the change of distance of the moved reflector…
        let exact = (line + moved).norm() - line.norm();
        assert!(
            (d - exact).abs() < 1e-15,
            "q {q:?}: read {d:e}, exact {exact:e}"
        );
        // …which is u_x·EXX to first order; the rest is below EXX²/(2·distance).
        let expect = u.x * moved.x;
        assert!(
            (d - expect).abs() <= moved.x.powi(2) / (2.0 * line.norm()),
            "q {q:?}: read {d:e}, projection {expect:e}"
        );
        seen = seen.max(moved.x.abs());
    }
    assert!(
        seen > 1e-6,
        "the planted EXX never moved the tool by a micrometre"
    );
}

#[test]
fn a_station_shift_reads_as_the_change_of_distance() {
    let machine = zfyx().machine;
    let station = [-420.0, 320.0, 80.0];
    let (s, table) = setup(&machine, station, [0.0, 0.0, 100.0]);
    let shift = Vector3::new(1.5e-3, -0.8e-3, 0.4e-3);
    let nuisance = [shift.x, shift.y, shift.z, 0.0];
    for q in grid(&machine, &table) {
        let pose = machine.tool_in_workpiece(&q);
        let x = pose.t + pose.r * Vector3::new(0.0, 0.0, 0.1);
        let s0 = Vector3::from(station) * 1e-3;
        let exact = (x - s0 - shift).norm() - (x - s0).norm();
        let d = read(&s, &q, &pose, &nuisance);
        assert!((d - exact).abs() < 1e-15, "{d:e} vs {exact:e}");
        // And to first order, −u·δs.
        let u = (x - s0).normalize();
        assert!((d + u.dot(&shift)).abs() < shift.norm_squared() / (x - s0).norm());
    }
}

#[test]
fn a_dead_path_reads_as_a_constant_and_a_nominal_machine_as_zero() {
    let machine = zfyx().machine;
    let (s, table) = setup(&machine, [420.0, 320.0, 0.0], [100.0, 0.0, 50.0]);
    let dead = 37.5e-6;
    for q in grid(&machine, &table) {
        let pose = machine.tool_in_workpiece(&q);
        assert_eq!(read(&s, &q, &pose, &[0.0; 4]), 0.0);
        let d = read(&s, &q, &pose, &[0.0, 0.0, 0.0, dead]);
        assert!((d - dead).abs() < 1e-18, "{d:e}");
    }
}

#[test]
fn an_offset_reflector_sees_the_tool_turn_and_a_centred_one_does_not() {
    let machine = zfyx().machine;
    let (centred, table) = setup(&machine, [420.0, 320.0, 0.0], [0.0; 3]);
    let (offset, _) = setup(&machine, [420.0, 320.0, 0.0], [0.0, 0.0, 200.0]);
    assert!(!centred.touches().orientation && offset.touches().orientation);
    let q = grid(&machine, &table)[13].clone();
    let pose = machine.tool_in_workpiece(&q);
    let tilt = 5e-6;
    let turned = Rigid::new(
        mtcal_kinematics::rigid::exp_so3(&Vector3::new(tilt, 0.0, 0.0)) * pose.r,
        pose.t,
    );
    assert_eq!(read(&centred, &q, &turned, &[0.0; 4]), 0.0);
    // The reflector 200 mm up the tool moves by δθ × (R·r) = (0, −200 mm·tilt, 0).
    let x = pose.t + pose.r * Vector3::new(0.0, 0.0, 0.2);
    let u = (x - Vector3::new(0.42, 0.32, 0.0)).normalize();
    let expect = u.y * (-0.2 * tilt);
    let d = read(&offset, &q, &turned, &[0.0; 4]);
    // First order; the rest is of order (0.2 m·tilt)²/distance.
    assert!(
        (d - expect).abs() < (0.2 * tilt).powi(2) / 0.2,
        "{d:e} vs {expect:e}"
    );
    assert!(expect.abs() > 1e-7);
}

#[test]
fn sigma_combines_the_constant_and_the_length_parts_at_the_typical_distance() {
    let machine = zfyx().machine;
    let table: toml::Table =
        toml::from_str("station = [420.0, 320.0, 0.0]\nsigma_um = 0.1\nsigma_um_per_m = 0.15")
            .unwrap();
    let s = mtcal_tracer::load(&table, &SetupContext { machine: &machine }).unwrap();
    let mid = machine.tool_in_workpiece(&mtcal_tracer::middle_of_strokes(&machine));
    let dist = (mid.t - Vector3::new(0.42, 0.32, 0.0)).norm();
    assert!((s.typical_distance() - dist).abs() < 1e-12);
    let want = (0.1 + 0.15 * dist) * 1e-6;
    assert!((s.channels()[0].sigma - want).abs() < 1e-18);
    assert!(dist > 0.3, "{dist}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// The reading is `|x − s| − |x₀ − s₀| + δL` for any pose near the nominal one, station,
    /// reflector and nuisance: the cancellation-free evaluation changes nothing but rounding.
    #[test]
    fn the_reading_is_the_change_of_distance_plus_the_dead_path(
        st in proptest::array::uniform3(-600.0f64..600.0),
        refl in proptest::array::uniform3(-150.0f64..150.0),
        k in 0usize..27,
        dt in proptest::array::uniform3(-50e-6f64..50e-6),
        dth in proptest::array::uniform3(-50e-6f64..50e-6),
        ds in proptest::array::uniform3(-3e-3f64..3e-3),
        dead in -1e-4f64..1e-4,
    ) {
        let machine = zfyx().machine;
        let (s, table) = setup(&machine, [st[0], st[1], st[2] - 700.0], refl);
        let q = grid(&machine, &table)[k].clone();
        let nominal = machine.tool_in_workpiece(&q);
        let pose = Rigid::new(
            mtcal_kinematics::rigid::exp_so3(&Vector3::from(dth)) * nominal.r,
            nominal.t + Vector3::from(dt),
        );
        let r = Vector3::from(refl) * 1e-3;
        let s0 = Vector3::new(st[0], st[1], st[2] - 700.0) * 1e-3;
        let x = pose.t + pose.r * r;
        let x0 = nominal.t + nominal.r * r;
        let exact = (x - s0 - Vector3::from(ds)).norm() - (x0 - s0).norm() + dead;
        let d = read(&s, &q, &pose, &[ds[0], ds[1], ds[2], dead]);
        proptest::prop_assert!((d - exact).abs() < 1e-15, "{} vs {}", d, exact);
    }
}
