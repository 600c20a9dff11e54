//! SINUMERIK EEC (`%_N_AX_EEC_INI`) and CEC (`%_N_NC_CEC_INI`) files: round trips, the
//! refusals of what the control would refuse or misread, and the files applied the way the K3
//! manual says the control applies them, written here independently of the crate's reader.

use crate::common;

use common::{TOL_UM, load};
use mtcal_compensate::*;
use mtcal_kinematics::{AxisKind, MachineModel};
use mtcal_testkit::random::SplitMix64;
use proptest::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// Every coefficient uniform in ±5 µm / µrad.
fn random_coeffs(model: &MachineModel, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix64(seed);
    (0..model.n_coeffs()).map(|_| 5e-6 * rng.signed()).collect()
}

/// The linear axes' letters.
fn linear_letters(model: &MachineModel) -> Vec<char> {
    model
        .machine()
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Linear)
        .map(|a| a.letter().as_char())
        .collect()
}

/// A tenth of the stroke of `letter` (mm): mid-stroke, the default held position, is a node.
fn tenth_mm(model: &MachineModel, letter: char) -> f64 {
    let i = model.machine().axis_index(letter).unwrap();
    let (lo, hi) = model.machine().axes()[i].limits().unwrap();
    (hi - lo) * 1e3 / 10.0
}

/// The EEC tables of every linear axis and the CEC tables of every pair, each axis' points a
/// tenth of its stroke apart.
fn model_tables(model: &MachineModel, coeffs: &[f64]) -> (Vec<EecTable>, Vec<CecTable>) {
    let hold = default_hold(model.machine());
    let names = siemens_axis_names(model.machine());
    let letters = linear_letters(model);
    let eec = letters
        .iter()
        .map(|&a| siemens_eec_table(model, coeffs, a, tenth_mm(model, a), &hold, &names).unwrap())
        .collect();
    let mut cec = Vec::new();
    for &i in &letters {
        for &o in letters.iter().filter(|&&o| o != i) {
            let index = cec.len();
            let spacing = tenth_mm(model, i);
            cec.push(
                siemens_cec_table(model, coeffs, index, i, o, spacing, &hold, &names).unwrap(),
            );
        }
    }
    (eec, cec)
}

fn texts(model: &MachineModel, eec: &[EecTable], cec: &[CecTable]) -> (String, String) {
    let names = siemens_axis_names(model.machine());
    let note = siemens_note(model.machine(), &default_hold(model.machine()));
    let limits = SiemensLimits::default();
    let e = siemens_eec_text(eec, &eec_card(eec, &names), &note, &limits).unwrap();
    let c = siemens_cec_text(cec, &cec_card(cec, &names), &note, &limits).unwrap();
    (e, c)
}

// ----- The control, as K3 describes it, written without the crate's reader -----

/// One table as the control holds it: interpolation points MIN + N·STEP up to MAX.
#[derive(Default)]
struct CtlTable {
    min: f64,
    step: f64,
    max: f64,
    values: Vec<f64>,
    modulo: bool,
}

impl CtlTable {
    /// K3: linear interpolation between neighbouring points; below MIN the value of point 0,
    /// above MAX the value of the last point; a modulo table repeats with period MAX − MIN.
    fn at(&self, position: f64) -> f64 {
        let mut x = position;
        if self.modulo {
            let period = self.max - self.min;
            x = self.min + (x - self.min).rem_euclid(period);
        }
        let last = self.values.len() - 1;
        if x <= self.min {
            return self.values[0];
        }
        if x >= self.max {
            return self.values[last];
        }
        let u = (x - self.min) / self.step;
        let k = (u.floor() as usize).min(last - 1);
        let t = u - k as f64;
        self.values[k] + t * (self.values[k + 1] - self.values[k])
    }

    fn set(&mut self, index: usize, value: f64) {
        if self.values.len() <= index {
            self.values.resize(index + 1, f64::NAN);
        }
        self.values[index] = value;
    }
}

/// Every `$NAME[i,j,…]=value` of an INI text, comments (`;` to the end of line) dropped.
fn assignments(text: &str) -> Vec<(String, Vec<String>, String)> {
    text.lines()
        .filter_map(|l| {
            let code = l.split(';').next().unwrap().trim();
            let (lhs, rhs) = code.split_once('=')?;
            let (name, idx) = lhs.trim().split_once('[')?;
            let idx = idx.trim().trim_end_matches(']');
            let idx = idx.split(',').map(|s| s.trim().to_string()).collect();
            Some((name.trim().to_string(), idx, rhs.trim().to_string()))
        })
        .collect()
}

