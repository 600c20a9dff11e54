//! The reported σ are honest: 95 % intervals contain the truth about 95 % of the time.

use crate::common;

use common::*;
use mtcal_solve::{Silent, solve};

#[test]
fn ninety_five_percent_intervals_cover_the_truth() {
    let (mut hits, mut total) = (0, 0);
    for seed in 0..300 {
        let mut g = rng(1000 + seed);
        let n = 3;
        let truth: Vec<f64> = (0..n).map(|_| uniform(&mut g, -5.0, 5.0)).collect();
        let rows: Vec<Row> = (0..15)
            .map(|_| {
                let a: Vec<f64> = (0..n).map(|_| uniform(&mut g, -1.0, 1.0)).collect();
                let sigma = uniform(&mut g, 0.05, 0.5);
                let y =
                    a.iter().zip(&truth).map(|(a, t)| a * t).sum::<f64>() + sigma * normal(&mut g);
                Row {
                    cols: (0..n).collect(),
                    a,
                    y,
                    sigma,
                }
            })
            .collect();
        let p = Linear {
            n,
            blocks: vec![rows],
        };
        let sol = solve(&p, &params(n), &options(1), &mut Silent).unwrap();
        for (k, t) in truth.iter().enumerate().take(n) {
            total += 1;
            if (sol.x[k] - t).abs() <= 1.96 * sol.sigma[k].unwrap() {
                hits += 1;
            }
        }
    }
    let share = hits as f64 / total as f64;
    assert!((0.93..=0.97).contains(&share), "coverage {share}");
}
