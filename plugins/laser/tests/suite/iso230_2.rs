//! The ISO 230-2:2014 evaluation against a small example computed by hand, the uncertainty
//! budget by hand and against a Monte Carlo of repeated runs, the approach directions from the
//! motion, and the plugin's `evaluate` on a run.

use mtcal_instrument::Evaluation;
use mtcal_laser::{
    Approaches, Iso230_2Error, approach_directions, approach_table, evaluate, iso230_2,
    straightness,
};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// Two targets, three approaches each way (µm):
/// target 0: ↑ 1, 2, 3 (x̄ 2, s 1); ↓ −1, 0, 1 (x̄ 0, s 1); B = 2, R = max(2+2+2, 4, 4) = 6
/// target 1: ↑ 3, 3, 3 (x̄ 3, s 0); ↓ 5, 7, 6 (x̄ 6, s 1); B = −3, R = max(0+2+3, 0, 4) = 5
fn example() -> Approaches {
    Approaches {
        targets: vec![0.0, 100.0],
        up: vec![vec![1.0, 2.0, 3.0], vec![3.0, 3.0, 3.0]],
        down: vec![vec![-1.0, 0.0, 1.0], vec![5.0, 7.0, 6.0]],
    }
}

#[test]
fn the_axis_values_are_those_computed_by_hand() {
    let r = iso230_2(&example()).unwrap();
    let t = &r.targets;
    assert_eq!((t[0].mean_up, t[0].mean_down, t[0].mean), (2.0, 0.0, 1.0));
    assert_eq!((t[0].s_up, t[0].s_down, t[0].reversal), (1.0, 1.0, 2.0));
    assert_eq!((t[0].r_up, t[0].r_down, t[0].r), (4.0, 4.0, 6.0));
    assert_eq!((t[1].mean_up, t[1].mean_down, t[1].mean), (3.0, 6.0, 4.5));
    assert_eq!((t[1].s_up, t[1].s_down, t[1].reversal), (0.0, 1.0, -3.0));
    assert_eq!((t[1].r_up, t[1].r_down, t[1].r), (0.0, 4.0, 5.0));
    // B = max |B_i|, B̄ = mean B_i (signed).
    assert_eq!((r.b, r.b_mean), (3.0, -0.5));
    // R↑, R↓ unidirectional; R bidirectional includes 2s↑ + 2s↓ + |B_i| (6, not max(R↑, R↓) = 4).
    assert_eq!((r.r_up, r.r_down, r.r), (4.0, 4.0, 6.0));
    // E↑ = 3 − 2, E↓ = 6 − 0, E = max(2, 0, 3, 6) − min(2, 0, 3, 6).
    assert_eq!((r.e_up, r.e_down, r.e), (1.0, 6.0, 6.0));
    // M = 4.5 − 1.
    assert_eq!(r.m, 3.5);
    // A↑ = max(2+2, 3+0) − min(2−2, 3−0); A↓ = max(0+2, 6+2) − min(0−2, 6−2); A = 8 − (−2).
    assert_eq!((r.a_up, r.a_down, r.a), (4.0, 10.0, 10.0));
    // As metrics (µm in, SI out, reported in µm).
    let m = r.metrics(1e-6);
    let get = |n: &str| {
        m.iter()
            .find(|x| x.name == format!("{n} (ISO 230-2)"))
            .unwrap()
            .value
    };
    assert!((get("R") - 6e-6).abs() < 1e-18 && (get("B̄") + 0.5e-6).abs() < 1e-18);
    assert_eq!(m.len(), 12);
}

