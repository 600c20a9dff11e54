//! Property: however the rows are grouped, split into blocks, spread over threads, and whichever
//! parameters are fixed, the streaming factor reproduces the dense normal equations:
//! `RᵀR = JᵀJ`, `Rᵀz = Jᵀr` and `zᵀz + rss = rᵀr`.

use crate::common;

use common::*;
use mtcal_solve::linearize;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

fn random_problem(seed: u64, n: usize, n_blocks: usize) -> Linear {
    let mut g = rng(seed);
    let blocks = (0..n_blocks)
        .map(|_| {
            let mut rows = Vec::new();
            let groups = 1 + (uniform(&mut g, 0.0, 4.0) as usize);
            for _ in 0..groups {
                let mut cols: Vec<usize> =
                    (0..n).filter(|_| uniform(&mut g, 0.0, 1.0) < 0.5).collect();
                if cols.is_empty() {
                    cols.push((uniform(&mut g, 0.0, n as f64) as usize).min(n - 1));
                }
                let count = 1 + (uniform(&mut g, 0.0, 9.0) as usize);
                for _ in 0..count {
                    let a = cols.iter().map(|_| uniform(&mut g, -1.0, 1.0)).collect();
                    rows.push(Row {
                        cols: cols.clone(),
                        a,
                        y: uniform(&mut g, -1.0, 1.0),
                        sigma: uniform(&mut g, 0.5, 2.0),
                    });
                }
            }
            rows
        })
        .collect();
    Linear { n, blocks }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn streaming_factor_reproduces_the_normal_equations(
        seed in any::<u64>(),
        n in 1usize..12,
        n_blocks in 1usize..6,
        threads in 1usize..4,
        fixed_mask in any::<u16>(),
    ) {
        let p = random_problem(seed, n, n_blocks);
        let mut spec = params(n);
        for (i, s) in spec.iter_mut().enumerate() {
            s.fixed = fixed_mask >> i & 1 == 1;
            s.group = (i % 3 == 0).then(|| "local".to_string());
        }
        prop_assume!(spec.iter().any(|s| !s.fixed));
        let x: Vec<f64> = (0..n).map(|i| 0.1 * i as f64 - 0.3).collect();
        let lin = linearize(&p, &spec, &x, threads).unwrap();
        let (mut j, w) = p.dense();
        let r = &j * DVector::from_column_slice(&x) - &w;
        for (i, s) in spec.iter().enumerate() {
            if s.fixed {
                j.column_mut(i).fill(0.0);
            }
        }
        let rm = DMatrix::from_row_slice(n, n, &lin.r);
        let z = DVector::from_column_slice(&lin.z);
        let jtj = j.transpose() * &j;
        let scale = jtj.amax().max(1e-300);
        prop_assert!((rm.transpose() * &rm - &jtj).amax() <= 1e-12 * scale);
        let jtr = j.transpose() * &r;
        prop_assert!((rm.transpose() * &z - &jtr).amax() <= 1e-12 * (jtr.amax() + scale));
        let rr = r.norm_squared();
        prop_assert!((z.norm_squared() + lin.rss - rr).abs() <= 1e-12 * rr.max(1.0));
        prop_assert!((lin.cost - 0.5 * rr).abs() <= 1e-12 * rr.max(1.0));
        prop_assert_eq!(lin.n_rows, p.blocks.iter().map(Vec::len).sum::<usize>());
    }
}
