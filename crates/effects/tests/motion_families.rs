//! The families of an axis' motion and shape (`reversal` with its unknown start and along the
//! stroke, `lateral-play`, `reversal-spike`, `stick-slip`'s start, `local-error`) and
//! `spindle-growth` on a small hand-made session: their features' values sample by sample, what
//! they propose and when, and their plant tables.

use mtcal_effects::view::{AxisView, RunView, SessionView, SetupView};
use mtcal_effects::{Candidate, Effect, ParamKind, PreparedEffects, Target, plant};
use mtcal_instrument::{Channel, Nuisance, Unit};
use std::sync::Arc;

fn channel(name: &str) -> Channel {
    Channel {
        name: name.into(),
        unit: Unit::Um,
        sigma: 0.5e-6,
    }
}

fn nuisance(name: &str) -> Nuisance {
    Nuisance {
        name: name.into(),
        unit: Unit::Um,
        free: true,
        prior_sigma: None,
    }
}

/// Run "a" of the session (X, Y, Z, A, C per sample): X stands, moves up, reverses, stands;
/// Y moves up only; Z stands; A and C turn back.
const X_A: [f64; 11] = [
    0.0, 0.0, 0.01, 0.02, 0.03, 0.02, 0.01, 0.0, -0.01, -0.01, -0.01,
];
const RUN_B: usize = 81;

/// Five axes (X Y Z linear, A rotary of limited stroke, C endless), an R-test-like set-up and a
/// ball-bar-like one, each with a `tool_length`; two fitted runs a second apart per sample:
/// "a" (11 samples, R-test) and "b" (81 samples from t = 100 s, ball bar: X and Y on a circle,
/// the spindle speed stepping when `speed`).
fn view(pose: bool, tool_length: bool, speed: bool) -> Arc<SessionView> {
    view_read(pose, tool_length, speed, false)
}

/// [`view`] with both set-ups reading with the axes standing (`at_standstill`) or on the fly.
fn view_read(pose: bool, tool_length: bool, speed: bool, at_standstill: bool) -> Arc<SessionView> {
    let mut qa = Vec::new();
    for (i, x) in X_A.iter().enumerate() {
        let back = |k: usize, v: f64| {
            if k <= 2 {
                v * k as f64
            } else {
                v * (4.0 - k as f64)
            }
        };
        qa.extend([*x, 0.01 * i as f64, -0.2, back(i, 0.1), back(i, 0.2)]);
    }
    let ta: Vec<f64> = (0..X_A.len()).map(|i| i as f64).collect();
    let mut qb = Vec::new();
    for k in 0..RUN_B {
        let phi = std::f64::consts::TAU * k as f64 / (RUN_B - 1) as f64;
        qb.extend([0.1 * phi.sin(), 0.1 * phi.cos(), -0.2, 0.0, 0.0]);
    }
    let tb: Vec<f64> = (0..RUN_B).map(|i| 100.0 + i as f64).collect();
    let context = if speed {
        vec![(
            "S".to_string(),
            (0..RUN_B)
                .map(|k| if k > 20 { 6000.0 } else { 0.0 })
                .collect(),
        )]
    } else {
        Vec::new()
    };
    let tool = |mut n: Vec<Nuisance>| {
        if tool_length {
            n.push(nuisance("tool_length"));
        }
        n
    };
    let linear = |letter: char, stroke: (f64, f64)| AxisView {
        letter,
        rotary: false,
        stroke,
    };
    Arc::new(SessionView::new(
        vec![
            linear('X', (-0.5, 0.5)),
            linear('Y', (-0.5, 0.5)),
            linear('Z', (-0.4, 0.0)),
            AxisView {
                letter: 'A',
                rotary: true,
                stroke: (-2.0, 2.0),
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
                channels: vec![channel("dx"), channel("dy"), channel("dz")],
                reads_pose: vec![pose; 3],
                nuisance: tool(vec![nuisance("ball_x")]),
                field_like: vec![false; 1 + usize::from(tool_length)],
                at_standstill,
            },
            SetupView {
                name: "bar".into(),
                instrument: "ballbar".into(),
                channels: vec![channel("dr")],
                reads_pose: vec![pose],
                nuisance: tool(vec![nuisance("length")]),
                field_like: vec![false; 1 + usize::from(tool_length)],
                at_standstill,
            },
        ],
        vec![
            RunView::from_vectors("a", 0, true, &ta, &qa, &[]),
            RunView::from_vectors("b", 1, true, &tb, &qb, &context),
        ],
        vec![],
    ))
}

