//! The physics search on sessions it did not write: the independent simulator
//! (`mtcal-indsim`: its own 4 × 4 kinematics, effects planted by their physics — lost motion as
//! a dead band, a spindle head warming through two thermal nodes and cooling, a screw error of
//! several harmonics at a pitch not in the candidates' grid, a scale expanding with a recorded
//! temperature, a twist, a sag, a ball bar growing with its own temperature, X's position loop
//! lagging, an R-test ball or a ball-bar pivot settling on the table), realistic noise
//! (AR(1) with φ = 0.6, σ 0.3 µm stated as 0.24, readings quantised to 0.1 µm, time jitter,
//! set-ups 20 µm off the manifest), identified as a user would: a bare URDF (the default full
//! ISO 230-1 model), no `[identify]` table, `search` as `identify --search` runs it.
//!
//! Each case plants effects in the trunnion's thermal-check campaign (R-test and ball bar
//! alternating, validation runs spread over the session, the first run repeated at the end) and
//! checks that every planted effect is named (class and axis, driver or component — or the
//! data's look-alikes, named with it), that nothing else is claimed, and that the validation
//! runs the fitted runs determine are predicted within 1.2 × the noise (their error against
//! the noise-free readings at most 0.66 σ). Effects that the full model already contains (a
//! twist is the pitch of Y growing along Y, a sag the straightness of X) must be explained by it
//! — nothing claimed, the validation predicted — and found when the model leaves them out (the
//! eleven location and squareness errors of source 000).

use mtcal_identify::search::{SearchOptions, SearchResult, search};
use mtcal_identify::{Study, base, predict_run};
use mtcal_indsim::effects::{Effect, HeatSource, Programme, TemperatureProgramme};
use mtcal_indsim::{Campaign, JointKind, Machine, Realism, Truth, Written, shipped_machine};
use mtcal_solve::Options;
use mtcal_testkit::sessions::parallel;
use rand::SeedableRng;
use std::path::Path;

/// The eleven location and squareness errors source 000 identifies on the trunnion.
const ELEVEN: &str =
    r#"["EC0Y", "EB0Z", "EA0Z", "EY0A", "EZ0A", "EB0A", "EC0A", "EX0C", "EY0C", "EA0C", "EB0C"]"#;

/// The error model a case's session is identified in.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Model {
    /// No `[identify]`: the full ISO 230-1 model, what the runs determine taken.
    Full,
    /// `[identify] parameters` = [`ELEVEN`].
    Eleven,
    /// `[identify] parameters` = every parameter of the truth's family (locations, squareness,
    /// the linear axes' component errors): a rich model the runs cannot wholly determine, with
    /// nothing held (null directions, not priors).
    Family,
}

/// The trunnion's truth family: its location and squareness errors and the linear axes'
/// component errors.
const FAMILY: &str = r#"["EC0Y", "EB0Z", "EA0Z", "EY0A", "EZ0A", "EB0A", "EC0A", "EX0C", "EY0C", "EA0C", "EB0C", "EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EXY", "EYY", "EZY", "EAY", "EBY", "ECY", "EXZ", "EYZ", "EZZ", "EAZ", "EBZ", "ECZ"]"#;

/// How a planted effect must be named: the class, and the axis, driver or component.
#[derive(Clone, Debug)]
struct Named {
    class: &'static str,
    on: &'static str,
}

/// Which campaign a case measures.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Layout {
    /// The trunnion's R-test and ball-bar thermal check ([`Campaign::trunnion_thermal_check`]).
    Trunnion,
    /// The three-axis machine's laser and tracer campaign
    /// ([`Campaign::three_axis_laser_tracer`]).
    ThreeAxis,
}

struct Case {
    name: String,
    layout: Layout,
    effects: Vec<Effect>,
    /// Per planted effect how it must be named; empty for a case whose effects the model
    /// contains (nothing may be claimed).
    named: Vec<Named>,
    model: Model,
    seed: u64,
}

/// A warm-up of the spindle head along Z: a fast node heated for the first five minutes and
/// then cooling, and a slow one heated throughout (µm at steady state).
fn thermal(fast_um: f64, slow_um: f64) -> Effect {
    thermal_along([0.0, 0.0, 1.0], fast_um, slow_um)
}

/// [`thermal`] along another direction (a column bending as it warms: the head moves in X).
fn thermal_along(direction: [f64; 3], fast_um: f64, slow_um: f64) -> Effect {
    Effect::Thermal {
        direction,
        sources: vec![
            HeatSource {
                gain: fast_um * 1e-6,
                tau_s: 600.0,
                power: Programme::steps(&[(0.0, 3.0), (300.0, 0.0)]),
            },
            HeatSource {
                gain: slow_um * 1e-6,
                tau_s: 2400.0,
                power: Programme::constant(1.0),
            },
        ],
    }
}

fn backlash(um: f64) -> Effect {
    Effect::Backlash {
        axis: 'X',
        lost_motion: um * 1e-6,
    }
}

/// A screw error of X at a 7 mm pitch (between the candidates' 6 and 8 mm), with its second and
/// third harmonics.
fn screw(um: f64, pitch_mm: f64) -> Effect {
    Effect::ScrewError {
        axis: 'X',
        pitch: pitch_mm * 1e-3,
        harmonics: vec![
            (1, um * 1e-6, 0.3),
            (2, 0.4 * um * 1e-6, 1.0),
            (3, 0.2 * um * 1e-6, 2.0),
        ],
    }
}

/// X's scale expanding by 11.5 ppm/K while its temperature (recorded as `T_xscale`) rises by
/// `rise_k` with τ = 15 min.
fn scale(rise_k: f64) -> Effect {
    Effect::ThermalScale {
        axis: 'X',
        ppm_per_k: 11.5,
        reference: 0.0,
        temperature: TemperatureProgramme {
            ambient_c: 20.0,
            drift_k_per_h: 0.0,
            rises: vec![HeatSource {
                gain: rise_k,
                tau_s: 900.0,
                power: Programme::constant(1.0),
            }],
        },
        column: "T_xscale".into(),
    }
}

/// Z ∝ x·y: `um` at the corners x = y = ±150 mm.
fn twist(um: f64) -> Effect {
    Effect::Twist {
        per_m2: um * 1e-6 / (0.15 * 0.15),
    }
}

/// Z ∝ x²: `um` at x = ±150 mm.
fn sag(um: f64) -> Effect {
    Effect::Sag {
        axis: 'X',
        direction: 'Z',
        per_m2: um * 1e-6 / (0.15 * 0.15),
    }
}