fn num(s: &str) -> f64 {
    s.parse().unwrap()
}

/// The EEC tables of a file by axis name.
fn control_eec(text: &str) -> HashMap<String, CtlTable> {
    let mut tables: HashMap<String, CtlTable> = HashMap::new();
    for (name, idx, v) in assignments(text) {
        let axis = idx.last().unwrap().clone();
        let t = tables.entry(axis).or_default();
        match name.as_str() {
            "$AA_ENC_COMP" => t.set(idx[1].parse().unwrap(), num(&v)),
            "$AA_ENC_COMP_STEP" => t.step = num(&v),
            "$AA_ENC_COMP_MIN" => t.min = num(&v),
            "$AA_ENC_COMP_MAX" => t.max = num(&v),
            "$AA_ENC_COMP_IS_MODULO" => t.modulo = v == "1",
            other => panic!("unexpected {other}"),
        }
    }
    tables
}

/// The CEC tables of a file: input axis, output axis, table.
fn control_cec(text: &str) -> Vec<(String, String, CtlTable)> {
    let mut tables: HashMap<usize, (String, String, CtlTable)> = HashMap::new();
    for (name, idx, v) in assignments(text) {
        let entry = tables.entry(idx[0].parse().unwrap()).or_default();
        let axis = || v.trim_matches(['(', ')']).to_string();
        match name.as_str() {
            "$AN_CEC" => entry.2.set(idx[1].parse().unwrap(), num(&v)),
            "$AN_CEC_INPUT_AXIS" => entry.0 = axis(),
            "$AN_CEC_OUTPUT_AXIS" => entry.1 = axis(),
            "$AN_CEC_STEP" => entry.2.step = num(&v),
            "$AN_CEC_MIN" => entry.2.min = num(&v),
            "$AN_CEC_MAX" => entry.2.max = num(&v),
            "$AN_CEC_IS_MODULO" => entry.2.modulo = v == "1",
            "$AN_CEC_DIRECTION" | "$AN_CEC_MULT_BY_TABLE" => assert_eq!(v, "0"),
            other => panic!("unexpected {other}"),
        }
    }
    tables.into_values().collect()
}

struct Control {
    eec: HashMap<String, CtlTable>,
    cec: Vec<(String, String, CtlTable)>,
}

impl Control {
    /// Where the axes come to rest (mm, by name) for `setpoints` (mm, by name). CEC: the sum
    /// of the tables of an output axis, each taken at its input axis' setpoint. MSEC: the
    /// table taken at the axis' actual position. The compensation value modifies the actual
    /// value, so the axis settles where actual + compensation = setpoint: a positive value
    /// moves it in the negative direction (K3; assumed alike for CEC).
    fn positions(&self, setpoints: &HashMap<String, f64>) -> HashMap<String, f64> {
        let mut cec_total: HashMap<&str, f64> = HashMap::new();
        for (input, output, t) in &self.cec {
            *cec_total.entry(output.as_str()).or_default() += t.at(setpoints[input]);
        }
        setpoints
            .iter()
            .map(|(axis, &x)| {
                let cross = cec_total.get(axis.as_str()).copied().unwrap_or(0.0);
                let mut actual = x;
                for _ in 0..30 {
                    let own = self.eec.get(axis).map_or(0.0, |t| t.at(actual));
                    actual = x - (own + cross);
                }
                (axis.clone(), actual)
            })
            .collect()
    }
}

