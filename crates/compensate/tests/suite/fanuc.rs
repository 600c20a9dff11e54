//! Fanuc pitch error compensation: the rotary positioning table, the parameter record's round
//! trip, the validator, and — the test that matters — the record applied the way Fanuc's
//! documentation says the control applies it, cancelling the modelled positioning error at
//! the points.

use crate::common;

use common::{TOL_UM, load};
use mtcal_compensate::*;
use mtcal_kinematics::{Machine, MachineModel};
use mtcal_testkit::random::SplitMix64;
use nalgebra::{Matrix3, Vector3};
use std::collections::HashMap;
use std::path::Path;

const MACHINE: &str = "mcu630-cafyxz.urdf";

/// Every coefficient uniform in ±`size` (m or rad).
fn random_coeffs(model: &MachineModel, seed: u64, size: f64) -> Vec<f64> {
    let mut rng = SplitMix64(seed);
    (0..model.n_coeffs()).map(|_| size * rng.signed()).collect()
}

// ---------------------------------------------------------------------------------------
// The model, evaluated here without the crate's tables.

/// Unit vector along which (linear) or about which (rotary) a positive command of axis `i`
/// moves the tool relative to the workpiece, from two nominal poses.
fn nominal_direction(machine: &Machine, q: &[f64], i: usize, rotary: bool) -> Vector3<f64> {
    let mut q1 = q.to_vec();
    q1[i] += 0.25;
    let (a, b) = (machine.tool_in_workpiece(q), machine.tool_in_workpiece(&q1));
    if !rotary {
        return (b.t - a.t).normalize();
    }
    let r: Matrix3<f64> = b.r * a.r.transpose();
    Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    )
    .normalize()
}

/// The model's compensation (−error along or about the axis) of axis `letter` at `position`
/// (mm → µm, or degrees → µrad), the other axes at `hold`.
fn model_compensation(
    model: &MachineModel,
    coeffs: &[f64],
    hold: &[f64],
    letter: char,
    position: f64,
) -> f64 {
    let machine = model.machine();
    let i = machine.axis_index(letter).unwrap();
    let rotary = letter.is_ascii_uppercase() && "ABC".contains(letter);
    let mut q = hold.to_vec();
    q[i] = if rotary {
        position.to_radians()
    } else {
        position * 1e-3
    };
    let e = model.pose_error(&q, coeffs, &mut model.workspace());
    let d = nominal_direction(machine, &q, i, rotary);
    let part = if rotary { e.rotation } else { e.translation };
    -part.dot(&d) * 1e6
}

// ---------------------------------------------------------------------------------------
// The control's side, written from the documentation (B-63980EN pp. 99–100, A-77810E): parse
// the record's text, then add up the values from the reference point.

/// The record as the control reads it: parameter words by (parameter, axis) and pitch data
/// by point number.
struct Tape {
    params: HashMap<(u32, u32), String>,
    points: HashMap<u32, i64>,
}

fn read_tape(text: &str) -> Tape {
    let blocks: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    assert_eq!(blocks.first(), Some(&"%"), "a record starts with %");
    assert_eq!(blocks.last(), Some(&"%"), "a record ends with %");
    let mut tape = Tape {
        params: HashMap::new(),
        points: HashMap::new(),
    };
    for block in &blocks[1..blocks.len() - 1] {
        let rest = block.strip_prefix('N').expect("a block starts with N");
        let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
        let number: u32 = digits.parse().unwrap();
        let rest = &rest[digits.len()..];
        if number >= 10_000 {
            let rest = rest.strip_prefix("Q0").unwrap_or(rest);
            let value = rest.strip_prefix('P').unwrap().parse().unwrap();
            assert!(tape.points.insert(number - 10_000, value).is_none());
        } else {
            let rest = rest.strip_prefix("Q1").unwrap_or(rest);
            for word in rest.split('A').skip(1) {
                let (axis, value) = word.split_once('P').unwrap();
                tape.params
                    .insert((number, axis.parse().unwrap()), value.to_string());
            }
        }
    }
    tape
}

impl Tape {
    fn int(&self, parameter: u32, axis: u32) -> i64 {
        self.params[&(parameter, axis)].parse().unwrap()
    }

    /// 3624/3625 in detection units: integers on 16/18, mm or degrees on 30i.
    fn length_units(&self, parameter: u32, axis: u32, du: f64) -> i64 {
        let text = &self.params[&(parameter, axis)];
        if text.contains('.') {
            (text.parse::<f64>().unwrap() / du).round() as i64
        } else {
            text.parse().unwrap()
        }
    }
}

/// One point as the control reaches it: its offset from the reference position (detection
/// units) and the total compensation there (detection units).
#[derive(Debug)]
struct Applied {
    point: i64,
    offset_units: i64,
    total_units: i64,
}

