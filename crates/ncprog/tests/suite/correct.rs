//! Pose correction on shipped machines with random identified errors of a few µm/µrad.

use crate::common;

use common::model;
use mtcal_kinematics::{AxisKind, MachineModel};
use mtcal_ncprog::{
    CorrectError, CorrectOptions, Decimals, Program, correct_program, gcode::AXIS_LETTERS,
};
use mtcal_testkit::random::uniform;

fn coeffs(model: &MachineModel, seed: u64) -> Vec<f64> {
    uniform(seed, model.n_coeffs())
        .iter()
        .map(|u| u * 5e-6)
        .collect()
}

const THREE_AXIS: &str = "%\n(TEST PART)\n(mm; written by hand)\nG90 G21 G94\n\
N10 G0 X-100.0 Y50.0 Z-20.0 S8000 M3\n\
N20 G1 Z-150.0 F500.0 ; plunge\n\
N30 X120.5 (along x)\n\
N40 Y-80.25\n\
N50 X0.0 Y0.0 Z-300.0\n\
G4 P1\n\
N60 G0 Z-10\n\
M30\n%\n";

const FIVE_AXIS: &str = "%\r\n(FIVE AXIS)\r\nG90 G21\r\n\
N10 G0 X50.0 Y-20.0 Z-100.0 A30.0 C0.0\r\n\
N20 G1 X80.0 A45.0 C90.0 F800\r\n\
N30 Y40.0 C-135.5 ; turn\r\n\
N40 X-60.0 Y10.0 Z-250.0 A-20.0 C200.0\r\n\
N50 A100.0 (tilted)\r\n\
M30\r\n%\r\n";

/// Checks every corrected pose and the program as written (read back) against the targets.
fn check(model: &MachineModel, c: &[f64], text: &str, opts: &CorrectOptions) {
    let program = Program::parse(text).unwrap();
    let corr = correct_program(model, c, &program, opts).unwrap();
    let machine = model.machine();
    let mut ws = model.workspace();
    let rotary = machine.axes().iter().any(|a| a.kind() == AxisKind::Rotary);
    let miss = |q: &[f64], q_cmd: &[f64], ws: &mut _| {
        let act = model.tool_pose(q, c, ws);
        let nom = machine.tool_in_workpiece(q_cmd);
        let dv = (act.r.column(2) - nom.r.column(2)).norm();
        (
            (act.t - nom.t).norm() * 1e6,
            if rotary { dv * 1e6 } else { 0.0 },
        )
    };
    for p in &corr.poses {
        assert!(
            p.iterations <= 3,
            "line {}: {} Newton steps",
            p.line,
            p.iterations
        );
        let (dp, dv) = miss(&p.q, &p.q_cmd, &mut ws);
        assert!(
            dp < 1e-3 && dv < 1e-3,
            "line {}: {dp} µm, {dv} µrad",
            p.line
        );
        let (dp0, _) = miss(&p.q_cmd, &p.q_cmd, &mut ws);
        assert!(
            dp0 > 0.1,
            "line {}: the errors should matter ({dp0} µm)",
            p.line
        );
    }
    // The written program, read back: its modal poses put the tool on the targets too.
    let written = Program::parse(&corr.text).unwrap();
    let states = written.modal_states();
    assert_eq!(written.lines.len(), program.lines.len());
    for p in &corr.poses {
        let m = &states[p.line - 1];
        let q: Vec<f64> = machine
            .axes()
            .iter()
            .map(|ax| {
                let a = AXIS_LETTERS
                    .iter()
                    .position(|&l| l == ax.letter().as_char())
                    .unwrap();
                let v = m.axes[a].unwrap();
                ax.kind().from_file(v)
            })
            .collect();
        let (dp, dv) = miss(&q, &p.q_cmd, &mut ws);
        assert!(
            dp < 1e-3 && dv < 1e-3,
            "written line {}: {dp} µm, {dv} µrad",
            p.line
        );
    }
    // Lines without axis words are byte-identical, others keep their non-axis words.
    for (old, new) in program.lines.iter().zip(&written.lines) {
        if !old.has_axis_word() {
            assert_eq!(old.text, new.text);
        }
        assert_eq!(old.eol, new.eol);
        let others = |l: &mtcal_ncprog::Line| -> Vec<(char, f64)> {
            l.words
                .iter()
                .filter(|w| !AXIS_LETTERS.contains(&w.letter))
                .map(|w| (w.letter, w.value))
                .collect()
        };
        assert_eq!(others(old), others(new));
        let comment = |t: &str| t.find(['(', ';']).map(|i| t[i..].to_string());
        assert_eq!(comment(&old.text), comment(&new.text));
    }
}

/// Enough decimals that rounding stays below 1e-3 µm / µrad.
fn fine() -> CorrectOptions {
    CorrectOptions {
        decimals: Decimals::Fixed {
            linear_mm: 7,
            linear_inch: 8,
            rotary_deg: 9,
        },
        ..CorrectOptions::default()
    }
}