#[test]
fn the_uncertainties_are_those_computed_by_hand() {
    // Reading noise 0.5: σ_eff = max(s, 0.5) is s everywhere but at target 1 ↑ (s = 0 → 0.5).
    // Each mean's variance σ_eff²/3, each s's σ_eff²/(2·2).
    let r = iso230_2(&example()).unwrap();
    let u = r.uncertainty(0.5);
    let (v1, v05) = (1.0 / 3.0, 0.25 / 3.0);
    let close = |got: f64, var: f64, what: &str| {
        let want = 2.0 * var.sqrt();
        assert!((got - want).abs() < 1e-12, "{what}: {got} vs {want}");
    };
    // E = x̄↓_1 − x̄↓_0; E↑ = x̄↑_1 − x̄↑_0; E↓ = x̄↓_1 − x̄↓_0.
    close(u.e, v1 + v1, "E");
    close(u.e_up, v05 + v1, "E↑");
    close(u.e_down, v1 + v1, "E↓");
    // M = x̄_1 − x̄_0, each x̄ half of two means.
    close(u.m, 0.25 * (v05 + v1) + 0.25 * (v1 + v1), "M");
    // R = R_0 = 2 s↑_0 + 2 s↓_0 + (x̄↑_0 − x̄↓_0): each side a mean (±1) and an s (×2).
    close(u.r, 2.0 * (v1 + 4.0 * 0.25), "R");
    // R↑ = 4 s↑_0 (s↑_1 = 0); R↓ = 4 s↓_0 (the first of two equal ones).
    close(u.r_up, 16.0 * 0.25, "R↑");
    close(u.r_down, 16.0 * 0.25, "R↓");
    // A = (x̄↓_1 + 2 s↓_1) − (x̄↓_0 − 2 s↓_0).
    close(u.a, 2.0 * (v1 + 4.0 * 0.25), "A");
    // A↑ = (x̄↑_0 + 2 s↑_0) − (x̄↑_0 − 2 s↑_0) = 4 s↑_0: one sample, the mean cancels.
    close(u.a_up, 16.0 * 0.25, "A↑");
    // B = |x̄↑_1 − x̄↓_1|; B̄ = (B_0 + B_1)/2 over all four means.
    close(u.b, v05 + v1, "B");
    close(u.b_mean, 0.25 * (v1 + v1 + v05 + v1), "B̄");
    // As metrics: the uncertainty scaled with the value.
    let m = r.metrics_with_uncertainty(1e-6, &u);
    let e = m.iter().find(|x| x.name == "E (ISO 230-2)").unwrap();
    assert!((e.u95.unwrap() - u.e * 1e-6).abs() < 1e-18);
    assert!(r.metrics(1e-6).iter().all(|x| x.u95.is_none()));
}

/// One simulated bidirectional table: `cycles` approaches each way at `targets` with the
/// systematic deviation `truth(x, up)` and reading noise `sigma` (µm).
fn simulated(
    rng: &mut rand_chacha::ChaCha8Rng,
    targets: &[f64],
    cycles: usize,
    sigma: f64,
    truth: &dyn Fn(f64, bool) -> f64,
) -> Approaches {
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut draw = |x: f64, up: bool| -> Vec<f64> {
        (0..cycles)
            .map(|_| truth(x, up) + noise.sample(rng))
            .collect()
    };
    Approaches {
        targets: targets.to_vec(),
        up: targets.iter().map(|&x| draw(x, true)).collect(),
        down: targets.iter().map(|&x| draw(x, false)).collect(),
    }
}

