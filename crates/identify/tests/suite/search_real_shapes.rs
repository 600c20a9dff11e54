//! The physics search when the truth is not one of its candidates: sessions of the independent
//! simulator (`mtcal-indsim`, its own kinematics, effects written from their physics and not
//! from mtcal's families) on five machines — the CAFYXZ trunnion, a table-table B/C machine, a
//! head-head C/A machine, a C table with a B head, and ball-bar-only sessions of a three-axis
//! machine (circles in three planes, both directions, two feeds) — with realistic noise (AR(1)
//! with φ = 0.6, σ stated 20 % small, readings quantised to 0.1 µm, set-ups up to 0.2 mm off
//! the manifest) and a random geometry, identified as a user would (a bare URDF: the default
//! full ISO 230-1 model, `search` as `identify --search` runs it).
//!
//! The shapes real machines have, planted alone, below the noise, masked by a larger effect and
//! in pairs: lost motion whose starting state differs from run to run (the approach is not in
//! the file) or grows along the stroke, a rotary axis' backlash, lateral play (the carriage
//! rocking across its guideway as the axis reverses), reversal spikes decaying in time,
//! stick-slip with its own catching-up law, a local bump of a guideway (a raised cosine, not a
//! polynomial) and the spindle growing along its own axis. What is measured, per session:
//! - each planted effect named (class and axis, or among the discovery's look-alikes);
//! - claims: discoveries that match nothing planted;
//! - the validation runs against the simulator's noise-free readings, after the search and
//!   before it: within 1.2 × the noise after, and never worse than before (worse: by more
//!   than the standard uncertainty mtcal states for the prediction, a change the model itself
//!   says it cannot resolve, or 0.02 × the noise if that is larger) — for the runs the
//!   fitted runs determine; those mtcal reports as undetermined (their prediction depends on
//!   parameters no fitted run sees) are counted and printed, not asserted. A run is judged
//!   from the sample where every axis it moves has moved: before that the axes stand as the
//!   approach left them, which the file does not hold (the simulator draws a lost motion's
//!   side at random per run; a rotary axis' half turn goes either way round), and no model
//!   predicts a play's side it cannot know;
//! - the location and squareness errors' 95 % intervals against the truth.
//!
//! And on clean sessions of the same machines, the share that claims anything.
//!
//! `CASES="a,b"` runs the cases whose names hold `a` or `b`, `VERBOSE=1` prints every search,
//! `SEED_SHIFT=k` draws every session anew, `KEEP=dir` keeps the sessions to look at. Every search
//! result, planted or clean, holds the honesty rules of `search_honesty.rs`
//! (`common::honesty`).

use crate::common;

use common::honesty::honest;
use mtcal_identify::search::{Discovery, SearchResult, search};
use mtcal_identify::{Study, band, base, predict_run};
use mtcal_indsim::effects::{Effect, HeatSource, Programme};
use mtcal_indsim::{
    Approach, Campaign, FiveAxisLayout, JointKind, Machine, Realism, Truth, Written,
    shipped_machine,
};
use mtcal_solve::Options;
use mtcal_testkit::sessions::{as_a_user_has_it, parallel};
use rand::SeedableRng;
use std::path::Path;

/// The machines.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Layout {
    Five(FiveAxisLayout),
    /// `machines/mcv754-zfyx.urdf`, ball bar only ([`Campaign::three_axis_ballbar_planes`]).
    Planes,
}

impl Layout {
    fn machine(self) -> Machine {
        match self {
            Layout::Five(l) => l.machine().unwrap(),
            Layout::Planes => {
                Machine::from_urdf_file(&shipped_machine("mcv754-zfyx.urdf")).unwrap()
            }
        }
    }

    fn write(self, dir: &Path, truth: &Truth, effects: &[Effect], r: &Realism) -> Written {
        match self {
            Layout::Five(l) => Campaign::five_axis_check(l, dir, truth, effects, r),
            Layout::Planes => Campaign::three_axis_ballbar_planes(dir, truth, effects, r),
        }
        .unwrap()
    }

