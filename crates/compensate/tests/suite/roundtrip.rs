//! Export → reload → same model at the nodes, on shipped machines with random parameters.

use crate::common;

use common::{TOL_UM, load};
use mtcal_compensate::*;
use mtcal_kinematics::{AxisLetter, Direction, MachineModel, ParamName};
use mtcal_testkit::random::SplitMix64;
use std::path::Path;

/// Every coefficient uniform in ±5 µm / µrad.
fn random_coeffs(model: &MachineModel, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64(seed);
    (0..model.n_coeffs()).map(|_| 5e-6 * rng.signed()).collect()
}

/// Model error along the axis' travel direction (µm) at `position_mm`, others at `hold`.
fn model_error_um(
    model: &MachineModel,
    coeffs: &[f64],
    axis: char,
    hold: &[f64],
    p_mm: f64,
) -> f64 {
    let i = model.machine().axis_index(axis).unwrap();
    let dir = travel_direction(model.machine(), hold, i);
    let mut q = hold.to_vec();
    q[i] = p_mm * 1e-3;
    let mut ws = model.workspace();
    model.pose_error(&q, coeffs, &mut ws).translation.dot(&dir) * 1e6
}

fn check_pitch_round_trip(name: &str, seed: u64) {
    let model = load(name);
    let coeffs = random_coeffs(&model, seed);
    let hold = default_hold(model.machine());
    let dir = tempfile::tempdir().unwrap();
    for axis in ['X', 'Y', 'Z'] {
        let table = pitch_table(&model, &coeffs, axis, 25.0, &hold).unwrap();
        assert!(
            table.forward_um.iter().any(|v| v.abs() > 0.5),
            "{name} {axis}: errors too small to test"
        );
        // Unidirectional CSV.
        let csv = dir.path().join(format!("{axis}.csv"));
        write_pitch_csv(&csv, &table).unwrap();
        let back = read_pitch_csv(&csv, axis).unwrap();
        assert_eq!(back.len(), table.len());
        assert!(back.reverse_um.is_none());
        for (p, c) in back.positions_mm.iter().zip(&back.forward_um) {
            let e = model_error_um(&model, &coeffs, axis, &hold, *p);
            assert!(
                (c + e).abs() < TOL_UM,
                "{name} {axis} at {p} mm: {c} vs {}",
                -e
            );
            assert!((c + e).abs() < 1e-5, "print precision: {}", c + e);
        }
        // Bidirectional LinuxCNC and CSV.
        let bi = table.clone().with_reversal_um(-3.25);
        let comp = dir.path().join(format!("{axis}.comp"));
        write_linuxcnc_comp(&comp, &bi).unwrap();
        let back = read_linuxcnc_comp(&comp, axis).unwrap();
        let csv_bi = dir.path().join(format!("{axis}-bi.csv"));
        write_pitch_csv(&csv_bi, &bi).unwrap();
        let back_csv = read_pitch_csv(&csv_bi, axis).unwrap();
        for b in [&back, &back_csv] {
            let rev = b.reverse_um.as_ref().expect("bidirectional");
            for ((p, f), r) in b.positions_mm.iter().zip(&b.forward_um).zip(rev) {
                let e = model_error_um(&model, &coeffs, axis, &hold, *p);
                assert!((f + e).abs() < TOL_UM, "{name} {axis} forward at {p} mm");
                assert!(
                    (r - (-e - 3.25)).abs() < TOL_UM,
                    "{name} {axis} reverse at {p} mm"
                );
            }
        }
    }
}

#[test]
fn pitch_tables_round_trip_three_axis() {
    check_pitch_round_trip("mcv754-zfyx.urdf", 1);
    check_pitch_round_trip("mcv754-zfyx.urdf", 2);
}

#[test]
fn pitch_tables_round_trip_five_axis_at_rotary_zero() {
    check_pitch_round_trip("mcu630-cafyxz.urdf", 3);
}