/// The 100 mm ball bar (steel, 11.5 ppm/K) warming by `rise_k` (τ 20 min), its temperature
/// recorded as `T_bar`; and the air around it drifting by `drift_k_per_h`.
fn bar(rise_k: f64, drift_k_per_h: f64) -> Effect {
    Effect::BallBarThermal {
        setup: "bar1".into(),
        ppm_per_k: 11.5,
        temperature: TemperatureProgramme {
            ambient_c: 20.0,
            drift_k_per_h,
            rises: vec![HeatSource {
                gain: rise_k,
                tau_s: 1200.0,
                power: Programme::constant(1.0),
            }],
        },
        column: Some("T_bar".into()),
    }
}

/// The fixed element of `setup` (the R-test ball or the ball bar's pivot on the table) settling
/// by `settle_um` (workpiece frame) with τ = 10 min from its first use: an instrument set-up's
/// drift, the look-alike of a machine's.
fn creep(setup: &str, settle_um: [f64; 3]) -> Effect {
    Effect::SetupCreep {
        setup: setup.into(),
        settle: settle_um.map(|v| v * 1e-6),
        tau_s: 600.0,
    }
}

/// X trailing its command by `ms` (its position loop slower than the others'): the following
/// error of a gain mismatch, a look-alike of lost motion (both turn with the direction).
fn servo(ms: f64) -> Effect {
    Effect::ServoLag {
        axis: 'X',
        lag_s: ms * 1e-3,
    }
}

const REVERSAL: Named = Named {
    class: "reversal",
    on: "X",
};
const DRIFT: Named = Named {
    class: "thermal-drift",
    on: "Z",
};
const DRIFT_X: Named = Named {
    class: "thermal-drift",
    on: "X",
};
const CYCLIC: Named = Named {
    class: "cyclic",
    on: "X",
};
const EXPANSION: Named = Named {
    class: "thermal-expansion",
    on: "X",
};
const BAR: Named = Named {
    class: "temperature-coupling",
    on: "bar1.length",
};
const SERVO: Named = Named {
    class: "servo-lag",
    on: "X",
};
const CREEP_BALL: Named = Named {
    class: "setup-drift",
    on: "ball1.ball_x",
};
const CREEP_PIVOT: Named = Named {
    class: "setup-drift",
    on: "bar1.pivot_x",
};
const TWIST: Named = Named {
    class: "cross-coupling",
    on: "X*Y",
};
const SAG: Named = Named {
    class: "omitted-parameter",
    on: "EZX",
};

fn cases() -> Vec<Case> {
    let case = |name: &str, effects: Vec<Effect>, named: Vec<Named>| Case {
        name: name.into(),
        layout: Layout::Trunnion,
        effects,
        named,
        model: Model::Full,
        seed: 1,
    };
    let mut out = vec![
        // Each effect at a size the noise hides sample by sample…
        case(
            "backlash below the noise",
            vec![backlash(0.5)],
            vec![REVERSAL],
        ),
        case(
            "thermal below the noise",
            vec![thermal(0.3, 0.6)],
            vec![DRIFT],
        ),
        case(
            "screw below the noise",
            vec![screw(0.25, 7.0)],
            vec![CYCLIC],
        ),
        case("scale below the noise", vec![scale(0.3)], vec![EXPANSION]),
        case("bar below the noise", vec![bar(1.0, 0.0)], vec![BAR]),
        // … partly inside the span of the fitted parameters …
        case("backlash absorbed", vec![backlash(2.0)], vec![REVERSAL]),
        case("thermal absorbed", vec![thermal(0.0, 8.0)], vec![DRIFT]),
        case("screw absorbed", vec![screw(1.0, 45.0)], vec![CYCLIC]),
        case("scale absorbed", vec![scale(2.0)], vec![EXPANSION]),
        case("bar absorbed", vec![bar(2.0, 0.0)], vec![BAR]),
        // … masked by a larger effect of another class …
        case(
            "backlash masked by a drift",
            vec![backlash(1.0), thermal(6.0, 6.0)],
            vec![REVERSAL, DRIFT],
        ),
        case(
            "thermal masked by lost motion",
            vec![thermal(1.0, 2.0), backlash(5.0)],
            vec![DRIFT, REVERSAL],
        ),
        case(
            "screw masked by lost motion",
            vec![screw(0.6, 7.0), backlash(4.0)],
            vec![CYCLIC, REVERSAL],
        ),
        case(
            "scale masked by a drift",
            vec![scale(1.0), thermal(6.0, 6.0)],
            vec![EXPANSION, DRIFT],
        ),
        case(
            "bar masked by lost motion",
            vec![bar(2.0, 0.0), backlash(4.0)],
            vec![BAR, REVERSAL],
        ),
        // … and in pairs of alike size.
        case(
            "thermal and scale",
            vec![thermal(3.0, 3.0), scale(1.5)],
            vec![DRIFT, EXPANSION],
        ),
        case(
            "screw and scale",
            vec![screw(1.0, 7.0), scale(1.5)],
            vec![CYCLIC, EXPANSION],
        ),
        // An instrument's set-up settling, the look-alike of a machine drift: only its own
        // set-up's runs see it.
        case(
            "ball creep below the noise",
            vec![creep("ball1", [0.8, 0.0, 0.0])],
            vec![CREEP_BALL],
        ),
        case(
            "ball creep",
            vec![creep("ball1", [3.0, 0.0, 0.0])],
            vec![CREEP_BALL],
        ),
        case(
            "pivot creep",
            vec![creep("bar1", [2.0, 0.0, 0.0])],
            vec![CREEP_PIVOT],
        ),
        case(
            "ball creep masked by a drift",
            vec![creep("ball1", [2.0, 0.0, 0.0]), thermal(6.0, 6.0)],
            vec![CREEP_BALL, DRIFT],
        ),
        // X's position loop lagging (a gain mismatch), alone and beside lost motion, which also
        // turns with the direction of motion. Only the ball bar's circles both ways tell it
        // from the location errors (an R-test run turns C one way: X's velocity follows Y's
        // position), and there its ellipse is T·v/2: 0.17 µm at 0.15 ms, below the noise.
        case("servo lag below the noise", vec![servo(0.15)], vec![SERVO]),
        case("servo lag absorbed", vec![servo(0.3)], vec![SERVO]),
        case(
            "servo lag masked by lost motion",
            vec![servo(0.15), backlash(4.0)],
            vec![SERVO, REVERSAL],
        ),
        // Inside the full model: explained by it, nothing claimed.
        case("twist in the full model", vec![twist(4.0)], vec![]),
        case("sag in the full model", vec![sag(3.0)], vec![]),
    ];
    for (name, effects, named) in [
        ("twist outside the model", vec![twist(4.0)], vec![TWIST]),
        ("sag outside the model", vec![sag(3.0)], vec![SAG]),
    ] {
        out.push(Case {
            name: name.into(),
            layout: Layout::Trunnion,
            effects,
            named,
            model: Model::Eleven,
            seed: 1,
        });
    }
    // A rich model the user names (the truth's family), with null directions: a drift in
    // time, a reversal and a cycle are still seen, projected off what the fit determines.
    for (name, effects, named) in [
        ("family model: clean", vec![], vec![]),
        (
            "family model: backlash",
            vec![backlash(2.0)],
            vec![REVERSAL],
        ),
        (
            "family model: thermal",
            vec![thermal(4.0, 4.0)],
            vec![DRIFT],
        ),
        ("family model: screw", vec![screw(1.0, 7.0)], vec![CYCLIC]),
    ] {
        out.push(Case {
            name: name.into(),
            layout: Layout::Trunnion,
            effects,
            named,
            model: Model::Family,
            seed: 1,
        });
    }
    // The three-axis machine measured with a laser interferometer and a laser tracer.
    for (name, effects, named) in [
        ("three-axis: clean", vec![], vec![]),
        ("three-axis: backlash", vec![backlash(2.0)], vec![REVERSAL]),
        // The laser and the tracer zero every run: a drift shows only within runs, and a
        // growth along Z only in the few that read Z; the column bending in X shows in the
        // X positioning runs and every tracer run.
        (
            "three-axis: thermal",
            vec![thermal_along([1.0, 0.0, 0.0], 6.0, 6.0)],
            vec![DRIFT_X],
        ),
        ("three-axis: scale", vec![scale(2.0)], vec![EXPANSION]),
        (
            "three-axis: backlash and scale",
            vec![backlash(1.5), scale(1.5)],
            vec![REVERSAL, EXPANSION],
        ),
    ] {
        out.push(Case {
            name: name.into(),
            layout: Layout::ThreeAxis,
            effects,
            named,
            model: Model::Full,
            seed: 1,
        });
    }
    out
}

