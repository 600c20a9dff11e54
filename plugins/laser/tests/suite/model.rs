//! The measurement model on hand-made poses: what each optic reads for known geometric errors
//! (ISO 230-1 conventions: pose error `[p − p₀; log(R R₀ᵀ)]` of the tool relative to the
//! workpiece), the loader's rejections and the paths.

use mtcal_instrument::{At, PathSpec, Setup, SetupContext};
use mtcal_kinematics::rigid::exp_so3;
use mtcal_kinematics::{Machine, Rigid};
use mtcal_laser::{LaserSetup, load, path};
use nalgebra::Vector3;

fn machine() -> Machine {
    mtcal_machine::load_machine("ZFYX", mtcal_machine::topology::Reading::default())
        .unwrap()
        .machine
}

fn setup(m: &Machine, text: &str) -> LaserSetup {
    let t: toml::Table = toml::from_str(text).unwrap();
    load(&t, &SetupContext { machine: m }).unwrap_or_else(|e| panic!("{e}"))
}

fn reject(m: &Machine, text: &str) -> String {
    let t: toml::Table = toml::from_str(text).unwrap();
    load(&t, &SetupContext { machine: m }).unwrap_err().key
}

/// The reading at `q` for the nominal pose moved by `dt` and turned by `dth` (left, workpiece
/// frame), with nuisance `nuis`.
fn read(s: &LaserSetup, m: &Machine, q: &[f64], dt: [f64; 3], dth: [f64; 3], nuis: &[f64]) -> f64 {
    let p0 = m.tool_in_workpiece(q);
    let pose = Rigid::new(
        exp_so3(&Vector3::from(dth)) * p0.r,
        p0.t + Vector3::from(dt),
    );
    let mut out = [f64::NAN];
    s.predict(
        &At {
            q,
            t: 0.0,
            w_t_t: &pose,
            label: 0,
        },
        nuis,
        &mut out,
    );
    out[0]
}

const Q: [f64; 3] = [0.12, -0.05, -0.2];

#[test]
fn a_pure_positioning_error_is_the_linear_reading_for_either_optic() {
    let m = machine();
    for optic in ["tool", "table"] {
        let s = setup(
            &m,
            &format!("mode = \"linear\"\ndirection = \"X\"\noptic = \"{optic}\""),
        );
        // EXX = +3 µm: the tool 3 µm further along +X relative to the workpiece.
        let d = read(&s, &m, &Q, [3e-6, 0.0, 0.0], [0.0; 3], &[0.0; 3]);
        assert!((d - 3e-6).abs() < 1e-15, "{optic}: {d}");
        // A lateral (straightness) error is not read at first order.
        let d = read(&s, &m, &Q, [0.0, 4e-6, -2e-6], [0.0; 3], &[0.0; 3]);
        assert!(d.abs() < 1e-15, "{optic}: {d}");
        // The zero offset adds.
        let d = read(&s, &m, &Q, [0.0; 3], [0.0; 3], &[1.5e-6, 0.0, 0.0]);
        assert_eq!(d, 1.5e-6);
    }
    // A beam pointing the other way reads the opposite sign.
    let s = setup(&m, "mode = \"linear\"\ndirection = \"-X\"");
    let d = read(&s, &m, &Q, [3e-6, 0.0, 0.0], [0.0; 3], &[0.0; 3]);
    assert!((d + 3e-6).abs() < 1e-15);
}

#[test]
fn a_pitch_couples_through_the_optic_offset_abbe() {
    let m = machine();
    let h = 0.08;
    let eps = 20e-6;
    // EBX = ε: the tool turned about +Y; the optic h above the tool point moves by
    // ε ŷ × h ẑ = ε h x̂: the linear X reading is h·sin ε.
    let s = setup(
        &m,
        "mode = \"linear\"\ndirection = \"X\"\noptic_offset = [0.0, 0.0, 80.0]",
    );
    let d = read(&s, &m, &Q, [0.0; 3], [0.0, eps, 0.0], &[0.0; 3]);
    assert!((d - h * eps.sin()).abs() < 1e-15, "{d} vs {}", h * eps);
    // Without the offset the pitch is not seen.
    let s0 = setup(&m, "mode = \"linear\"\ndirection = \"X\"");
    assert!(read(&s0, &m, &Q, [0.0; 3], [0.0, eps, 0.0], &[0.0; 3]).abs() < 1e-15);
    // A yaw ECX with a sideways offset (optic 30 mm along +Y): ε ẑ × 0.03 ŷ = −0.03 ε x̂.
    let s = setup(
        &m,
        "mode = \"linear\"\ndirection = \"X\"\noptic_offset = [0.0, 30.0, 0.0]",
    );
    let d = read(&s, &m, &Q, [0.0; 3], [0.0, 0.0, eps], &[0.0; 3]);
    assert!((d + 0.03 * eps.sin()).abs() < 1e-15, "{d}");
}

