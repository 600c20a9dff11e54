//! The fit evaluates a reduced copy of the machine model (only estimated parameters and those
//! with a nonzero starting value). It must give exactly the poses of the full model.

use mtcal_identify::Study;
use std::path::Path;

#[test]
fn reduced_fit_model_gives_the_full_models_poses() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/five-axis/session");
    let study = Study::load(&dir).unwrap();
    // The example estimates the 11-error set of a machine whose error model has every
    // component error too: the fit model must carry just those 11 coefficients.
    assert_eq!(study.layout().n_machine(), 11);
    assert_eq!(
        study.fit_model.n_coeffs(),
        11,
        "{:?}",
        study.layout().fit_coeffs()
    );
    assert!(study.model.n_coeffs() > 100);
    let mut lcg = mtcal_testkit::random::Lcg64(7);
    let mut ws_full = study.model.workspace();
    let mut ws_fit = study.fit_model.workspace();
    for _ in 0..5 {
        // Values of a few tens of µm / µrad for the estimated coefficients.
        let x: Vec<f64> = (0..study.layout().n_x())
            .map(|_| 5e-5 * lcg.signed())
            .collect();
        let full = study.coeffs_from(&x);
        let fit = study.fit_coeffs_from(&x);
        for &k in study.layout().fit_coeffs() {
            assert!(study.layout().estimated().contains(&k) || study.base_coeffs[k] != 0.0);
        }
        for run in study.runs.iter() {
            let na = study.model.machine().n_axes();
            let q_all = run.q.to_row_major();
            for q in q_all.chunks_exact(na).step_by(7) {
                let a = study.model.tool_pose(q, &full, &mut ws_full);
                let b = study.fit_model.tool_pose(q, &fit, &mut ws_fit);
                assert!((a.t - b.t).norm() < 1e-15, "{:?} vs {:?}", a.t, b.t);
                assert!((a.r - b.r).norm() < 1e-15);
            }
        }
    }
}