/// A random draw of location, squareness and linear-axis component errors (on the trunnion the
/// rotary axes' error motions removed).
fn truth(layout: Layout, seed: u64) -> (Machine, Truth) {
    let file = match layout {
        Layout::Trunnion => "mcu630-cafyxz.urdf",
        Layout::ThreeAxis => "mcv754-zfyx.urdf",
    };
    let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
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

/// The session as a user has it: the machine's URDF beside it without its `.errors.toml`, and
/// `[identify] parameters` only for [`Model::Eleven`] and [`Model::Family`].
fn as_a_user_has_it(dir: &Path, model: Model) {
    let list = match model {
        Model::Full => None,
        Model::Eleven => Some(ELEVEN),
        Model::Family => Some(FAMILY),
    };
    mtcal_testkit::sessions::as_a_user_has_it(dir, list);
}

/// What a case came to.
struct Outcome {
    name: String,
    /// Per planted effect: named (by the discovery or among its look-alikes).
    named: Vec<bool>,
    /// Discoveries that match no planted effect.
    claims: Vec<String>,
    /// Per validation run the fitted runs determine: RMS of prediction − truth over σ.
    validation: Vec<(String, f64)>,
    /// Machine parameters a discovery corrected (it had biased them): name, whether the value
    /// after the search is within its 99 % interval of the truth.
    corrected: Vec<(String, bool)>,
    /// The case's effects are inside the model: nothing may be claimed.
    inside: bool,
    summary: String,
}

impl Outcome {
    fn right(&self) -> bool {
        self.named.iter().all(|&n| n) && self.claims.is_empty()
    }

    fn predicted(&self) -> bool {
        self.validation.iter().all(|v| v.1 <= PREDICTION_OVER_NOISE)
    }
}

/// A prediction within 1.2 × the noise: readings scatter about it by at most 1.2 σ,
/// `√(σ² + e²) ≤ 1.2 σ`, i.e. its RMS error against the truth is at most 0.66 σ.
const PREDICTION_OVER_NOISE: f64 = 0.663;

fn matches(d: &mtcal_identify::search::Discovery, n: &Named) -> bool {
    let on =
        |class: &str, axis: &Option<String>, driver: &Option<String>, comp: &Option<String>| {
            class == n.class
                && [axis, driver, comp]
                    .iter()
                    .any(|f| f.as_deref() == Some(n.on))
        };
    on(&d.effect, &d.axis, &d.driver, &d.component)
        || d.alternatives.iter().any(|a| {
            a.effect == n.class
                && (a.label.contains(&format!(" {} ", n.on))
                    || a.label.contains(&format!("({})", n.on)))
        })
}

fn run_case(case: &Case) -> Outcome {
    let tmp = tempfile::tempdir().unwrap();
    // `KEEP=dir` keeps each session (under its case's name and seed) to look at or time with
    // `mtcal`.
    let dir = match std::env::var("KEEP") {
        Ok(keep) => Path::new(&keep).join(format!(
            "{}_seed_{}",
            case.name.replace([' ', '\'', ','], "_"),
            case.seed
        )),
        Err(_) => tmp.path().join("session"),
    };
    let (_, mut truth) = truth(case.layout, case.seed);
    if case.model == Model::Eleven {
        // The truth inside the eleven-error family: the twist or sag is all it leaves out.
        for axis in truth.axes.iter_mut() {
            axis.component = [[0.0; 4]; 6];
        }
    }
    let realism = Realism::realistic(1000 + case.seed);
    let written = match case.layout {
        Layout::Trunnion => Campaign::trunnion_thermal_check(&dir, &truth, &case.effects, &realism),
        Layout::ThreeAxis => {
            Campaign::three_axis_laser_tracer(&dir, &truth, &case.effects, &realism)
        }
    }
    .unwrap();
    as_a_user_has_it(&dir, case.model);
    let (study, base) =
        base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
    let mut result = search(study, &SearchOptions::default()).unwrap();
    if let Some(base) = &base {
        result = result.with_base(base).unwrap();
    }
    outcome(case, &written, &realism, &result)
}

/// 99 % over 95 % half-width of a normal interval.
const K99: f64 = 2.576 / 1.96;

/// The truth of an mtcal parameter name (µm, µrad): `E<d>0<axis>` a location or squareness
/// error, `E<d><axis>.P<k>` a Legendre coefficient of a linear axis' component error (the
/// simulator keeps the same Legendre coefficients over the stroke); `None` for the others.
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

fn outcome(case: &Case, written: &Written, realism: &Realism, result: &SearchResult) -> Outcome {
    let id = &result.identification;
    let found = &result.findings;
    let named: Vec<bool> = case
        .named
        .iter()
        .map(|n| found.discoveries.iter().any(|d| matches(d, n)))
        .collect();
    let claims = found
        .discoveries
        .iter()
        .filter(|d| !case.named.iter().any(|n| matches(d, n)))
        .map(|d| d.label.clone())
        .collect();
    let noise_um = (realism.noise_sigma_um.powi(2) + realism.resolution_um.powi(2) / 12.0).sqrt();
    let study = &result.study;
    let mut validation = Vec::new();
    for (r, run) in study.runs.iter().enumerate() {
        if run.fit
            || id
                .undetermined_validation
                .iter()
                .any(|(n, _)| *n == run.name)
        {
            continue;
        }
        let clean = &written
            .runs
            .iter()
            .find(|w| w.name == run.name)
            .unwrap()
            .clean_um;
        let pred = predict_run(study, r, &result.solution.x);
        let nch = study.channels(r).len();
        // The simulator zeroes a tracer's readings at each run's first sample, the plugin keeps
        // one dead path per set-up: a tracer run is compared up to its datum.
        let datum = study.setups[run.setup].plugin.name == "tracer";
        let mut ss = 0.0;
        for c in 0..nch {
            let errors: Vec<f64> = clean
                .iter()
                .enumerate()
                .map(|(i, row)| pred[i * nch + c] * 1e6 - row[c])
                .collect();
            let mean = if datum {
                errors.iter().sum::<f64>() / errors.len() as f64
            } else {
                0.0
            };
            ss += errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>();
        }
        let rms = (ss / (clean.len() * nch) as f64).sqrt();
        validation.push((run.name.clone(), rms / noise_um));
    }
    let (machine, _) = truth(case.layout, case.seed);
    let corrected = found
        .discoveries
        .iter()
        .flat_map(|d| &d.corrected)
        .filter_map(|c| {
            let t = truth_value(&machine, &written.truth, &c.name)?;
            Some((c.name.clone(), (c.after - t).abs() <= K99 * c.u95))
        })
        .collect();
    Outcome {
        name: case.name.clone(),
        named,
        claims,
        validation,
        corrected,
        inside: case.named.is_empty() && !case.effects.is_empty(),
        summary: found.summary(),
    }
}

/// Seeds of the truth and the noise each case is run with.
const SEEDS: [u64; 2] = [1, 2];

#[test]
fn planted_effects_are_named_and_the_validation_runs_predicted() {
    let only = std::env::var("CASES").ok();
    let seeds: Vec<u64> = match std::env::var("SEED") {
        Ok(seed) => vec![seed.parse().unwrap()],
        Err(_) => SEEDS.to_vec(),
    };
    let cases: Vec<Case> = seeds
        .iter()
        .flat_map(|&seed| {
            cases()
                .into_iter()
                .filter(|c| {
                    only.as_deref()
                        .is_none_or(|o| o.split(',').any(|w| c.name.contains(w)))
                })
                .map(move |c| Case { seed, ..c })
        })
        .collect();
    let outcomes = parallel(&cases, run_case);
    let (mut right, mut predicted, mut effects, mut named) = (0, 0, 0, 0);
    let (mut corrected, mut within) = (0, 0);
    for (o, case) in outcomes.iter().zip(&cases) {
        let worst = o.validation.iter().map(|v| v.1).fold(0.0, f64::max);
        eprintln!(
            "{:<34} seed {} {} named {}/{}, claims {:?}, worst validation {:.2} σ, corrected {:?}",
            o.name,
            case.seed,
            if o.right() { "RIGHT" } else { "WRONG" },
            o.named.iter().filter(|&&n| n).count(),
            o.named.len(),
            o.claims,
            worst,
            o.corrected
        );
        if !o.right() || std::env::var("VERBOSE").is_ok() {
            eprintln!("validation {:?}", o.validation);
            eprintln!("{}", o.summary);
        }
        // An effect the model already contains is explained by it: nothing is claimed.
        assert!(
            !o.inside || o.claims.is_empty(),
            "{} (seed {}): claims {:?} for an effect the model contains\n{}",
            o.name,
            case.seed,
            o.claims,
            o.summary
        );
        right += usize::from(o.right());
        predicted += usize::from(o.predicted());
        effects += o.named.len();
        named += o.named.iter().filter(|&&n| n).count();
        corrected += o.corrected.len();
        within += o.corrected.iter().filter(|c| c.1).count();
    }
    let n = outcomes.len();
    eprintln!(
        "{right}/{n} cases right; {named}/{effects} planted effects named; validation runs \
         within 1.2 × the noise in {predicted}/{n} cases; {within}/{corrected} biased parameters \
         corrected to within their 99 % interval of the truth"
    );
    let share = |a: usize, b: usize| a as f64 / b.max(1) as f64;
    assert!(share(named, effects) >= 0.9, "{named}/{effects} named");
    assert!(share(right, n) >= 0.9, "{right}/{n} cases right");
    assert!(share(predicted, n) >= 0.9, "{predicted}/{n} predicted");
    assert!(
        share(within, corrected) >= 0.9,
        "{within}/{corrected} corrected"
    );
}

/// Fifty clean sessions (the truth inside the full model, nothing planted; AR(1) noise, the σ in
/// the manifest 20 % too small or too large): the search claims an effect in at most 5 % of
/// them.
#[test]
fn clean_sessions_from_the_independent_simulator_rarely_raise_a_claim() {
    let seeds: Vec<u64> = match std::env::var("CLEAN_SEEDS") {
        Ok(list) => list.split(',').map(|s| s.parse().unwrap()).collect(),
        Err(_) => (100..150).collect(),
    };
    let claims = parallel(&seeds, |&seed| {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("session");
        let (_, truth) = truth(Layout::Trunnion, seed);
        let realism = Realism {
            manifest_sigma_factor: if seed % 2 == 0 { 0.8 } else { 1.2 },
            ..Realism::realistic(2000 + seed)
        };
        Campaign::trunnion_thermal_check(&dir, &truth, &[], &realism).unwrap();
        as_a_user_has_it(&dir, Model::Full);
        let (study, _) =
            base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
        let result = search(study, &SearchOptions::default()).unwrap();
        if std::env::var("VERBOSE").is_ok() {
            eprintln!("seed {seed}: {}", result.findings.summary());
        }
        result
            .findings
            .discoveries
            .iter()
            .map(|d| d.label.clone())
            .collect::<Vec<_>>()
    });
    let claimed: Vec<(u64, &Vec<String>)> = seeds
        .iter()
        .copied()
        .zip(&claims)
        .filter(|(_, c)| !c.is_empty())
        .collect();
    eprintln!(
        "{} of 50 clean sessions claimed an effect: {claimed:?}",
        claimed.len()
    );
    assert!(claimed.len() <= 2, "{} of 50: {claimed:?}", claimed.len());
}

/// Look-alikes: the head warms along Z as a recorded temperature rises, both as
/// `1 − exp(−t/15 min)`. A drift in time and a coupling to that temperature explain the
/// recordings alike: the search keeps one for its predictions, names the other beside it with
/// the measurement that would tell them apart, and claims neither as the answer.
#[test]
fn a_drift_and_a_temperature_that_follows_it_are_named_together() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("session");
    let (_, truth) = truth(Layout::Trunnion, 1);
    let rise = |gain: f64| HeatSource {
        gain,
        tau_s: 900.0,
        power: Programme::constant(1.0),
    };
    let effects = vec![
        Effect::Thermal {
            direction: [0.0, 0.0, 1.0],
            sources: vec![rise(6e-6)],
        },
        // Only the column: the scale does not move.
        Effect::ThermalScale {
            axis: 'X',
            ppm_per_k: 0.0,
            reference: 0.0,
            temperature: TemperatureProgramme {
                ambient_c: 20.0,
                drift_k_per_h: 0.0,
                rises: vec![rise(2.0)],
            },
            column: "T_head".into(),
        },
    ];
    let realism = Realism::realistic(1001);
    Campaign::trunnion_thermal_check(&dir, &truth, &effects, &realism).unwrap();
    as_a_user_has_it(&dir, Model::Full);
    let (study, _) =
        base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
    let result = search(study, &SearchOptions::default()).unwrap();
    let found = &result.findings;
    let summary = found.summary();
    let d = found
        .discoveries
        .iter()
        .find(|d| d.axis.as_deref() == Some("Z"))
        .unwrap_or_else(|| panic!("no discovery on Z:\n{summary}"));
    let classes: Vec<&str> = std::iter::once(d.effect.as_str())
        .chain(d.alternatives.iter().map(|a| a.effect.as_str()))
        .collect();
    assert!(
        classes.contains(&"thermal-drift") && classes.contains(&"temperature-coupling"),
        "{classes:?}\n{summary}"
    );
    assert!(
        d.alternatives.iter().all(|a| !a.measurement.is_empty()),
        "{summary}"
    );
    let brief = d.in_brief();
    assert!(brief.contains("CANNOT TELL IT FROM"), "{brief}");
}

