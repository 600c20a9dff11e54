//! Source 004's zero point on its 10,164-point grid of a shipped machine, and the postprocessor.

use crate::common;

use mtcal_kinematics::MachineModel;
use mtcal_kinematics::volmap::{Grid, MapOptions, volumetric_map};
use mtcal_ncprog::zero_point::{ErrorVectors, zero_point, zero_point_naive};
use mtcal_ncprog::{Decimals, Program, model_zero_point, offset_program};
use mtcal_testkit::random::uniform;

/// The three-axis machine of source 004's grid.
fn model() -> MachineModel {
    common::model("mcv754-zfyx.urdf")
}

#[test]
fn the_source004_grid_search_equals_the_naive_one_and_improves_the_sum() {
    let m = model();
    let c: Vec<f64> = uniform(3, m.n_coeffs()).iter().map(|u| u * 5e-6).collect();
    let grid = Grid::source004(m.machine()).unwrap();
    let map = volumetric_map(&m, &c, &grid, &MapOptions::default());
    let d = ErrorVectors::new(map.translations_um());
    assert_eq!(d.len(), 10_164);
    let fast = zero_point(&d).unwrap();
    let naive = zero_point_naive(&d).unwrap();
    assert_eq!(
        fast,
        mtcal_ncprog::ZeroPoint {
            completed: fast.completed,
            visited: fast.visited,
            ..naive
        }
    );
    eprintln!("completed {} visited {}", fast.completed, fast.visited);
    assert!(
        fast.completed < d.len() / 10,
        "pruning: {} completed",
        fast.completed
    );
    assert!(fast.sum_after_um <= fast.sum_before_um);
    let mz = model_zero_point(&m, &c, &grid).unwrap();
    assert_eq!(mz.zero_point.index, fast.index);
    assert_eq!(mz.positions, map.positions(fast.index));
    assert!(mz.median.sum_um <= fast.sum_after_um);
    // The offset program moves the zero point's commanded position by −d_k* (mm = µm / 1000).
    let q = &mz.positions;
    let text = format!(
        "G90 G21\nG1 X{:.4} Y{:.4} Z{:.4} F100\n",
        q[0] * 1e3,
        q[1] * 1e3,
        q[2] * 1e3
    );
    let off = mz.zero_point.offset_um.map(|v| v * 1e-3);
    let out = offset_program(&Program::parse(&text).unwrap(), off, Decimals::default()).unwrap();
    let states = Program::parse(&out).unwrap().modal_states();
    for a in 0..3 {
        let moved = states[1].axes[a].unwrap() - (q[a] * 1e3);
        assert!(
            (moved - off[a]).abs() < 1e-4,
            "axis {a}: {moved} vs {}",
            off[a]
        );
    }
}