    /// The rotary axis the layout's R-test turns most (for its backlash).
    fn rotary(self) -> Option<char> {
        match self {
            Layout::Five(FiveAxisLayout::Trunnion) => Some('C'),
            Layout::Five(FiveAxisLayout::TableTable) => Some('B'),
            Layout::Five(FiveAxisLayout::HeadHead) => Some('A'),
            Layout::Five(FiveAxisLayout::Mixed) => Some('C'),
            Layout::Planes => None,
        }
    }
}

/// How a planted effect must be named: its class and the axis (or component).
#[derive(Clone, Debug)]
struct Named {
    class: &'static str,
    on: String,
}

fn named(class: &'static str, on: impl Into<String>) -> Named {
    Named {
        class,
        on: on.into(),
    }
}

/// A planted shape, `size` × its nominal size, and how it must be named.
fn shape(kind: &str, size: f64, seed: u64, layout: Layout) -> (Effect, Named) {
    let um = |v: f64| v * size * 1e-6;
    match kind {
        // Lost motion of X, its state at each run's start drawn at random (the approach).
        "backlash" => (
            Effect::LostMotion {
                axis: 'X',
                lost_motion_low: um(3.0),
                lost_motion_high: um(3.0),
                approach: Approach::RandomPerRun { seed },
            },
            named("reversal", "X"),
        ),
        // A worn screw: Y's lost motion from 1 µm at one end of the stroke to 5 µm at the other.
        "worn" => (
            Effect::LostMotion {
                axis: 'Y',
                lost_motion_low: um(1.0),
                lost_motion_high: um(5.0),
                approach: Approach::Carried,
            },
            named("reversal", "Y"),
        ),
        "rotary" => {
            let axis = layout.rotary().expect("a rotary axis");
            (
                Effect::Backlash {
                    axis,
                    lost_motion: um(20.0),
                },
                named("reversal", axis.to_string()),
            )
        }
        // X's carriage rocking across Y in its guideway clearance.
        "lateral" => (
            Effect::LateralPlay {
                axis: 'X',
                across: [0.0, 1.0, 0.0],
                play: um(3.0),
                take_up: 0.5e-3,
            },
            named("lateral-play", "X"),
        ),
        "spike" => (
            Effect::ReversalSpike {
                axis: 'X',
                height: um(4.0),
                recovery_s: 1.0,
            },
            named("reversal-spike", "X"),
        ),
        "stick" => (
            Effect::StickSlip {
                axis: 'Y',
                height: um(2.0),
                slip_travel: 2e-3,
            },
            named("stick-slip", "Y"),
        ),
        // A dent in X's guideway 80 mm wide, lifting the tool in Z.
        "bump" => (
            Effect::GuidewayBump {
                axis: 'X',
                direction: [0.0, 0.0, 1.0],
                centre: 0.04,
                width: 0.08,
                height: um(3.0),
            },
            named("local-error", "X"),
        ),
        "spindle" => (
            Effect::SpindleGrowth {
                sources: vec![HeatSource {
                    gain: um(8.0),
                    tau_s: 900.0,
                    power: Programme::constant(1.0),
                }],
            },
            named("spindle-growth", "tool axis"),
        ),
        // The larger effect that masks: the head warming along Z.
        "drift" => (
            Effect::Thermal {
                direction: [0.0, 0.0, 1.0],
                sources: vec![
                    HeatSource {
                        gain: um(6.0),
                        tau_s: 600.0,
                        power: Programme::steps(&[(0.0, 3.0), (300.0, 0.0)]),
                    },
                    HeatSource {
                        gain: um(6.0),
                        tau_s: 2400.0,
                        power: Programme::constant(1.0),
                    },
                ],
            },
            named("thermal-drift", "Z"),
        ),
        other => panic!("no shape {other}"),
    }
}