#[test]
fn angular_mode_reads_the_rotation_about_its_axis() {
    let m = machine();
    let s = setup(&m, "mode = \"angular\"\ndirection = \"X\"\nabout = \"Y\"");
    let (pitch, yaw) = (12e-6, -7e-6);
    let d = read(&s, &m, &Q, [5e-6, 0.0, 0.0], [0.0, pitch, yaw], &[0.0]);
    assert!((d - pitch).abs() < 1e-15, "{d}");
    let s = setup(
        &m,
        "mode = \"angular\"\ndirection = \"X\"\nabout = \"Z\"\noptic = \"table\"",
    );
    let d = read(&s, &m, &Q, [5e-6, 0.0, 0.0], [0.0, pitch, yaw], &[0.0]);
    assert!((d - yaw).abs() < 1e-15, "{d}");
    assert_eq!(s.channels()[0].unit, mtcal_instrument::Unit::Urad);
}

#[test]
fn straightness_reads_the_lateral_deviation_and_its_reference_slope() {
    let m = machine();
    let s = setup(
        &m,
        "mode = \"straightness\"\ndirection = \"X\"\nsense = \"Y\"",
    );
    // EYX = 2 µm read; EXX and EZX not.
    let d = read(&s, &m, &Q, [7e-6, 2e-6, -3e-6], [0.0; 3], &[0.0, 0.0]);
    assert!((d - 2e-6).abs() < 1e-15, "{d}");
    // The reference leaning by γ towards +Y: a perfect axis reads −γ·travel (+ const).
    let g = 50e-6;
    let mut q2 = Q;
    q2[0] += 0.3;
    let d1 = read(&s, &m, &Q, [0.0; 3], [0.0; 3], &[0.0, g]);
    let d2 = read(&s, &m, &q2, [0.0; 3], [0.0; 3], &[0.0, g]);
    // (s' − s)·Δp₀ with s' = (s − γ n)/√(1 + γ²) and Δp₀ = 0.3 m along n.
    let want = -0.3 * g / (1.0 + g * g).sqrt();
    assert!(((d2 - d1) - want).abs() < 1e-15, "{} vs {want}", d2 - d1);
}

#[test]
fn a_tilted_beam_gives_the_cosine_error_exactly() {
    let m = machine();
    let s = setup(&m, "mode = \"linear\"\ndirection = \"X\"");
    let alpha = 1e-3;
    let mut q2 = Q;
    q2[0] += 0.5;
    // Nominal motion along X, the beam tilted by α: the reading grows by (cos α − 1)·0.5 m
    // (to second order −α²/2 · 0.5 m = −0.25 µm); cos α = 1/√(1 + tan² α), α being tan α here.
    for nuis in [[0.0, alpha, 0.0], [0.0, 0.0, alpha]] {
        let d1 = read(&s, &m, &Q, [0.0; 3], [0.0; 3], &nuis);
        let d2 = read(&s, &m, &q2, [0.0; 3], [0.0; 3], &nuis);
        let want = 0.5 * (1.0 / (1.0 + alpha * alpha).sqrt() - 1.0);
        assert!(((d2 - d1) - want).abs() < 1e-16, "{} vs {want}", d2 - d1);
        assert!((want + 0.25e-6).abs() < 1e-12);
    }
    // The tilt's priors are declared.
    let n = s.nuisance();
    assert_eq!(n.len(), 3);
    assert!((n[1].prior_sigma.unwrap() - 100e-6).abs() < 1e-18);
    assert!(n[0].prior_sigma.is_none() && n[0].free);
}

