//! The hot paths of the kinematic error model allocate nothing per evaluation: all scratch lives
//! in a `Workspace` created once (issue 2, "no allocation per evaluation"). The counting
//! allocator (`allocation-counter`) counts this thread's allocations only, so the test harness's
//! own threads cannot make it fail.

use mtcal::kinematics::model::iso_full_config;
use mtcal::kinematics::{BasisChoice, MachineModel};
use std::hint::black_box;
use std::path::Path;

#[test]
fn evaluations_allocate_nothing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("machines/mcu630-cafyxz.urdf");
    let machine = mtcal::machine::urdf::load_urdf_file(&path).unwrap();
    let cubic = BasisChoice::Legendre { degree: 3 };
    let config = iso_full_config(&machine, &cubic, &cubic).unwrap();
    let model = MachineModel::new(machine, &config).unwrap();
    let n_axes = model.machine().n_axes();
    let poses: Vec<Vec<f64>> = (0..64)
        .map(|i| {
            model
                .machine()
                .axes()
                .iter()
                .enumerate()
                .map(|(a, ax)| {
                    let (lo, hi) = ax.limits().unwrap_or((-3.0, 3.0));
                    lo + (hi - lo) * (((i * (a + 3) * 37) % 101) as f64 / 100.0)
                })
                .collect()
        })
        .collect();
    // Two coefficient vectors: switching between them rebuilds the packed coefficients in the
    // workspace, which must not allocate either.
    let coeffs: Vec<Vec<f64>> = (0..2)
        .map(|s| {
            (0..model.n_coeffs())
                .map(|k| 1e-6 * (((k * 7919 + s * 13) % 41) as f64 - 20.0))
                .collect()
        })
        .collect();
    let mut ws = model.workspace();
    let mut jac = vec![0.0; 6 * model.n_coeffs()];
    let mut axis_jac = vec![0.0; 6 * n_axes];
    let evaluate = |ws: &mut _, jac: &mut [f64], axis_jac: &mut [f64]| {
        for (i, q) in poses.iter().enumerate() {
            let c = &coeffs[i % 2];
            black_box(model.pose_error_first_order(q, c, ws));
            black_box(model.pose_error(q, c, ws));
            black_box(model.pose_error_jacobian(q, c, ws, jac));
            black_box(model.tool_pose_jacobian(q, c, ws, jac));
            black_box(model.tool_pose(q, c, ws));
            black_box(model.tool_jacobian(q, c, ws, axis_jac));
        }
    };
    // Warm-up (first use of anything lazily initialised), then count.
    evaluate(&mut ws, &mut jac, &mut axis_jac);
    let during =
        allocation_counter::measure(|| evaluate(&mut ws, &mut jac, &mut axis_jac)).bytes_total;
    // The counter sees allocations (so the zero above means something).
    let probe = allocation_counter::measure(|| drop(black_box(vec![0u8; 4096]))).bytes_total;
    assert_eq!(
        during, 0,
        "{during} bytes allocated during 64 × 6 evaluations"
    );
    assert!(
        probe >= 4096,
        "the counting allocator missed a 4 kB allocation ({probe})"
    );
}