/// The files of `seed`'s random machine applied by the control: at every point of every axis'
/// table (that axis at the point, the others held), the tool point's error along every linear
/// axis is cancelled. Returns the largest uncompensated and compensated errors (µm).
fn applied_residual_um(name: &str, seed: u64) -> (f64, f64) {
    let model = load(name);
    let machine = model.machine();
    let coeffs = random_coeffs(&model, seed);
    let (eec, cec) = model_tables(&model, &coeffs);
    let (eec_text, cec_text) = texts(&model, &eec, &cec);
    let control = Control {
        eec: control_eec(&eec_text),
        cec: control_cec(&cec_text),
    };
    let hold = default_hold(machine);
    let names: HashMap<char, String> = siemens_axis_names(machine)
        .into_iter()
        .map(|m| (m.mtcal, m.control))
        .collect();
    let letters = linear_letters(&model);
    let dirs: Vec<_> = letters
        .iter()
        .map(|&l| travel_direction(machine, &hold, machine.axis_index(l).unwrap()))
        .collect();
    let mut ws = model.workspace();
    let (mut before, mut after) = (0.0f64, 0.0f64);
    for &moving in &letters {
        let table = &control.eec[&names[&moving]];
        for n in 0..table.values.len() {
            let node_mm = table.min + table.step * n as f64;
            let mut setpoints = HashMap::new();
            for &l in &letters {
                let held_mm = hold[machine.axis_index(l).unwrap()] * 1e3;
                let x = if l == moving { node_mm } else { held_mm };
                setpoints.insert(names[&l].clone(), x);
            }
            let reached = control.positions(&setpoints);
            let (mut q_target, mut q_actual) = (hold.clone(), hold.clone());
            for &l in &letters {
                let i = machine.axis_index(l).unwrap();
                q_target[i] = setpoints[&names[&l]] * 1e-3;
                q_actual[i] = reached[&names[&l]] * 1e-3;
            }
            let target = machine.tool_in_workpiece(&q_target).t;
            let uncompensated = model.pose_error(&q_target, &coeffs, &mut ws).translation;
            let actual = machine.tool_in_workpiece(&q_actual).t
                + model.pose_error(&q_actual, &coeffs, &mut ws).translation;
            for d in &dirs {
                before = before.max((uncompensated.dot(d) * 1e6).abs());
                after = after.max(((actual - target).dot(d) * 1e6).abs());
            }
        }
    }
    (before, after)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// EEC + CEC, applied as the control does, cancel the modelled tool-point error at every
    /// point of the tables to 0.1 µm (the values are written to 1 nm).
    #[test]
    fn the_control_cancels_the_modelled_error_at_the_points(seed in any::<u64>()) {
        for name in ["mcv754-zfyx.urdf", "mcu630-cafyxz.urdf"] {
            let (before, after) = applied_residual_um(name, seed);
            prop_assert!(before > 1.0, "{name}: errors of {before} µm are too small to test");
            prop_assert!(after < TOL_UM, "{name}: residual {after} µm (uncompensated {before} µm)");
        }
    }
}

// ----- Round trips -----

#[test]
fn eec_and_cec_files_round_trip() {
    let model = load("mcu630-cafyxz.urdf");
    let coeffs = random_coeffs(&model, 7);
    let (eec, cec) = model_tables(&model, &coeffs);
    let limits = SiemensLimits::default();
    let names = siemens_axis_names(model.machine());
    let note = siemens_note(model.machine(), &default_hold(model.machine()));
    let dir = tempfile::tempdir().unwrap();
    let (eec_path, cec_path) = (dir.path().join("AX_EEC.INI"), dir.path().join("NC_CEC.INI"));
    write_siemens_eec(&eec_path, &eec, &eec_card(&eec, &names), &note, &limits).unwrap();
    write_siemens_cec(&cec_path, &cec, &cec_card(&cec, &names), &note, &limits).unwrap();
    let eec_back = read_siemens_eec(&eec_path, &limits).unwrap();
    let cec_back = read_siemens_cec(&cec_path, &limits).unwrap();
    assert_eq!(eec_back.len(), eec.len());
    for (a, b) in eec.iter().zip(&eec_back) {
        assert_eq!(
            (&a.axis, a.encoder, a.is_modulo),
            (&b.axis, b.encoder, b.is_modulo)
        );
        assert_close(&a.positions, &b.positions, 1e-9);
        assert_close(&a.values, &b.values, 5.1e-7);
    }
    assert_eq!(cec_back.len(), cec.len());
    for (a, b) in cec.iter().zip(&cec_back) {
        assert_eq!(
            (
                a.index,
                &a.input_axis,
                &a.output_axis,
                a.direction,
                a.mult_by_table
            ),
            (
                b.index,
                &b.input_axis,
                &b.output_axis,
                b.direction,
                b.mult_by_table
            )
        );
        assert_close(&a.positions, &b.positions, 1e-9);
        assert_close(&a.values, &b.values, 5.1e-7);
    }
}

fn assert_close(a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{x} vs {y}");
    }
}