fn std_dev(x: &[f64]) -> f64 {
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Repeated runs of one axis with known reading noise: the spread of E (and of the other values
/// that are linear in the means) over the runs is what U/2 says. With the declared noise far
/// below the real one, U comes from each run's own repeatability and matches within the Monte
/// Carlo's error; with the real noise declared, the floor max(s, σ) makes U larger by what the
/// floor adds (a few approaches scatter less than σ about half the time), never smaller.
#[test]
fn the_uncertainty_of_e_matches_the_spread_of_repeated_runs() {
    let sigma = 0.5;
    let targets: Vec<f64> = (0..11).map(|i| 60.0 * i as f64).collect();
    // A pitch error of 10 µm over the stroke with a bow, and 1.5 µm of reversal: the extreme
    // means are well apart (≥ 1 µm, five standard uncertainties of a mean).
    let truth =
        |x: f64, up: bool| 10.0 * x / 600.0 + 0.8 * (x / 150.0).sin() - if up { 0.0 } else { 1.5 };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2302);
    let runs = 4000;
    let mut values: Vec<[f64; 4]> = Vec::with_capacity(runs);
    let mut half_u_own: Vec<[f64; 4]> = Vec::with_capacity(runs);
    let mut half_u_floor: Vec<[f64; 4]> = Vec::with_capacity(runs);
    for _ in 0..runs {
        let r = iso230_2(&simulated(&mut rng, &targets, 5, sigma, &truth)).unwrap();
        values.push([r.e, r.e_up, r.m, r.b_mean]);
        let pick = |u: mtcal_laser::Iso230_2Uncertainty| {
            [u.e / 2.0, u.e_up / 2.0, u.m / 2.0, u.b_mean / 2.0]
        };
        half_u_own.push(pick(r.uncertainty(0.01 * sigma)));
        half_u_floor.push(pick(r.uncertainty(sigma)));
    }
    for (k, name) in ["E", "E↑", "M", "B̄"].iter().enumerate() {
        let column = |rows: &[[f64; 4]]| rows.iter().map(|r| r[k]).collect::<Vec<f64>>();
        let spread = std_dev(&column(&values));
        let own = rms(&column(&half_u_own)) / spread;
        let floor = rms(&column(&half_u_floor)) / spread;
        assert!(
            (0.94..=1.06).contains(&own),
            "{name}: U/2 over the spread {own}"
        );
        assert!(
            (1.0..=1.25).contains(&floor),
            "{name}: with the floor {floor}"
        );
    }
    // E's spread is that of the difference of two means of five: σ·√(2/5).
    let spread_e = std_dev(&values.iter().map(|r| r[0]).collect::<Vec<_>>());
    let want = sigma * (2.0f64 / 5.0).sqrt();
    assert!((spread_e / want - 1.0).abs() < 0.05, "{spread_e} vs {want}");
}

#[test]
fn too_few_approaches_are_an_error_naming_the_target() {
    let mut t = example();
    t.down[1].truncate(1);
    let e = iso230_2(&t).unwrap_err();
    assert!(e.to_string().contains("target 2"), "{e}");
    assert!(matches!(
        e,
        Iso230_2Error::TooFewApproaches {
            number: 2,
            up: 3,
            down: 1,
            ..
        }
    ));
}

#[test]
fn directions_come_from_the_motion() {
    let up = Some(true);
    let down = Some(false);
    // No overrun: the reversal point is recorded twice (last ↑ reading, first ↓ reading).
    assert_eq!(
        approach_directions(&[0.0, 5.0, 5.0, 0.0, 0.0, 5.0, 5.0, 0.0], 1e-9),
        [up, up, down, down, up, up, down, down]
    );
    // With overrun samples, each approached one way.
    assert_eq!(
        approach_directions(&[-0.5, 0.0, 5.0, 5.5, 5.0, 0.0, -0.5], 1e-9),
        [up, up, up, up, down, down, down]
    );
    // A run that starts with the descending pass.
    assert_eq!(
        approach_directions(&[5.0, 0.0, 0.0, 5.0], 1e-9),
        [down, down, up, up]
    );
    // Overrun points are not targets: above, approached ↑ only; below, the start (↑ once)
    // and the ends of the ↓ passes.
    let t = approach_table(
        &[
            -0.5, 0.0, 5.0, 5.5, 5.0, 0.0, -0.5, 0.0, 5.0, 5.5, 5.0, 0.0, -0.5,
        ],
        &[
            9.0, 1.0, 2.0, 9.0, 3.0, 4.0, 9.0, 5.0, 6.0, 9.0, 7.0, 8.0, 9.0,
        ],
        1e-9,
    );
    assert_eq!(t.targets, [0.0, 5.0]);
    assert_eq!(t.up, [vec![1.0, 5.0], vec![2.0, 6.0]]);
    assert_eq!(t.down, [vec![4.0, 8.0], vec![3.0, 7.0]]);
}

/// The example as a laser run along X of a nominal `ZFYX`, in ISO 230-2 cycle order, or with
/// every cycle's passes reversed in time (↓ first).
fn run(reversed: bool) -> (Vec<f64>, Vec<f64>) {
    let ex = example();
    let (mut q, mut d) = (Vec::new(), Vec::new());
    for j in 0..3 {
        let mut pass_up: Vec<(f64, f64)> = (0..2).map(|i| (ex.targets[i], ex.up[i][j])).collect();
        let mut pass_down: Vec<(f64, f64)> = (0..2)
            .rev()
            .map(|i| (ex.targets[i], ex.down[i][j]))
            .collect();
        if reversed {
            // ↓ pass first: come down onto the targets from above, then go up.
            std::mem::swap(&mut pass_up, &mut pass_down);
        }
        for (x, v) in pass_up.into_iter().chain(pass_down) {
            q.extend([x * 1e-3, 0.0, -0.1]);
            d.push(v * 1e-6);
        }
    }
    (q, d)
}

#[test]
fn the_plugin_evaluates_a_linear_run_by_its_motion() {
    let machine = mtcal_machine::load_machine("ZFYX", mtcal_machine::topology::Reading::default())
        .unwrap()
        .machine;
    let want = iso230_2(&example()).unwrap().metrics(1e-6);
    for reversed in [false, true] {
        let (q, d) = run(reversed);
        let t: Vec<f64> = (0..d.len()).map(|k| k as f64).collect();
        let setup: toml::Table = toml::from_str("mode = \"linear\"\ndirection = \"X\"").unwrap();
        let loaded_0 = mtcal_laser::load_setup(
            &setup,
            &mtcal_instrument::SetupContext { machine: &machine },
        )
        .unwrap();
        let got = evaluate(&Evaluation {
            machine: &machine,
            setup: &*loaded_0,
            q: &q,
            readings: &d,
            t: &t,
            labels: &[],
        });
        assert_eq!(got.len(), want.len());
        // Along X, with the default reading noise 0.5 µm in the budget.
        let u = iso230_2(&example()).unwrap().uncertainty(0.5);
        let e = got.iter().find(|m| m.name == "E (ISO 230-2)").unwrap();
        assert_eq!(e.subject.as_deref(), Some("X"));
        assert!((e.u95.unwrap() - u.e * 1e-6).abs() < 1e-18, "{e:?}");
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(g.name, w.name);
            assert!(
                (g.value - w.value).abs() < 1e-15,
                "{}: {} vs {}",
                g.name,
                g.value,
                w.value
            );
        }
        // A beam pointing the other way reads the opposite deviations; evaluated along the
        // axis, the values are the same.
        let minus: toml::Table = toml::from_str("mode = \"linear\"\ndirection = \"-X\"").unwrap();
        let negated: Vec<f64> = d.iter().map(|v| -v).collect();
        let loaded_1 = mtcal_laser::load_setup(
            &minus,
            &mtcal_instrument::SetupContext { machine: &machine },
        )
        .unwrap();
        let got = evaluate(&Evaluation {
            machine: &machine,
            setup: &*loaded_1,
            q: &q,
            readings: &negated,
            t: &t,
            labels: &[],
        });
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert!(
                (g.value - w.value).abs() < 1e-15,
                "-X {}: {} vs {}",
                g.name,
                g.value,
                w.value
            );
        }
        // A straightness run has no ISO 230-2 values (its own straightness value instead).
        let st: toml::Table =
            toml::from_str("mode = \"straightness\"\ndirection = \"X\"\nsense = \"Y\"").unwrap();
        let loaded_2 =
            mtcal_laser::load_setup(&st, &mtcal_instrument::SetupContext { machine: &machine })
                .unwrap();
        let none = evaluate(&Evaluation {
            machine: &machine,
            setup: &*loaded_2,
            q: &q,
            readings: &d,
            t: &t,
            labels: &[],
        });
        assert!(
            none.iter().all(|m| !m.name.contains("ISO 230-2")),
            "{none:?}"
        );
    }
}

