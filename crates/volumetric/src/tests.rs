//! Unit tests on visits built in memory: the cycles found, the noise estimate against the
//! noise put in, the time bases on a known drift, the uncertainty of a deformation, the
//! verdict's three outcomes.

use super::*;
use crate::bootstrap::Normals;

/// A synthetic test: `n` points on a 3 × 3 × … grid (one set-up each), `cycles` cycles of
/// `dwell_s` between visits, `pause_s` between cycles, the order reversed every other cycle
/// when `reverse`; the reading of point j at time t is `−field(j, t)` plus AR(1) noise of σ,
/// φ along the point's visits.
struct Synthetic {
    n: usize,
    cycles: usize,
    dwell_s: f64,
    pause_s: f64,
    reverse: bool,
    sigma_um: f64,
    phi: f64,
    seed: u64,
}

fn position(j: usize) -> [f64; 3] {
    [
        100.0 * (j % 3) as f64,
        100.0 * ((j / 3) % 3) as f64,
        100.0 * (j / 9) as f64,
    ]
}

impl Synthetic {
    fn build(&self, field: &dyn Fn(usize, f64) -> [f64; 3]) -> Visits {
        let mut g = Normals::new(self.seed);
        let mut noise = vec![[0.0; 3]; self.n];
        let mut points: Vec<Point> = (0..self.n)
            .map(|j| Point {
                name: format!("b{j}"),
                setup: format!("b{j}"),
                rotary_deg: Vec::new(),
                position_mm: position(j),
                visits: Vec::new(),
            })
            .collect();
        let mut t = 0.0;
        for c in 0..self.cycles {
            let order: Vec<usize> = match self.reverse && c % 2 == 1 {
                true => (0..self.n).rev().collect(),
                false => (0..self.n).collect(),
            };
            for j in order {
                let first = points[j].visits.is_empty();
                let innovation = (1.0 - self.phi * self.phi).sqrt();
                noise[j] = [0, 1, 2].map(|i| match first {
                    true => self.sigma_um * g.next(),
                    false => self.phi * noise[j][i] + innovation * self.sigma_um * g.next(),
                });
                let d = field(j, t);
                points[j].visits.push(Visit {
                    t_s: t,
                    reading_um: [0, 1, 2].map(|i| -d[i] + noise[j][i]),
                    run: format!("b{j}"),
                    row: c,
                });
                t += self.dwell_s;
            }
            t += self.pause_s;
        }
        Visits::new("in memory", points).unwrap()
    }
}

fn standard() -> Synthetic {
    Synthetic {
        n: 15,
        cycles: 12,
        dwell_s: 15.0,
        pause_s: 600.0,
        reverse: false,
        sigma_um: 0.3,
        phi: 0.0,
        seed: 1,
    }
}

#[test]
fn cycles_are_found_in_any_order_and_a_missing_visit_is_named() {
    let s = Synthetic {
        reverse: true,
        ..standard()
    };
    let mut visits = s.build(&|_, _| [0.0; 3]);
    // b7 misses its visit in the fourth cycle.
    visits.points[7].visits.remove(3);
    let cycles = cycles::cut(&visits);
    assert_eq!(cycles.len(), 12);
    assert_eq!(cycles.complete_count(), 11);
    assert_eq!(
        cycles.incomplete,
        vec![IncompleteCycle {
            cycle: 4,
            missing: vec!["b7".into()]
        }]
    );
    assert!(cycles.phases_between);
    // The reversed cycles start with the point the last one ended on: a pause cuts them.
    assert_eq!(cycles.cut.by_pause + cycles.cut.by_return, 11);
    let e = evaluate(&visits, &Options::default()).unwrap();
    assert!(e.notes.iter().any(|n| n.contains("cycle 4 misses b7")));
}

#[test]
fn the_noise_estimate_finds_the_noise_put_in_under_a_changing_field() {
    // A field that grows uniformly, tilts linearly with position and drifts within the cycle.
    let field = |j: usize, t: f64| {
        let p = position(j);
        let h = t / 3600.0;
        [
            5.0 * h + 0.01 * h * p[2],
            -3.0 * h * h,
            -40.0 * (1.0 - (-h).exp()) + 0.02 * h * p[0],
        ]
    };
    for (phi, seed) in [(0.0, 3), (0.6, 4)] {
        let s = Synthetic {
            cycles: 40,
            phi,
            seed,
            ..standard()
        };
        let visits = s.build(&field);
        let cycles = cycles::cut(&visits);
        let noise = noise::estimate(&visits, &cycles).unwrap();
        for i in 0..3 {
            let ratio = noise.sigma_um[i] / s.sigma_um;
            assert!(
                (0.85..1.15).contains(&ratio),
                "φ {phi}: σ {:?}",
                noise.sigma_um
            );
        }
        assert!(
            (noise.phi - phi).abs() < 0.12,
            "φ {phi}: found {}",
            noise.phi
        );
    }
}

