//! Properties: the χ² test ignores sample order; rescaling a context variable moves no span.

use crate::common;

use proptest::prelude::*;

use mtcal_mismatch::{Options, RunResiduals, TestKind, locate};

fn chi_square_record(analysis: &mtcal_mismatch::Analysis) -> (f64, f64) {
    let record = analysis
        .tests
        .iter()
        .find(|r| r.test == TestKind::ChiSquare)
        .unwrap();
    (record.statistic, record.p_value)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn permuting_samples_does_not_change_chi_square(seed in 0_u64..1_000_000, shuffle in 0_u64..1_000_000) {
        let mut rng = common::rng(seed);
        let n = 150;
        let r = common::white(&mut rng, n);
        let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
        // A permutation from a second seed: sort indices by a random key.
        let mut keys_rng = common::rng(shuffle);
        let keys = common::white(&mut keys_rng, n);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]));
        let permuted: Vec<f64> = order.iter().map(|&i| r[i]).collect();
        let options = Options::default();
        let a = locate(&[RunResiduals::new("a").channel("d", &r).context("t", &t)], &options).unwrap();
        let b = locate(&[RunResiduals::new("a").channel("d", &permuted).context("t", &t)], &options).unwrap();
        let ((sa, pa), (sb, pb)) = (chi_square_record(&a), chi_square_record(&b));
        prop_assert!((sa - sb).abs() <= 1e-10 * sa, "{sa} vs {sb}");
        prop_assert!((pa - pb).abs() <= 1e-9, "{pa} vs {pb}");
    }

    #[test]
    fn scaling_a_variable_does_not_move_the_span(seed in 0_u64..1_000_000, scale in -3.0_f64..3.0) {
        let scale = 10_f64.powf(scale);
        let mut rng = common::rng(seed);
        let n = 200;
        let x = common::positions(&mut rng, n, 0.0, 500.0);
        // A 2 σ offset for 100 mm ≤ X < 200 mm: found along X whatever the units.
        let r: Vec<f64> = common::white(&mut rng, n)
            .iter()
            .zip(&x)
            .map(|(e, &x)| if (100.0..200.0).contains(&x) { e + 2.0 } else { *e })
            .collect();
        let scaled: Vec<f64> = x.iter().map(|v| v * scale).collect();
        let options = Options::default();
        let a = locate(&[RunResiduals::new("a").channel("d", &r).context("X", &x)], &options).unwrap();
        let b = locate(&[RunResiduals::new("a").channel("d", &r).context("X", &scaled)], &options).unwrap();
        let (la, lb) = (&a.mismatch.locations[0], &b.mismatch.locations[0]);
        prop_assert_eq!(la.along.as_deref(), Some("X"));
        prop_assert_eq!(lb.along.as_deref(), Some("X"));
        // The same samples: the scaled bounds are the scaled originals, the share identical.
        let (from, to) = (la.from.unwrap(), la.to.unwrap());
        let same = |original: f64, rescaled: f64| (original * scale - rescaled).abs() <= 1e-12 * rescaled.abs().max(1e-300);
        prop_assert!(same(from, lb.from.unwrap()) && same(to, lb.to.unwrap()), "{from}..{to} vs {:?}..{:?}", lb.from, lb.to);
        prop_assert_eq!(la.share, lb.share);
    }
}