struct Case {
    layout: Layout,
    /// (shape, size) planted.
    shapes: Vec<(&'static str, f64)>,
    seed: u64,
}

impl Case {
    fn name(&self) -> String {
        let shapes: Vec<String> = self
            .shapes
            .iter()
            .map(|(k, s)| format!("{k}×{s}"))
            .collect();
        format!("{:?} {} seed {}", self.layout, shapes.join("+"), self.seed)
    }
}

/// `SEED_SHIFT=k` draws every session anew (its geometry, noise and set-ups): to see that
/// the numbers do not belong to one draw.
fn seed_shift() -> u64 {
    std::env::var("SEED_SHIFT")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// Sixty-odd sessions: on each machine each shape alone, below the noise (a third of its size),
/// masked by the head's warm-up, and in pairs.
fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    let five = [
        FiveAxisLayout::Trunnion,
        FiveAxisLayout::TableTable,
        FiveAxisLayout::HeadHead,
        FiveAxisLayout::Mixed,
    ];
    for (m, layout) in five.into_iter().map(Layout::Five).enumerate() {
        let seed = 10 + m as u64 + seed_shift();
        let mut add = |shapes: Vec<(&'static str, f64)>| {
            out.push(Case {
                layout,
                shapes,
                seed,
            })
        };
        for kind in ["backlash", "worn", "rotary", "lateral", "bump", "spindle"] {
            add(vec![(kind, 1.0)]);
        }
        add(vec![("backlash", 0.3)]);
        add(vec![("lateral", 0.4)]);
        add(vec![("worn", 1.0), ("drift", 1.0)]);
        add(vec![("bump", 1.0), ("drift", 1.0)]);
        add(vec![("backlash", 1.0), ("lateral", 1.0)]);
        add(vec![("rotary", 1.0), ("spindle", 1.0)]);
    }
    for kind in ["backlash", "worn", "lateral", "spike", "stick", "bump"] {
        out.push(Case {
            layout: Layout::Planes,
            shapes: vec![(kind, 1.0)],
            seed: 20 + seed_shift(),
        });
    }
    for shapes in [
        vec![("backlash", 0.3)],
        vec![("spike", 0.4)],
        vec![("lateral", 1.0), ("backlash", 1.0)],
        vec![("stick", 1.0), ("worn", 1.0)],
        vec![("spike", 1.0), ("lateral", 1.0)],
        vec![("bump", 1.0), ("backlash", 1.0)],
    ] {
        out.push(Case {
            layout: Layout::Planes,
            shapes,
            seed: 21 + seed_shift(),
        });
    }
    out
}

/// A random geometry of `layout`'s machine (its rotary axes' error motions removed: the
/// full model keeps only their first harmonics).
fn truth(layout: Layout, seed: u64) -> (Machine, Truth) {
    let machine = layout.machine();
    let mut truth = Truth::random(
        &machine,
        &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed),
        1.0,
    );
    for (axis, joint) in truth.axes.iter_mut().zip(&machine.joints) {
        if joint.kind == JointKind::Rotary {
            axis.component = [[0.0; 4]; 6];
        }
    }
    (machine, truth)
}

/// The noise of the sessions: AR(1), σ stated 20 % small, quantised, set-ups up to 0.2 mm off.
fn realism(seed: u64) -> Realism {
    let r = Realism {
        setup_position_bound_um: 200.0,
        ..Realism::realistic(3000 + seed)
    };
    // `HARSH=f`: noise more coloured (φ = 0.8), its σ stated `f` times the real one, readings
    // quantised to 0.2 µm — to see how the search fares on noise further from what it assumes
    // (measured 2026-11-30: f = 1.5: 76 of 80 named, no claim, 36 of 36 determined validation
    // runs within 1.2 × the noise, none worse; f = 0.5: 75 of 80, no claim, 70 of 72, none
    // worse — the C table + B head beside the head's warm-up, whose second drift node these
    // data cannot tell from the fitted parameters).
    match std::env::var("HARSH").ok().and_then(|f| f.parse().ok()) {
        Some(factor) => Realism {
            noise_phi: 0.8,
            manifest_sigma_factor: factor,
            resolution_um: 0.2,
            ..r
        },
        None => r,
    }
}