#[test]
fn the_files_hold_the_card_as_ascii_comments_between_name_line_and_m17() {
    let model = load("mcv754-zfyx.urdf");
    let coeffs = random_coeffs(&model, 3);
    let (eec, cec) = model_tables(&model, &coeffs);
    let (eec_text, cec_text) = texts(&model, &eec, &cec);
    let names = siemens_axis_names(model.machine());
    for (text, first, card) in [
        (&eec_text, "%_N_AX_EEC_INI", eec_card(&eec, &names)),
        (&cec_text, "%_N_NC_CEC_INI", cec_card(&cec, &names)),
    ] {
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], first);
        assert_eq!(*lines.last().unwrap(), "M17");
        assert!(lines.contains(&"CHANDATA(1)"));
        for l in &lines[1..lines.len() - 1] {
            assert!(l.is_ascii(), "{l}");
            assert!(
                l.starts_with(';') || l.starts_with('$') || *l == "CHANDATA(1)",
                "{l}"
            );
        }
        let comments: String = lines
            .iter()
            .filter(|l| l.starts_with(';'))
            .copied()
            .collect();
        for key in [
            "format",
            "values are",
            "sign",
            "squareness",
            "units",
            "the control will",
        ] {
            assert!(comments.contains(&format!("; {key}")), "{key} missing");
        }
        assert!(comments.contains("X -> X1") && comments.contains("Z -> Z1"));
        assert!(card.quantity == Quantity::Error);
    }
    assert!(eec_text.contains("MD32700") && eec_text.contains("MD38000"));
    assert!(cec_text.contains("MD18342") && cec_text.contains("8040"));
}

// ----- What the tables are -----

/// The EEC table is the negated pitch table (when the spacing divides the stroke), and the
/// CEC tables are zero with their input axis at its held position.
#[test]
fn eec_is_the_negated_pitch_table_and_cec_is_zero_at_the_hold() {
    let model = load("mcv754-zfyx.urdf");
    let coeffs = random_coeffs(&model, 11);
    let hold = default_hold(model.machine());
    let names = siemens_axis_names(model.machine());
    for a in linear_letters(&model) {
        let spacing = tenth_mm(&model, a);
        let eec = siemens_eec_table(&model, &coeffs, a, spacing, &hold, &names).unwrap();
        let pitch = pitch_table(&model, &coeffs, a, spacing, &hold).unwrap();
        assert_close(&eec.positions, &pitch.positions_mm, 1e-9);
        let negated: Vec<f64> = pitch.forward_um.iter().map(|c| -c / 1e3).collect();
        assert_close(&eec.values, &negated, 1e-12);
        assert!(
            eec.values.iter().any(|v| v.abs() > 1e-3),
            "errors too small"
        );
        let from_pitch = eec_from_pitch(&pitch, &format!("{a}1")).unwrap();
        assert_close(&from_pitch.values, &negated, 0.0);
    }
    let (_, cec) = model_tables(&model, &coeffs);
    for t in &cec {
        let letter = t.input_axis.chars().next().unwrap();
        let held_mm = hold[model.machine().axis_index(letter).unwrap()] * 1e3;
        assert!(t.value_at(held_mm).abs() < 1e-12, "{}", t.name());
        assert!(
            t.values.iter().any(|v| v.abs() > 1e-4),
            "{} is flat",
            t.name()
        );
    }
}

#[test]
fn the_step_is_the_largest_one_dividing_the_stroke() {
    let nodes = equidistant_nodes_mm(-0.27, 0.27, 50.0, "x").unwrap();
    assert_eq!(nodes.len(), 12);
    assert!((nodes[1] - nodes[0] - 540.0 / 11.0).abs() < 1e-12);
    assert_eq!((nodes[0], nodes[11]), (-270.0, 270.0));
    let nodes = equidistant_nodes_mm(-0.27, 0.27, 54.0, "x").unwrap();
    assert_eq!(nodes.len(), 11);
    assert!(equidistant_nodes_mm(0.0, 1.0, 0.0, "x").is_err());
}

// ----- Modulo tables (a rotary axis' table, as the rotary positioning table will pass it) -----

/// A periodic error over one turn (degrees), sampled every 15°; the ends match.
fn periodic_table(a: &[f64]) -> EecTable {
    let f = |deg: f64| {
        let t = deg.to_radians();
        a[0] * t.cos() + a[1] * t.sin() + a[2] * (2.0 * t).cos() + a[3] * (3.0 * t).sin()
    };
    let positions: Vec<f64> = (0..=24).map(|k| 15.0 * k as f64).collect();
    let mut values: Vec<f64> = positions.iter().map(|&p| f(p)).collect();
    values[24] = values[0];
    EecTable::new("C1", positions, values, true)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The control repeats a modulo table every turn: a position one or more turns away gets
    /// the same value, the points get their values, and the crate's interpolation agrees.
    #[test]
    fn a_modulo_table_repeats_every_turn(
        a in proptest::collection::vec(-5e-3f64..5e-3, 4),
        at in 0.0f64..360.0,
        turns in -3i32..=3,
    ) {
        let table = periodic_table(&a);
        let card = eec_card(std::slice::from_ref(&table), &[AxisMap { mtcal: 'C', control: "C1".into() }]);
        prop_assert!(card.rotary_direction.contains("right-handed"));
        let text = siemens_eec_text(std::slice::from_ref(&table), &card, "", &SiemensLimits::default()).unwrap();
        let ctl = &control_eec(&text)["C1"];
        prop_assert!(ctl.modulo);
        let shifted = at + 360.0 * turns as f64;
        prop_assert!((ctl.at(shifted) - ctl.at(at)).abs() < 1e-12);
        prop_assert!((ctl.at(shifted) - table.value_at(shifted)).abs() < 1e-6);
        for (p, v) in table.positions.iter().zip(&table.values) {
            prop_assert!((ctl.at(p + 360.0 * turns as f64) - v).abs() < 5.1e-7);
        }
        let back = read_siemens_eec_str(&text, Path::new("c.ini"), &SiemensLimits::default()).unwrap();
        prop_assert!(back[0].is_modulo && back[0].values.len() == 25);
    }
}