/// The independent simulator's volumetric session on `which` (`file` its URDF) from `spec`
/// with realistic noise of `seed`, loaded as a user would and searched.
fn searched_volumetric(
    which: mtcal_indsim::VolumetricMachine,
    file: &str,
    spec: &mtcal_indsim::VolumetricSpec,
    seed: u64,
) -> (SearchResult, mtcal_indsim::VolumetricWritten) {
    use mtcal_indsim::VolumetricMachine;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("session");
    let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
    let truth = Truth::zero(&machine);
    let realism = Realism::realistic(seed);
    let written = match which {
        VolumetricMachine::Trunnion => Campaign::volumetric_trunnion(&dir, &truth, spec, &realism),
        VolumetricMachine::ThreeAxis => {
            Campaign::volumetric_three_axis(&dir, &truth, spec, &realism)
        }
    }
    .unwrap();
    let (study, base) =
        base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
    let mut result = search(study, &SearchOptions::default()).unwrap();
    if let Some(base) = &base {
        result = result.with_base(base).unwrap();
    }
    (result, written)
}

/// The volumetric thermal test of source 000 (docs/VOLUMETRIC.md) as the search sees it on a
/// short course: the independent simulator's Y-drive load (the Y screw's scale growing
/// 1.5 ppm/K with the drive's temperature, the spindle head turning about X with it, 3 µrad/K
/// about a line far above the work volume), twelve cycles of fifteen visits, realistic noise.
/// Both are named with the planted values inside their 95 % intervals, and nothing but thermal
/// effects is claimed (before the balls' runs, which overlap in time, had their temperatures
/// evaluated in time, the three-axis machine's scale growth went unnamed; before a set-up seen
/// at one pose stopped being a candidate for a drift of its own, its balls were said to drift).
fn volumetric_search_names_the_drive(which: mtcal_indsim::VolumetricMachine, file: &str) {
    use mtcal_indsim::{VolumetricLoad, VolumetricSpec};
    let thermal = [
        "thermal-drift",
        "temperature-coupling",
        "thermal-expansion",
        "thermal-model",
        "thermal-tilt",
    ];
    let spec = VolumetricSpec::short(VolumetricLoad::YDrive, 12);
    let (result, _) = searched_volumetric(which, file, &spec, 7);
    let found = &result.findings;
    let summary = found.summary_with(std::env::var("VERBOSE").is_ok());
    for d in &found.discoveries {
        assert!(
            thermal.contains(&d.effect.as_str()),
            "{which:?}: {} claimed\n{summary}",
            d.label
        );
    }
    for (effect, on, planted) in [
        ("thermal-expansion", "Y", 1.5),
        ("thermal-tilt", "turn about X", 3.0),
    ] {
        let d = found
            .discoveries
            .iter()
            .find(|d| {
                d.effect == effect
                    && (d.axis.as_deref() == Some(on) || d.component.as_deref() == Some(on))
                    && d.driver.as_deref() == Some("T_ydrive")
            })
            .unwrap_or_else(|| panic!("{which:?}: {effect} {on} is not named\n{summary}"));
        let p = &d.parameters[0];
        let u95 = p.u95.unwrap_or(0.0);
        assert!(
            (p.value - planted).abs() <= u95,
            "{which:?}: {} = {} ± {} {}, planted {planted}\n{summary}",
            p.name,
            p.value,
            u95,
            p.unit
        );
    }
}