fn matches(d: &Discovery, n: &Named) -> bool {
    let on = |class: &str, fields: [&Option<String>; 3]| {
        class == n.class && fields.iter().any(|f| f.as_deref() == Some(n.on.as_str()))
    };
    on(&d.effect, [&d.axis, &d.driver, &d.component])
        || d.alternatives.iter().any(|a| {
            a.effect == n.class
                && (a.label.contains(&format!(" {} ", n.on))
                    || a.label.contains(&format!("({})", n.on)))
        })
}

/// What a session came to.
struct Outcome {
    name: String,
    named: Vec<bool>,
    claims: Vec<String>,
    /// Per validation run: RMS of prediction − truth over the noise, after and before, and
    /// whether the fitted runs determine its prediction.
    validation: Vec<Validation>,
    /// Location and squareness errors: (name, inside its 95 % interval of the truth).
    intervals: Vec<(String, bool)>,
    summary: String,
    /// The honesty rules (`common::honesty`): which failed, if one did.
    dishonest: Option<String>,
}

/// A prediction within 1.2 × the noise: `√(σ² + e²) ≤ 1.2 σ`, an RMS error of 0.66 σ.
const PREDICTION_OVER_NOISE: f64 = 0.663;
/// "Never worse": after within this much (in units of the noise) of before — the rounding of
/// two fits of the same data — or within the standard uncertainty mtcal states for the
/// prediction after the search ([`Validation::stated`]), whichever is larger.
const NO_WORSE: f64 = 0.02;

fn run_case(case: &Case) -> Outcome {
    let tmp = tempfile::tempdir().unwrap();
    // `KEEP=dir` keeps each session (under its case's name) to look at with `mtcal`.
    let dir = match std::env::var("KEEP") {
        Ok(keep) => Path::new(&keep).join(case.name().replace([' ', '×', '+', '(', ')'], "_")),
        Err(_) => tmp.path().join("session"),
    };
    let (machine, truth) = truth(case.layout, case.seed);
    let planted: Vec<(Effect, Named)> = case
        .shapes
        .iter()
        .map(|(k, s)| shape(k, *s, case.seed, case.layout))
        .collect();
    let effects: Vec<Effect> = planted.iter().map(|p| p.0.clone()).collect();
    let realism = realism(case.seed);
    let written = case.layout.write(&dir, &truth, &effects, &realism);
    as_a_user_has_it(&dir, None);
    let (study, base) =
        base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
    let mut result = search(study, &Default::default()).unwrap();
    if let Some(base) = &base {
        result = result.with_base(base).unwrap();
    }
    let found = &result.findings;
    // The drift that masks is named too when found, but not required below the others.
    let named = planted
        .iter()
        .map(|(_, n)| found.discoveries.iter().any(|d| matches(d, n)))
        .collect();
    let claims = found
        .discoveries
        .iter()
        .filter(|d| !planted.iter().any(|(_, n)| matches(d, n)))
        .map(|d| d.label.clone())
        .collect();
    Outcome {
        name: case.name(),
        named,
        claims,
        validation: validation(&result, &written, &realism),
        intervals: intervals(&result, &machine, &truth),
        summary: found.summary(),
        dishonest: honest(&result).err(),
    }
}

/// One validation run's RMS error of the prediction against the simulator's noise-free
/// readings over the noise, after the search and before it.
struct Validation {
    run: String,
    after: f64,
    before: f64,
    /// The standard uncertainty mtcal states for the prediction after the search (its 95 %
    /// band over 1.96, RMS over the judged samples, in units of the noise): a change of the
    /// error smaller than this is one the model itself says it cannot resolve.
    stated: f64,
    /// Whether the fitted runs determine the run's prediction (mtcal reports the others as
    /// undetermined: counted, not asserted).
    determined: bool,
}

