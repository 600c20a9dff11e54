//! The effect families on a small synthetic session: what each proposes, how plant tables are
//! read (and rejected, with the key and what was expected), and every feature's derivative by
//! its shape parameter against central differences.

use mtcal_effects::view::{AxisView, RunView, SessionView, SetupView};
use mtcal_effects::{Candidate, PreparedEffects, SampleEffects, configure, plant};
use mtcal_instrument::{Channel, Nuisance, Unit};
use std::sync::Arc;

fn channel(name: &str) -> Channel {
    Channel {
        name: name.into(),
        unit: Unit::Um,
        sigma: 0.5e-6,
    }
}

/// Two axes (X linear, C rotary), an R-test-like set-up reading the pose and a sensor set-up
/// with one channel on its own; two runs with spindle speed and a temperature.
fn view() -> Arc<SessionView> {
    let n = 400;
    let run = |name: &str, setup: usize, t0: f64| {
        let t: Vec<f64> = (0..n).map(|i| t0 + i as f64).collect();
        let mut q = Vec::with_capacity(2 * n);
        for i in 0..n {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            q.push(0.1 * a.cos()); // X goes back and forth: reversals
            q.push(a); // C turns once
        }
        let context = vec![
            (
                "S".into(),
                (0..n).map(|i| if i > 100 { 3000.0 } else { 0.0 }).collect(),
            ),
            (
                "T_bed".into(),
                (0..n).map(|i| 20.0 + (i as f64 / 70.0).sin()).collect(),
            ),
        ];
        RunView::from_vectors(name, setup, true, &t, &q, &context)
    };
    Arc::new(SessionView::new(
        vec![
            AxisView {
                letter: 'X',
                rotary: false,
                stroke: (-0.3, 0.3),
            },
            AxisView {
                letter: 'C',
                rotary: true,
                stroke: (-std::f64::consts::PI, std::f64::consts::PI),
            },
        ],
        vec![
            SetupView {
                name: "head".into(),
                instrument: "rtest".into(),
                channels: vec![channel("dx"), channel("dy")],
                reads_pose: vec![true, true],
                nuisance: vec![
                    Nuisance {
                        name: "ball_x".into(),
                        unit: Unit::Um,
                        free: true,
                        prior_sigma: None,
                    },
                    Nuisance {
                        name: "tool_length".into(),
                        unit: Unit::Um,
                        free: false,
                        prior_sigma: None,
                    },
                ],
                field_like: vec![false; 2],
                at_standstill: false,
            },
            SetupView {
                name: "sensors".into(),
                instrument: "displacement".into(),
                channels: vec![channel("d_s1")],
                reads_pose: vec![false],
                nuisance: vec![],
                field_like: vec![],
                at_standstill: false,
            },
        ],
        vec![run("a", 0, 0.0), run("b", 1, 500.0)],
        vec![],
    ))
}

fn table(text: &str) -> toml::Table {
    toml::from_str(text).unwrap()
}

#[test]
fn families_propose_what_the_session_can_show() {
    let v = view();
    let all = mtcal_effects::candidates(&v);
    let count = |class: &str| all.iter().filter(|c| c.class() == class).count();
    // Thermal effects on the linear axis and the sensor on its own, in time and driven by S.
    assert!(count("thermal-drift") > 0);
    assert!(count("temperature-coupling") > 0);
    assert!(all.iter().any(|c| c.label() == "thermal-drift d_s1 (S^2)"));
    // X reverses; C turns one way only: no reversal of C.
    assert!(all.iter().any(|c| c.label() == "reversal X (X)"));
    assert!(!all.iter().any(|c| c.label() == "reversal C (C)"));
    // One linear axis: no pair for a cross-coupling. No model here: no model changes.
    assert_eq!(count("cross-coupling"), 0);
    assert_eq!(count("omitted-parameter"), 0);
    // The scale of the pose-reading channels, not of the sensor on its own.
    assert!(all.iter().any(|c| c.label() == "instrument-scale dx"));
    assert!(!all.iter().any(|c| c.label() == "instrument-scale d_s1"));
    for c in &all {
        if let Candidate::Effect(e) = c {
            assert!(!e.params().is_empty(), "{}", c.label());
        }
    }
}

