//! Topology codes: the short strings the literature uses for a machine's kinematic chain, and
//! the nominal machines they stand for.
//!
//! A code lists the axis letters of the chain from one end to the other, with `F` marking the
//! machine frame. Letters: linear `X Y Z U V W`, rotary `A B C`, the frame `F`; lower-case `w`
//! and `t` mark the workpiece and tool ends.
//!
//! - **Explicit** `wCAFYXZt` reads from the workpiece (`w`) through the frame to the tool (`t`):
//!   C carries the workpiece and sits on A, A sits on the frame; Y sits on the frame, X on Y, Z on
//!   X, and Z carries the tool. The reversed explicit form `tZXYFACw` means the same machine.
//! - **Bare** `CAFYXZ` has no end markers, and the literature reads it both ways. mtcal reads a
//!   bare code **from the workpiece** by default ([`Reading::FromWorkpiece`]), the convention of
//!   the five-axis thesis (source 000: `CAFYXZ` for the MCU 630, `CAXFYZ` for the MU 6300).
//!   [`Reading::FromTool`] reverses it, as the rail paper needs (source 001: `ZFYX` is a C-frame
//!   machine with Z in the tool branch, and Y (saddle) then X (table) in the workpiece branch).
//!   End markers, when present, override the reading.
//!
//! [`nominal_machine`] builds a machine with documented default geometry for codes that stand in
//! for a URDF where nominal geometry does not matter.

use mtcal_kinematics::machine::{
    AxisKind, BranchSpec, JointSpec, Machine, MachineError, MachineSpec,
};
use mtcal_kinematics::names::AxisLetter;
use nalgebra::{Isometry3, Vector3};
use std::fmt;
use std::str::FromStr;

/// How to read a bare code (one without `w`/`t` end markers).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reading {
    /// The first letters are the workpiece branch, from the workpiece towards the frame
    /// (`CAFYXZ`: C carries the workpiece). The default: source 000's convention.
    #[default]
    FromWorkpiece,
    /// The first letters are the tool branch, from the tool towards the frame (`ZFYX`: Z carries
    /// the tool). Source 001's convention.
    FromTool,
}

/// A parsed topology code: the axis letters of each branch, from the frame outwards.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopologyCode {
    workpiece: Vec<AxisLetter>,
    tool: Vec<AxisLetter>,
}

impl TopologyCode {
    /// Axes of the workpiece branch from the frame to the workpiece (`wCAFYXZt` → A, C).
    pub fn workpiece_axes(&self) -> &[AxisLetter] {
        &self.workpiece
    }

    /// Axes of the tool branch from the frame to the tool (`wCAFYXZt` → Y, X, Z).
    pub fn tool_axes(&self) -> &[AxisLetter] {
        &self.tool
    }
}

/// The explicit form, e.g. `wCAFYXZt` — the same string as [`Machine::topology_code`].
impl fmt::Display for TopologyCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let wp: String = self.workpiece.iter().rev().map(|a| a.as_char()).collect();
        let tool: String = self.tool.iter().map(|a| a.as_char()).collect();
        write!(f, "w{wp}F{tool}t")
    }
}

/// Parses with the default [`Reading::FromWorkpiece`].
impl FromStr for TopologyCode {
    type Err = TopologyError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_code(s, Reading::default())
    }
}

