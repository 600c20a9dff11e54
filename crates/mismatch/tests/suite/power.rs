//! Power: planted structures are detected and located.

use crate::common;

use mtcal_mismatch::{Analysis, Location, Options, RunResiduals, TestKind, locate};

fn analyse(run: RunResiduals<'_>) -> Analysis {
    locate(&[run], &Options::default()).expect("valid input")
}

/// The location along `along`, if any.
fn along<'a>(analysis: &'a Analysis, along: &str) -> Option<&'a Location> {
    analysis
        .mismatch
        .locations
        .iter()
        .find(|l| l.along.as_deref() == Some(along))
}

/// Whether `test` along `along` was rejected.
fn rejected(analysis: &Analysis, test: TestKind, along: &str) -> bool {
    analysis
        .tests
        .iter()
        .any(|r| r.test == test && r.along.as_deref() == Some(along) && r.rejected)
}

#[test]
fn slow_drift_in_time_is_located_along_t() {
    let mut rng = common::rng(1);
    let n = 400;
    let t = common::uneven_times(&mut rng, n, 3600.0);
    let x = common::positions(&mut rng, n, 0.0, 500.0);
    // Thermal drift: 0 at the start, 1.5 σ after an hour, growing like 1 − e^{−t/τ}.
    let r: Vec<f64> = common::white(&mut rng, n)
        .iter()
        .zip(&t)
        .map(|(e, t)| e + 1.5 * (1.0 - (-t / 1200.0).exp()) / (1.0 - (-3.0_f64).exp()))
        .collect();
    let analysis = analyse(
        RunResiduals::new("drift")
            .channel("dz", &r)
            .context("t", &t)
            .context("X", &x),
    );
    assert!(analysis.mismatch.detected);
    let first = &analysis.mismatch.locations[0];
    assert_eq!(
        first.along.as_deref(),
        Some("t"),
        "{:#?}",
        analysis.mismatch
    );
    assert!(rejected(&analysis, TestKind::Cusum, "t"));
    // The excess grows with time, so the span runs to (within a few samples of) the end.
    assert!(first.to.unwrap() >= 0.97 * 3600.0, "span to {:?}", first.to);
    assert!(first.share > 0.7, "share {}", first.share);
    assert!(
        along(&analysis, "X").is_none(),
        "X is unrelated to the drift: {:#?}",
        analysis.mismatch
    );
}

#[test]
fn periodic_error_along_an_unevenly_sampled_axis_is_found_by_lomb_scargle() {
    let mut rng = common::rng(2);
    let n = 600;
    let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
    // Positions visited in random order: along t the error is white, along X it is a sinusoid.
    let x = common::positions(&mut rng, n, 0.0, 500.0);
    let period_mm = 37.0;
    let r: Vec<f64> = common::white(&mut rng, n)
        .iter()
        .zip(&x)
        .map(|(e, x)| e + 0.5 * (2.0 * std::f64::consts::PI * x / period_mm).sin())
        .collect();
    let analysis = analyse(
        RunResiduals::new("cyclic")
            .channel("dx", &r)
            .context("t", &t)
            .context("X", &x),
    );
    assert!(
        rejected(&analysis, TestKind::LombScargle, "X"),
        "{:#?}",
        analysis.tests
    );
    let record = analysis
        .tests
        .iter()
        .find(|r| r.test == TestKind::LombScargle && r.along.as_deref() == Some("X"))
        .unwrap();
    // Within one grid step (1/(5 · span)) of the planted frequency.
    let span = 500.0;
    assert!(
        (1.0 / record.detail - 1.0 / period_mm).abs() < 1.0 / (5.0 * span) * 1.5,
        "period {}",
        record.detail
    );
    // A cyclic error is everywhere along X: the span is X's whole range.
    let location = &analysis.mismatch.locations[0];
    assert_eq!(location.along.as_deref(), Some("X"));
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    assert_eq!((location.from, location.to), (Some(lo), Some(hi)));
    assert!(along(&analysis, "t").is_none(), "{:#?}", analysis.mismatch);
}

/// White noise over t = 0 … 599 with a step of 1.5 σ for 120 ≤ t ≤ 300 (run `rtest-xyc-a0`,
/// channel `dz`), analysed.
fn step_in_a_sub_span() -> Analysis {
    let mut rng = common::rng(3);
    let n = 600;
    let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let r: Vec<f64> = common::white(&mut rng, n)
        .iter()
        .zip(&t)
        .map(|(e, &t)| {
            if (120.0..=300.0).contains(&t) {
                e + 1.5
            } else {
                *e
            }
        })
        .collect();
    analyse(
        RunResiduals::new("rtest-xyc-a0")
            .channel("dz", &r)
            .context("t", &t),
    )
}