/// A pure positioning error (EXX only, up to ~20 µm): commanding `x + c(x)` puts the tool at
/// `x` to well below 0.1 µm at the nodes.
#[test]
fn pitch_correction_cancels_a_pure_positioning_error() {
    for name in ["mcv754-zfyx.urdf", "mcu630-cafyxz.urdf"] {
        let model = load(name);
        for axis in ['X', 'Y', 'Z'] {
            let letter = AxisLetter::new(axis).unwrap();
            let d = Direction::from_letter(axis).unwrap();
            let p = model
                .errors()
                .find(&ParamName::component(d, letter))
                .unwrap();
            let mut coeffs = vec![0.0; model.n_coeffs()];
            for (k, c) in coeffs[p.offset..p.offset + p.len].iter_mut().enumerate() {
                *c = [12e-6, -6e-6, 4e-6][k % 3];
            }
            let hold = default_hold(model.machine());
            let table = pitch_table(&model, &coeffs, axis, 20.0, &hold).unwrap();
            let i = model.machine().axis_index(axis).unwrap();
            let dir = travel_direction(model.machine(), &hold, i);
            let mut ws = model.workspace();
            let mut worst: f64 = 0.0;
            for (&x, &c) in table.positions_mm.iter().zip(&table.forward_um) {
                let mut q = hold.clone();
                q[i] = x * 1e-3;
                let target = model.machine().tool_in_workpiece(&q).t;
                q[i] = (x + c * 1e-3) * 1e-3;
                let actual = model.machine().tool_in_workpiece(&q).t
                    + model.pose_error(&q, &coeffs, &mut ws).translation;
                worst = worst.max(((actual - target).dot(&dir) * 1e6).abs());
            }
            let largest = table.forward_um.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                largest > 5.0,
                "{name} {axis}: error {largest} µm too small to test"
            );
            assert!(worst < TOL_UM, "{name} {axis}: residual {worst} µm");
            eprintln!(
                "{name} {axis}: largest compensation {largest:.2} µm, residual {worst:.2e} µm"
            );
        }
    }
}

fn check_grid_round_trip(name: &str, seed: u64, orientation: bool) {
    let model = load(name);
    let coeffs = random_coeffs(&model, seed);
    let mut spec = GridSpec::new(model.machine(), [60.0, 75.0, 90.0]);
    spec.orientation = orientation;
    let grid = error_grid(&model, &coeffs, &spec).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grid.csv");
    write_grid_csv(&path, &grid).unwrap();
    let back = read_grid_csv(&path).unwrap();
    assert_eq!(back.len(), grid.len());
    assert_eq!(back.error_urad.is_some(), orientation);
    let mut ws = model.workspace();
    let mut q = spec.hold_q.clone();
    let idx = ['X', 'Y', 'Z'].map(|a| model.machine().axis_index(a).unwrap());
    for n in 0..back.len() {
        let p = back.position_mm(n);
        for d in 0..3 {
            q[idx[d]] = p[d] * 1e-3;
        }
        let e = model.pose_error(&q, &coeffs, &mut ws);
        for d in 0..3 {
            let t = back.error_um[n][d] - e.translation[d] * 1e6;
            assert!(
                t.abs() < 1e-5 && t.abs() < TOL_UM,
                "{name} node {n} dir {d}: {t}"
            );
            if let Some(r) = &back.error_urad {
                assert!((r[n][d] - e.rotation[d] * 1e6).abs() < 1e-5);
            }
        }
        // Interpolation reproduces the nodes.
        let i = back.error_at_um(p);
        let c = back.compensation_at_um(p);
        for d in 0..3 {
            assert!((i[d] - back.error_um[n][d]).abs() < 1e-9);
            assert_eq!(c[d], -i[d]);
        }
    }
}

#[test]
fn error_grid_round_trips_three_axis() {
    check_grid_round_trip("mcv754-zfyx.urdf", 4, false);
}

#[test]
fn error_grid_round_trips_five_axis_with_orientation() {
    check_grid_round_trip("mcu630-cafyxz.urdf", 5, true);
}