/// Per validation run: [`Validation`].
fn validation(result: &SearchResult, written: &Written, realism: &Realism) -> Vec<Validation> {
    let noise_um = (realism.noise_sigma_um.powi(2) + realism.resolution_um.powi(2) / 12.0).sqrt();
    let id = &result.identification;
    let before = result
        .study
        .rebuild(result.initial_changes.clone())
        .unwrap();
    let mut out = Vec::new();
    for (r, run) in result.study.runs.iter().enumerate() {
        if run.fit {
            continue;
        }
        let determined = !id
            .undetermined_validation
            .iter()
            .any(|(n, _)| *n == run.name);
        let w = written.runs.iter().find(|w| w.name == run.name).unwrap();
        let clean = &w.clean_um;
        // The samples before every axis that moves in the run has first moved hold the
        // approach's state, which the file does not hold (the simulator draws a lost motion's
        // side at random per run, a rotary axis' half turn goes either way): no model predicts
        // them, so the run is judged from there on.
        let skip = (0..w.positions[0].len())
            .filter_map(|a| w.positions.iter().position(|p| p[a] != w.positions[0][a]))
            .max()
            .unwrap_or(0);
        let rms = |study: &Study, x: &[f64]| {
            let pred = predict_run(study, r, x);
            let nch = study.channels(r).len();
            let ss: f64 = clean
                .iter()
                .enumerate()
                .skip(skip)
                .flat_map(|(i, row)| (0..nch).map(move |c| (i, c, row[c])))
                .map(|(i, c, v)| (pred[i * nch + c] * 1e6 - v).powi(2))
                .sum();
            (ss / ((clean.len() - skip).max(1) * nch) as f64).sqrt() / noise_um
        };
        let nch = result.study.channels(r).len();
        let band = band::prediction_u95(&result.study, &result.solution, r);
        let judged = &band[skip * nch..];
        let stated = (judged.iter().map(|u| (u * 1e6 / 1.96).powi(2)).sum::<f64>()
            / judged.len().max(1) as f64)
            .sqrt()
            / noise_um;
        out.push(Validation {
            run: run.name.clone(),
            after: rms(&result.study, &result.solution.x),
            before: rms(&before, &result.initial_solution.x),
            stated,
            determined,
        });
    }
    out
}

/// The truth of an mtcal parameter name (µm, µrad): `E<d>0<axis>` a location or squareness
/// error, `E<d><axis>.P<k>` a Legendre coefficient of a linear axis' component error (the
/// simulator keeps the same coefficients over the stroke); `None` for the others.
fn truth_value(machine: &Machine, truth: &Truth, name: &str) -> Option<f64> {
    let d = |c: char| "XYZABC".find(c);
    let b: Vec<char> = name.chars().collect();
    if b.len() == 4 && b[0] == 'E' && b[2] == '0' {
        return Some(truth.axes[machine.index(b[3])?].location[d(b[1])?] * 1e6);
    }
    let (head, term) = name.split_once('.')?;
    let h: Vec<char> = head.chars().collect();
    let k: usize = term.strip_prefix('P')?.parse().ok()?;
    if h.len() != 3 || h[0] != 'E' {
        return None;
    }
    Some(truth.axes[machine.index(h[2])?].component[d(h[1])?][k] * 1e6)
}

fn is_location(name: &str) -> bool {
    let b: Vec<char> = name.chars().collect();
    b.len() == 4 && b[0] == 'E' && b[2] == '0'
}

/// The location and squareness errors the final fit gives with an interval — alone, or as the
/// combination of component coefficients the runs determine with it — whether each interval
/// holds the truth (of the combination, where it is one).
fn intervals(result: &SearchResult, machine: &Machine, truth: &Truth) -> Vec<(String, bool)> {
    let id = &result.identification;
    let alone = id
        .parameters
        .iter()
        .filter(|p| p.kind == "machine" && is_location(&p.name))
        .filter_map(|p| {
            let t = truth_value(machine, truth, &p.name)?;
            Some((p.name.clone(), (p.value - t).abs() <= p.u95))
        });
    let combined = id
        .combinations
        .iter()
        .filter(|c| c.kind == "machine" && is_location(&c.name))
        .filter_map(|c| {
            let mut t = truth_value(machine, truth, &c.name)?;
            for term in &c.terms {
                t += term.coefficient * truth_value(machine, truth, &term.name)?;
            }
            Some((c.expression.clone(), (c.value - t).abs() <= c.u95))
        });
    alone.chain(combined).collect()
}