/// The beam tilts about its `origin`: on a straight path through the origin a tilt only gives
/// the (second-order) cosine error, while about the workpiece origin it also shifts every
/// reading by tilt × the path's distance from there — a constant the run's zero would have to
/// take, leaving zero and tilt traded off against each other.
#[test]
fn the_beam_tilts_about_its_origin() {
    let m = machine();
    let p0 = m.tool_in_workpiece(&Q).t * 1e3;
    let on_path = setup(
        &m,
        &format!(
            "mode = \"linear\"\ndirection = \"X\"\norigin = [0.0, {}, {}]",
            p0.y, p0.z
        ),
    );
    let about_zero = setup(&m, "mode = \"linear\"\ndirection = \"X\"");
    let alpha = 1e-4;
    for nuis in [[0.0, alpha, 0.0], [0.0, 0.0, alpha]] {
        let d = read(&on_path, &m, &Q, [0.0; 3], [0.0; 3], &nuis);
        // Cosine error over |x| = 0.12 m: α²/2 · 0.12 m = 0.6 nm.
        assert!(d.abs() < 1e-9, "{d}");
        let d = read(&about_zero, &m, &Q, [0.0; 3], [0.0; 3], &nuis);
        assert!(d.abs() > 1e-6, "{d}");
    }
}

#[test]
fn a_beam_on_the_tool_turns_with_it() {
    let m = machine();
    // A yaw ε turns a tool-side beam along X towards +Y: a lateral deviation δ then reads
    // sin ε · δ (second order), which the table-side beam does not see.
    let eps = 1e-3;
    let delta = 1e-3;
    let table = setup(
        &m,
        "mode = \"linear\"\ndirection = \"X\"\noptic = \"table\"",
    );
    let tool = setup(&m, "mode = \"linear\"\ndirection = \"X\"");
    let dt = [0.0, delta, 0.0];
    let dth = [0.0, 0.0, eps];
    assert!((read(&table, &m, &Q, dt, dth, &[0.0; 3]) - eps.sin() * delta).abs() < 1e-15);
    assert!(read(&tool, &m, &Q, dt, dth, &[0.0; 3]).abs() < 1e-15);
}

#[test]
fn the_loader_names_what_is_wrong() {
    let m = machine();
    assert_eq!(
        reject(&m, "mode = \"linear\"\ndirection = \"X\"\nbogus = 1"),
        "bogus"
    );
    assert_eq!(reject(&m, "mode = \"lin\"\ndirection = \"X\""), "mode");
    assert_eq!(reject(&m, "mode = \"linear\""), "direction");
    assert_eq!(
        reject(&m, "mode = \"linear\"\ndirection = \"W\""),
        "direction"
    );
    assert_eq!(
        reject(&m, "mode = \"linear\"\ndirection = [0, 0, 0]"),
        "direction"
    );
    assert_eq!(
        reject(&m, "mode = \"straightness\"\ndirection = \"X\""),
        "sense"
    );
    assert_eq!(
        reject(
            &m,
            "mode = \"straightness\"\ndirection = \"X\"\nsense = [1, 1, 0]"
        ),
        "sense"
    );
    assert_eq!(
        reject(&m, "mode = \"linear\"\ndirection = \"X\"\nsense = \"Y\""),
        "sense"
    );
    assert_eq!(
        reject(&m, "mode = \"angular\"\ndirection = \"X\"\nabout = \"X\""),
        "about"
    );
    assert_eq!(
        reject(
            &m,
            "mode = \"angular\"\ndirection = \"X\"\nabout = \"Y\"\nsigma_um = 1.0"
        ),
        "sigma_um"
    );
    assert_eq!(
        reject(
            &m,
            "mode = \"linear\"\ndirection = \"X\"\noptic = \"spindle\""
        ),
        "optic"
    );
    assert_eq!(
        reject(
            &m,
            "mode = \"linear\"\ndirection = \"X\"\nair_temperature_c = 20.0"
        ),
        "air_temperature_c"
    );
    assert_eq!(
        reject(
            &m,
            "mode = \"linear\"\ndirection = \"X\"\nwavelength_compensated = false\nair_pressure_hpa = 101325.0"
        ),
        "air_pressure_hpa"
    );
    assert_eq!(
        reject(
            &m,
            "mode = \"angular\"\ndirection = \"X\"\nabout = \"Y\"\ntilt_free = true"
        ),
        "tilt_free"
    );
    assert_eq!(
        reject(
            &m,
            "mode = \"linear\"\ndirection = \"X\"\nmaterial_temperature_c = 21.0"
        ),
        "material_temperature_c"
    );
}