#[test]
fn a_table_without_modulo_holds_its_end_values() {
    let mut table = periodic_table(&[1e-3, 2e-3, 0.0, 0.0]);
    table.is_modulo = false;
    table.values[24] = 4e-3;
    let text = siemens_eec_text(
        std::slice::from_ref(&table),
        &eec_card(&[], &[]),
        "",
        &SiemensLimits::default(),
    )
    .unwrap();
    let ctl = &control_eec(&text)["C1"];
    for (x, want) in [(-30.0, table.values[0]), (400.0, 4e-3), (720.0, 4e-3)] {
        assert!((ctl.at(x) - want).abs() < 1e-12);
        assert!((table.value_at(x) - want).abs() < 1e-12);
    }
}

// ----- The validators: what the control would refuse or misread -----

fn eec(positions: &[f64], values: &[f64]) -> EecTable {
    EecTable::new("X1", positions.to_vec(), values.to_vec(), false)
}

fn refusal_eec(tables: &[EecTable], limits: &SiemensLimits) -> SiemensError {
    match siemens_eec_text(tables, &eec_card(tables, &[]), "", limits) {
        Err(CompensateError::Siemens(e)) => e,
        other => panic!("expected a Siemens refusal, got {other:?}"),
    }
}

fn refusal_cec(tables: &[CecTable], limits: &SiemensLimits) -> SiemensError {
    match siemens_cec_text(tables, &cec_card(tables, &[]), "", limits) {
        Err(CompensateError::Siemens(e)) => e,
        other => panic!("expected a Siemens refusal, got {other:?}"),
    }
}

#[test]
fn too_many_points_are_refused_with_the_machine_data_to_change() {
    let positions: Vec<f64> = (0..201).map(|k| k as f64).collect();
    let t = eec(&positions, &vec![0.0; 201]);
    let e = refusal_eec(std::slice::from_ref(&t), &SiemensLimits::default());
    assert!(matches!(
        e,
        SiemensError::TooManyPoints {
            points: 201,
            max: 200,
            ..
        }
    ));
    assert!(e.to_string().contains("MD38000"), "{e}");
    let roomy = SiemensLimits {
        enc_comp_max_points: 801,
        ..SiemensLimits::default()
    };
    assert!(siemens_eec_text(&[t], &eec_card(&[], &[]), "", &roomy).is_ok());
    let c = CecTable::new(0, "X1", "Y1", positions, vec![0.0; 201]);
    let e = refusal_cec(&[c], &SiemensLimits::default());
    assert!(e.to_string().contains("MD18342"), "{e}");
}

#[test]
fn unequal_steps_unsorted_and_short_tables_are_refused() {
    let limits = SiemensLimits::default();
    let e = refusal_eec(&[eec(&[0.0, 10.0, 20.0, 35.0], &[0.0; 4])], &limits);
    assert!(
        matches!(e, SiemensError::UnequalSteps { index: 1, .. }),
        "{e}"
    );
    let e = refusal_eec(&[eec(&[0.0, 10.0, 5.0], &[0.0; 3])], &limits);
    assert!(matches!(e, SiemensError::Unsorted { index: 2, .. }), "{e}");
    let e = refusal_eec(&[eec(&[0.0], &[0.0])], &limits);
    assert!(
        matches!(e, SiemensError::TooFewPoints { points: 1, .. }),
        "{e}"
    );
    let e = refusal_eec(&[eec(&[0.0, 1.0], &[0.0; 3])], &limits);
    assert!(matches!(e, SiemensError::LengthMismatch { .. }), "{e}");
    // A pitch table's shorter last interval cannot be a Siemens table.
    let model = load("mcv754-zfyx.urdf");
    let hold = default_hold(model.machine());
    let coeffs = vec![0.0; model.n_coeffs()];
    let pitch = pitch_table(&model, &coeffs, 'X', 40.0, &hold).unwrap();
    let e = eec_from_pitch(&pitch, "X1").unwrap_err();
    assert!(
        matches!(
            e,
            CompensateError::Siemens(SiemensError::UnequalSteps { .. })
        ),
        "{e}"
    );
    let e = eec_from_pitch(&pitch.with_reversal_um(2.0), "X1").unwrap_err();
    assert!(matches!(
        e,
        CompensateError::Siemens(SiemensError::Bidirectional { axis: 'X' })
    ));
}

