//! A discovery's numbers about positions hold over the positions that were measured, not over
//! the stroke: a worn screw's lost motion that grows along Y (the independent simulator's
//! dead band, its width linear over the stroke), measured by ISO 230-2 runs over a fifth of the
//! stroke with realistic noise. The search names the backlash along the stroke and gives it at
//! the middle of the measured span and its change to the span's end, with the span — what the
//! simulator's truth has there, within the stated intervals (eight draws of the noise). Given over the stroke instead, the
//! change would be the line through the measured fifth carried five times as far: on real runs
//! over a thirtieth of the stroke, "865 ± 421 µm" for a backlash of 17 µm.

use crate::common;

use common::honesty::honest;
use mtcal_identify::search::search;
use mtcal_identify::{Study, base};
use mtcal_indsim::effects::Effect;
use mtcal_indsim::{
    Approach, Instrument, LaserMode, Machine, Plan, Realism, RunPlan, SetupPlan, Truth, paths,
    shipped_machine, write_session,
};
use mtcal_solve::Options;
use mtcal_testkit::sessions::as_a_user_has_it;
use rand::SeedableRng;
use std::path::Path;

/// Y's lost motion at its stroke's low and high end (m): 2 µm to 22 µm.
const LOW_M: f64 = 2e-6;
const HIGH_M: f64 = 22e-6;
/// The targets: Y −60…60 mm (and 5 mm of overrun beyond each end), of a −250…250 mm stroke.
const FROM_M: f64 = -0.06;
const TO_M: f64 = 0.06;

fn session(dir: &Path, seed: u64) -> Machine {
    let urdf = shipped_machine("mcv754-zfyx.urdf");
    let machine = Machine::from_urdf_file(&urdf).unwrap();
    let truth = Truth::random(
        &machine,
        &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed),
        1.0,
    );
    let hold = [('X', 0.0), ('Z', -0.25)];
    let iso = || paths::bidirectional(&machine, 'Y', FROM_M, TO_M, 13, 5, 0.005, &hold).unwrap();
    let laser = Instrument::Laser {
        mode: LaserMode::Linear,
        direction: [0.0, 1.0, 0.0],
        across: [0.0; 3],
        optic_offset_mm: [0.0, 0.0, -80.0],
    };
    let run = |name: &str, validate: bool| RunPlan {
        name: name.into(),
        setup: "laser-y".into(),
        validate,
        poses: iso(),
        labels: Vec::new(),
        interval_s: None,
        pause_before_s: None,
    };
    let plan = Plan {
        machine_urdf: urdf,
        setups: vec![SetupPlan {
            name: "laser-y".into(),
            instrument: laser,
        }],
        runs: vec![
            run("y-first", false),
            run("y-second", false),
            run("y-check", true),
        ],
        effects: vec![Effect::LostMotion {
            axis: 'Y',
            lost_motion_low: LOW_M,
            lost_motion_high: HIGH_M,
            approach: Approach::Carried,
        }],
    };
    write_session(dir, &machine, &truth, &plan, &Realism::realistic(seed)).unwrap();
    as_a_user_has_it(dir, Some(r#"["EYY"]"#));
    machine
}

#[test]
fn a_backlash_along_part_of_the_stroke_is_given_over_the_positions_measured() {
    let (mut within, mut judged) = (0, 0);
    for seed in 1..=8 {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("session");
        let machine = session(&dir, seed);
        let (lo, hi) = machine.joints[machine.index('Y').unwrap()].stroke();
        let (study, _) =
            base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
        let result = search(study, &Default::default()).unwrap();
        honest(&result).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let found = &result.findings.discoveries;
        // Nothing else is planted, nothing else is claimed.
        let labels: Vec<&str> = found.iter().map(|d| d.label.as_str()).collect();
        assert_eq!(labels, ["reversal Y (along Y)"], "seed {seed}");
        let along = found
            .iter()
            .find(|d| d.label == "reversal Y (along Y)")
            .unwrap_or_else(|| {
                let labels: Vec<&str> = found.iter().map(|d| d.label.as_str()).collect();
                panic!("seed {seed}: no backlash along Y among {labels:?}")
            });
        // The span is what the fitted runs cover: the targets and the overrun beyond them.
        let [span] = &along.spans[..] else {
            panic!("seed {seed}: spans {:?}", along.spans)
        };
        assert_eq!((span.axis.as_str(), span.unit.as_str()), ("Y", "mm"));
        let (from_mm, to_mm) = (span.from, span.to);
        assert!(
            (from_mm - (FROM_M * 1e3 - 5.0)).abs() < 0.01
                && (to_mm - (TO_M * 1e3 + 5.0)).abs() < 0.01,
            "seed {seed}: span {from_mm} … {to_mm} mm"
        );
        // The truth there: the dead band's width, linear over the stroke.
        let width_um =
            |q_mm: f64| 1e6 * (LOW_M + (HIGH_M - LOW_M) * (q_mm * 1e-3 - lo) / (hi - lo));
        let middle_mm = 0.5 * (from_mm + to_mm);
        let param = |name: &str| {
            along
                .parameters
                .iter()
                .find(|p| p.name == name)
                .unwrap_or_else(|| panic!("seed {seed}: no {name}"))
        };
        for (name, truth_um) in [
            ("backlash_um", width_um(middle_mm)),
            ("backlash_change_um", width_um(to_mm) - width_um(middle_mm)),
        ] {
            let p = param(name);
            let u95 = p
                .u95
                .unwrap_or_else(|| panic!("seed {seed}: {name} undetermined"));
            eprintln!(
                "seed {seed}: {name} {:.3} ± {u95:.3} µm, truth {truth_um:.3} µm",
                p.value
            );
            // The noise is coloured (AR(1), φ = 0.6), which an interval from white residuals
            // does not know: each within 1.5 of its intervals, most within one (below).
            judged += 1;
            within += usize::from((p.value - truth_um).abs() <= u95);
            assert!(
                (p.value - truth_um).abs() <= 1.5 * u95,
                "seed {seed}: {name} {:.3} ± {u95:.3} µm, the truth over {from_mm} … {to_mm} mm \
                 {truth_um:.3} µm",
                p.value
            );
        }
        assert!(
            along
                .sentence
                .contains("the positions the fitted runs cover")
                && along.sentence.contains(&format!("to {} mm", to_mm)),
            "seed {seed}: {}",
            along.sentence
        );
    }
    // Measured 2026-11-30: 15 of 16 (seed 1's backlash 1.17 intervals off).
    assert!(within >= 13, "{within} of {judged} within their intervals");
}