/// Why a string is not a topology code. Positions count characters from 1.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TopologyError {
    #[error("empty topology code: expected axis letters and F for the frame, e.g. wCAFYXZt")]
    Empty,
    #[error(
        "topology code `{code}`: `{letter}` at position {position} is not an axis letter; \
         expected X Y Z U V W (linear), A B C (rotary), F (frame) or w/t at the ends{hint}"
    )]
    UnknownLetter {
        code: String,
        letter: char,
        position: usize,
        hint: &'static str,
    },
    #[error(
        "topology code `{code}` has no F: mark the machine frame between the two branches, \
         e.g. CAFYXZ"
    )]
    NoFrame { code: String },
    #[error(
        "topology code `{code}` has two frames (F at positions {first} and {second}); \
         a machine has one frame"
    )]
    TwoFrames {
        code: String,
        first: usize,
        second: usize,
    },
    #[error(
        "topology code `{code}`: axis {letter} appears twice (positions {first} and {second}); \
         each axis letter may name one axis only"
    )]
    DuplicateAxis {
        code: String,
        letter: char,
        first: usize,
        second: usize,
    },
    #[error(
        "topology code `{code}`: `{letter}` at position {position} is misplaced; w and t mark \
         the two ends (wCAFYXZt or tZXYFACw), or leave both out (CAFYXZ)"
    )]
    MisplacedEnd {
        code: String,
        letter: char,
        position: usize,
    },
    #[error("topology code `{code}` has no axis letters; a machine needs at least one axis")]
    NoAxes { code: String },
    /// The nominal machine failed validation. [`parse_code`] rules out every known cause; this
    /// variant exists so that a future rule in `Machine::try_new` surfaces as an error, not a
    /// panic.
    #[error("topology code `{code}`: {cause}")]
    Machine { code: String, cause: MachineError },
}

/// Parses a topology code. `reading` applies to bare codes only; `w`/`t` markers decide for
/// explicit ones. Surrounding whitespace is ignored.
pub fn parse_code(code: &str, reading: Reading) -> Result<TopologyCode, TopologyError> {
    let trimmed = code.trim();
    if trimmed.is_empty() {
        return Err(TopologyError::Empty);
    }
    let chars: Vec<char> = trimmed.chars().collect();
    let (body, offset, left_is_workpiece) = split_ends(trimmed, &chars, reading)?;
    let frame = find_frame(trimmed, body, offset)?;
    let letters = axis_letters(trimmed, body, offset, frame)?;
    let (left, right) = letters.split_at(frame);
    // The left part is read from its end towards the frame; store both from the frame outwards.
    let near_frame_first: Vec<AxisLetter> = left.iter().rev().copied().collect();
    let (workpiece, tool) = if left_is_workpiece {
        (near_frame_first, right.to_vec())
    } else {
        (right.to_vec(), near_frame_first)
    };
    if workpiece.is_empty() && tool.is_empty() {
        return Err(TopologyError::NoAxes {
            code: trimmed.into(),
        });
    }
    Ok(TopologyCode { workpiece, tool })
}

/// Strips `w…t` / `t…w` markers. Returns the letters between them, the 0-based index of the
/// first of those letters in `chars`, and whether the left part is the workpiece branch.
fn split_ends<'c>(
    code: &str,
    chars: &'c [char],
    reading: Reading,
) -> Result<(&'c [char], usize, bool), TopologyError> {
    let is_end = |c: char| c == 'w' || c == 't';
    let n = chars.len();
    let (first, last) = (chars[0], chars[n - 1]);
    let explicit = n >= 2 && is_end(first) && is_end(last) && first != last;
    let (body, offset) = if explicit {
        (&chars[1..n - 1], 1)
    } else {
        (chars, 0)
    };
    if let Some(i) = body.iter().position(|&c| is_end(c)) {
        return Err(TopologyError::MisplacedEnd {
            code: code.into(),
            letter: body[i],
            position: offset + i + 1,
        });
    }
    let left_is_workpiece = if explicit {
        first == 'w'
    } else {
        reading == Reading::FromWorkpiece
    };
    Ok((body, offset, left_is_workpiece))
}

/// Index of the single `F` within `body`.
fn find_frame(code: &str, body: &[char], offset: usize) -> Result<usize, TopologyError> {
    let mut frames = body.iter().enumerate().filter(|(_, c)| **c == 'F');
    let first = frames
        .next()
        .ok_or_else(|| TopologyError::NoFrame { code: code.into() })?;
    if let Some((second, _)) = frames.next() {
        return Err(TopologyError::TwoFrames {
            code: code.into(),
            first: offset + first.0 + 1,
            second: offset + second + 1,
        });
    }
    Ok(first.0)
}

