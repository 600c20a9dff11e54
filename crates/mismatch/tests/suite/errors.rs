//! Bad input is a clear error naming the run, channel and variable; odd but valid input
//! (constant variables, splits without two usable groups) is skipped, not an error.

use mtcal_mismatch::{MismatchError, Options, RunResiduals, locate};

fn residuals(n: usize) -> Vec<f64> {
    (0..n).map(|i| ((i * 37) % 11) as f64 / 5.0 - 1.0).collect()
}

fn time(n: usize) -> Vec<f64> {
    (0..n).map(|i| i as f64).collect()
}

fn error(run: RunResiduals<'_>) -> MismatchError {
    locate(&[run], &Options::default()).expect_err("bad input")
}

#[test]
fn length_mismatch_names_run_channel_and_variable() {
    let (r, t) = (residuals(30), time(29));
    let err = error(
        RunResiduals::new("ballbar-1")
            .channel("dr", &r)
            .context("t", &t),
    );
    assert!(
        matches!(&err, MismatchError::LengthMismatch { run, channel, variable, expected: 30, found: 29 }
        if run == "ballbar-1" && channel == "dr" && variable == "t")
    );
    let message = err.to_string();
    assert!(
        message.contains("ballbar-1") && message.contains("`dr`") && message.contains("`t`"),
        "{message}"
    );
}

#[test]
fn split_length_mismatch_is_an_error() {
    let (r, t, dir) = (residuals(30), time(30), vec![1; 31]);
    let err = error(
        RunResiduals::new("a")
            .channel("dz", &r)
            .context("t", &t)
            .split("direction", &dir),
    );
    assert!(
        matches!(err, MismatchError::LengthMismatch { ref variable, found: 31, .. } if variable == "direction")
    );
}

#[test]
fn non_finite_residual_names_its_index() {
    let mut r = residuals(30);
    r[7] = f64::NAN;
    let t = time(30);
    let err = error(RunResiduals::new("a").channel("dz", &r).context("t", &t));
    assert!(
        matches!(err, MismatchError::NonFiniteResidual { ref channel, index: 7, .. } if channel == "dz")
    );
    r[7] = f64::INFINITY;
    let err = error(RunResiduals::new("a").channel("dz", &r).context("t", &t));
    assert!(matches!(
        err,
        MismatchError::NonFiniteResidual { index: 7, .. }
    ));
}

#[test]
fn non_finite_context_names_the_variable() {
    let r = residuals(30);
    let mut x = time(30);
    x[3] = f64::NEG_INFINITY;
    let t = time(30);
    let err = error(
        RunResiduals::new("a")
            .channel("dz", &r)
            .context("t", &t)
            .context("X", &x),
    );
    assert!(
        matches!(err, MismatchError::NonFiniteContext { ref variable, index: 3, .. } if variable == "X")
    );
}

#[test]
fn too_few_samples_is_an_error() {
    let (r, t) = (residuals(10), time(10));
    let err = error(
        RunResiduals::new("short")
            .channel("dz", &r)
            .context("t", &t),
    );
    assert!(matches!(
        err,
        MismatchError::TooFewSamples {
            found: 10,
            min: 20,
            ..
        }
    ));
    assert!(err.to_string().contains("short"));
}

#[test]
fn duplicate_names_are_errors() {
    let (r, t) = (residuals(30), time(30));
    let err = error(RunResiduals::new("a").channel("dz", &r).channel("dz", &r));
    assert!(matches!(
        err,
        MismatchError::DuplicateName {
            what: "channel",
            ..
        }
    ));
    let dir = vec![1; 30];
    let err = error(
        RunResiduals::new("a")
            .channel("dz", &r)
            .context("t", &t)
            .split("t", &dir),
    );
    assert!(matches!(err, MismatchError::DuplicateName { ref name, .. } if name == "t"));
    let runs = [
        RunResiduals::new("a").channel("dz", &r),
        RunResiduals::new("a").channel("dz", &r),
    ];
    let err = locate(&runs, &Options::default()).unwrap_err();
    assert!(matches!(
        err,
        MismatchError::DuplicateName { what: "run", .. }
    ));
}

#[test]
fn invalid_options_are_errors() {
    let (r, t) = (residuals(30), time(30));
    let run = RunResiduals::new("a").channel("dz", &r).context("t", &t);
    for options in [
        Options {
            alpha: 0.0,
            ..Options::default()
        },
        Options {
            alpha: f64::NAN,
            ..Options::default()
        },
        Options {
            min_samples: 2,
            ..Options::default()
        },
        Options {
            ljung_box_lags: 0,
            ..Options::default()
        },
        Options {
            min_group_samples: 1,
            ..Options::default()
        },
    ] {
        let err = locate(std::slice::from_ref(&run), &options).unwrap_err();
        assert!(
            matches!(err, MismatchError::InvalidOption { .. }),
            "{options:?}"
        );
    }
}

#[test]
fn constant_variables_and_single_group_splits_are_skipped() {
    let (r, t) = (residuals(40), time(40));
    let spindle = vec![12_000.0; 40];
    let mut dir = vec![1; 40];
    dir[0] = -1; // one sample moving the other way: too small a group
    let run = RunResiduals::new("a")
        .channel("dz", &r)
        .context("S", &spindle)
        .context("t", &t)
        .split("direction", &dir);
    let analysis = locate(&[run], &Options::default()).expect("skipped, not an error");
    let skipped: Vec<&str> = analysis.skipped.iter().map(|s| s.along.as_str()).collect();
    assert_eq!(skipped, ["S", "direction"]);
    assert!(
        analysis
            .tests
            .iter()
            .all(|r| !matches!(r.along.as_deref(), Some("S" | "direction")))
    );
    // χ² plus the four ordered tests along t.
    assert_eq!(analysis.tests.len(), 5);
}

#[test]
fn a_run_without_context_still_gets_its_chi_square() {
    let r = residuals(25);
    let analysis = locate(
        &[RunResiduals::new("bare").channel("d", &r)],
        &Options::default(),
    )
    .unwrap();
    assert_eq!(analysis.tests.len(), 1);
    assert!(locate(&[], &Options::default()).unwrap().tests.is_empty());
}