#[test]
fn a_volumetric_thermal_test_on_the_trunnion_names_the_drive_s_scale_and_tilt() {
    volumetric_search_names_the_drive(
        mtcal_indsim::VolumetricMachine::Trunnion,
        "mcu630-cafyxz.urdf",
    );
}

/// On the three-axis machine the balls stand at three heights, each visited at one place: the
/// head's turn moves them along Y in proportion to their height.
#[test]
fn a_volumetric_thermal_test_on_the_three_axis_machine_names_the_drive_s_scale_and_tilt() {
    volumetric_search_names_the_drive(
        mtcal_indsim::VolumetricMachine::ThreeAxis,
        "mcv754-zfyx.urdf",
    );
}

/// A volumetric session of the independent simulator and what it planted: per planted effect,
/// the discovery that names it (family, what it acts on, its driver) and, where the family
/// carries the planted number, that number.
struct VolumetricCase {
    which: mtcal_indsim::VolumetricMachine,
    file: &'static str,
    load: mtcal_indsim::VolumetricLoad,
    ambient: bool,
    seed: u64,
}

/// One planted effect as the search should name it.
struct Planted {
    what: &'static str,
    /// Whether a discovery names it: its family (or one that holds it), what it acts on, its
    /// driver.
    names: fn(&mtcal_identify::search::Discovery) -> bool,
    /// Whether a discovery describes it without naming its driver (not a false claim): the
    /// spindle's growth as a drift in time.
    describes: fn(&mtcal_identify::search::Discovery) -> bool,
    /// The planted value of the discovery's first parameter, where the family carries it.
    value: Option<f64>,
}