/// The axis letters of `body` with the frame left out, checked for known and unique letters.
fn axis_letters(
    code: &str,
    body: &[char],
    offset: usize,
    frame: usize,
) -> Result<Vec<AxisLetter>, TopologyError> {
    let mut out: Vec<(AxisLetter, usize)> = Vec::with_capacity(body.len());
    for (i, &c) in body.iter().enumerate() {
        let position = offset + i + 1;
        if i == frame {
            continue;
        }
        let letter = AxisLetter::new(c).ok_or_else(|| TopologyError::UnknownLetter {
            code: code.into(),
            letter: c,
            position,
            hint: letter_hint(c),
        })?;
        if let Some(&(_, first)) = out.iter().find(|(l, _)| *l == letter) {
            return Err(TopologyError::DuplicateAxis {
                code: code.into(),
                letter: c,
                first,
                second: position,
            });
        }
        out.push((letter, position));
    }
    Ok(out.into_iter().map(|(l, _)| l).collect())
}

fn letter_hint(c: char) -> &'static str {
    let upper = c.to_ascii_uppercase();
    if upper != c && (AxisLetter::new(upper).is_some() || upper == 'F') {
        " (axis letters and F are upper case; only w and t are lower case)"
    } else {
        ""
    }
}

/// Height of the head pivot above the tool point in a nominal machine (m): every rotary axis of
/// the tool branch passes through this point at the zero pose, so that a head's rotation moves
/// the tool point, as on a real head, and the pivot length shows up in the kinematics.
pub const NOMINAL_HEAD_PIVOT: f64 = 0.15;

/// Travel limits of an axis in a nominal machine (m or rad); `None` for C (continuous).
///
/// Linear strokes are X, U 1.0 m; Y, V 0.8 m; Z, W 0.6 m, **centred on zero** (−half…+half), so
/// that the zero pose — tool point on the workpiece origin — lies mid-travel and random positions
/// within the limits surround the workpiece. A and B turn −120°…+120°; C is unlimited.
pub fn nominal_limits(letter: AxisLetter) -> Option<(f64, f64)> {
    let half = match letter.as_char() {
        'X' | 'U' => 0.5,
        'Y' | 'V' => 0.4,
        'Z' | 'W' => 0.3,
        'A' | 'B' => 120f64.to_radians(),
        _ => return None,
    };
    Some((-half, half))
}

/// A nominal machine for a topology code, with this default geometry:
///
/// - linear axes move along their nominal machine direction (X, U → x; Y, V → y; Z, W → z);
///   rotary A, B, C turn about x, y, z; limits from [`nominal_limits`];
/// - CNC sign convention: joints of the workpiece branch get **negated** axis vectors, so that a
///   positive command moves the tool relative to the workpiece in the positive direction;
/// - all joint frames of the workpiece branch sit at the frame origin, which is also the
///   workpiece origin: its rotary axes pass through the workpiece origin;
/// - every rotary axis of the tool branch passes through a head pivot [`NOMINAL_HEAD_PIVOT`]
///   above the tool point (along +z, the tool axis);
/// - at all-zero axes every frame is aligned with the machine frame and the tool point sits on
///   the workpiece origin.
pub fn nominal_machine(code: &TopologyCode, name: &str) -> Result<Machine, TopologyError> {
    Machine::try_new(&nominal_spec(code, name)).map_err(|source| TopologyError::Machine {
        code: code.to_string(),
        cause: source,
    })
}

/// The [`MachineSpec`] behind [`nominal_machine`].
pub fn nominal_spec(code: &TopologyCode, name: &str) -> MachineSpec {
    let workpiece = BranchSpec {
        joints: code
            .workpiece
            .iter()
            .map(|&l| nominal_joint(l, -1.0, Isometry3::identity()))
            .collect(),
        end: Isometry3::identity(),
    };
    let mut pivot_placed = false;
    let mut tool_joints = Vec::with_capacity(code.tool.len());
    for &l in &code.tool {
        let mut origin = Isometry3::identity();
        if l.is_rotary() && !pivot_placed {
            origin = Isometry3::translation(0.0, 0.0, NOMINAL_HEAD_PIVOT);
            pivot_placed = true;
        }
        tool_joints.push(nominal_joint(l, 1.0, origin));
    }
    let tool_end = if pivot_placed {
        Isometry3::translation(0.0, 0.0, -NOMINAL_HEAD_PIVOT)
    } else {
        Isometry3::identity()
    };
    MachineSpec {
        name: name.to_string(),
        workpiece,
        tool: BranchSpec {
            joints: tool_joints,
            end: tool_end,
        },
    }
}