#[test]
fn real_shapes_are_named_nothing_else_is_claimed_and_nothing_predicts_worse() {
    let only = std::env::var("CASES").ok();
    let cases: Vec<Case> = cases()
        .into_iter()
        .filter(|c| {
            only.as_deref()
                .is_none_or(|o| o.split(',').any(|w| c.name().contains(w)))
        })
        .collect();
    let outcomes = parallel(&cases, run_case);
    let (mut effects, mut found, mut claimed) = (0, 0, 0);
    let (mut predicted, mut never_worse, mut runs) = (0, 0, 0);
    let (mut undetermined, mut undetermined_no_worse) = (0, 0);
    let (mut held, mut checked) = (0, 0);
    let mut worse = Vec::new();
    for o in &outcomes {
        let determined = || o.validation.iter().filter(|v| v.determined);
        let worst = determined().map(|v| v.after).fold(0.0, f64::max);
        let ratio = o
            .validation
            .iter()
            .map(|v| v.after / v.before.max(1e-9))
            .fold(0.0, f64::max);
        eprintln!(
            "{:<48} named {}/{}, claims {:?}, worst validation {worst:.2} σ (before {:.2}), \
             worst after/before {ratio:.2}",
            o.name,
            o.named.iter().filter(|&&n| n).count(),
            o.named.len(),
            o.claims,
            determined().map(|v| v.before).fold(0.0, f64::max),
        );
        if std::env::var("VERBOSE").is_ok() || !o.claims.is_empty() {
            eprintln!("{}", o.summary);
            for v in &o.validation {
                eprintln!(
                    "  validation {}: {:.2} σ (before {:.2}, stated ±{:.2}){}",
                    v.run,
                    v.after,
                    v.before,
                    v.stated,
                    if v.determined { "" } else { ", undetermined" }
                );
            }
        }
        effects += o.named.len();
        found += o.named.iter().filter(|&&n| n).count();
        claimed += usize::from(!o.claims.is_empty());
        for v in &o.validation {
            let no_worse = v.after <= v.before + NO_WORSE.max(v.stated);
            if !v.determined {
                // mtcal says these predictions depend on parameters the fitted runs do not
                // determine: counted, not asserted (their error moves with whatever the fit
                // leaves along those directions, before the search as after it).
                undetermined += 1;
                undetermined_no_worse += usize::from(no_worse);
                continue;
            }
            runs += 1;
            predicted += usize::from(v.after <= PREDICTION_OVER_NOISE);
            if no_worse {
                never_worse += 1;
            } else {
                worse.push(format!(
                    "{} {}: {:.2} → {:.2} σ (stated ±{:.2})",
                    o.name, v.run, v.before, v.after, v.stated
                ));
            }
        }
        held += o.intervals.iter().filter(|i| i.1).count();
        checked += o.intervals.len();
    }
    let n = outcomes.len();
    eprintln!(
        "{n} sessions: {found}/{effects} planted effects named; claims in {claimed}/{n} sessions; \
         validation runs the fitted runs determine: within 1.2 × the noise {predicted}/{runs}, \
         no worse than before the search {never_worse}/{runs} (those mtcal calls undetermined: \
         no worse {undetermined_no_worse}/{undetermined}); location and squareness intervals \
         holding the truth: {held}/{checked}\nworse: {worse:?}"
    );
    let share = |a: usize, b: usize| a as f64 / b.max(1) as f64;
    // Every discovery of every session determined and physical, none on an unconverged fit,
    // the first line agreeing: not a floor, a rule.
    let dishonest: Vec<(&str, &str)> = outcomes
        .iter()
        .filter_map(|o| Some((o.name.as_str(), o.dishonest.as_deref()?)))
        .collect();
    assert!(dishonest.is_empty(), "{dishonest:?}");
    if only.is_some() {
        return;
    }
    // The bar, met: the location and squareness intervals hold the truth.
    assert!(share(held, checked) >= 0.9, "{held}/{checked} intervals");
    assert!(checked >= 100, "{checked} intervals checked");
    // The bar, met: 90 % named (measured 76/80), claims in 5 % of the sessions at most
    // (measured 0/60, and 0/60 on each of the draws `SEED_SHIFT=100` to 500 — 11/60 on 300
    // before a concealed candidate had to predict clearly better, 1/60 before a forecast left
    // effects without a course in time at the full fit, 1/60 on 500 before a scan's best shape
    // paid for its looks). On the draws 200 and 300, 70 of
    // 72 validation runs are predicted within 1.2 × the noise (the bar below: the trunnion
    // beside the head's two-source warm-up misses it), none worse than before the search.
    assert!(share(found, effects) >= 0.9, "{found}/{effects} named");
    assert!(
        share(claimed, n) <= 0.05,
        "claims in {claimed}/{n} sessions"
    );
    // The bar, met: every validation run the fitted runs determine within 1.2 × the
    // noise (measured 72/72, the worst 0.52 of the 0.66 allowed).
    assert_eq!(predicted, runs, "{predicted}/{runs} predicted");
    // The bar, met: none predicted worse than before the search (measured 72/72;
    // worse means beyond the uncertainty mtcal states for the prediction, or 0.02 × the noise).
    assert_eq!(
        never_worse, runs,
        "{never_worse}/{runs} no worse: {worse:?}"
    );
}