fn table(text: &str) -> toml::Table {
    toml::from_str(text).unwrap()
}

/// The planted effect's changes of the axes (µm or µrad) and the set-up's parameters (µm)
/// at every sample of run `r`: `(dq, dn)` per sample.
fn planted(v: &Arc<SessionView>, text: &str, r: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    let (e, values) = plant(&table(text), v).unwrap_or_else(|e| panic!("{text}: {e}"));
    let prepared = PreparedEffects::new(&[e], v, &values);
    let mut out = prepared.scratch(5, 2, 3);
    (0..v.runs[r].len())
        .map(|i| {
            prepared.sample(r, v.runs[r].setup, i, &values, &mut out);
            (
                out.dq.iter().map(|x| x * 1e6).collect(),
                out.dn.iter().map(|x| x * 1e6).collect(),
            )
        })
        .collect()
}

/// Axis `a`'s change (µm / µrad) at every sample of run "a".
fn on_axis(v: &Arc<SessionView>, text: &str, a: usize) -> Vec<f64> {
    planted(v, text, 0)
        .into_iter()
        .map(|(dq, _)| dq[a])
        .collect()
}

fn assert_close(got: &[f64], expected: &[f64], what: &str) {
    assert_eq!(got.len(), expected.len(), "{what}");
    for (i, (g, e)) in got.iter().zip(expected).enumerate() {
        assert!(
            (g - e).abs() < 1e-9,
            "{what}: sample {i}: {g} vs {e}\n{got:?}"
        );
    }
}

#[test]
fn reversal_is_unknown_before_a_runs_first_motion_and_changes_along_the_stroke() {
    let v = view(true, true, false);
    // X stands for two samples (unknown: 0, the mean of ±B/2), moves up (lags B/2 = 1 µm
    // behind: −1), reverses at sample 5 and stays on the down side while it stands.
    let plain = on_axis(
        &v,
        "effect = \"reversal\"\naxis = \"X\"\nbacklash_um = 2.0",
        0,
    );
    let dirs = [0.0, 0.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0];
    let expected: Vec<f64> = dirs.iter().map(|d| -0.5 * d * 2.0).collect();
    assert_close(&plain, &expected, "reversal X");
    // Z never moves: unknown all through the run.
    let z = on_axis(
        &v,
        "effect = \"reversal\"\naxis = \"Z\"\nbacklash_um = 2.0",
        2,
    );
    assert_close(&z, &[0.0; 11], "reversal Z");
    // Along the stroke: B + ΔB·û, û = 2X/1 m over X's stroke of ±0.5 m.
    let along = on_axis(
        &v,
        "effect = \"reversal\"\naxis = \"X\"\nbacklash_um = 2.0\nbacklash_change_um = 1.0",
        0,
    );
    let expected: Vec<f64> = dirs
        .iter()
        .zip(X_A)
        .map(|(d, x)| -0.5 * d * (2.0 + 1.0 * 2.0 * x))
        .collect();
    assert_close(&along, &expected, "reversal X (along X)");
    // A rotary axis' backlash, in µrad on the axis itself.
    let a = on_axis(
        &v,
        "effect = \"reversal\"\naxis = \"A\"\nbacklash_urad = 10.0",
        3,
    );
    assert_close(
        &a,
        &[0.0, -5.0, -5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0],
        "reversal A",
    );
}