fn nominal_joint(letter: AxisLetter, sign: f64, origin: Isometry3<f64>) -> JointSpec {
    let mut axis = Vector3::zeros();
    axis[letter.nominal_cartesian()] = sign;
    JointSpec {
        letter: letter.as_char(),
        kind: if letter.is_rotary() {
            AxisKind::Rotary
        } else {
            AxisKind::Linear
        },
        origin,
        axis,
        limits: nominal_limits(letter),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_kinematics::machine::Side;
    use nalgebra::{Matrix3, Rotation3};
    use proptest::prelude::*;

    fn branches(code: &str, reading: Reading) -> (String, String) {
        let c = parse_code(code, reading).unwrap();
        let s = |v: &[AxisLetter]| v.iter().map(|a| a.as_char()).collect::<String>();
        (s(c.workpiece_axes()), s(c.tool_axes()))
    }

    #[test]
    fn literature_layouts_parse_to_their_branches() {
        // (code, reading, workpiece branch from the frame, tool branch from the frame)
        let table = [
            ("ZFYX", Reading::FromTool, "YX", "Z"), // source 001, MCV 754
            ("CAFYXZ", Reading::FromWorkpiece, "AC", "YXZ"), // source 000, MCU 630
            ("ZXYFAC", Reading::FromTool, "AC", "YXZ"), // source 000, MCU 700 reversed
            ("CAXFYZ", Reading::FromWorkpiece, "XAC", "YZ"), // source 000, MU 6300
            ("wCBXYFZt", Reading::FromTool, "YXBC", "Z"), // MCV1000 + NIKKEN (explicit wins)
            ("wFXYZCAt", Reading::FromWorkpiece, "", "XYZCA"), // head-head gantry
            ("wCXFYZBt", Reading::FromWorkpiece, "XC", "YZB"), // mixed table/head
        ];
        for (code, reading, wp, tool) in table {
            let (w, t) = branches(code, reading);
            assert_eq!((w.as_str(), t.as_str()), (wp, tool), "{code}");
        }
    }

    #[test]
    fn bare_explicit_and_reversed_forms_agree() {
        let explicit = parse_code("wCAFYXZt", Reading::FromTool).unwrap();
        let bare = parse_code("CAFYXZ", Reading::FromWorkpiece).unwrap();
        let reversed = parse_code("tZXYFACw", Reading::FromWorkpiece).unwrap();
        let bare_from_tool = parse_code("ZXYFAC", Reading::FromTool).unwrap();
        assert_eq!(explicit, bare);
        assert_eq!(explicit, reversed);
        assert_eq!(explicit, bare_from_tool);
        assert_eq!(explicit.to_string(), "wCAFYXZt");
        assert_eq!(" CAFYXZ ".parse::<TopologyCode>().unwrap(), explicit);
        assert_eq!(
            parse_code("ZFYX", Reading::FromTool).unwrap().to_string(),
            "wXYFZt"
        );
    }

    #[test]
    fn rejects_bad_codes_with_positions() {
        let err = |code: &str| parse_code(code, Reading::FromWorkpiece).unwrap_err();
        let table: [(&str, &str); 10] = [
            ("", "empty topology code"),
            ("CAQFYXZ", "`Q` at position 3 is not an axis letter"),
            ("cAFYXZ", "axis letters and F are upper case"),
            ("CAYXZ", "has no F"),
            ("CAFYFXZ", "F at positions 3 and 5"),
            ("wCAFYXCt", "axis C appears twice (positions 2 and 7)"),
            ("wCAFYXZ", "`w` at position 1 is misplaced"),
            ("CAwFYXZt", "`w` at position 3 is misplaced"),
            ("tCAFYtXZw", "`t` at position 6 is misplaced"),
            ("wFt", "no axis letters"),
        ];
        for (code, expected) in table {
            let msg = err(code).to_string();
            assert!(msg.contains(expected), "{code:?}: {msg}");
        }
        assert_eq!(
            err("wCAFYXCt"),
            TopologyError::DuplicateAxis {
                code: "wCAFYXCt".into(),
                letter: 'C',
                first: 2,
                second: 7,
            }
        );
    }

    #[test]
    fn nominal_geometry_is_as_documented() {
        let code = parse_code("CAXFYZB", Reading::FromWorkpiece).unwrap();
        let m = nominal_machine(&code, "nominal").unwrap();
        assert_eq!(m.topology_code(), "wCAXFYZBt");
        let x = &m.axes()[m.axis_index('X').unwrap()];
        assert_eq!(x.limits(), Some((-0.5, 0.5)));
        assert_eq!(*x.direction(), Vector3::new(-1.0, 0.0, 0.0));
        assert_eq!(m.axes()[m.axis_index('C').unwrap()].limits(), None);
        // B turns the head about its pivot 0.15 m above the tool point.
        let mut q = vec![0.0; m.n_axes()];
        q[m.axis_index('B').unwrap()] = std::f64::consts::FRAC_PI_2;
        let p = m.branch_pose(Side::Tool, &q).t;
        assert!((p - Vector3::new(-0.15, 0.0, 0.15)).norm() < 1e-12, "{p}");
    }

    fn code_strategy() -> impl Strategy<Value = (String, String)> {
        let letters: Vec<char> = "XYZUVWABC".chars().collect();
        (
            Just(letters).prop_shuffle(),
            1usize..=9,
            0usize..=9,
            any::<bool>(),
        )
            .prop_map(|(letters, n, split, bare)| {
                let used = &letters[..n];
                let (wp_from_w, tool) = used.split_at(split.min(n));
                let wp: String = wp_from_w.iter().collect();
                let tool: String = tool.iter().collect();
                let explicit = format!("w{wp}F{tool}t");
                let input = if bare {
                    format!("{wp}F{tool}")
                } else {
                    explicit.clone()
                };
                (input, explicit)
            })
    }

    /// The rotation of the tool relative to the workpiece when only `letter` moves by `v`.
    fn relative_motion(m: &Machine, letter: char, v: f64) -> (Vector3<f64>, Matrix3<f64>) {
        let mut q = vec![0.0; m.n_axes()];
        q[m.axis_index(letter).unwrap()] = v;
        let t = m.tool_in_workpiece(&q);
        (t.t, t.r)
    }

    proptest! {
        #[test]
        fn nominal_machines_follow_the_code((input, explicit) in code_strategy()) {
            let code = parse_code(&input, Reading::FromWorkpiece).unwrap();
            prop_assert_eq!(code.to_string(), explicit.clone());
            let m = nominal_machine(&code, "p").unwrap();
            prop_assert_eq!(m.topology_code(), explicit);
            let zero = m.tool_in_workpiece(&vec![0.0; m.n_axes()]);
            prop_assert!(zero.t.norm() < 1e-15);
            prop_assert!((zero.r - Matrix3::identity()).norm() < 1e-15);
            for a in m.axes() {
                let letter = a.letter();
                let mut dir = Vector3::zeros();
                dir[letter.nominal_cartesian()] = 1.0;
                let (t, r) = relative_motion(&m, letter.as_char(), 0.1);
                if letter.is_rotary() {
                    let expected = Rotation3::from_axis_angle(
                        &nalgebra::Unit::new_normalize(dir), 0.1);
                    prop_assert!((r - expected.matrix()).norm() < 1e-12, "{}", letter);
                } else {
                    prop_assert!((t - dir * 0.1).norm() < 1e-12, "{}: {}", letter, t);
                }
            }
        }
    }
}