/// The draw `SEED_SHIFT=300` of the trunnion (seed 310), a backlash planted: every session of
/// that draw claimed a settling of the R-test set-up `ball2` (10 ± 8.5 µm, τ = 42 ± 30 s) that
/// the simulator never planted — a candidate 99.4 % like the fitted location errors, adding a
/// per cent of held-out prediction (10 of 60 sessions of the draw). A concealed candidate
/// must now predict clearly better; the backlash is still named and predicts the validation
/// runs, and nothing else is claimed.
#[test]
fn a_concealed_set_up_settling_is_not_claimed_on_a_few_per_cent_of_prediction() {
    let case = Case {
        layout: Layout::Five(FiveAxisLayout::Trunnion),
        shapes: vec![("backlash", 1.0)],
        seed: 310,
    };
    kept_session_holds(&case);
}

/// A session kept because a draw once went wrong on it: honest, every planted effect named,
/// nothing else claimed, every determined validation run within 1.2 × the noise.
fn kept_session_holds(case: &Case) -> Outcome {
    let o = run_case(case);
    assert!(o.dishonest.is_none(), "{:?}", o.dishonest);
    assert!(o.named.iter().all(|&n| n), "{:?}\n{}", o.named, o.summary);
    assert_eq!(o.named.len(), case.shapes.len());
    assert!(o.claims.is_empty(), "{:?}\n{}", o.claims, o.summary);
    for v in o.validation.iter().filter(|v| v.determined) {
        assert!(
            v.after <= PREDICTION_OVER_NOISE,
            "{}: {:.2} σ\n{}",
            v.run,
            v.after,
            o.summary
        );
    }
    o
}

/// The draw `SEED_SHIFT=300` of the ball-bar planes (seed 320), a guideway bump of X planted:
/// the bump's local error, refitted from the first half of the session where one run crosses
/// it, forecast the rest worse than the fit without it and was refused, and a bump of Z and a
/// drift (neither planted) were claimed in its place. A bump has no course over the session:
/// the forecast now leaves it at the full fit (as it leaves a change of the error model), the
/// blocked folds judge it, and the planted bump is named with nothing else.
#[test]
fn a_guideway_bump_is_not_judged_by_a_forecast_in_time() {
    let case = Case {
        layout: Layout::Planes,
        shapes: vec![("bump", 1.0)],
        seed: 320,
    };
    kept_session_holds(&case);
}