#[test]
fn lateral_play_steps_the_tool_across_the_reversing_axis() {
    let v = view(true, true, false);
    let text = "effect = \"lateral-play\"\naxis = \"X\"\nacross = \"Y\"\nplay_um = 3.0";
    let (e, values) = plant(&table(text), &v).unwrap();
    let info = e.info();
    assert_eq!(info.label, "lateral-play X (in Y)");
    assert_eq!(info.class, "lateral-play");
    assert_eq!(
        (info.axis, info.component.as_deref(), info.driver.as_deref()),
        (Some('X'), Some("EYX"), Some("X"))
    );
    assert_eq!(values, vec![3e-6]);
    assert_eq!(e.terms()[0].target, Target::Axis(1));
    let samples = planted(&v, text, 0);
    let dirs = [0.0, 0.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0, -1.0, -1.0];
    let y: Vec<f64> = samples.iter().map(|(dq, _)| dq[1]).collect();
    let expected: Vec<f64> = dirs.iter().map(|d| -0.5 * d * 3.0).collect();
    assert_close(&y, &expected, "lateral-play X (in Y)");
    assert!(samples.iter().all(|(dq, _)| dq[0] == 0.0 && dq[2] == 0.0));
}

#[test]
fn transients_follow_reversals_within_a_run_only() {
    let v = view(true, true, false);
    // Reversal spike, τ = 2 s: X first moves at sample 2 (from where it stood at t = 1 s): no
    // spike (whether it turned there is unknown); it reverses at sample 5, leaving the
    // turning point (sample 4, t = 4 s) downwards: a full spike, decaying in time while the
    // axis moves on and stands.
    let spike = on_axis(
        &v,
        "effect = \"reversal-spike\"\naxis = \"X\"\nheight_um = 1.0\ntau_s = 2.0",
        0,
    );
    let e = |dt: f64| (-dt / 2.0).exp();
    let expected = [
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        -e(1.0),
        -e(2.0),
        -e(3.0),
        -e(4.0),
        -e(5.0),
        -e(6.0),
    ];
    assert_close(&spike, &expected, "reversal-spike X");
    // Stick-slip decays with travel (λ = 10 mm) from the first motion (a run whose approach is
    // unknown starts its transient there) and from each reversal; it stops decaying while the
    // axis stands.
    let stick = on_axis(
        &v,
        "effect = \"stick-slip\"\naxis = \"X\"\nheight_um = 1.0\ndecay_mm = 10.0",
        0,
    );
    let e = |d: f64| (-d / 0.01).exp();
    let expected = [
        0.0,
        0.0,
        e(0.01),
        e(0.02),
        e(0.03),
        -e(0.01),
        -e(0.02),
        -e(0.03),
        -e(0.04),
        -e(0.04),
        -e(0.04),
    ];
    assert_close(&stick, &expected, "stick-slip X");
}