fn planted_in(case: &VolumetricCase) -> Vec<Planted> {
    use mtcal_indsim::VolumetricLoad;
    let mut out = match case.load {
        VolumetricLoad::YDrive => vec![
            Planted {
                what: "the Y scale growing 1.5 ppm/K with T_ydrive",
                names: |d| {
                    d.effect == "thermal-expansion"
                        && d.axis.as_deref() == Some("Y")
                        && d.driver.as_deref() == Some("T_ydrive")
                },
                // Where the scale is fixed is an offset that follows the temperature.
                describes: |d| {
                    d.effect == "temperature-coupling" && d.driver.as_deref() == Some("T_ydrive")
                },
                value: Some(1.5),
            },
            Planted {
                what: "the head turning 3 µrad/K about X with T_ydrive",
                names: |d| {
                    d.effect == "thermal-tilt"
                        && d.component.as_deref() == Some("turn about X")
                        && d.driver.as_deref() == Some("T_ydrive")
                },
                describes: |_| false,
                value: Some(3.0),
            },
        ],
        VolumetricLoad::Spindle => vec![
            // The spindle stands still at every visit: its speed is 0 in every row, and the
            // growth shows through the spindle's temperature.
            Planted {
                what: "the spindle growing along Z with its heat",
                names: |d| {
                    d.axis.as_deref() == Some("Z")
                        && d.driver.as_deref().is_some_and(|x| {
                            x.split(',')
                                .any(|p| p == "S" || p == "S^2" || p == "T_spindle")
                        })
                },
                describes: |d| {
                    d.effect == "spindle-growth"
                        || (d.axis.as_deref() == Some("Z") && d.driver.as_deref() == Some("t"))
                },
                value: None,
            },
            Planted {
                what: "the Z screw's scale 2 ppm/K with T_znut",
                names: |d| {
                    d.effect == "thermal-expansion"
                        && d.axis.as_deref() == Some("Z")
                        && d.driver.as_deref() == Some("T_znut")
                },
                // Fixed far from the balls (at Z = 0): an offset that follows T_znut.
                describes: |d| {
                    d.effect == "temperature-coupling" && d.driver.as_deref() == Some("T_znut")
                },
                value: Some(2.0),
            },
        ],
        VolumetricLoad::RotaryDrives => {
            unreachable!("the matrix's loads are the spindle's and the Y drive's")
        }
    };
    if case.ambient {
        out.push(Planted {
            what: "the structure following the room's step",
            names: |d| {
                d.driver
                    .as_deref()
                    .is_some_and(|x| x.split(',').any(|p| p == "T_ambient"))
            },
            // The room moves every axis: a drift of one in time is the step without its driver
            // (along Z, the spindle's axis on these machines, a growth of the spindle in time
            // is the same drift).
            describes: |d| {
                matches!(d.effect.as_str(), "thermal-drift" | "spindle-growth")
                    && d.driver.as_deref() == Some("t")
            },
            value: None,
        });
    }
    out
}

/// What the search made of one volumetric session: planted effects named (of all planted),
/// discoveries that name nothing planted, the withheld cycle's RMS prediction error over the
/// simulator's noise σ and over the RMS of the noise in the withheld readings themselves.
fn run_volumetric(case: &VolumetricCase) -> (usize, usize, Vec<String>, [f64; 2], String) {
    use mtcal_indsim::{AmbientChange, VolumetricSpec};
    let mut spec = VolumetricSpec::new(case.load);
    spec.stream = None;
    if case.ambient {
        spec.ambient_step = Some(AmbientChange::air_conditioning_failure());
    }
    let (result, written) = searched_volumetric(case.which, case.file, &spec, case.seed);
    let id = &result.identification;
    let found = &result.findings;
    let summary = found.summary_with(std::env::var("VERBOSE").is_ok());
    let planted = planted_in(case);
    let mut named = 0;
    let mut notes = Vec::new();
    for p in &planted {
        match found.discoveries.iter().find(|d| (p.names)(d)) {
            Some(d) => {
                let within = p.value.is_none_or(|v| {
                    let q = &d.parameters[0];
                    (q.value - v).abs() <= 1.5 * q.u95.unwrap_or(0.0)
                });
                if within {
                    named += 1;
                } else {
                    notes.push(format!("{}: {} = {:?}", p.what, d.label, d.parameters[0]));
                }
            }
            None => notes.push(format!("{}: not named", p.what)),
        }
    }
    // A joint model is widened when the search proposes it again, never stacked on itself
    // (a second bank of the same columns, withdrawn piece by piece, once left the model at
    // the first one's narrow prior).
    for d in &found.discoveries {
        assert!(
            !(d.effect == "thermal-model" && d.label.contains(" #")),
            "{} stacked on itself\n{summary}",
            d.label
        );
    }
    let false_claims: Vec<String> = found
        .discoveries
        .iter()
        .filter(|d| !planted.iter().any(|p| (p.names)(d) || (p.describes)(d)))
        .map(|d| d.label.clone())
        .collect();
    // The withheld cycle: its readings' RMS prediction error over the noise the simulator
    // added (its σ, not the manifest's, which states 0.8 of it).
    let (mut sum, mut count) = (0.0, 0usize);
    for v in &id.validation {
        for c in &v.channels {
            sum += c.rms * c.rms * c.samples as f64;
            count += c.samples;
        }
    }
    let worst = (sum / count.max(1) as f64).sqrt() / Realism::realistic(case.seed).noise_sigma_um;
    // The noise in the withheld readings themselves: written less noise-free, per visit.
    let (mut sum, mut count) = (0.0, 0usize);
    for v in written
        .visits
        .iter()
        .filter(|v| id.validation.iter().any(|r| r.name == v.run))
    {
        for k in 0..3 {
            sum += (v.written_um[k] - v.clean_um[k]).powi(2);
            count += 1;
        }
    }
    let sigma = Realism::realistic(case.seed).noise_sigma_um;
    let realised = (sum / count.max(1) as f64).sqrt() / sigma;
    let own = worst / realised;
    notes.push(format!(
        "the withheld readings' own noise {realised:.2} σ: the error {own:.2} × it"
    ));
    let text = format!(
        "{:?} {:?} ambient {} seed {}: {named}/{} named, false {false_claims:?}, withheld {worst:.2} × noise {notes:?}\n{summary}",
        case.which,
        case.load,
        case.ambient,
        case.seed,
        planted.len()
    );
    (named, planted.len(), false_claims, [worst, own], text)
}