/// The totals of control axis `axis` at its points 3621 − 1 … 3622: moving away from the
/// reference point the control outputs each interval's value (× 3623) as the axis passes
/// through it, so the total at point k is the sum of the values of the points between the
/// reference and k (negative on the negative side). `reverse`: the negative-direction set
/// (3626…), which starts from 3627 at the reference (reference return in the positive
/// direction).
fn control_totals(tape: &Tape, axis: u32, du: f64, reverse: bool) -> Vec<Applied> {
    let reference = tape.int(3620, axis);
    let first = tape.int(3621, axis);
    let last = tape.int(3622, axis);
    let m = tape.int(3623, axis);
    let interval = tape.length_units(3624, axis, du);
    let (shift, start) = if reverse {
        (tape.int(3626, axis) - first, tape.int(3627, axis))
    } else {
        (0, 0)
    };
    let value = |k: i64| tape.points[&((k + shift) as u32)];
    (first - 1..=last)
        .map(|k| {
            let sum: i64 = if k >= reference {
                (reference + 1..=k).map(value).sum()
            } else {
                -(k + 1..=reference).map(value).sum::<i64>()
            };
            Applied {
                point: k,
                offset_units: (k - reference) * interval,
                total_units: start + m * sum,
            }
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// The rotary positioning table.

#[test]
fn a_full_revolution_rotary_table_is_periodic() {
    let model = load(MACHINE);
    let hold = default_hold(model.machine());
    for seed in [11, 12, 13] {
        let coeffs = random_coeffs(&model, seed, 5e-6);
        let t = rotary_table(&model, &coeffs, 'C', 15.0, &hold).unwrap();
        assert!(t.full_turn);
        assert_eq!(t.positions_deg.first(), Some(&0.0));
        assert_eq!(t.positions_deg.last(), Some(&360.0));
        let largest = t
            .compensation_urad
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            largest > 1.0,
            "seed {seed}: errors too small to test ({largest} µrad)"
        );
        let (a, b) = (t.compensation_urad[0], *t.compensation_urad.last().unwrap());
        assert!(
            (a - b).abs() < 1e-9,
            "seed {seed}: {a} µrad at 0°, {b} µrad at 360°"
        );
        // Wrapping: any angle reads the value of the same angle in the first revolution.
        for x in [7.5, 100.0, 359.0] {
            let v = t.correction_at_urad(x);
            assert!((t.correction_at_urad(x + 720.0) - v).abs() < 1e-9);
            assert!((t.correction_at_urad(x - 360.0) - v).abs() < 1e-9);
        }
        // The A axis has limits: its table runs over them.
        let a_table = rotary_table(&model, &coeffs, 'A', 10.0, &hold).unwrap();
        assert!(!a_table.full_turn);
        assert!((a_table.positions_deg[0] + 30.0).abs() < 1e-9);
        assert!((a_table.positions_deg.last().unwrap() - 120.0).abs() < 1e-9);
    }
    let err = rotary_table(&model, &vec![0.0; model.n_coeffs()], 'X', 10.0, &hold).unwrap_err();
    assert!(
        matches!(err, CompensateError::NotRotary { letter: 'X' }),
        "{err}"
    );
}

/// Commanding θ + c(θ) turns the actual axis to the nominal θ about its own direction (the
/// orientation of the actual tool pose against the nominal one, computed here from the
/// model's tool pose): the compensation has the right sign and size.
#[test]
fn the_rotary_compensation_turns_the_axis_onto_the_command() {
    let model = load(MACHINE);
    let machine = model.machine();
    let hold = default_hold(machine);
    let coeffs = random_coeffs(&model, 21, 5e-6);
    for (letter, spacing) in [('C', 30.0), ('A', 15.0)] {
        let t = rotary_table(&model, &coeffs, letter, spacing, &hold).unwrap();
        let i = machine.axis_index(letter).unwrap();
        let mut worst: f64 = 0.0;
        for (&deg, &c) in t.positions_deg.iter().zip(&t.compensation_urad) {
            let mut q = hold.clone();
            q[i] = deg.to_radians();
            let target = machine.tool_in_workpiece(&q).r;
            let u = nominal_direction(machine, &q, i, true);
            q[i] += c * 1e-6;
            let actual = model.tool_pose(&q, &coeffs, &mut model.workspace()).r;
            let r = actual * target.transpose();
            let about = Vector3::new(
                r[(2, 1)] - r[(1, 2)],
                r[(0, 2)] - r[(2, 0)],
                r[(1, 0)] - r[(0, 1)],
            ) / 2.0;
            worst = worst.max((about.dot(&u) * 1e6).abs());
        }
        let largest = t
            .compensation_urad
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(largest > 1.0, "{letter}: too small to test");
        assert!(
            worst < 1e-3,
            "{letter}: residual {worst} µrad of up to {largest} µrad"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Round trip.

fn axes_of_export(
    model: &MachineModel,
    coeffs: &[f64],
    control: &FanucControl,
    requests: &[FanucRequest],
) -> Vec<FanucConversion> {
    let hold = default_hold(model.machine());
    fanuc_export(model, coeffs, requests, control, &hold).unwrap()
}

fn request(letter: char, number: u32, rotary: bool, interval: f64) -> FanucRequest {
    FanucRequest {
        axis: FanucAxis::new(letter, number, rotary),
        interval,
        layout: FanucLayout::default(),
        reversal: None,
    }
}

#[test]
fn the_parameter_record_reads_back_into_the_same_tables() {
    let model = load(MACHINE);
    let coeffs = random_coeffs(&model, 31, 5e-6);
    let dir = tempfile::tempdir().unwrap();
    for (series, increment) in [
        (FanucSeries::Series30i, IncrementSystem::IsC),
        (FanucSeries::Series16, IncrementSystem::IsB),
    ] {
        let control = FanucControl::new(series, increment);
        let mut x = request('X', 1, false, 10.0);
        x.reversal = Some(Reversal::constant(-3.0));
        let mut z = request('Z', 3, false, 50.0);
        z.layout.first_point = Some(700);
        let requests = [
            x,
            request('Y', 2, false, 20.0),
            z,
            request('A', 4, true, 10.0),
            request('C', 5, true, 15.0),
        ];
        let conversions = axes_of_export(&model, &coeffs, &control, &requests);
        let tables: Vec<FanucTable> = conversions.iter().map(|c| c.table.clone()).collect();
        assert!(tables[0].is_bidirectional());
        assert_eq!(
            tables[4].revolution_units,
            Some((360.0 / increment.detection_unit()).round() as i64)
        );
        assert_eq!(tables[3].revolution_units, None);
        let params = dir.path().join(format!("{}.txt", increment.name()));
        let values = dir.path().join("values.csv");
        let card = write_fanuc(&params, &values, &control, &conversions, &[]).unwrap();
        let axes: Vec<FanucAxis> = requests.iter().map(|r| r.axis).collect();
        let back = read_fanuc_parameters(&params, &control, &axes).unwrap();
        assert_eq!(back, tables, "{}", series.name());
        // As a control punches it with NCR set (parameter 0100 bit 3): each block ends LF CR
        // CR (B-63524EN p.649), and the record reads the same.
        let punched = dir.path().join("punched.txt");
        let text = std::fs::read_to_string(&params).unwrap();
        std::fs::write(&punched, text.replace('\n', "\n\r\r")).unwrap();
        let back = read_fanuc_parameters(&punched, &control, &axes).unwrap();
        assert_eq!(back, tables, "{} punched LF CR CR", series.name());
        // The values table carries the card and one row per node and set.
        let csv = std::fs::read_to_string(&values).unwrap();
        for line in card.file_lines("# ").lines() {
            assert!(csv.contains(line), "missing card line {line}");
        }
        let rows = csv.lines().filter(|l| !l.starts_with('#')).count() - 1;
        let nodes: usize = tables
            .iter()
            .map(|t| (t.values.len() + 1) * if t.is_bidirectional() { 2 } else { 1 })
            .sum();
        assert_eq!(rows, nodes);
        assert!(card.squareness.starts_with("not held"));
        assert_eq!(card.axis_mapping[2].mtcal, 'Z');
        assert!(card.axis_mapping[2].control.contains("axis 3"));
        assert!(card.control_will.iter().any(|s| s.contains("power off")));
        assert!(card.control_will.iter().any(|s| s.contains("3605#0")));
    }
}

// ---------------------------------------------------------------------------------------
// The control applies the record: the modelled error is cancelled at the points.

/// Checks every point of linear axis `letter` (control axis `number`) in `record`: the
/// control's total equals the model's compensation relative to the reference position within
/// `tol_um`. Returns the largest |compensation| (µm) the model asks for, so a caller can see
/// the test bites.
fn check_linear(
    model: &MachineModel,
    coeffs: &[f64],
    tape: &Tape,
    axis: &FanucAxis,
    du_mm: f64,
    reversal_um: Option<f64>,
    tol_um: f64,
) -> f64 {
    let hold = default_hold(model.machine());
    let comp = |x: f64| model_compensation(model, coeffs, &hold, axis.letter, x);
    let at_reference = comp(axis.reference_position);
    let mut largest: f64 = 0.0;
    let sets = [(false, 0.0)]
        .into_iter()
        .chain(reversal_um.map(|b| (true, b)));
    for (reverse, b) in sets {
        for a in control_totals(tape, axis.number, du_mm, reverse) {
            let x = axis.reference_position + a.offset_units as f64 * du_mm;
            let applied_um = a.total_units as f64 * du_mm * 1e3;
            let wanted_um = comp(x) + b - at_reference;
            assert!(
                (applied_um - wanted_um).abs() <= tol_um,
                "axis {} point {} at {x} mm{}: the control applies {applied_um} µm, the model \
                 wants {wanted_um} µm",
                axis.letter,
                a.point,
                if reverse { " (negative direction)" } else { "" }
            );
            largest = largest.max(wanted_um.abs());
        }
    }
    largest
}

fn magnification_of(tape: &Tape, axis: u32) -> f64 {
    tape.int(3623, axis) as f64
}

mod application {
    use super::*;
    use proptest::prelude::*;

    const INTERVALS_MM: [f64; 4] = [10.0, 20.0, 25.0, 50.0];
    const INTERVALS_DEG: [f64; 5] = [5.0, 10.0, 15.0, 30.0, 45.0];

    /// A reference position on the interval grid inside the stroke of `letter`.
    fn reference_in(model: &MachineModel, letter: char, interval: f64, frac: f64) -> f64 {
        let a = &model.machine().axes()[model.machine().axis_index(letter).unwrap()];
        let (lo, hi) = a.limits().unwrap();
        let (lo, hi) = (lo * 1e3, hi * 1e3);
        let (k_lo, k_hi) = ((lo / interval).ceil(), (hi / interval).floor());
        (k_lo + (frac * (k_hi - k_lo + 1.0)).floor().min(k_hi - k_lo)) * interval
    }

    fn linear_requests(
        model: &MachineModel,
        pick: [usize; 3],
        fracs: [f64; 3],
    ) -> Vec<FanucRequest> {
        ['X', 'Y', 'Z']
            .into_iter()
            .enumerate()
            .map(|(k, letter)| {
                let interval = INTERVALS_MM[pick[k]];
                let mut r = request(letter, k as u32 + 1, false, interval);
                r.axis.reference_position = reference_in(model, letter, interval, fracs[k]);
                r
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        /// IS-C on a 30i: every point within 0.1 µm (half a detection unit, 0.05 µm, and
        /// rounding); the X axis bidirectional with a random reversal value.
        #[test]
        fn is_c_cancels_the_linear_error_at_the_points_within_0_1_um(
            seed in any::<u64>(),
            pick in proptest::array::uniform3(0usize..4),
            fracs in proptest::array::uniform3(0.0f64..1.0),
            reversal_um in -10.0f64..10.0,
        ) {
            let model = load(MACHINE);
            let coeffs = random_coeffs(&model, seed, 5e-6);
            let control = FanucControl::new(FanucSeries::Series30i, IncrementSystem::IsC);
            let mut requests = linear_requests(&model, pick, fracs);
            requests[0].reversal = Some(Reversal::constant(reversal_um));
            let conversions = axes_of_export(&model, &coeffs, &control, &requests);
            let tables: Vec<FanucTable> = conversions.iter().map(|c| c.table.clone()).collect();
            let tape = read_tape(&fanuc_parameter_text(&control, &tables).unwrap());
            let du = control.increment.detection_unit();
            let mut largest: f64 = 0.0;
            for r in &requests {
                prop_assert_eq!(magnification_of(&tape, r.axis.number), 1.0);
                let tol = (0.5 * du * 1e3 + 1e-6).min(TOL_UM);
                largest = largest.max(check_linear(&model, &coeffs, &tape, &r.axis, du, r.reversal.map(|r| r.middle_um), tol));
            }
            prop_assert!(largest > 1.0, "errors too small to test: {largest} µm");
        }

        /// IS-B on a 16i (±7 per point): the magnification is chosen to fit, and every point
        /// is within half a detection unit × magnification.
        #[test]
        fn is_b_cancels_the_linear_error_within_half_a_step(
            seed in any::<u64>(),
            pick in proptest::array::uniform3(0usize..4),
            fracs in proptest::array::uniform3(0.0f64..1.0),
        ) {
            let model = load(MACHINE);
            let coeffs = random_coeffs(&model, seed, 5e-6);
            let control = FanucControl::new(FanucSeries::Series16, IncrementSystem::IsB);
            let requests = linear_requests(&model, pick, fracs);
            let conversions = axes_of_export(&model, &coeffs, &control, &requests);
            let tables: Vec<FanucTable> = conversions.iter().map(|c| c.table.clone()).collect();
            let tape = read_tape(&fanuc_parameter_text(&control, &tables).unwrap());
            let du = control.increment.detection_unit();
            for r in &requests {
                let m = magnification_of(&tape, r.axis.number);
                let tol = 0.5 * m * du * 1e3 + 1e-6;
                check_linear(&model, &coeffs, &tape, &r.axis, du, None, tol);
                for v in tape.points.values() {
                    prop_assert!(v.abs() <= 7, "a value beyond ±7 was written: {v}");
                }
            }
        }

        /// A full-revolution rotary axis (C): every point within half a detection unit of the
        /// model, the increments sum to 0 over a turn, and two turns of the control's
        /// accumulation return to the same totals (no drift turn by turn).
        #[test]
        fn a_rotary_axis_is_cancelled_turn_after_turn(
            seed in any::<u64>(),
            pick in 0usize..5,
            k in -12i64..12,
            is_c in any::<bool>(),
        ) {
            let model = load(MACHINE);
            let hold = default_hold(model.machine());
            let coeffs = random_coeffs(&model, seed, 5e-6);
            let increment = if is_c { IncrementSystem::IsC } else { IncrementSystem::IsB };
            let control = FanucControl::new(FanucSeries::Series30i, increment);
            let interval = INTERVALS_DEG[pick];
            let mut c = request('C', 5, true, interval);
            c.axis.reference_position = k as f64 * interval;
            let mut a = request('A', 4, true, 10.0);
            a.layout.first_point = Some(500);
            let conversions = axes_of_export(&model, &coeffs, &control, &[c, a]);
            let tables: Vec<FanucTable> = conversions.iter().map(|c| c.table.clone()).collect();
            let tape = read_tape(&fanuc_parameter_text(&control, &tables).unwrap());
            let du = control.increment.detection_unit();
            let tol_urad = 0.5 * du.to_radians() * 1e6 + 1e-6;
            let comp = |letter: char, x: f64| model_compensation(&model, &coeffs, &hold, letter, x);

            // Rotary rules as the manual states them.
            let (reference, first, last) = (tape.int(3620, 5), tape.int(3621, 5), tape.int(3622, 5));
            let per_turn = tape.length_units(3625, 5, du) / tape.length_units(3624, 5, du);
            prop_assert_eq!(first, reference);
            prop_assert_eq!(last, reference + per_turn);
            let v = |p: i64| tape.points[&(p as u32)];
            prop_assert_eq!(v(reference), v(last));
            prop_assert_eq!((reference + 1..=last).map(v).sum::<i64>(), 0);

            // Two turns from the reference, interval by interval as the axis passes them.
            let at_ref = comp('C', c.axis.reference_position);
            let m = tape.int(3623, 5);
            let mut total = 0i64;
            let mut largest: f64 = 0.0;
            for j in 1..=2 * per_turn {
                total += m * v(reference + 1 + (j - 1) % per_turn);
                let x = c.axis.reference_position + j as f64 * interval;
                let applied = (total as f64 * du).to_radians() * 1e6;
                let wanted = comp('C', x.rem_euclid(360.0)) - at_ref;
                prop_assert!((applied - wanted).abs() <= tol_urad,
                    "C at {x}°: applied {applied} µrad, model {wanted} µrad");
                largest = largest.max(wanted.abs());
            }
            prop_assert_eq!(total, 0, "a whole number of turns must leave no compensation");
            // The documented sums from the reference agree at every point, both sides.
            for p in control_totals(&tape, 5, du, false) {
                let x = c.axis.reference_position + p.offset_units as f64 * du;
                let applied = (p.total_units as f64 * du).to_radians() * 1e6;
                prop_assert!((applied - (comp('C', x.rem_euclid(360.0)) - at_ref)).abs() <= tol_urad);
            }
            // The limited A axis is a plain table over its stroke.
            prop_assert!(!tape.params.contains_key(&(3625, 4)));
            let a_ref = comp('A', 0.0);
            for p in control_totals(&tape, 4, du, false) {
                let x = p.offset_units as f64 * du;
                let applied = (p.total_units as f64 * du).to_radians() * 1e6;
                prop_assert!((applied - (comp('A', x) - a_ref)).abs() <= tol_urad, "A at {x}°");
            }
            prop_assert!(largest > 1.0, "C errors too small to test: {largest} µrad");
        }
    }
}

/// The reference return in the negative direction: the positive-direction set then starts from
/// 3627 and the negative one from 0.
#[test]
fn a_negative_reference_return_moves_3627_to_the_positive_set() {
    let model = load(MACHINE);
    let coeffs = random_coeffs(&model, 41, 5e-6);
    let control = FanucControl::new(FanucSeries::Series30i, IncrementSystem::IsC);
    let mut x = request('X', 1, false, 25.0);
    x.reversal = Some(Reversal::constant(4.0));
    x.axis.reference_return = Travel::Reverse;
    let c = &axes_of_export(&model, &coeffs, &control, &[x])[0];
    let t = &c.table;
    let r = (t.reference_point + 1 - t.first_point) as usize;
    assert_eq!(t.cumulative_units(Travel::Reverse)[r], 0);
    let opposite = t.reverse.as_ref().unwrap().opposite_at_reference_units;
    assert_eq!(t.cumulative_units(Travel::Forward)[r], opposite);
    // B = +4 µm: the forward total at the reference is 4 µm below the reverse one.
    assert_eq!(opposite, -40);
}

// ---------------------------------------------------------------------------------------
// The validator.

fn linear_table(positions_mm: Vec<f64>) -> PitchTable {
    let forward_um = positions_mm.iter().map(|p| 0.01 * p).collect();
    PitchTable {
        axis: 'X',
        positions_mm,
        forward_um,
        reverse_um: None,
        note: String::new(),
    }
}

fn fanuc_error(e: CompensateError) -> FanucError {
    match e {
        CompensateError::Fanuc(f) => f,
        other => panic!("expected a Fanuc error, got {other}"),
    }
}

fn convert_err(table: &PitchTable, control: &FanucControl, layout: &FanucLayout) -> FanucError {
    let axis = FanucAxis::new('X', 1, false);
    fanuc_error(fanuc_from_pitch(table, control, &axis, layout).unwrap_err())
}

fn grid(n: usize, interval: f64) -> Vec<f64> {
    (0..n).map(|k| k as f64 * interval).collect()
}

#[test]
fn the_validator_refuses_what_the_control_would() {
    let c30 = FanucControl::new(FanucSeries::Series30i, IncrementSystem::IsC);
    let c16 = FanucControl::new(FanucSeries::Series16, IncrementSystem::IsB);
    let layout = FanucLayout::default();

    // Irregular and unsorted nodes, a short last interval (as pitch_table makes them).
    let e = convert_err(&linear_table(vec![0.0, 10.0, 25.0]), &c30, &layout);
    assert!(
        matches!(e, FanucError::IrregularInterval { index: 2, .. }),
        "{e}"
    );
    let e = convert_err(&linear_table(vec![0.0, 10.0, 5.0]), &c30, &layout);
    assert!(matches!(e, FanucError::Unsorted { .. }), "{e}");
    let e = convert_err(&linear_table(vec![0.0]), &c30, &layout);
    assert!(matches!(e, FanucError::TooFewNodes { .. }), "{e}");
    let model = load(MACHINE);
    let hold = default_hold(model.machine());
    let zero = vec![0.0; model.n_coeffs()];
    let short_end = pitch_table(&model, &zero, 'X', 30.0, &hold).unwrap(); // 700 mm stroke
    let e = convert_err(&short_end, &c30, &layout);
    assert!(matches!(e, FanucError::IrregularInterval { .. }), "{e}");
    assert!(e.to_string().contains("constant interval (3624)"), "{e}");

    // An interval that is no whole number of detection units.
    let e = convert_err(&linear_table(grid(5, 25.0005)), &c16, &layout);
    assert!(matches!(e, FanucError::IntervalNotWhole { .. }), "{e}");
    assert!(
        fanuc_from_pitch(
            &linear_table(grid(5, 25.0005)),
            &c30,
            &FanucAxis::new('X', 1, false),
            &layout
        )
        .is_ok()
    );

    // The reference position off the nodes.
    let mut axis = FanucAxis::new('X', 1, false);
    axis.reference_position = 3.0;
    let e = fanuc_error(
        fanuc_from_pitch(&linear_table(grid(5, 25.0)), &c30, &axis, &layout).unwrap_err(),
    );
    assert!(matches!(e, FanucError::ReferenceOffNode { .. }), "{e}");

    // A value beyond ±7 at magnification 1; no magnification when nothing fits.
    let steep = PitchTable {
        forward_um: grid(5, 20.0),
        ..linear_table(grid(5, 25.0))
    };
    let fixed = FanucLayout {
        magnification: Some(1),
        ..layout
    };
    let e = convert_err(&steep, &c16, &fixed);
    assert!(
        matches!(
            e,
            FanucError::ValueOutOfRange {
                value: 20,
                limit: 7,
                ..
            }
        ),
        "{e}"
    );
    let auto = fanuc_from_pitch(&steep, &c16, &FanucAxis::new('X', 1, false), &layout).unwrap();
    assert_eq!(auto.table.magnification, 3);
    let none_fits = FanucControl {
        value_limit: 0,
        ..c16
    };
    let e = convert_err(&steep, &none_fits, &layout);
    assert!(matches!(e, FanucError::NoMagnification { .. }), "{e}");
    let e = convert_err(
        &steep,
        &c16,
        &FanucLayout {
            magnification: Some(101),
            ..layout
        },
    );
    assert!(matches!(e, FanucError::BadMagnification { .. }), "{e}");
    let bi = steep.clone().with_reversal_um(2.0);
    let e = convert_err(&bi, &c16, &layout);
    assert!(
        matches!(e, FanucError::NoMagnification { max: 1, .. }),
        "{e}"
    );
    let e = convert_err(
        &bi,
        &c16,
        &FanucLayout {
            magnification: Some(3),
            ..layout
        },
    );
    assert!(
        matches!(e, FanucError::BidirectionalMagnification { .. }),
        "{e}"
    );

    // The pool: too many points, running past its end, two axes on the same points.
    let long = linear_table(grid(30, 10.0));
    let small = FanucControl {
        pool_size: 20,
        ..c30
    };
    let e = convert_err(&long, &small, &layout);
    assert!(
        matches!(
            e,
            FanucError::TooManyPoints {
                points: 30,
                pool: 20,
                ..
            }
        ),
        "{e}"
    );
    let e = convert_err(
        &long,
        &c30,
        &FanucLayout {
            first_point: Some(1000),
            ..layout
        },
    );
    assert!(
        matches!(
            e,
            FanucError::PoolOverflow {
                from: 1000,
                to: 1029,
                last: 1023,
                ..
            }
        ),
        "{e}"
    );
    // One axis' points from 3621 to 3622: at most 128 unless the control is set otherwise
    // (a public summary's limit; the card and the error name the source). A 820 mm stroke at
    // 5 mm is 164 intervals.
    let fine = linear_table(grid(165, 5.0));
    let e = convert_err(&fine, &c30, &layout);
    assert!(
        matches!(e, FanucError::TooManyAxisPoints { points, max: 128, .. } if points > 128),
        "{e}"
    );
    assert!(e.to_string().contains("cnc.wiki"), "{e}");
    let roomy = FanucControl {
        axis_points: 200,
        ..c30
    };
    let conv = fanuc_from_pitch(&fine, &roomy, &FanucAxis::new('X', 1, false), &layout).unwrap();
    let card = fanuc_card(&roomy, std::slice::from_ref(&conv));
    assert!(
        card.control_will
            .iter()
            .any(|w| w.contains("at most 200 points per axis") && w.contains("cnc.wiki")),
        "{:?}",
        card.control_will
    );
    let x = fanuc_from_pitch(&long, &c30, &FanucAxis::new('X', 1, false), &layout)
        .unwrap()
        .table;
    let mut y = x.clone();
    y.axis = FanucAxis::new('Y', 2, false);
    let e = fanuc_error(validate_fanuc(&c30, &[x.clone(), y.clone()]).unwrap_err());
    assert!(
        matches!(
            e,
            FanucError::PointsOverlap {
                from: 0,
                to: 29,
                ..
            }
        ),
        "{e}"
    );
    y.axis.number = 1;
    y.first_point += 100;
    y.last_point += 100;
    y.reference_point += 100;
    let e = fanuc_error(validate_fanuc(&c30, &[x.clone(), y]).unwrap_err());
    assert!(
        matches!(e, FanucError::DuplicateAxisNumber { number: 1, .. }),
        "{e}"
    );
    // Bidirectional: the negative set placed on the positive one.
    let bi = fanuc_from_pitch(
        &long.clone().with_reversal_um(1.0),
        &c30,
        &FanucAxis::new('X', 1, false),
        &FanucLayout {
            reverse_first_point: Some(10),
            ..layout
        },
    );
    let e = fanuc_error(bi.unwrap_err());
    assert!(matches!(e, FanucError::PointsOverlap { .. }), "{e}");

    // A rotary table whose turn does not sum to zero, or whose ends differ.
    let rotary = RotaryTable {
        axis: 'C',
        positions_deg: grid(9, 45.0),
        compensation_urad: (0..9)
            .map(|k| 50.0 * (k as f64 * 45f64.to_radians()).sin())
            .collect(),
        full_turn: true,
        note: String::new(),
    };
    let c_axis = FanucAxis::new('C', 5, true);
    let good = fanuc_from_rotary(&rotary, &c30, &c_axis, &layout)
        .unwrap()
        .table;
    assert_eq!(good.revolution_units, Some(3_600_000));
    assert_eq!(
        (good.first_point, good.reference_point, good.last_point),
        (0, 0, 8)
    );
    validate_fanuc(&c30, std::slice::from_ref(&good)).unwrap();
    let mut drift = good.clone();
    drift.values[3] += 1;
    let e = fanuc_error(validate_fanuc(&c30, &[drift]).unwrap_err());
    assert!(
        matches!(
            e,
            FanucError::RevolutionSumNotZero {
                sum: 1,
                from: 1,
                to: 8,
                ..
            }
        ),
        "{e}"
    );
    let mut ends = good.clone();
    ends.values[0] += 1;
    let e = fanuc_error(validate_fanuc(&c30, &[ends]).unwrap_err());
    assert!(matches!(e, FanucError::RotaryEndsDiffer { .. }), "{e}");
    let mut odd = good.clone();
    odd.revolution_units = Some(3_600_000 + 1);
    let e = fanuc_error(validate_fanuc(&c30, &[odd]).unwrap_err());
    assert!(matches!(e, FanucError::RevolutionNotWhole { .. }), "{e}");
    let mut not_periodic = rotary.clone();
    not_periodic.compensation_urad[8] += 0.5;
    let e = fanuc_error(fanuc_from_rotary(&not_periodic, &c30, &c_axis, &layout).unwrap_err());
    assert!(matches!(e, FanucError::NotPeriodic { .. }), "{e}");
    let e = fanuc_error(
        fanuc_from_rotary(
            &RotaryTable {
                positions_deg: grid(9, 40.0),
                ..rotary.clone()
            },
            &c30,
            &c_axis,
            &layout,
        )
        .unwrap_err(),
    );
    assert!(matches!(e, FanucError::Layout { .. }), "{e}");

    // A structurally broken table.
    let mut short = x.clone();
    short.values.pop();
    let e = fanuc_error(validate_fanuc(&c30, &[short]).unwrap_err());
    assert!(matches!(e, FanucError::Layout { .. }), "{e}");
    let mut off = x;
    off.reference_point = off.last_point + 1;
    let e = fanuc_error(validate_fanuc(&c30, &[off]).unwrap_err());
    assert!(e.to_string().contains("must lie on the table"), "{e}");
}

/// The documented example 2 of B-63980EN: reference point 60, 45° intervals, one revolution
/// of 360° → points 60 to 68, point 60 carrying point 68's value.
#[test]
fn the_rotary_layout_matches_the_manuals_example() {
    let control = FanucControl::new(FanucSeries::Series16, IncrementSystem::IsB);
    let rotary = RotaryTable {
        axis: 'C',
        positions_deg: grid(9, 45.0),
        compensation_urad: (0..9)
            .map(|k| 20.0 * (k as f64 * 45f64.to_radians()).cos())
            .collect(),
        full_turn: true,
        note: String::new(),
    };
    let layout = FanucLayout {
        first_point: Some(60),
        ..FanucLayout::default()
    };
    let t = fanuc_from_rotary(&rotary, &control, &FanucAxis::new('C', 4, true), &layout)
        .unwrap()
        .table;
    assert_eq!(
        (t.reference_point, t.first_point, t.last_point),
        (60, 60, 68)
    );
    assert_eq!(t.revolution_units, Some(360_000));
    assert_eq!(t.interval_units, 45_000);
    let text = fanuc_parameter_text(&control, std::slice::from_ref(&t)).unwrap();
    assert!(text.starts_with("%\nN03620A4P60\nN03621A4P60\nN03622A4P68\nN03623A4P1\nN03624A4P45000\nN03625A4P360000\nN10060P"), "{text}");
    assert!(text.ends_with("\n%\n"));
}

/// The linear layout of B-63980EN's example: 50 mm intervals from −400 mm numbered from 33,
/// the reference (0 mm) point 40; a stroke to +800 mm then ends at point 56.
#[test]
fn the_linear_layout_matches_the_manuals_example() {
    let control = FanucControl::new(FanucSeries::Series30i, IncrementSystem::IsB);
    let table = linear_table((0..=24).map(|k| -400.0 + 50.0 * k as f64).collect());
    let layout = FanucLayout {
        first_point: Some(33),
        ..FanucLayout::default()
    };
    let t = fanuc_from_pitch(&table, &control, &FanucAxis::new('X', 1, false), &layout)
        .unwrap()
        .table;
    assert_eq!(
        (t.reference_point, t.first_point, t.last_point),
        (40, 33, 56)
    );
    let text = fanuc_parameter_text(&control, &[t]).unwrap();
    assert!(text.contains("N03624Q1A1P50.000\n"), "{text}");
    assert!(text.contains("\nN10033Q0P"), "{text}");
    // The reference at the first node: 3620 is its own number, the values start after it.
    let mut axis = FanucAxis::new('X', 1, false);
    axis.reference_position = -400.0;
    let t = fanuc_from_pitch(&table, &control, &axis, &layout)
        .unwrap()
        .table;
    assert_eq!(
        (t.reference_point, t.first_point, t.last_point),
        (33, 34, 57)
    );
}

// ---------------------------------------------------------------------------------------
// The reader's located errors.

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn read_err(path: &Path, control: &FanucControl) -> (usize, usize, String) {
    let axes = [FanucAxis::new('X', 1, false)];
    match read_fanuc_parameters(path, control, &axes).unwrap_err() {
        CompensateError::Parse { at, message } => {
            assert_eq!(at.file, path);
            (at.line, at.column, message)
        }
        other => panic!("expected a located error, got {other}"),
    }
}

#[test]
fn the_reader_names_line_and_column_of_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let c16 = FanucControl::new(FanucSeries::Series16, IncrementSystem::IsB);
    let c30 = FanucControl::new(FanucSeries::Series30i, IncrementSystem::IsB);
    let good = "%\nN03620A1P0\nN03621A1P1\nN03622A1P3\nN03623A1P1\nN03624A1P25000\nN10001P2\nN10002P-1\nN10003P0\n%\n";
    let ok = write(dir.path(), "ok.txt", good);
    let t = read_fanuc_parameters(&ok, &c16, &[FanucAxis::new('X', 1, false)]).unwrap();
    assert_eq!(t[0].values, vec![2, -1, 0]);
    assert_eq!(t[0].cumulative_units(Travel::Forward), vec![0, 2, 1, 1]);

    let cases: [(&str, &FanucControl, usize, usize, &str); 11] = [
        ("N03620A1P0\n%\n", &c16, 1, 1, "expected `%`"),
        (&good.replace("\n%\n", "\n"), &c16, 10, 1, "closing `%`"),
        (
            &good.replace("N03623A1P1", "N03623A1P1.5"),
            &c16,
            5,
            10,
            "an integer",
        ),
        (
            &good.replace("N03623A1P1", "N01850A1P1"),
            &c16,
            5,
            2,
            "parameter 1850",
        ),
        (
            &good.replace("N03623A1P1", "N03623Q1A1P1"),
            &c16,
            5,
            7,
            "expected `A`",
        ),
        (good, &c30, 2, 7, "expected `Q1`"),
        (
            &good.replace("N10002P-1", "N10002P-9"),
            &c16,
            8,
            8,
            "outside the control's range ±7",
        ),
        (&good.replace("N10002P-1\n", ""), &c16, 4, 10, "point 2"),
        (
            &good.replace("N10003P0", "N10003P0\nN10009P1"),
            &c16,
            10,
            8,
            "belongs to no axis",
        ),
        (
            &good.replace("N03620A1P0", "N03620A1P0A2P0"),
            &c16,
            2,
            14,
            "A2",
        ),
        (
            &good.replace("%\n", "%\nX\n").replacen("%\nX\n", "%\n", 1),
            &c16,
            11,
            1,
            "nothing after",
        ),
    ];
    for (k, (text, control, line, column, words)) in cases.iter().enumerate() {
        let p = write(dir.path(), &format!("bad{k}.txt"), text);
        let (l, c, m) = read_err(&p, control);
        assert_eq!((l, c), (*line, *column), "case {k}: {m}");
        assert!(m.contains(words), "case {k}: `{m}` lacks `{words}`");
    }
    // A 30i record needs whole detection units in 3624.
    let p = write(
        dir.path(),
        "q.txt",
        "%\nN03620Q1A1P0\nN03621Q1A1P1\nN03622Q1A1P1\nN03623Q1A1P1\nN03624Q1A1P25.0001\nN10001Q0P0\n%\n",
    );
    let (l, c, m) = read_err(&p, &c30);
    assert_eq!((l, c), (6, 12), "{m}");
    assert!(m.contains("at most 3 decimals"), "{m}");
    // A record whose rotary turn does not sum to 0 reads but is refused by the validator.
    let p = write(
        dir.path(),
        "r.txt",
        "%\nN03620A1P0\nN03621A1P0\nN03622A1P4\nN03623A1P1\nN03624A1P90000\nN03625A1P360000\nN10000P1\nN10001P1\nN10002P0\nN10003P-1\nN10004P1\n%\n",
    );
    let e = read_fanuc_parameters(&p, &c16, &[FanucAxis::new('C', 1, true)]).unwrap_err();
    assert!(
        matches!(
            e,
            CompensateError::Fanuc(FanucError::RevolutionSumNotZero { sum: 1, .. })
        ),
        "{e}"
    );
    // 3625 on a linear axis.
    let p = write(
        dir.path(),
        "l.txt",
        &good.replace("N10001P2", "N03625A1P360000\nN10001P2"),
    );
    let (l, _, m) = read_err(&p, &c16);
    assert_eq!(l, 7, "{m}");
}