#[test]
fn a_local_error_is_a_compact_bump_of_one_axis_on_another() {
    let v = view(true, true, false);
    let text = "effect = \"local-error\"\naxis = \"X\"\nacross = \"Y\"\namplitude_um = 2.0\ncentre_mm = 0.0\nhalf_width_mm = 40.0";
    let (e, values) = plant(&table(text), &v).unwrap();
    assert_eq!(e.info().label, "local-error EYX (X)");
    assert_eq!(e.info().component.as_deref(), Some("EYX"));
    assert_eq!(values, vec![2e-6, 0.0, 0.04]);
    // The cubic B-spline scaled to 1 at its centre, σ = |X − c|/w.
    let bump = |sigma: f64| {
        if sigma < 0.5 {
            1.0 - 6.0 * sigma * sigma + 6.0 * sigma.powi(3)
        } else if sigma < 1.0 {
            2.0 * (1.0 - sigma).powi(3)
        } else {
            0.0
        }
    };
    let y: Vec<f64> = planted(&v, text, 0).iter().map(|(dq, _)| dq[1]).collect();
    let expected: Vec<f64> = X_A.iter().map(|x| 2.0 * bump(x.abs() / 0.04)).collect();
    assert_close(&y, &expected, "local-error EYX");
    assert_eq!((bump(0.0), bump(0.5), bump(1.0)), (1.0, 0.25, 0.0));
    // Far from the centre: nothing.
    let far = "effect = \"local-error\"\naxis = \"X\"\namplitude_um = 2.0\ncentre_mm = 80.0\nhalf_width_mm = 20.0";
    assert_close(&on_axis(&v, far, 0), &[0.0; 11], "local-error EXX far away");
    // The centre's box is the stretch of X the fitted runs cover (±100 mm), the half-width's
    // from a thirty-second of it (6.25 mm), and two of the finest steps a fitted run moves X
    // by, to its half (100 mm).
    let (e, _) = plant(&table(far), &v).unwrap();
    let shapes: Vec<_> = e
        .params()
        .iter()
        .filter(|p| p.kind == ParamKind::Shape)
        .collect();
    assert_eq!(shapes[0].name, "centre_mm");
    let (lo, hi) = shapes[0].bounds.unwrap();
    assert!((lo + 0.1).abs() < 1e-12 && (hi - 0.1).abs() < 1e-12);
    let (lo, hi) = shapes[1].bounds.unwrap();
    let step = v.motion(0, 0).step.min(v.motion(1, 0).step);
    assert!(2.0 * step > 0.2 / 32.0);
    assert!((lo - 2.0 * step).abs() < 1e-12 && (hi - 0.1).abs() < 1e-12);
    // The scan before a refit moves the centre over that box a quarter of the half-width
    // apart, the width kept; a rescanned effect keeps its shapes' sizes.
    let scan = e.shape_scan(&v);
    assert_eq!(scan.len(), 41);
    assert!(
        scan.iter()
            .all(|s| s[1] == 0.02 && (-0.1..=0.1).contains(&s[0]))
    );
    assert!((scan[1][0] - scan[0][0] - 0.005).abs() < 1e-12);
    let moved = e.with_shape(&[0.0, 0.02]).unwrap();
    assert_eq!(moved.params()[1].initial, 0.0);
    assert_eq!(moved.params()[1].scale, e.params()[1].scale);
    assert!(moved.params()[1].scale > 0.0);
}

#[test]
fn the_spindle_grows_every_set_ups_tool_length_with_one_amplitude() {
    let v = view(true, true, true);
    let text = "effect = \"spindle-growth\"\namplitude_um = 5.0\ntau_s = 60.0";
    let (e, values) = plant(&table(text), &v).unwrap();
    assert_eq!(e.info().label, "spindle-growth tool axis (t)");
    assert_eq!(e.info().component.as_deref(), Some("tool axis"));
    assert_eq!(e.info().axis, None);
    assert_eq!(values, vec![5e-6, 60.0]);
    // One amplitude, a term on each set-up's tool length (index 1 in both).
    assert_eq!(e.params().len(), 2);
    assert_eq!(
        e.terms()
            .iter()
            .map(|t| (t.amplitude, t.target.clone()))
            .collect::<Vec<_>>(),
        vec![
            (0, Target::Nuisance { setup: 0, index: 1 }),
            (0, Target::Nuisance { setup: 1, index: 1 })
        ]
    );
    for r in 0..2 {
        let t0 = v.runs[r].t.get(0);
        for (i, (dq, dn)) in planted(&v, text, r).iter().enumerate() {
            let expected = 5.0 * (1.0 - (-(t0 + i as f64) / 60.0).exp());
            assert!((dn[1] - expected).abs() < 1e-9, "run {r} sample {i}");
            assert_eq!(dn[0], 0.0);
            assert!(dq.iter().all(|&x| x == 0.0));
        }
    }
    // The amplitude's column at a sample is the feature, on the sample's set-up only.
    let prepared = PreparedEffects::new(&[e], &v, &values);
    let mut out = prepared.scratch(5, 2, 3);
    prepared.sample(1, 1, 40, &values, &mut out);
    let f = 1.0 - (-140.0f64 / 60.0).exp();
    assert!((out.jn[1] - f).abs() < 1e-12 && out.jn[0] == 0.0);
    let mut entries = Vec::new();
    prepared.amplitude_entries(1, 1, 40, &mut out, &mut entries);
    assert_eq!(entries.len(), 1);
    assert_eq!(entries[0].slot, mtcal_effects::Slot::Nuisance(1));
    // Driven by the spindle speed.
    let (e, _) = plant(
        &table(
            "effect = \"spindle-growth\"\ndriver = \"S\"\ngain_um_per_krpm = 0.5\ntau_s = 300.0",
        ),
        &v,
    )
    .unwrap();
    assert_eq!(e.info().label, "spindle-growth tool axis (S)");
    assert_eq!(e.params()[0].name, "gain_um_per_krpm");
}