#[test]
fn plant_tables_are_read_and_bad_ones_named() {
    let v = view();
    let (e, values) = plant(
        &table("effect = \"thermal-drift\"\naxis = \"X\"\namplitude_um = 2.0\ntau_s = 300.0"),
        &v,
    )
    .unwrap();
    assert_eq!(e.info().label, "thermal-drift X (t)");
    assert_eq!(values, vec![2e-6, 300.0]);
    let cases = [
        ("axis = \"X\"\namplitude_um = 1.0", "missing `effect"),
        ("effect = \"warp\"\naxis = \"X\"", "unknown effect `warp`"),
        (
            "effect = \"thermal-drift\"\naxis = \"Q\"\namplitude_um = 1.0\ntau_s = 1.0",
            "the machine has axes XC",
        ),
        (
            "effect = \"thermal-drift\"\naxis = \"X\"\namplitude_um = 1.0",
            "takes rate_um_per_h",
        ),
        (
            "effect = \"thermal-drift\"\naxis = \"X\"\ntau_s = 300.0",
            "missing `amplitude_um`",
        ),
        (
            "effect = \"thermal-drift\"\naxis = \"X\"\namplitude_um = 1.0\ntau_s = 300.0\nspeed = 2",
            "unknown key `speed`",
        ),
        (
            "effect = \"thermal-drift\"\naxis = \"X\"\ndriver = \"T_bed\"\ngain_um_per_K = 1.0",
            "temperature-coupling",
        ),
        (
            "effect = \"temperature-coupling\"\nchannel = \"d_s1\"\ngain_um_per_K = 1.0",
            "needs `driver = \"T_<column>\"`",
        ),
        (
            "effect = \"reversal\"\nchannel = \"d_s1\"\nbacklash_um = 1.0",
            "acts on an axis",
        ),
        (
            "effect = \"cyclic\"\naxis = \"X\"\nsin_um = 1.0\ncos_um = 1.0\npitch_mm = \"20\"",
            "positive number",
        ),
        (
            "effect = \"stick-slip\"\naxis = \"X\"\nheight_um = 1.0\ndecay_mm = 500.0",
            "outside",
        ),
        (
            "effect = \"cross-coupling\"\naxis = \"X\"\ndriver = \"X*X\"\ncorner_um = 1.0",
            "two different axes",
        ),
        (
            "effect = \"setup-drift\"\nsetup = \"head\"\nnuisance = \"ball_q\"\nrate_um_per_h = 1.0",
            "has no parameter `ball_q`",
        ),
        (
            "effect = \"instrument-scale\"\nchannel = \"nope\"\ngain_ppm = 1.0",
            "no instrument of the plan has a channel `nope`",
        ),
        ("effect = \"omitted-parameter\"", "truth parameter file"),
    ];
    for (text, expected) in cases {
        let err = plant(&table(text), &v).map(|_| ()).unwrap_err();
        assert!(err.message.contains(expected), "{text}: {err}");
    }
}

#[test]
fn plant_errors_name_the_key_at_fault() {
    let v = view();
    let key = |text: &str| plant(&table(text), &v).map(|_| ()).unwrap_err().key;
    let drift = "effect = \"thermal-drift\"\naxis = \"X\"\ndriver = \"t\"";
    assert_eq!(
        key(&format!("{drift}\nrate_um_per_h = \"x\"")),
        Some("rate_um_per_h".into())
    );
    assert_eq!(key(&format!("{drift}\nbogus = 1")), Some("bogus".into()));
    assert_eq!(key("effect = \"no-such-family\""), Some("effect".into()));
    assert_eq!(
        key("effect = \"reversal\"\naxis = \"Z\""),
        Some("axis".into())
    );
    // No target at all is the table's problem, not one key's.
    assert_eq!(key("effect = \"reversal\"\nbacklash_um = 1.0"), None);
}

#[test]
fn configured_effects_take_their_values_as_optional_starts() {
    let v = view();
    let (e, values) = configure(
        &table("effect = \"temperature-coupling\"\nchannel = \"d_s1\"\ndriver = \"T_bed\""),
        &v,
    )
    .unwrap();
    assert_eq!(e.info().driver.as_deref(), Some("T_bed"));
    assert_eq!(values, vec![0.0]);
}

