//! The campaigns the identification tests use: they write sessions mtcal's loader accepts, with
//! the runs and validation runs the docs promise, and the realism knobs do what they say.

use mtcal_indsim::{Campaign, Realism};
use mtcal_session::{RunColumns, RunUse, load_session, read_run};

fn columns<'a>(instrument: &str, axes: &'a [char]) -> RunColumns<'a> {
    RunColumns {
        axes,
        readings: match instrument {
            "rtest" => &["dx", "dy", "dz"],
            _ => &["dr"],
        },
        readings_optional: false,
        labels: &[],
    }
}

#[test]
fn trunnion_campaign_is_a_valid_session() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    let written = Campaign::trunnion_rtest_ballbar(&dir, 7, &Realism::ideal()).unwrap();
    let session = load_session(&dir).unwrap();
    assert!(
        session.machine.ends_with("machines/mcu630-cafyxz.urdf"),
        "{}",
        session.machine
    );
    let names: Vec<&str> = session.runs.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "rtest-xyc",
            "rtest-yza",
            "rtest-xyzac",
            "rtest-xyc-a+30",
            "rtest-xyc-a-30",
            "ballbar-xy-ccw",
            "ballbar-xy-cw",
            "ballbar-xy-c90",
            "rtest-validate",
            "ballbar-validate",
            "rtest-validate-a15",
            "ballbar-validate-c180"
        ]
    );
    let validate: Vec<&str> = session
        .runs
        .iter()
        .filter(|r| r.use_ == RunUse::Validate)
        .map(|r| r.name.as_str())
        .collect();
    assert_eq!(
        validate,
        [
            "rtest-validate",
            "ballbar-validate",
            "rtest-validate-a15",
            "ballbar-validate-c180"
        ]
    );
    let axes = ['X', 'Y', 'Z', 'A', 'C'];
    for run in &session.runs {
        let t = read_run(&run.file, &columns(&run.instrument, &axes)).unwrap();
        assert!(t.t.windows(2).all(|w| w[1] > w[0]));
        // A machine with errors of a few µm reads a few µm, not zero and not millimetres.
        let v = t.values.unwrap();
        let max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(max > 0.5 && max < 500.0, "{}: {max} µm", run.name);
    }
    assert!(dir.join("truth/params.toml").is_file());
    assert_eq!(written.runs.len(), 12);
}

#[test]
fn three_axis_campaign_and_realism() {
    let tmp = tempfile::tempdir().unwrap();
    let ideal = Campaign::three_axis_ballbar(&tmp.path().join("a"), 3, &Realism::ideal()).unwrap();
    let real = Realism::realistic(11);
    let noisy = Campaign::three_axis_ballbar(&tmp.path().join("b"), 3, &real).unwrap();
    let session = load_session(&tmp.path().join("b")).unwrap();
    assert_eq!(session.runs.len(), 2);
    // The stated σ is the factor times the one used.
    let stated = session.setups["bar1"]["sigma_um"].as_float().unwrap();
    assert!((stated - real.noise_sigma_um * real.manifest_sigma_factor).abs() < 1e-12);
    for (a, b) in ideal.runs.iter().zip(&noisy.runs) {
        // Same truth and path; the written readings are quantised to the resolution.
        for r in &b.written_um {
            let steps = r[0] / real.resolution_um;
            assert!((steps - steps.round()).abs() < 1e-6, "{}", r[0]);
        }
        // The noise (with the real set-up offsets in `clean_um`) has about the σ used.
        let res: Vec<f64> = b
            .written_um
            .iter()
            .zip(&b.clean_um)
            .map(|(w, c)| w[0] - c[0])
            .collect();
        let rms = (res.iter().map(|x| x * x).sum::<f64>() / res.len() as f64).sqrt();
        assert!((rms / real.noise_sigma_um - 1.0).abs() < 0.35, "rms {rms}");
        // AR(1): neighbouring noise values are correlated about φ.
        let lag1 = res.windows(2).map(|w| w[0] * w[1]).sum::<f64>()
            / res.iter().map(|x| x * x).sum::<f64>();
        assert!((lag1 - real.noise_phi).abs() < 0.2, "lag-1 {lag1}");
        // The real set-up differs from the stated one: the clean readings differ too.
        let moved = a
            .clean_um
            .iter()
            .zip(&b.clean_um)
            .map(|(x, y)| (x[0] - y[0]).abs())
            .fold(0.0, f64::max);
        assert!(moved > 1.0, "set-up offsets change the readings: {moved}");
    }
}