/// Trilinear interpolation of smooth (Legendre degree ≤ 3) errors: between nodes it is within
/// `Σ_d h_d² max|∂²e/∂x_d²| / 8` of the model (per cell, h_d its size), the second derivatives
/// taken from central differences at the nodes (exact for cubics; their maxima over the box
/// are reached at nodes since they are at most linear in each coordinate to first order).
#[test]
fn trilinear_interpolation_error_within_the_second_derivative_bound() {
    for (name, seed) in [("mcv754-zfyx.urdf", 6), ("mcu630-cafyxz.urdf", 7)] {
        let model = load(name);
        let coeffs = random_coeffs(&model, seed);
        let spec = GridSpec::new(model.machine(), [50.0, 50.0, 50.0]);
        let grid = error_grid(&model, &coeffs, &spec).unwrap();
        let axes = [&grid.x_mm, &grid.y_mm, &grid.z_mm];
        // Largest second derivative per direction and component (µm/mm²), from triples of
        // equally spaced nodes.
        let mut curv = [[0.0f64; 3]; 3];
        for n in 0..grid.len() {
            let p = grid.position_mm(n);
            let ijk = [
                grid.x_mm.iter().position(|&v| v == p[0]).unwrap(),
                grid.y_mm.iter().position(|&v| v == p[1]).unwrap(),
                grid.z_mm.iter().position(|&v| v == p[2]).unwrap(),
            ];
            for d in 0..3 {
                let a = axes[d];
                let c = ijk[d];
                if c == 0 || c + 1 >= a.len() || (a[c + 1] - a[c] - (a[c] - a[c - 1])).abs() > 1e-9
                {
                    continue;
                }
                let h = a[c] - a[c - 1];
                let mut lo = ijk;
                let mut hi = ijk;
                lo[d] -= 1;
                hi[d] += 1;
                let (el, ec, eh) = (
                    grid.error_um[grid.index(lo[0], lo[1], lo[2])],
                    grid.error_um[n],
                    grid.error_um[grid.index(hi[0], hi[1], hi[2])],
                );
                for k in 0..3 {
                    curv[d][k] = curv[d][k].max(((el[k] - 2.0 * ec[k] + eh[k]) / (h * h)).abs());
                }
            }
        }
        let mut rng = SplitMix64(seed + 100);
        let mut ws = model.workspace();
        let mut q = spec.hold_q.clone();
        let idx = ['X', 'Y', 'Z'].map(|a| model.machine().axis_index(a).unwrap());
        let mut worst_ratio: f64 = 0.0;
        for _ in 0..2000 {
            let mut p = [0.0; 3];
            let mut h = [0.0; 3];
            for d in 0..3 {
                let a = axes[d];
                let (lo, hi) = (a[0], a[a.len() - 1]);
                p[d] = lo + (hi - lo) * 0.5 * (rng.signed() + 1.0);
                let c = a.partition_point(|&v| v <= p[d]).clamp(1, a.len() - 1);
                h[d] = a[c] - a[c - 1];
                q[idx[d]] = p[d] * 1e-3;
            }
            let e = model.pose_error(&q, &coeffs, &mut ws).translation * 1e6;
            let interp = grid.error_at_um(p);
            for k in 0..3 {
                // 1 nm slack for print rounding and the model's second-order terms.
                let bound: f64 = (0..3).map(|d| h[d] * h[d] * curv[d][k] / 8.0).sum::<f64>() + 1e-3;
                let err = (interp[k] - e[k]).abs();
                assert!(
                    err <= bound,
                    "{name} at {p:?} comp {k}: {err} µm > bound {bound} µm"
                );
                worst_ratio = worst_ratio.max(err / bound);
            }
        }
        eprintln!("{name}: worst |trilinear - model| / bound = {worst_ratio:.3}");
        assert!(
            worst_ratio > 0.05,
            "{name}: the bound is never approached ({worst_ratio})"
        );
    }
}

#[test]
fn argument_errors_are_reported() {
    let model = load("mcu630-cafyxz.urdf");
    let coeffs = vec![0.0; model.n_coeffs()];
    let hold = default_hold(model.machine());
    let err = |r: Result<PitchTable, CompensateError>| r.unwrap_err().to_string();
    assert!(err(pitch_table(&model, &coeffs, 'C', 10.0, &hold)).contains("rotary"));
    assert!(err(pitch_table(&model, &coeffs, 'W', 10.0, &hold)).contains("no axis W"));
    assert!(err(pitch_table(&model, &coeffs, 'X', -1.0, &hold)).contains("spacing"));
    assert!(err(pitch_table(&model, &coeffs, 'X', 1e-7, &hold)).contains("nodes"));
    assert!(err(pitch_table(&model, &coeffs, 'X', 10.0, &hold[1..])).contains("axis positions"));
    assert!(err(pitch_table(&model, &coeffs[1..], 'X', 10.0, &hold)).contains("coefficients"));
    let table = pitch_table(&model, &coeffs, 'X', 1.0, &hold).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let e = write_linuxcnc_comp(&dir.path().join("x.comp"), &table).unwrap_err();
    assert!(e.to_string().contains("at most 256"), "{e}");
}