fn labels(all: &[Candidate], class: &str) -> Vec<String> {
    all.iter()
        .filter(|c| c.class() == class)
        .map(|c| c.label())
        .collect()
}

#[test]
fn motion_families_propose_where_the_axes_move_and_reverse() {
    let v = view(true, true, false);
    let all = mtcal_effects::candidates(&v);
    // X, Y (in run b), A and C reverse; Z stands. Along the stroke: not on the endless C.
    let mut reversal = labels(&all, "reversal");
    reversal.sort();
    assert_eq!(
        reversal,
        [
            "reversal A (A)",
            "reversal A (along A)",
            "reversal C (C)",
            "reversal X (X)",
            "reversal X (along X)",
            "reversal Y (Y)",
            "reversal Y (along Y)",
        ]
    );
    let c = all.iter().find(|c| c.label() == "reversal C (C)").unwrap();
    let Candidate::Effect(c) = c else {
        panic!("an effect")
    };
    assert_eq!(c.params()[0].name, "backlash_urad");
    assert_eq!(c.params()[0].unit, "urad");
    // Lateral play of the reversing linear axes across every other linear one, as a step and
    // taken up over travel.
    let mut lateral = labels(&all, "lateral-play");
    lateral.sort();
    assert_eq!(
        lateral,
        [
            "lateral-play X (in Y)",
            "lateral-play X (in Y, taken up)",
            "lateral-play X (in Z)",
            "lateral-play X (in Z, taken up)",
            "lateral-play Y (in X)",
            "lateral-play Y (in X, taken up)",
            "lateral-play Y (in Z)",
            "lateral-play Y (in Z, taken up)",
        ]
    );
    // Spikes at 1 and 5 s (samples a second apart: 0.05 and 0.2 s are gone before the next
    // sample) on the four reversing axes, first-order and critically damped.
    let spikes = labels(&all, "reversal-spike");
    assert_eq!(spikes.len(), 16);
    assert_eq!(
        spikes.iter().filter(|l| l.ends_with(", damped)")).count(),
        8
    );
    // Local errors along X and Y (Z never moves) on each of X, Y, Z: seven each.
    let local = labels(&all, "local-error");
    assert_eq!(local.len(), 2 * 3 * 7);
    for name in ["EXX", "EYX", "EZX", "EXY", "EYY", "EZY"] {
        assert_eq!(
            local.iter().filter(|l| l.contains(name)).count(),
            7,
            "{name}"
        );
    }
    assert!(!local.iter().any(|l| l.ends_with("(Z)")));
    // Every local error starts inside its box.
    for c in all.iter().filter(|c| c.class() == "local-error") {
        let Candidate::Effect(e) = c else { continue };
        for p in e.params().iter().filter(|p| p.kind == ParamKind::Shape) {
            let (lo, hi) = p.bounds.unwrap();
            assert!(
                p.initial > lo && p.initial < hi,
                "{}: {}",
                c.label(),
                p.name
            );
            assert!(p.scale > 0.0);
        }
    }
    // Without a channel that reads the pose, nothing acts through the axes.
    let blind = mtcal_effects::candidates(&view(false, true, false));
    for class in ["reversal", "lateral-play", "reversal-spike", "local-error"] {
        assert!(labels(&blind, class).is_empty(), "{class}");
    }
}