#[test]
fn three_axis_program_lands_on_the_nominal_targets() {
    let m = model("mcv754-zfyx.urdf");
    for seed in 1..4 {
        check(&m, &coeffs(&m, seed), THREE_AXIS, &fine());
    }
}

#[test]
fn an_inch_program_is_corrected_in_inches() {
    let m = model("mcv754-zfyx.urdf");
    let text = "G20 G90\nN1 G0 X-3.93701 Y1.9685 Z-0.7874\nN2 G1 Z-5.9055 F20.\nN3 X4.74409\n";
    check(&m, &coeffs(&m, 9), text, &fine());
    let corr = correct_program(
        &m,
        &coeffs(&m, 9),
        &Program::parse(text).unwrap(),
        &Default::default(),
    );
    let line = corr.unwrap().text.lines().nth(3).unwrap().to_string();
    assert!(line.starts_with("N3 X4.74"), "{line}");
    assert_eq!(
        line.split(' ').nth(1).unwrap().len(),
        "X4.74409".len(),
        "5 decimals: {line}"
    );
}

#[test]
fn five_axis_program_lands_on_the_nominal_targets_and_tool_axis() {
    let m = model("mcu630-cafyxz.urdf");
    for seed in 1..4 {
        check(&m, &coeffs(&m, seed), FIVE_AXIS, &fine());
    }
}

#[test]
fn default_decimals_write_four_and_round_trip_without_correction() {
    let m = model("mcv754-zfyx.urdf");
    let program = Program::parse(THREE_AXIS).unwrap();
    assert_eq!(program.text(), THREE_AXIS);
    let corr = correct_program(&m, &vec![0.0; m.n_coeffs()], &program, &Default::default());
    let text = corr.unwrap().text;
    // Zero errors: the same poses, numbers rewritten with 4 decimals.
    assert!(text.contains("N30 X120.5000 (along x)\n"), "{text}");
    assert!(
        text.contains("N20 G1 Z-150.0000 F500.0 ; plunge\n"),
        "{text}"
    );
    let corr = correct_program(&m, &coeffs(&m, 5), &program, &Default::default()).unwrap();
    for line in corr.text.lines().filter(|l| l.starts_with("N30")) {
        // Y and Z are corrected too, so they are written although the input had only X.
        assert!(line.contains(" Y") && line.contains(" Z"), "{line}");
    }
}

#[test]
fn a_singular_pose_is_reported_and_position_only_correction_works() {
    let m = model("mcu630-cafyxz.urdf");
    let c = coeffs(&m, 2);
    let text = "G90 G21\nN10 G1 X10 Y20 Z-100 A0 C30 F100\nN20 A30\n";
    let err = correct_program(&m, &c, &Program::parse(text).unwrap(), &fine()).unwrap_err();
    match &err {
        CorrectError::Poses { failures } => {
            assert_eq!(failures.len(), 1, "{err}");
            assert_eq!(failures[0].line, 2);
        }
        e => panic!("{e}"),
    }
    assert!(err.to_string().contains("line 2: singular"), "{err}");
    let opts = CorrectOptions {
        match_tool_axis: false,
        ..fine()
    };
    let corr = correct_program(&m, &c, &Program::parse(text).unwrap(), &opts).unwrap();
    assert_eq!(corr.poses.len(), 2);
    assert_eq!(corr.poses[0].q[3], 0.0);
}

#[test]
fn unsupported_programs_are_refused_with_the_line() {
    let m = model("mcv754-zfyx.urdf");
    let c = coeffs(&m, 1);
    let run = |t: &str| correct_program(&m, &c, &Program::parse(t).unwrap(), &fine());
    let cases = [
        ("G91 G1 X1 Y1 Z-1\n", CorrectError::Incremental { line: 1 }),
        (
            "G1 X0 Y0 Z-10\nG2 X1 Y1 I1 J0\n",
            CorrectError::Arc { line: 2 },
        ),
        ("X1 Y1 Z-1\n", CorrectError::NoMotionMode { line: 1 }),
        (
            "G1 X1 Y1\n",
            CorrectError::MissingAxis {
                line: 1,
                letter: 'Z',
            },
        ),
        ("G53 G0 Z0\n", CorrectError::NonModal { line: 1, code: 53 }),
    ];
    for (text, expect) in cases {
        assert_eq!(run(text).unwrap_err(), expect, "{text}");
    }
    assert!(matches!(
        run("G1 X1 Y1 Z-1 A5\n"),
        Err(CorrectError::UnknownAxis {
            line: 1,
            letter: 'A',
            ..
        })
    ));
}

#[test]
fn a_program_file_round_trips_through_the_file_system() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("part.nc");
    std::fs::write(&path, FIVE_AXIS).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let program = Program::parse(&text).unwrap();
    std::fs::write(&path, program.text()).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), FIVE_AXIS.as_bytes());
}