/// Writes `text` to a file and reads it with `read`, expecting an error at `line:column`.
fn expect_parse_error<T: std::fmt::Debug>(
    text: &str,
    read: impl Fn(&Path) -> Result<T, CompensateError>,
    line: usize,
    column: usize,
    says: &str,
) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.txt");
    std::fs::write(&path, text).unwrap();
    match read(&path) {
        Err(CompensateError::Parse { at, message }) => {
            assert_eq!((at.line, at.column), (line, column), "{message}");
            assert_eq!(at.file, path);
            assert!(message.contains(says), "`{message}` should say `{says}`");
        }
        other => panic!("expected a parse error for {text:?}, got {other:?}"),
    }
}

#[test]
fn bad_files_name_file_line_and_column() {
    let comp = |p: &Path| read_linuxcnc_comp(p, 'X');
    expect_parse_error("0 0 0\n1 0.001\n", comp, 2, 8, "expected 3 fields");
    expect_parse_error("0 0 0\n1 0.001 x2\n", comp, 2, 9, "`x2`");
    expect_parse_error("0 0 0\n0 0 0\n", comp, 2, 1, "ascend");
    expect_parse_error("\n\n", comp, 3, 1, "at least one row");
    expect_parse_error("0 0 0 0\n", comp, 1, 7, "expected 3 fields");
    expect_parse_error("1 nan 0\n", comp, 1, 3, "finite");

    let csv = |p: &Path| read_pitch_csv(p, 'X');
    expect_parse_error("# c\npos,comp\n", csv, 2, 1, "header");
    expect_parse_error(
        "position_mm,compensation_um\n1,2\n2, 3,4\n",
        csv,
        3,
        6,
        "expected 2 fields",
    );
    expect_parse_error(
        "position_mm,forward_um,reverse_um\n1,2,\n",
        csv,
        2,
        5,
        "finite number",
    );
    expect_parse_error("", csv, 1, 1, "header");

    let grid = read_grid_csv;
    let h = "X,Y,Z,dx_um,dy_um,dz_um\n";
    expect_parse_error(
        &format!("{h}0,0,0,1,2,3\n0,0,1,1,2,3\n0,1,1,1,2,3\n"),
        grid,
        4,
        1,
        "expected the node",
    );
    expect_parse_error(
        &format!("{h}0,0,0,1,2,3\n0,1,0,1,2,3\n1,0,0,1,2,3\n"),
        grid,
        5,
        1,
        "end after 3",
    );
    expect_parse_error(&format!("{h}0,0,0,1,2\n"), grid, 2, 10, "expected 6 fields");
    expect_parse_error("X,Y,Z,dx,dy,dz\n", grid, 1, 1, "header");

    let missing = read_grid_csv(Path::new("/nonexistent/grid.csv")).unwrap_err();
    assert!(missing.to_string().contains("/nonexistent/grid.csv"));
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Linear interpolation hits the nodes, stays within neighbouring values and clamps.
        #[test]
        fn pitch_interpolation_is_linear_between_nodes(
            steps in proptest::collection::vec(0.1f64..50.0, 1..20),
            values in proptest::collection::vec(-20.0f64..20.0, 21),
            t in 0.0f64..1.0,
        ) {
            let mut positions_mm = vec![-100.0];
            for s in &steps {
                positions_mm.push(positions_mm.last().unwrap() + s);
            }
            let n = positions_mm.len();
            let table = PitchTable {
                axis: 'X',
                forward_um: values[..n].to_vec(),
                positions_mm,
                reverse_um: None,
                note: String::new(),
            };
            for k in 0..n {
                let p = table.positions_mm[k];
                prop_assert!((table.correction_at_um(p, Travel::Forward) - table.forward_um[k]).abs() < 1e-12);
                prop_assert_eq!(table.correction_at_um(p, Travel::Reverse), table.correction_at_um(p, Travel::Forward));
            }
            for k in 0..n - 1 {
                let (a, b) = (table.positions_mm[k], table.positions_mm[k + 1]);
                let v = table.correction_at_um(a + t * (b - a), Travel::Forward);
                let (fa, fb) = (table.forward_um[k], table.forward_um[k + 1]);
                prop_assert!((v - (fa + t * (fb - fa))).abs() < 1e-9);
            }
            prop_assert_eq!(table.correction_at_um(-1e6, Travel::Forward), table.forward_um[0]);
            prop_assert_eq!(table.correction_at_um(1e6, Travel::Forward), table.forward_um[n - 1]);
        }
    }
}