/// Source 000's volumetric thermal test on both machines of the independent simulator, under
/// spindle load and Y-drive load, with and without the room's temperature stepping, three
/// noise seeds each (24 sessions of 36 cycles): the planted physics (the spindle's growth, the
/// Z screw's and the Y screw's scale, the head turning about X, the structure following the
/// room) is named with its planted values in ≥ 90 % of cases and nothing else is claimed
/// anywhere. The withheld cycle is predicted within 1.2 × the noise its readings hold (45
/// coloured, quantised readings: 0.80 to 1.29 σ by themselves) in every session, and within
/// 1.2 × the simulator's σ in at least 90 % of them and 1.5 × in all. Measured: 59 of 60
/// named (the trunnion's Z-screw scale with the room stepping, seed 110, not), over the
/// readings' own noise 0.88–1.15 ×, over σ 22 of 24 within 1.2 × (the trunnion under Y-drive
/// load, seeds 107 and 109, 1.23 and 1.28 σ: readings of 1.29 and 1.13 σ of noise; their
/// searches find exactly what was planted). Before a scale change was taken about the middle
/// of the heights the balls stand at (about the middle of Z's stroke it was 88 % the offset a
/// joint model of Z already held, and the search took it for a second law of that), the
/// trunnion's Z-screw scale went unnamed in 5 of 6 spindle sessions and one withheld cycle
/// was at 1.22 × its own noise; before a joint model's width was chosen with the machine held
/// when a ball is left out, and widened rather than stacked on itself, 20 of 24 over σ, the
/// trunnion with the room stepping at 1.4–1.7 ×.
#[test]
fn volumetric_thermal_tests_name_what_was_planted() {
    use mtcal_indsim::{VolumetricLoad, VolumetricMachine};
    let mut cases = Vec::new();
    for shift in [0, 100, 200] {
        for (which, file) in [
            (VolumetricMachine::Trunnion, "mcu630-cafyxz.urdf"),
            (VolumetricMachine::ThreeAxis, "mcv754-zfyx.urdf"),
        ] {
            for (load, ambient, seed) in [
                (VolumetricLoad::YDrive, false, 7),
                (VolumetricLoad::Spindle, false, 8),
                (VolumetricLoad::YDrive, true, 9),
                (VolumetricLoad::Spindle, true, 10),
            ] {
                cases.push(VolumetricCase {
                    which,
                    file,
                    load,
                    ambient,
                    seed: seed + shift,
                });
            }
        }
    }
    // One session alone, to look at it (`VOLUMETRIC_SEED=109 VERBOSE=1`).
    if let Ok(seed) = std::env::var("VOLUMETRIC_SEED") {
        let seed: u64 = seed.parse().unwrap();
        cases.retain(|c| c.seed == seed);
    }
    let outcomes = parallel(&cases, run_volumetric);
    let (mut named, mut planted) = (0, 0);
    let mut report = String::new();
    for (n, p, _, _, text) in &outcomes {
        named += n;
        planted += p;
        report.push_str(text);
        report.push('\n');
    }
    let lines: Vec<&str> = report
        .lines()
        .filter(|l| l.contains(" named, false "))
        .collect();
    eprintln!("{}", lines.join("\n"));
    assert!(
        outcomes.iter().all(|o| o.2.is_empty()),
        "claims of what was not planted:\n{report}"
    );
    assert!(
        10 * named >= 9 * planted,
        "{named} of {planted} named\n{report}"
    );
    // Over the noise the withheld readings hold (a cycle's 45 coloured, quantised readings
    // are 0.8 to 1.3 σ of noise by themselves): every one within 1.2 ×.
    let within_own = outcomes.iter().filter(|o| o.3[1] <= 1.2).count();
    assert!(
        within_own == outcomes.len(),
        "withheld cycles: {within_own} of {} within 1.2 × the noise in them\n{report}",
        outcomes.len()
    );
    // Over the noise's σ: nine in ten within 1.2 ×, all within 1.5 ×.
    let within = outcomes.iter().filter(|o| o.3[0] <= 1.2).count();
    assert!(
        10 * within >= 9 * outcomes.len() && outcomes.iter().all(|o| o.3[0] <= 1.5),
        "withheld cycles: {within} of {} within 1.2 × σ\n{report}",
        outcomes.len()
    );
}