#[test]
fn modulo_ends_values_in_um_and_bad_names_are_refused() {
    let limits = SiemensLimits::default();
    let mut t = eec(&[0.0, 180.0, 360.0], &[0.001, 0.002, 0.0]);
    t.is_modulo = true;
    let e = refusal_eec(std::slice::from_ref(&t), &limits);
    assert!(matches!(e, SiemensError::ModuloEnds { .. }), "{e}");
    t.values[2] = 0.001;
    assert!(siemens_eec_text(&[t], &eec_card(&[], &[]), "", &limits).is_ok());
    let e = refusal_eec(&[eec(&[0.0, 10.0], &[0.0, 12.5])], &limits);
    assert!(matches!(e, SiemensError::ValueTooLarge { index: 1, .. }));
    assert!(e.to_string().contains("µm written as mm"), "{e}");
    let mut bad = eec(&[0.0, 10.0], &[0.0, 0.001]);
    bad.axis = "1X".into();
    assert!(matches!(
        refusal_eec(&[bad], &limits),
        SiemensError::BadAxisName { .. }
    ));
    let twice = [eec(&[0.0, 10.0], &[0.0; 2]), eec(&[0.0, 5.0], &[0.0; 2])];
    assert!(matches!(
        refusal_eec(&twice, &limits),
        SiemensError::DuplicateTable { .. }
    ));
}

#[test]
fn cec_table_numbers_and_multiplications_are_checked() {
    let limits = SiemensLimits::default();
    let t = |index: usize| CecTable::new(index, "X1", "Z1", vec![0.0, 10.0], vec![0.0, 0.001]);
    let e = refusal_cec(&[t(8)], &limits);
    assert!(
        matches!(
            e,
            SiemensError::TableIndex {
                index: 8,
                max: 8,
                ..
            }
        ),
        "{e}"
    );
    let e = refusal_cec(&[t(0), t(0)], &limits);
    assert!(matches!(e, SiemensError::DuplicateTable { .. }), "{e}");
    let mut m = t(1);
    m.mult_by_table = 5;
    let e = refusal_cec(&[t(0), m.clone()], &limits);
    assert!(
        matches!(e, SiemensError::MultByTable { refers: 5, .. }),
        "{e}"
    );
    m.mult_by_table = 1;
    assert!(siemens_cec_text(&[t(0), m], &cec_card(&[], &[]), "", &limits).is_ok());
    let model = load("mcv754-zfyx.urdf");
    let hold = default_hold(model.machine());
    let names = siemens_axis_names(model.machine());
    let coeffs = vec![0.0; model.n_coeffs()];
    let e = siemens_cec_table(&model, &coeffs, 0, 'X', 'X', 50.0, &hold, &names).unwrap_err();
    assert!(matches!(
        e,
        CompensateError::Siemens(SiemensError::SameAxis { axis: 'X' })
    ));
    let e = siemens_cec_table(&model, &coeffs, 0, 'X', 'Y', 50.0, &hold, &[]).unwrap_err();
    assert!(matches!(
        e,
        CompensateError::Siemens(SiemensError::NoControlName { letter: 'X', .. })
    ));
}

// ----- The readers: every bad file refused with file, line and column -----

/// A small EEC file and a small CEC file.
fn small_texts() -> (String, String) {
    let limits = SiemensLimits::default();
    let e = eec(&[-10.0, 0.0, 10.0, 20.0], &[0.001, -0.002, 0.003, 0.0]);
    let c = CecTable::new(0, "X1", "Z1", vec![0.0, 5.0, 10.0], vec![0.0, 0.002, 0.001]);
    let eec_text = siemens_eec_text(&[e], &eec_card(&[], &[]), "", &limits).unwrap();
    let cec_text = siemens_cec_text(&[c], &cec_card(&[], &[]), "", &limits).unwrap();
    (eec_text, cec_text)
}