#[test]
fn spindle_growth_is_proposed_where_a_set_up_has_a_tool_length() {
    // The session lasts 180 s: drifts at 180/16 … 360 s (six), and with a varying spindle
    // speed its lag at 300 s (the one of 5 min … 11 h within twice the session).
    let v = view(true, true, false);
    let all = mtcal_effects::candidates(&v);
    assert_eq!(labels(&all, "spindle-growth").len(), 6);
    let v = view(true, true, true);
    let all = mtcal_effects::candidates(&v);
    let growth = labels(&all, "spindle-growth");
    assert_eq!(growth.len(), 7);
    assert_eq!(
        growth
            .iter()
            .filter(|l| *l == "spindle-growth tool axis (S)")
            .count(),
        1
    );
    for c in all.iter().filter(|c| c.class() == "spindle-growth") {
        let Candidate::Effect(e) = c else { continue };
        assert_eq!(e.terms().len(), 2);
        assert!(e.terms().iter().all(|t| t.amplitude == 0));
    }
    let none = mtcal_effects::candidates(&view(true, false, true));
    assert!(labels(&none, "spindle-growth").is_empty());
}

#[test]
fn new_plant_tables_are_read_and_bad_ones_named() {
    let v = view(true, true, false);
    let cases: [(&str, &str, Option<&str>); 9] = [
        (
            "effect = \"lateral-play\"\naxis = \"X\"\nplay_um = 1.0",
            "needs `across",
            None,
        ),
        (
            "effect = \"lateral-play\"\naxis = \"X\"\nacross = \"X\"\nplay_um = 1.0",
            "along another one",
            Some("across"),
        ),
        (
            "effect = \"lateral-play\"\naxis = \"C\"\nacross = \"X\"\nplay_um = 1.0",
            "two linear axes",
            Some("axis"),
        ),
        (
            "effect = \"lateral-play\"\naxis = \"X\"\nacross = \"Q\"\nplay_um = 1.0",
            "no axis Q",
            Some("across"),
        ),
        (
            "effect = \"local-error\"\naxis = \"X\"\nacross = \"C\"\namplitude_um = 1.0\ncentre_mm = 0.0\nhalf_width_mm = 20.0",
            "linear axis",
            Some("across"),
        ),
        (
            "effect = \"local-error\"\naxis = \"X\"\namplitude_um = 1.0\ncentre_mm = 300.0\nhalf_width_mm = 20.0",
            "outside",
            Some("centre_mm"),
        ),
        (
            "effect = \"reversal-spike\"\naxis = \"X\"\nheight_um = 1.0\ntau_s = 100.0",
            "outside",
            Some("tau_s"),
        ),
        (
            "effect = \"reversal\"\naxis = \"C\"\nbacklash_urad = 1.0\nbacklash_change_urad = 1.0",
            "needs an axis with ends",
            Some("axis"),
        ),
        (
            "effect = \"spindle-growth\"\ndriver = \"T_bed\"\ngain_um_per_K = 1.0",
            "grows in time",
            Some("driver"),
        ),
    ];
    for (text, expected, key) in cases {
        let err = plant(&table(text), &v).map(|_| ()).unwrap_err();
        assert!(err.message.contains(expected), "{text}: {err}");
        assert_eq!(err.key.as_deref(), key, "{text}");
    }
    let err = plant(
        &table("effect = \"spindle-growth\"\namplitude_um = 1.0\ntau_s = 60.0"),
        &view(true, false, false),
    )
    .map(|_| ())
    .unwrap_err();
    assert!(err.message.contains("tool_length"), "{err}");
    // A local error across the axis itself is its positioning.
    let (e, _) = plant(
        &table("effect = \"local-error\"\naxis = \"Y\"\namplitude_um = 1.0\ncentre_mm = 10.0\nhalf_width_mm = 20.0"),
        &v,
    )
    .unwrap();
    assert_eq!(e.info().label, "local-error EYY (Y)");
    assert_eq!(e.terms()[0].target, Target::Axis(1));
}