fn path_of(
    m: &Machine,
    setup: &str,
    path_t: &str,
) -> Result<Vec<Vec<f64>>, mtcal_instrument::SetupError> {
    let s: toml::Table = toml::from_str(setup).unwrap();
    let p: toml::Table = toml::from_str(path_t).unwrap();
    let loaded = mtcal_laser::load(&s, &mtcal_instrument::SetupContext { machine: m })?;
    path(&PathSpec {
        path: &p,
        setup: &loaded,
        machine: m,
    })
}

#[test]
fn iso230_2_cycles_approach_every_target_from_both_sides() {
    let m = machine();
    let poses = path_of(
        &m,
        "mode = \"linear\"\ndirection = \"X\"",
        "from = -100.0\nto = 100.0\npoints = 3\ncycles = 2\noverrun = 5.0\nhold = { Z = -200.0 }",
    )
    .unwrap();
    let x: Vec<f64> = poses.iter().map(|q| (q[0] * 1e4).round() / 10.0).collect();
    assert_eq!(
        x,
        [
            -105.0, -100.0, 0.0, 100.0, 105.0, 100.0, 0.0, -100.0, -105.0, -100.0, 0.0, 100.0,
            105.0, 100.0, 0.0, -100.0, -105.0
        ]
    );
    assert!(poses.iter().all(|q| q[1] == 0.0 && q[2] == -0.2));
    // Without overrun the reversal points are recorded twice.
    let poses = path_of(
        &m,
        "mode = \"linear\"\ndirection = \"X\"",
        "targets = [0.0, 50.0]\ncycles = 2",
    )
    .unwrap();
    let x: Vec<f64> = poses.iter().map(|q| (q[0] * 1e4).round() / 10.0).collect();
    assert_eq!(x, [0.0, 50.0, 50.0, 0.0, 0.0, 50.0, 50.0, 0.0]);
    // The beam must lie along the travel.
    let e = path_of(
        &m,
        "mode = \"linear\"\ndirection = \"Y\"",
        "axis = \"X\"\ntargets = [0.0, 50.0]",
    )
    .unwrap_err();
    assert_eq!(e.key, "direction");
    // Limits.
    let e = path_of(
        &m,
        "mode = \"linear\"\ndirection = \"X\"",
        "from = 0.0\nto = 500.0\noverrun = 5.0",
    )
    .unwrap_err();
    assert_eq!(e.key, "overrun");
}

#[test]
fn step_diagonal_moves_one_axis_at_a_time_along_the_body_diagonal() {
    let m = machine();
    let dir = "[1.0, 1.0, 1.0]";
    let from = "{ X = -300.0, Y = -200.0, Z = -200.0 }";
    let to = "{ X = 300.0, Y = 200.0, Z = 100.0 }";
    let setup_t = format!("mode = \"step-diagonal\"\ndirection = {dir}");
    let e = path_of(
        &m,
        &setup_t,
        &format!("from = {from}\nto = {to}\npoints = 3"),
    )
    .unwrap_err();
    assert_eq!(e.key, "direction", "{e}");
    let dir = "[600.0, 400.0, 300.0]";
    let setup_t = format!("mode = \"step-diagonal\"\ndirection = {dir}");
    let poses = path_of(
        &m,
        &setup_t,
        &format!("from = {from}\nto = {to}\npoints = 3\ncycles = 1"),
    )
    .unwrap();
    // 3 targets ↑ and ↓; two intermediate steps between neighbouring targets, none at the
    // reversal (the same target).
    assert_eq!(poses.len(), 3 + 2 * 2 + 3 + 2 * 2);
    for w in poses.windows(2) {
        let moved = (0..3).filter(|&i| w[0][i] != w[1][i]).count();
        assert!(moved <= 1, "{w:?}");
    }
    // The plain diagonal moves every axis together.
    let setup_t = format!("mode = \"diagonal\"\ndirection = {dir}");
    let poses = path_of(
        &m,
        &setup_t,
        &format!("from = {from}\nto = {to}\npoints = 3"),
    )
    .unwrap();
    assert_eq!(poses.len(), 6);
}