/// `text` with the line starting with `prefix` replaced by `with` (or removed when `None`),
/// and the replaced line's number.
fn edit(text: &str, prefix: &str, with: Option<&str>) -> (String, usize) {
    let mut at = 0;
    let mut out = String::new();
    for (i, l) in text.lines().enumerate() {
        if at == 0 && l.starts_with(prefix) {
            at = i + 1;
            if let Some(w) = with {
                out.push_str(w);
                out.push('\n');
            }
        } else {
            out.push_str(l);
            out.push('\n');
        }
    }
    assert!(at > 0, "no line starts with {prefix}");
    (out, at)
}

fn line_of(text: &str, prefix: &str) -> usize {
    text.lines().position(|l| l.starts_with(prefix)).unwrap() + 1
}

/// The reader's refusal: (line, column, message).
fn refused(text: &str, cec: bool, limits: &SiemensLimits) -> (usize, usize, String) {
    let file = Path::new("bad.ini");
    let r = if cec {
        read_siemens_cec_str(text, file, limits).map(|_| ())
    } else {
        read_siemens_eec_str(text, file, limits).map(|_| ())
    };
    match r {
        Err(CompensateError::Parse { at, message }) => {
            assert_eq!(at.file, file);
            (at.line, at.column, message)
        }
        other => panic!("expected a located refusal, got {other:?}"),
    }
}

#[test]
fn the_small_files_read_back() {
    let (e, c) = small_texts();
    let limits = SiemensLimits::default();
    let eec_back = read_siemens_eec_str(&e, Path::new("e"), &limits).unwrap();
    assert_close(&eec_back[0].positions, &[-10.0, 0.0, 10.0, 20.0], 1e-12);
    assert_close(&eec_back[0].values, &[0.001, -0.002, 0.003, 0.0], 0.0);
    let cec_back = read_siemens_cec_str(&c, Path::new("c"), &limits).unwrap();
    assert_eq!(
        (
            cec_back[0].input_axis.as_str(),
            cec_back[0].output_axis.as_str()
        ),
        ("X1", "Z1")
    );
    // K3's own spelling: blanks around `=` and in the indices, comments after statements.
    let spaced = e
        .replace("$AA_ENC_COMP[0,1,X1]=", "$AA_ENC_COMP[0, 1, X1] = ")
        .replace("CHANDATA(1)", "CHANDATA(1) ; channel 1");
    assert_eq!(
        read_siemens_eec_str(&spaced, Path::new("e"), &limits).unwrap(),
        eec_back
    );
}