/// Which set-up parameters move the readings as the machine's own field at the place the
/// set-up is seen would: on the trunnion each ball is seen at three turns of C (A level), so its
/// place across the table turns with C while its height and the tool's length stay along the
/// machine's Z; on the three-axis machine each ball is seen at one place, and every parameter
/// is the field there by another name. Their drift is proposed only where it is not.
#[test]
fn set_up_parameters_that_look_like_the_machine_s_field() {
    use mtcal_indsim::{VolumetricLoad, VolumetricSpec};
    let spec = VolumetricSpec::short(VolumetricLoad::YDrive, 3);
    for (file, turns) in [("mcu630-cafyxz.urdf", true), ("mcv754-zfyx.urdf", false)] {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("session");
        let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
        let truth = Truth::zero(&machine);
        let realism = Realism::realistic(3);
        if turns {
            Campaign::volumetric_trunnion(&dir, &truth, &spec, &realism)
        } else {
            Campaign::volumetric_three_axis(&dir, &truth, &spec, &realism)
        }
        .unwrap();
        let study = Study::load(&dir).unwrap();
        let view = study.view();
        for setup in &view.setups {
            for (n, &like) in setup.nuisance.iter().zip(&setup.field_like) {
                let expected = !turns || matches!(n.name.as_str(), "ball_z" | "tool_length");
                assert_eq!(like, expected, "{file}: {}.{}", setup.name, n.name);
            }
        }
    }
}

/// Source 000's R-test sets repeated between load cycles of the rotary drives (§5.5): an XYC
/// and a YZA set of the trunnion measured in every cycle, the A cradle and the C table loaded
/// in turn, the A drive's temperature moving A's line 0.8 µm/K along Y and the C motor's
/// moving C's line 0.5 µm/K along X (the independent simulator's axis lines, not mtcal's
/// family), realistic noise; 16 cycles, the first 12 phases between them loaded, the last
/// cycle withheld. The search names both location errors with their drivers, the planted
/// gains inside their 95 % intervals, claims nothing else, and the withheld cycle is predicted
/// within 1.5 × the noise; cycle by cycle, each moving line's own change agrees with the
/// truth and no other location error is said to change.
#[test]
fn repeated_rtest_sets_between_rotary_load_cycles_name_the_moving_axis_lines() {
    use mtcal_indsim::{VolumetricLoad, VolumetricMachine, VolumetricSpec};
    let spec = VolumetricSpec {
        loaded_phases: 12,
        ..VolumetricSpec::short(VolumetricLoad::RotaryDrives, 16)
    };
    for seed in [7, 8] {
        let (result, _) = searched_volumetric(
            VolumetricMachine::Trunnion,
            "mcu630-cafyxz.urdf",
            &spec,
            seed,
        );
        let id = &result.identification;
        let found = &result.findings;
        let summary = found.summary_with(std::env::var("VERBOSE").is_ok());
        eprintln!("seed {seed}\n{summary}");
        for (parameter, driver, planted) in [("EY0A", "T_adrive", 0.8), ("EX0C", "T_cdrive", 0.5)] {
            let d = found
                .discoveries
                .iter()
                .find(|d| {
                    d.effect == "thermal-location"
                        && d.component.as_deref() == Some(parameter)
                        && d.driver.as_deref() == Some(driver)
                })
                .unwrap_or_else(|| {
                    panic!("seed {seed}: {parameter} ({driver}) is not named\n{summary}")
                });
            let p = &d.parameters[0];
            let u95 = p.u95.unwrap_or(0.0);
            assert!(
                (p.value - planted).abs() <= u95,
                "seed {seed}: {} = {} ± {} {}, planted {planted}\n{summary}",
                p.name,
                p.value,
                u95,
                p.unit
            );
        }
        assert_eq!(
            found.discoveries.len(),
            2,
            "seed {seed}: more claimed\n{summary}"
        );
        // The location errors cycle by cycle: each moving line's change in each cycle within
        // its interval (and 0.1 µm for the fit's constant) of the truth, the planted gain
        // times the drive's rise over the cycle, in 14 of 16 cycles; no other error said to
        // change.
        let series = mtcal_identify::series::summary(&id.location_series, true);
        let view = result.study.view();
        let timeline = view.timeline();
        let times: Vec<f64> = (0..timeline.len()).map(|k| timeline.get(k)).collect();
        for (parameter, driver, gain) in [("EY0A", "T_adrive", 0.8), ("EX0C", "T_cdrive", 0.5)] {
            let l = id
                .location_series
                .iter()
                .find(|l| l.parameter == parameter)
                .unwrap_or_else(|| panic!("seed {seed}: no series of {parameter}\n{series}"));
            assert!(
                l.modelled && !l.departs,
                "seed {seed}: {parameter}\n{series}"
            );
            assert_eq!(l.cycles.len(), 16, "seed {seed}\n{series}");
            let rise = view.input(&mtcal_effects::Input::Context(driver.into()));
            let mut near = 0;
            for v in &l.cycles {
                let (from, to) = (v.t_first_h * 3600.0 - 1e-6, v.t_last_h * 3600.0 + 1e-6);
                let inside: Vec<f64> = (0..times.len())
                    .filter(|&k| times[k] >= from && times[k] <= to)
                    .map(|k| rise[k])
                    .collect();
                let truth = gain * inside.iter().sum::<f64>() / inside.len() as f64;
                if let (Some(x), Some(u)) = (v.value, v.u95)
                    && (x - truth).abs() <= u + 0.1
                {
                    near += 1;
                }
            }
            assert!(
                near >= 14,
                "seed {seed}: {parameter} near the truth in {near} of 16\n{series}"
            );
        }
        for l in &id.location_series {
            assert!(
                !l.departs,
                "seed {seed}: {} said to change beyond the model\n{series}",
                l.parameter
            );
        }
        // Neither is said to be indistinguishable from the other: both are in the model.
        for d in &found.discoveries {
            for a in &d.alternatives {
                assert!(
                    !found.discoveries.iter().any(|o| o.label == a.label),
                    "seed {seed}: {} said to look like {}, a discovery of its own\n{summary}",
                    d.label,
                    a.label
                );
            }
        }
        // The withheld cycle (the last, after four cycles of rest): its RMS prediction error
        // over the noise the simulator added.
        let (mut sum, mut count) = (0.0, 0usize);
        for v in &id.validation {
            for c in &v.channels {
                sum += c.rms * c.rms * c.samples as f64;
                count += c.samples;
            }
        }
        assert!(count > 0, "seed {seed}: no withheld cycle");
        let ratio = (sum / count as f64).sqrt() / Realism::realistic(seed).noise_sigma_um;
        eprintln!("seed {seed}: withheld cycle {ratio:.2} × the noise");
        assert!(
            ratio <= 1.5,
            "seed {seed}: withheld cycle at {ratio:.2} × the noise\n{summary}"
        );
    }
}
