//! NC programs for measuring paths: the commanded poses of a run as plain ISO G-code, so the
//! path a plugin plans (`InstrumentPlugin::path`) can be run on the machine as planned.
//!
//! ```text
//! %
//! (MTCAL R-TEST XYC)
//! (machine mcu630, axes XYZAC, 73 poses, feed 500.0 mm/min)
//! (linear axes mm, rotary axes deg; written by mtcal)
//! G90 G21 G94
//! N10 G01 X250.0000 Y0.0000 Z-150.0000 A0.0000 C0.0000 F500.0
//! …
//! M30
//! %
//! ```
//!
//! Absolute positions (`G90`), millimetres (`G21`), feed per minute (`G94`); every pose is one
//! linear move `G01` with every axis word, in the machine's canonical axis order, 4 decimals.
//! The feed is what the control makes of `F` for a move with rotary axes (without tool-centre-
//! point control, usually a feed along the combined axis motion); choose it for the instrument's
//! sampling rate.

use mtcal_kinematics::Machine;
use std::fmt::Write;

/// The G-code program of `poses` (SI axis positions in the machine's canonical order, one
/// `Vec` per pose) at feed `feed_mm_min`. `title` goes into the first comment line (parentheses
/// and line breaks in it are replaced, so it cannot end the comment early).
///
/// Panics if a pose does not have one finite position per axis or the feed is not finite and
/// positive: the poses come from a path function, so that is a programming error.
pub fn nc_program(machine: &Machine, poses: &[Vec<f64>], feed_mm_min: f64, title: &str) -> String {
    assert!(
        feed_mm_min.is_finite() && feed_mm_min > 0.0,
        "nc_program: feed {feed_mm_min} mm/min is not finite and positive"
    );
    let n = machine.n_axes();
    let clean: String = title
        .chars()
        .map(|c| match c {
            '(' => '[',
            ')' => ']',
            '\n' | '\r' | '\t' => ' ',
            c => c,
        })
        .collect();
    let mut s = String::new();
    s.push_str("%\n");
    let _ = writeln!(s, "({})", clean.trim());
    let _ = writeln!(
        s,
        "(machine {}, axes {}, {} poses, feed {:.1} mm/min)",
        machine.name().replace(['(', ')'], ""),
        machine.letters(),
        poses.len(),
        feed_mm_min
    );
    s.push_str("(linear axes mm, rotary axes deg; written by mtcal)\n");
    s.push_str("G90 G21 G94\n");
    for (k, q) in poses.iter().enumerate() {
        assert!(
            q.len() == n && q.iter().all(|v| v.is_finite()),
            "nc_program: pose {k} {q:?} needs one finite position per axis of {}",
            machine.letters()
        );
        let _ = write!(s, "N{} G01", 10 * (k + 1));
        for (axis, &v) in machine.axes().iter().zip(q) {
            let value = axis.kind().to_file(v);
            let _ = write!(s, " {}{}", axis.letter().as_char(), fixed4(value));
        }
        let _ = writeln!(s, " F{feed_mm_min:.1}");
    }
    s.push_str("M30\n%\n");
    s
}

/// `v` with 4 decimals, never `-0.0000`.
fn fixed4(v: f64) -> String {
    let s = format!("{v:.4}");
    if s == "-0.0000" { "0.0000".into() } else { s }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_kinematics::{AxisKind, BranchSpec, JointSpec, MachineSpec};
    use nalgebra::{Isometry3, Vector3};

    fn machine() -> Machine {
        let joint = |letter: char, kind: AxisKind, axis: [f64; 3]| JointSpec {
            letter,
            kind,
            origin: Isometry3::identity(),
            axis: Vector3::from(axis),
            limits: (kind == AxisKind::Linear).then_some((-1.0, 1.0)),
        };
        let spec = MachineSpec {
            name: "test (xyzac)".into(),
            workpiece: BranchSpec {
                joints: vec![
                    joint('A', AxisKind::Rotary, [-1.0, 0.0, 0.0]),
                    joint('C', AxisKind::Rotary, [0.0, 0.0, -1.0]),
                ],
                end: Isometry3::identity(),
            },
            tool: BranchSpec {
                joints: vec![
                    joint('X', AxisKind::Linear, [1.0, 0.0, 0.0]),
                    joint('Y', AxisKind::Linear, [0.0, 1.0, 0.0]),
                    joint('Z', AxisKind::Linear, [0.0, 0.0, 1.0]),
                ],
                end: Isometry3::identity(),
            },
        };
        Machine::try_new(&spec).expect("valid machine")
    }

    #[test]
    fn the_program_reads_back_as_the_poses() {
        let m = machine();
        assert_eq!(m.letters(), "XYZAC");
        let poses: Vec<Vec<f64>> = (0..7)
            .map(|k| {
                let k = k as f64;
                vec![
                    0.25 - 0.01 * k,
                    -0.0000001,
                    -0.15 + 0.0123456 * k,
                    (-30.0f64 + 10.0 * k).to_radians(),
                    (60.0 * k).to_radians(),
                ]
            })
            .collect();
        let text = m_program(&m, &poses);
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("%"));
        assert_eq!(lines.next(), Some("(R-TEST [XYC] 1/2)"));
        assert!(text.contains("\nG90 G21 G94\n"), "{text}");
        assert!(text.ends_with("M30\n%\n"), "{text}");
        let moves: Vec<&str> = text.lines().filter(|l| l.starts_with('N')).collect();
        assert_eq!(moves.len(), poses.len());
        for (k, (line, q)) in moves.iter().zip(&poses).enumerate() {
            let words: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(words[0], format!("N{}", 10 * (k + 1)));
            assert_eq!(words[1], "G01");
            assert_eq!(words.last(), Some(&"F500.0"));
            let axis_words = &words[2..words.len() - 1];
            assert_eq!(axis_words.len(), m.n_axes(), "{line}");
            for ((word, axis), &v) in axis_words.iter().zip(m.axes()).zip(q) {
                let (letter, number) = word.split_at(1);
                assert_eq!(
                    letter.chars().next(),
                    Some(axis.letter().as_char()),
                    "{line}"
                );
                assert!(!number.starts_with("-0.0000"), "{line}");
                assert_eq!(number.split('.').nth(1).map(str::len), Some(4), "{line}");
                let read: f64 = number.parse().expect("a number");
                let expect = axis.kind().to_file(v);
                assert!((read - expect).abs() <= 0.5e-4 + 1e-9, "{word} vs {expect}");
            }
        }
    }

    fn m_program(m: &Machine, poses: &[Vec<f64>]) -> String {
        nc_program(m, poses, 500.0, "R-TEST (XYC)\n1/2")
    }

    #[test]
    #[should_panic(expected = "one finite position per axis")]
    fn a_short_pose_is_a_programming_error() {
        nc_program(&machine(), &[vec![0.0; 3]], 500.0, "x");
    }
}