#[test]
fn eec_reader_refusals_are_located() {
    let (text, _) = small_texts();
    let limits = SiemensLimits::default();
    // MAX not at MIN + STEP·(n − 1): the MAX line, at its value.
    let (bad, line) = edit(
        &text,
        "$AA_ENC_COMP_MAX",
        Some("$AA_ENC_COMP_MAX[0,X1]=25.0"),
    );
    let (l, c, m) = refused(&bad, false, &limits);
    assert_eq!((l, c), (line, 24), "{m}");
    assert!(m.contains("MAX = 25"), "{m}");
    // A gap: the last point's line.
    let (bad, _) = edit(&text, "$AA_ENC_COMP[0,2,X1]", None);
    let (l, _, m) = refused(&bad, false, &limits);
    assert_eq!(l, line_of(&bad, "$AA_ENC_COMP[0,3,X1]"), "{m}");
    assert!(m.contains("point 2 is not assigned"), "{m}");
    // Twice the same point.
    let dup = text.replace(
        "$AA_ENC_COMP_STEP",
        "$AA_ENC_COMP[0,1,X1]=0.0\n$AA_ENC_COMP_STEP",
    );
    let (l, c, m) = refused(&dup, false, &limits);
    assert_eq!((l, c), (line_of(&dup, "$AA_ENC_COMP_STEP") - 1, 1), "{m}");
    assert!(m.contains("assigned twice"), "{m}");
    // An exponent the control does not read.
    let (bad, line) = edit(
        &text,
        "$AA_ENC_COMP[0,0,X1]",
        Some("$AA_ENC_COMP[0,0,X1]=1e-3"),
    );
    assert_eq!(refused(&bad, false, &limits).0, line);
    assert_eq!(refused(&bad, false, &limits).1, 22);
    // A value in µm.
    let (bad, line) = edit(
        &text,
        "$AA_ENC_COMP[0,1,X1]",
        Some("$AA_ENC_COMP[0,1,X1]=3.0"),
    );
    let (l, c, m) = refused(&bad, false, &limits);
    assert_eq!((l, c), (line, 22), "{m}");
    assert!(m.contains("µm written as mm"), "{m}");
    // More points than MD38000 allows: the first point beyond.
    let small = SiemensLimits {
        enc_comp_max_points: 3,
        ..limits.clone()
    };
    let (l, _, m) = refused(&text, false, &small);
    assert_eq!(l, line_of(&text, "$AA_ENC_COMP[0,3,X1]"), "{m}");
    assert!(m.contains("MD38000"), "{m}");
    // A modulo table whose ends differ: the last value.
    let (bad, _) = edit(
        &text,
        "$AA_ENC_COMP_IS_MODULO",
        Some("$AA_ENC_COMP_IS_MODULO[0,X1]=1"),
    );
    let (l, _, m) = refused(&bad, false, &limits);
    assert_eq!(l, line_of(&bad, "$AA_ENC_COMP[0,3,X1]"), "{m}");
    // Missing IS_MODULO: the table's first statement.
    let (bad, _) = edit(&text, "$AA_ENC_COMP_IS_MODULO", None);
    let (l, _, m) = refused(&bad, false, &limits);
    assert_eq!(l, line_of(&bad, "$AA_ENC_COMP[0,0,X1]"), "{m}");
    assert!(m.contains("IS_MODULO"), "{m}");
    // The frame: name line, M17 last, known variables only.
    let (bad, _) = edit(&text, "%_N_AX_EEC_INI", Some("%_N_NC_CEC_INI"));
    assert_eq!(refused(&bad, false, &limits).0, 1);
    let (bad, _) = edit(&text, "M17", None);
    let (l, _, m) = refused(&bad, false, &limits);
    assert_eq!(l, bad.lines().count() + 1, "{m}");
    let after = format!("{text}$AA_ENC_COMP_STEP[0,X1]=1.0\n");
    assert_eq!(refused(&after, false, &limits).0, text.lines().count() + 1);
    let unknown = text.replace("CHANDATA(1)", "$AA_ENC_COMP_FOO[0,X1]=1");
    let (l, c, m) = refused(&unknown, false, &limits);
    assert_eq!((l, c), (line_of(&text, "CHANDATA"), 1), "{m}");
    let (bad, line) = edit(
        &text,
        "$AA_ENC_COMP_STEP",
        Some("$AA_ENC_COMP_STEP[2,X1]=10.0"),
    );
    assert_eq!(refused(&bad, false, &limits).0, line);
}

#[test]
fn cec_reader_refusals_are_located() {
    let (_, text) = small_texts();
    let limits = SiemensLimits::default();
    let (bad, line) = edit(&text, "$AN_CEC_DIRECTION", Some("$AN_CEC_DIRECTION[0]=2"));
    assert_eq!(refused(&bad, true, &limits).0, line);
    assert_eq!(refused(&bad, true, &limits).1, 22);
    let (bad, line) = edit(
        &text,
        "$AN_CEC_INPUT_AXIS",
        Some("$AN_CEC_INPUT_AXIS[0]=X1"),
    );
    let (l, c, m) = refused(&bad, true, &limits);
    assert_eq!((l, c), (line, 23), "{m}");
    let (bad, line) = edit(
        &text,
        "$AN_CEC_MULT_BY_TABLE",
        Some("$AN_CEC_MULT_BY_TABLE[0]=4"),
    );
    let (l, c, m) = refused(&bad, true, &limits);
    assert_eq!((l, c), (line, 26), "{m}");
    assert!(m.contains("MULT_BY_TABLE = 4"), "{m}");
    let (bad, line) = edit(&text, "$AN_CEC_STEP", Some("$AN_CEC_STEP[0]=-5.0"));
    assert_eq!(refused(&bad, true, &limits).0, line);
    let (bad, _) = edit(&text, "$AN_CEC_OUTPUT_AXIS", None);
    let (l, _, m) = refused(&bad, true, &limits);
    assert_eq!(l, line_of(&bad, "$AN_CEC[0,0]"), "{m}");
    assert!(m.contains("OUTPUT_AXIS"), "{m}");
    let few = SiemensLimits {
        cec_max_tables: 0,
        ..limits.clone()
    };
    let (l, _, m) = refused(&text, true, &few);
    assert_eq!(l, line_of(&text, "$AN_CEC[0,0]"), "{m}");
    assert!(m.contains("MD18342"), "{m}");
    let wrong_args = text.replace("$AN_CEC_MIN[0]", "$AN_CEC_MIN[0,1]");
    assert_eq!(
        refused(&wrong_args, true, &limits).0,
        line_of(&text, "$AN_CEC_MIN")
    );
}