/// Every feature's derivative by each of its shape parameters equals central differences of
/// the effect's value, at every sample of both runs.
#[test]
fn shape_derivatives_equal_differences() {
    let v = view();
    let plants = [
        "effect = \"thermal-drift\"\naxis = \"X\"\namplitude_um = 2.0\ntau_s = 150.0",
        "effect = \"thermal-drift\"\nchannel = \"d_s1\"\ndriver = \"S\"\ngain_um_per_krpm = 1.0\ntau_s = 90.0",
        "effect = \"thermal-drift\"\naxis = \"X\"\ndriver = \"S^2\"\ngain_um_per_krpm2 = 1.0\ntau_s = 90.0",
        "effect = \"temperature-coupling\"\naxis = \"X\"\ndriver = \"T_bed\"\ngain_um_per_K = 1.0\ntau_s = 40.0",
        "effect = \"cyclic\"\naxis = \"X\"\nsin_um = 1.0\ncos_um = -0.5\npitch_mm = 16.0",
        "effect = \"cyclic\"\naxis = \"C\"\nsin_urad = 1.0\ncos_urad = 0.3\nperiod_deg = 40.0",
        "effect = \"stick-slip\"\naxis = \"X\"\nheight_um = 1.0\ndecay_mm = 3.0",
        "effect = \"reversal-spike\"\naxis = \"X\"\nheight_um = 1.0\ntau_s = 7.0",
        "effect = \"local-error\"\naxis = \"X\"\namplitude_um = 1.5\ncentre_mm = 21.0\nhalf_width_mm = 37.0",
        "effect = \"spindle-growth\"\namplitude_um = 3.0\ntau_s = 120.0",
        "effect = \"spindle-growth\"\ndriver = \"S\"\ngain_um_per_krpm = 1.0\ntau_s = 60.0",
    ];
    for text in plants {
        let (e, values) = plant(&table(text), &v).unwrap();
        let shapes: Vec<usize> = e
            .params()
            .iter()
            .enumerate()
            .filter(|(_, p)| p.kind == mtcal_effects::ParamKind::Shape)
            .map(|(j, _)| j)
            .collect();
        assert!(!shapes.is_empty(), "{text}");
        let effects = vec![e];
        let mut compared = 0;
        for shape in shapes {
            let h = 1e-6 * values[shape].abs();
            let at = |x: &[f64]| PreparedEffects::new(&effects, &v, x);
            let (base, plus, minus) = {
                let mut p = values.clone();
                p[shape] += h;
                let mut m = values.clone();
                m[shape] -= h;
                (at(&values), at(&p), at(&m))
            };
            let mut out: SampleEffects = base.scratch(2, 2, 2);
            let mut op = plus.scratch(2, 2, 2);
            let mut om = minus.scratch(2, 2, 2);
            for r in 0..2 {
                let setup = v.runs[r].setup;
                for i in (0..v.runs[r].len()).step_by(7) {
                    base.sample(r, setup, i, &values, &mut out);
                    let mut p = values.clone();
                    p[shape] += h;
                    plus.sample(r, setup, i, &p, &mut op);
                    p[shape] -= 2.0 * h;
                    minus.sample(r, setup, i, &p, &mut om);
                    let blocks = [
                        (&op.dq, &om.dq, &out.jq, out.n_axes),
                        (&op.dn, &om.dn, &out.jn, out.n_nuis),
                        (&op.dr, &om.dr, &out.jr, out.n_ch),
                    ];
                    for (p, m, jac, width) in blocks {
                        for k in 0..p.len() {
                            let fd = (p[k] - m[k]) / (2.0 * h);
                            let an = jac[shape * width + k];
                            assert!(
                                (an - fd).abs() <= 1e-6 * fd.abs().max(1e-9),
                                "{text}: shape {shape} run {r} sample {i} slot {k}: {an:e} vs {fd:e}"
                            );
                            compared += usize::from(fd.abs() > 1e-9);
                        }
                    }
                }
            }
        }
        assert!(
            compared > 10,
            "{text}: the shapes change nothing ({compared})"
        );
    }
}