/// The draw `SEED_SHIFT=200` of the ball-bar planes (seed 221), a reversal spike and a
/// lateral play of X planted: the play was added taken up over travel, and the final fit
/// pinned the take-up at the lower edge of its box — a carriage on its new flank at once, the
/// plain play — so the play was withdrawn whole and the validation run left at 3.65 σ. The
/// family says what the edge is; the final model now holds the plain play.
#[test]
fn a_take_up_pinned_at_no_travel_keeps_the_plain_lateral_play() {
    let case = Case {
        layout: Layout::Planes,
        shapes: vec![("spike", 1.0), ("lateral", 1.0)],
        seed: 221,
    };
    let o = kept_session_holds(&case);
    assert!(
        o.summary.contains("where it is this simpler form"),
        "{}",
        o.summary
    );
}

/// The draw `SEED_SHIFT=500` of the head-head machine (seed 512), a backlash and a lateral
/// play of X planted: once both were in, a cyclic error of C (0.4 µrad, a period of 5.13°,
/// held-out mean square 0.6 % lower) was claimed. Its period was the best of the fourteen
/// independent ones its scan looked at, and the largest of fourteen chances clears the
/// information criterion that one chance seldom does: the best of a scan now pays for the
/// looks (`2 ln K`), and nothing but the planted effects is claimed.
#[test]
fn the_best_period_of_a_scan_pays_for_the_periods_it_looked_at() {
    let case = Case {
        layout: Layout::Five(FiveAxisLayout::HeadHead),
        shapes: vec![("backlash", 1.0), ("lateral", 1.0)],
        seed: 512,
    };
    kept_session_holds(&case);
}

/// Clean sessions of the five machines (ten each): the search claims an effect in at most 5 %.
#[test]
fn clean_sessions_of_five_machines_rarely_raise_a_claim() {
    let layouts = [
        Layout::Five(FiveAxisLayout::Trunnion),
        Layout::Five(FiveAxisLayout::TableTable),
        Layout::Five(FiveAxisLayout::HeadHead),
        Layout::Five(FiveAxisLayout::Mixed),
        Layout::Planes,
    ];
    let cases: Vec<(Layout, u64)> = layouts
        .iter()
        .flat_map(|&l| (0..10).map(move |k| (l, 200 + k + seed_shift())))
        .collect();
    let claims = parallel(&cases, |&(layout, seed)| {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("session");
        let (_, truth) = truth(layout, seed);
        let realism = Realism {
            manifest_sigma_factor: if seed % 2 == 0 { 0.8 } else { 1.2 },
            ..realism(seed)
        };
        layout.write(&dir, &truth, &[], &realism);
        as_a_user_has_it(&dir, None);
        let (study, _) =
            base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
        let result = search(study, &Default::default()).unwrap();
        if let Err(why) = honest(&result) {
            panic!("{layout:?} seed {seed}: {why}");
        }
        let labels: Vec<String> = result
            .findings
            .discoveries
            .iter()
            .map(|d| d.label.clone())
            .collect();
        if !labels.is_empty() || std::env::var("VERBOSE").is_ok() {
            eprintln!("{layout:?} seed {seed}: {}", result.findings.summary());
        }
        labels
    });
    let claimed: Vec<(&(Layout, u64), &Vec<String>)> = cases
        .iter()
        .zip(&claims)
        .filter(|(_, c)| !c.is_empty())
        .collect();
    eprintln!(
        "{} of {} clean sessions claimed: {claimed:?}",
        claimed.len(),
        cases.len()
    );
    assert!(
        claimed.len() * 20 <= cases.len(),
        "{} of {}: {claimed:?}",
        claimed.len(),
        cases.len()
    );
}