#[test]
fn step_in_a_sub_span_is_located_with_its_share() {
    let analysis = step_in_a_sub_span();
    let location = along(&analysis, "t").expect("located along t");
    let (from, to) = (location.from.unwrap(), location.to.unwrap());
    assert!(
        (from - 120.0).abs() <= 15.0 && (to - 300.0).abs() <= 15.0,
        "span {from}..{to}"
    );
    assert!(location.share >= 0.7, "share {}", location.share);
}

#[test]
fn direction_dependent_offset_is_found_by_the_direction_split() {
    let mut rng = common::rng(4);
    let n = 400;
    let t: Vec<f64> = (0..n).map(|i| 0.5 * i as f64).collect();
    let dir = common::directions(n, 25);
    // Reversal error: ±0.4 σ depending on the direction of motion.
    let r: Vec<f64> = common::white(&mut rng, n)
        .iter()
        .zip(&dir)
        .map(|(e, &d)| e + 0.4 * f64::from(d))
        .collect();
    let analysis = analyse(
        RunResiduals::new("reversal")
            .channel("dr", &r)
            .context("t", &t)
            .split("direction", &dir),
    );
    assert!(
        rejected(&analysis, TestKind::WelchMeans, "direction"),
        "{:#?}",
        analysis.tests
    );
    assert!(
        !rejected(&analysis, TestKind::BrownForsythe, "direction"),
        "spreads are equal"
    );
    let location = along(&analysis, "direction").expect("located along direction");
    assert!(location.from.unwrap() >= -1.0 && location.to.unwrap() <= 1.0);
}

#[test]
fn effect_below_the_per_sample_noise_is_detected_over_many_samples() {
    let mut rng = common::rng(5);
    let n = 5000;
    let t = common::uneven_times(&mut rng, n, 7200.0);
    let x = common::positions(&mut rng, n, 0.0, 800.0);
    // A drift from −0.3 σ to +0.3 σ: no single sample shows it.
    let r: Vec<f64> = common::white(&mut rng, n)
        .iter()
        .zip(&t)
        .map(|(e, t)| e + 0.3 * (2.0 * t / 7200.0 - 1.0))
        .collect();
    let analysis = analyse(
        RunResiduals::new("hidden")
            .channel("dz", &r)
            .context("t", &t)
            .context("X", &x),
    );
    assert!(analysis.mismatch.detected);
    assert_eq!(
        analysis.mismatch.locations[0].along.as_deref(),
        Some("t"),
        "{:#?}",
        analysis.mismatch
    );
    // Structure is what gives it away: the CUSUM along t is overwhelming, while χ² (which only
    // sees Σ r², an excess of 0.03 σ² per sample) is weak evidence on its own.
    let find = |test| {
        analysis
            .tests
            .iter()
            .find(|r| {
                r.test == test && (test == TestKind::ChiSquare || r.along.as_deref() == Some("t"))
            })
            .unwrap()
    };
    assert!(
        find(TestKind::Cusum).p_value < 1e-12,
        "CUSUM p = {}",
        find(TestKind::Cusum).p_value
    );
    assert!(
        find(TestKind::ChiSquare).p_value > 1e-3,
        "χ² p = {}",
        find(TestKind::ChiSquare).p_value
    );
}

#[test]
fn understated_sigma_shows_in_chi_square_only() {
    let mut rng = common::rng(6);
    let n = 500;
    let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let x = common::positions(&mut rng, n, 0.0, 300.0);
    // True noise 1.3 × the stated σ: more χ², but no structure along anything.
    let r: Vec<f64> = common::white(&mut rng, n).iter().map(|e| 1.3 * e).collect();
    let analysis = analyse(
        RunResiduals::new("sigma")
            .channel("dz", &r)
            .context("t", &t)
            .context("X", &x),
    );
    assert!(analysis.mismatch.detected);
    assert_eq!(analysis.mismatch.locations.len(), 1);
    let location = &analysis.mismatch.locations[0];
    assert_eq!(
        (location.along.as_deref(), location.from, location.to),
        (None, None, None)
    );
    assert_eq!(location.share, 1.0);
    assert!(
        analysis
            .tests
            .iter()
            .filter(|r| r.rejected)
            .all(|r| r.test == TestKind::ChiSquare)
    );
}

#[test]
fn output_has_the_formats_md_shape() {
    let analysis = step_in_a_sub_span();
    let json = serde_json::to_value(&analysis.mismatch).unwrap();
    assert_eq!(json["detected"], true);
    let first = &json["where"][0];
    let keys: Vec<&str> = first
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(keys, ["along", "channel", "from", "run", "share", "to"]);
    assert_eq!(first["run"], "rtest-xyc-a0");
    assert_eq!(first["channel"], "dz");
    assert_eq!(first["along"], "t");
    assert!(first["from"].is_f64() && first["to"].is_f64() && first["share"].is_f64());
    // The account reads as sentences.
    let words = analysis.describe();
    assert!(
        words
            .iter()
            .any(|w| w.contains("along t") && w.contains("% of the excess")),
        "{words:#?}"
    );
}