/// Every sample's changes of the axes (µm) of effect `e` at parameters `values` (SI), runs
/// "a" and "b" one after the other.
fn effect_on_axes(v: &Arc<SessionView>, e: &Arc<dyn Effect>, values: &[f64]) -> Vec<Vec<f64>> {
    let prepared = PreparedEffects::new(std::slice::from_ref(e), v, values);
    let mut out = prepared.scratch(5, 2, 3);
    let mut all = Vec::new();
    for r in 0..v.runs.len() {
        for i in 0..v.runs[r].len() {
            prepared.sample(r, v.runs[r].setup, i, values, &mut out);
            all.push(out.dq.iter().map(|x| x * 1e6).collect());
        }
    }
    all
}

#[test]
fn a_play_taken_up_over_no_travel_is_the_plain_play() {
    let v = view(true, true, false);
    let all = mtcal_effects::candidates(&v);
    let effect = |label: &str| -> Arc<dyn Effect> {
        match all.iter().find(|c| c.label() == label) {
            Some(Candidate::Effect(e)) => Arc::clone(e),
            _ => panic!("no effect {label}"),
        }
    };
    let taken_up = effect("lateral-play X (in Y, taken up)");
    let take_up = taken_up
        .params()
        .iter()
        .position(|p| p.name == "take_up_mm")
        .unwrap();
    let (low, _) = taken_up.params()[take_up].bounds.unwrap();
    // At the lower edge of its box the family names the plain play; at the upper one nothing.
    let simpler = taken_up.at_edge(take_up, true).expect("the plain play");
    assert_eq!(simpler.info().label, "lateral-play X (in Y)");
    assert!(taken_up.at_edge(take_up, false).is_none());
    assert!(simpler.at_edge(0, true).is_none());
    // And it is that play: the same step at every sample, the same start states.
    let values = |e: &Arc<dyn Effect>, play_m: f64| -> Vec<f64> {
        e.params()
            .iter()
            .map(|p| match p.kind {
                ParamKind::Amplitude => play_m,
                ParamKind::Shape if p.name == "take_up_mm" => low,
                ParamKind::Shape => p.initial,
            })
            .collect()
    };
    let at_edge = effect_on_axes(&v, &taken_up, &values(&taken_up, 3e-6));
    let plain = effect_on_axes(&v, &simpler, &values(&simpler, 3e-6));
    for (k, (a, b)) in at_edge.iter().zip(&plain).enumerate() {
        assert_close(a, b, &format!("sample {k}"));
    }
    assert!(plain.iter().any(|dq| dq[1].abs() > 1.0), "{plain:?}");
}

#[test]
fn only_effects_with_a_course_over_the_session_follow_it() {
    let v = view(true, true, true);
    let (mut timed, mut moved) = (0, 0);
    for c in mtcal_effects::candidates(&v) {
        let Candidate::Effect(e) = &c else { continue };
        let in_time = matches!(
            c.class(),
            "thermal-drift" | "temperature-coupling" | "setup-drift" | "spindle-growth"
        );
        let of_motion = matches!(
            c.class(),
            "reversal" | "lateral-play" | "reversal-spike" | "stick-slip" | "local-error"
        );
        if in_time {
            assert!(e.follows_the_session(), "{}", c.label());
            timed += 1;
        }
        if of_motion {
            assert!(!e.follows_the_session(), "{}", c.label());
            moved += 1;
        }
    }
    assert!(timed > 0 && moved > 0, "{timed} in time, {moved} of motion");
}