#[test]
fn straightness_is_the_range_about_the_least_squares_line() {
    // k u² at u = −2…2 about its least-squares line (slope 0, mean 2k): residuals 2k, −k, −2k,
    // −k, 2k: range 4k, whatever line is added.
    let k = 0.7e-6;
    let travel: Vec<f64> = (0..5).map(|i| 0.1 * i as f64).collect();
    let d: Vec<f64> = travel
        .iter()
        .map(|s| {
            let u = (s - 0.2) / 0.1;
            k * u * u + 3e-6 - 20e-6 * s
        })
        .collect();
    let got = straightness(&travel, &d).unwrap();
    assert!((got - 4.0 * k).abs() < 1e-15, "{got}");
    assert!(straightness(&travel[..2], &d[..2]).is_none());
    // Through the plugin: a straightness run along X of a ZFYX.
    let machine = mtcal_machine::load_machine("ZFYX", mtcal_machine::topology::Reading::default())
        .unwrap()
        .machine;
    let q: Vec<f64> = travel.iter().flat_map(|&x| [x, 0.0, -0.1]).collect();
    let setup: toml::Table =
        toml::from_str("mode = \"straightness\"\ndirection = \"X\"\nsense = \"Y\"").unwrap();
    let t: Vec<f64> = (0..5).map(f64::from).collect();
    let loaded_3 = mtcal_laser::load_setup(
        &setup,
        &mtcal_instrument::SetupContext { machine: &machine },
    )
    .unwrap();
    let m = evaluate(&Evaluation {
        machine: &machine,
        setup: &*loaded_3,
        q: &q,
        readings: &d,
        t: &t,
        labels: &[],
    });
    assert_eq!(m.len(), 1);
    assert_eq!(m[0].name, "straightness deviation (ISO 230-1)");
    assert!((m[0].value - 4.0 * k).abs() < 1e-15);
}