#[test]
fn a_deformation_s_uncertainty_follows_the_ar1_noise() {
    let s = Synthetic {
        phi: 0.5,
        seed: 5,
        ..standard()
    };
    let visits = s.build(&|_, _| [0.0; 3]);
    let e = evaluate(&visits, &Options::default()).unwrap();
    let (sigma, phi) = (e.noise.sigma_um, e.noise.phi);
    for v in &e.series[0].values {
        let lag = v.cycle as i32;
        for (u, s) in v.u95_um.iter().zip(sigma) {
            // d = −(r − r₀): var = 2σ²(1 − φ^lag); the first visit is 0 exactly.
            let want = K95 * (2.0 * s * s * (1.0 - phi.powi(lag))).sqrt();
            assert!((u - want).abs() < 1e-9, "{v:?}");
        }
    }
    assert_eq!(e.series[0].values[0].u95_um, [0.0; 3]);
}

#[test]
fn interpolating_follows_a_drift_that_the_cycle_s_own_visits_spread() {
    // A uniform growth along −Z with a time constant of an hour, no noise to speak of: the
    // field is the same everywhere, so any spread comes from the time base.
    let field = |_: usize, t: f64| [0.0, 0.0, -40.0 * (1.0 - (-t / 3600.0).exp())];
    let contiguous = Synthetic {
        pause_s: 30.0,
        sigma_um: 1e-6,
        ..standard()
    };
    let visits = contiguous.build(&field);
    let e = evaluate(&visits, &Options::default()).unwrap();
    assert_eq!(e.time_base.method, TimeBase::Interpolated);
    assert!(!e.cycles.phases_between);
    let cycle = Options {
        time_base: TimeBase::Cycle,
        ..Options::default()
    };
    let held = evaluate(&visits, &cycle).unwrap();
    let worst = |e: &Evaluation| {
        e.instants
            .iter()
            .map(|i| i.axes[2].range_um)
            .fold(0.0, f64::max)
    };
    // Interpolated: the curvature between visits (and beyond them at the ends); the cycle's
    // own visits: the drift's change of rate over the points' times in the cycle.
    let (a, b) = (worst(&e), worst(&held));
    assert!(a < 0.2 && b > 4.0 * a, "interpolated {a}, held {b}");
    // The mean follows the field between the first instant and each one.
    for inst in &e.instants {
        let want = field(0, inst.t_s)[2] - field(0, e.instants[0].t_s)[2];
        assert!((inst.axes[2].mean_um - want).abs() < 0.05, "{inst:?}");
    }
}

#[test]
fn the_verdict_has_three_outcomes() {
    // A uniform growth along −Z of 50 µm, plus a difference between points along Y growing
    // with it: 0, 20 % or 40 % of it across the points, with noise of σ 0.3 µm; and a
    // difference near the tolerance with much noise, which cannot be decided.
    let cases = [
        (0.0, 0.3, Verdict::Uniform),
        (0.4, 0.3, Verdict::NotUniform),
        (0.2, 3.0, Verdict::CannotDecide),
    ];
    for (share, sigma, want) in cases {
        let field = move |j: usize, t: f64| {
            let grow = 50.0 * (1.0 - (-t / 3600.0).exp());
            let across = share * grow * (position(j)[0] / 200.0);
            [0.0, across, -grow]
        };
        let s = Synthetic {
            sigma_um: sigma,
            seed: 6,
            ..standard()
        };
        let e = evaluate(&s.build(&field), &Options::default()).unwrap();
        let h = &e.homogeneity;
        assert_eq!(h.verdict, want, "{share} {sigma}: {}", h.sentence);
        assert_eq!(h.instant, 11);
        assert!(h.sentence.starts_with(match want {
            Verdict::Uniform => "Uniform.",
            Verdict::NotUniform => "Not uniform.",
            Verdict::CannotDecide => "Cannot decide.",
        }));
        assert!(
            e.to_json()
                .contains(&format!("\"overall\": \"{}\"", want.key()))
        );
    }
}

#[test]
fn bad_options_and_too_few_cycles_are_refused() {
    let visits = standard().build(&|_, _| [0.0; 3]);
    let bad = Options {
        tolerance_share: 0.0,
        ..Options::default()
    };
    let e = evaluate(&visits, &bad).unwrap_err().to_string();
    assert!(e.contains("--tolerance-share"), "{e}");
    let far = Options {
        phases_h: vec![100.0],
        ..Options::default()
    };
    let e = evaluate(&visits, &far).unwrap_err().to_string();
    assert!(e.contains("--phase 100 h"), "{e}");
    let two = Synthetic {
        cycles: 2,
        ..standard()
    };
    let e = evaluate(&two.build(&|_, _| [0.0; 3]), &Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("2 complete cycles"), "{e}");
}