#[test]
fn a_servo_lag_is_proposed_only_where_readings_are_taken_on_the_fly() {
    let servo = "effect = \"servo-lag\"\naxis = \"X\"\nlag_ms = 2.0";
    let on_the_fly = view_read(true, false, false, false);
    assert!(!labels(&mtcal_effects::candidates(&on_the_fly), "servo-lag").is_empty());
    assert!(on_axis(&on_the_fly, servo, 0).iter().any(|d| d.abs() > 1.0));
    // Read with the axes standing at each target (a laser's ISO 230-2 points): a step over the
    // time between two readings is no velocity, and no lag is proposed or planted there.
    let standing = view_read(true, false, false, true);
    assert!(labels(&mtcal_effects::candidates(&standing), "servo-lag").is_empty());
    assert!(on_axis(&standing, servo, 0).iter().all(|&d| d == 0.0));
    assert_eq!(standing.velocity(0, 0, 3), 0.0);
    assert!(on_the_fly.velocity(0, 0, 3) != 0.0);
}

#[test]
fn a_cross_coupling_is_given_at_the_farthest_corner_the_fitted_runs_reach() {
    use mtcal_effects::basic::{Corner, Span};
    let v = view(true, false, false);
    let over = [Span::fitted(&v, 0), Span::fitted(&v, 1)];
    // Where the fitted runs take X and Y.
    assert_eq!((over[0].lo, over[0].hi), v.fitted_range(0));
    assert_eq!((over[1].lo, over[1].hi), v.fitted_range(1));
    let corner = Corner::of(&v, over);
    let u = |a: usize, q: f64| {
        let (lo, hi) = v.axes[a].stroke;
        (2.0 * q - lo - hi) / (hi - lo)
    };
    assert_eq!(corner.product, u(0, corner.at[0]) * u(1, corner.at[1]));
    for x in [over[0].lo, over[0].hi] {
        for y in [over[1].lo, over[1].hi] {
            assert!(
                (u(0, x) * u(1, y)).abs() <= corner.product.abs() * (1.0 + 1e-9),
                "({x}, {y}) is farther than {:?}",
                corner.at
            );
        }
    }
    // The candidate is the plant's feature rescaled: the same fit, its amplitude the value
    // at that corner (a plant's at the strokes' corner).
    let all = mtcal_effects::candidates(&v);
    let Candidate::Effect(found) = all
        .iter()
        .find(|c| c.label() == "cross-coupling Z (X*Y)")
        .expect("a coupling of X and Y on Z")
    else {
        panic!("an effect")
    };
    assert_eq!(found.spans(), over.to_vec());
    let (planted, _) = plant(
        &table("effect = \"cross-coupling\"\naxis = \"Z\"\ndriver = \"X*Y\"\ncorner_um = 1.0"),
        &v,
    )
    .unwrap();
    let at_corner = effect_on_axes(&v, found, &[1e-6]);
    let at_strokes = effect_on_axes(&v, &planted, &[1e-6]);
    for (c, s) in at_corner.iter().zip(&at_strokes) {
        assert!((c[2] * corner.product - s[2]).abs() < 1e-12, "{c:?} {s:?}");
    }
    assert!(at_strokes.iter().any(|s| s[2].abs() > 1e-3));
    // The plant's amplitude is the value at the strokes' corner, as its key says.
    let samples = (0..v.runs.len()).flat_map(|r| (0..v.runs[r].len()).map(move |i| (r, i)));
    for ((r, i), s) in samples.zip(&at_strokes) {
        let want = u(0, v.q(r, i, 0)) * u(1, v.q(r, i, 1));
        assert!(
            (s[2] - want).abs() < 1e-12,
            "run {r} sample {i}: {} vs {want}",
            s[2]
        );
    }
}
