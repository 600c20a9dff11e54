//! Axis positions and map grids written as the command line takes them: held positions
//! `Y=0,Z=-270` (`--hold`, mm / degrees), rotary positions `A=30,C=45` (`--at`, degrees),
//! orientation grids `A=-30..90/5,C=0..270/4` (`--orientations`) and grid counts `21x22x22`
//! (`--grid`). Every message names the option and the item it could not read.

use mtcal_kinematics::volmap::{Grid, GridError};
use mtcal_kinematics::{AxisKind, Machine};
use std::num::{ParseFloatError, ParseIntError};

/// Points per linear axis of a map without `--grid`: source 004's 21 × 22 × 22 = 10,164 (21
/// on any further linear axis).
const SOURCE004_COUNTS: [usize; 6] = [21, 22, 22, 21, 21, 21];

/// Why a text could not be read.
#[derive(Debug, thiserror::Error)]
pub enum AxisTextError {
    /// An item not of the option's form `form`.
    #[error("{option} `{item}`: expected {form}")]
    Form {
        option: &'static str,
        item: String,
        form: &'static str,
    },
    /// A value that is not a number (`unit`: what number, e.g. ` of degrees`).
    #[error("{option} `{item}`: `{value}` is not a number{unit}")]
    Number {
        option: &'static str,
        item: String,
        value: String,
        unit: &'static str,
        #[source]
        source: ParseFloatError,
    },
    /// A letter naming no axis of the machine (`which`: `axis` or `rotary axis`).
    #[error("{option} `{item}`: the machine has no {which} {letter}")]
    NoAxis {
        option: &'static str,
        item: String,
        which: &'static str,
        letter: char,
    },
    #[error("{option}: the machine has no rotary axis")]
    NoRotaryAxes { option: &'static str },
    #[error("--grid `{text}`: expected counts like 21x22x22")]
    Counts {
        text: String,
        #[source]
        source: ParseIntError,
    },
    #[error("--grid needs one count ≥ 1 per linear axis ({linear} here), e.g. {example}")]
    CountPerAxis { linear: usize, example: String },
    #[error("cannot build the map grid")]
    Grid(#[source] GridError),
    #[error("cannot build the orientation grid")]
    Orientations(#[source] GridError),
}

/// The items of a comma-separated list, blanks around them and empty ones skipped.
fn items(text: &str) -> impl Iterator<Item = &str> {
    text.split(',').filter(|s| !s.trim().is_empty())
}

/// The axis letter of `LETTER=…`: its first character after blanks (`?` when there is none,
/// which names no axis).
fn letter(text: &str) -> char {
    text.trim().chars().next().unwrap_or('?')
}

/// The rotary axes' letters, in the machine's (canonical) order.
fn rotary_letters(machine: &Machine) -> Vec<char> {
    machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Rotary)
        .map(|a| a.letter().as_char())
        .collect()
}

/// The axis positions (SI) of `--hold Y=0,Z=-270,A=0` (mm / degrees): `defaults` with the
/// named axes replaced.
pub fn held_positions(
    machine: &Machine,
    defaults: Vec<f64>,
    text: &str,
) -> Result<Vec<f64>, AxisTextError> {
    const OPTION: &str = "--hold";
    let mut q = defaults;
    for item in items(text) {
        let (name, value) = item.split_once('=').ok_or_else(|| AxisTextError::Form {
            option: OPTION,
            item: item.to_string(),
            form: "LETTER=VALUE, e.g. Z=-270",
        })?;
        let letter = letter(name);
        let v: f64 = value
            .trim()
            .parse()
            .map_err(|source| AxisTextError::Number {
                option: OPTION,
                item: item.to_string(),
                value: value.to_string(),
                unit: "",
                source,
            })?;
        let k = machine
            .axis_index(letter)
            .ok_or_else(|| AxisTextError::NoAxis {
                option: OPTION,
                item: item.to_string(),
                which: "axis",
                letter,
            })?;
        q[k] = machine.axes()[k].kind().from_file(v);
    }
    Ok(q)
}

/// The rotary positions (rad, the machine's rotary axes in order) of `--at A=30,C=45`
/// (degrees); axes not named at 0.
pub fn rotary_positions(machine: &Machine, text: &str) -> Result<Vec<f64>, AxisTextError> {
    const OPTION: &str = "--at";
    let letters = rotary_letters(machine);
    let mut rotary = vec![0.0; letters.len()];
    for item in items(text) {
        let (name, value) = item.split_once('=').ok_or_else(|| AxisTextError::Form {
            option: OPTION,
            item: item.to_string(),
            form: "LETTER=DEGREES, e.g. C=45",
        })?;
        let letter = letter(name);
        let deg: f64 = value
            .trim()
            .parse()
            .map_err(|source| AxisTextError::Number {
                option: OPTION,
                item: item.to_string(),
                value: value.to_string(),
                unit: " of degrees",
                source,
            })?;
        let slot =
            letters
                .iter()
                .position(|&c| c == letter)
                .ok_or_else(|| AxisTextError::NoAxis {
                    option: OPTION,
                    item: item.to_string(),
                    which: "rotary axis",
                    letter,
                })?;
        rotary[slot] = deg.to_radians();
    }
    Ok(rotary)
}

/// The rotary positions (rad, the machine's rotary axes in order) of `--orientations
/// A=-30..90/5,C=0..270/4`: each named axis at COUNT positions from FROM to TO degrees (ends
/// included), the others at 0; every combination, the first axis slowest.
pub fn orientations(machine: &Machine, text: &str) -> Result<Vec<Vec<f64>>, AxisTextError> {
    const OPTION: &str = "--orientations";
    let letters = rotary_letters(machine);
    if letters.is_empty() {
        return Err(AxisTextError::NoRotaryAxes { option: OPTION });
    }
    let mut values = vec![vec![0.0]; letters.len()];
    for item in items(text) {
        let bad = || AxisTextError::Form {
            option: OPTION,
            item: item.to_string(),
            form: "LETTER=FROM..TO/COUNT in degrees, e.g. C=0..270/4",
        };
        let (name, range) = item.split_once('=').ok_or_else(bad)?;
        let letter = letter(name);
        let slot =
            letters
                .iter()
                .position(|&c| c == letter)
                .ok_or_else(|| AxisTextError::NoAxis {
                    option: OPTION,
                    item: item.to_string(),
                    which: "rotary axis",
                    letter,
                })?;
        let (span, count) = range.split_once('/').ok_or_else(bad)?;
        let (from, to) = span.split_once("..").ok_or_else(bad)?;
        let number = |t: &str| t.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let (Some(from), Some(to)) = (number(from), number(to)) else {
            return Err(bad());
        };
        let count: usize = count
            .trim()
            .parse()
            .ok()
            .filter(|&n| n >= 1)
            .ok_or_else(bad)?;
        values[slot] = (0..count)
            .map(|i| {
                let t = if count == 1 {
                    0.0
                } else {
                    i as f64 / (count - 1) as f64
                };
                (from + t * (to - from)).to_radians()
            })
            .collect();
    }
    Ok(combinations(&values))
}

/// Every combination of one value per axis, the first axis slowest.
fn combinations(values: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = vec![Vec::new()];
    for axis_values in values {
        out = out
            .iter()
            .flat_map(|prefix| {
                axis_values.iter().map(move |&v| {
                    let mut o = prefix.clone();
                    o.push(v);
                    o
                })
            })
            .collect();
    }
    out
}

/// The points per linear axis of `--grid 21x22x22`, one count ≥ 1 per linear axis; without
/// a text, source 004's.
pub fn grid_counts(machine: &Machine, text: Option<&str>) -> Result<Vec<usize>, AxisTextError> {
    let linear = machine
        .axes()
        .iter()
        .filter(|a| a.kind() == AxisKind::Linear)
        .count();
    let counts: Vec<usize> = match text {
        None => SOURCE004_COUNTS[..linear].to_vec(),
        Some(text) => text
            .split('x')
            .map(|s| s.trim().parse::<usize>())
            .collect::<Result<_, _>>()
            .map_err(|source| AxisTextError::Counts {
                text: text.to_string(),
                source,
            })?,
    };
    if counts.len() != linear || counts.iter().any(|&n| n < 1) {
        return Err(AxisTextError::CountPerAxis {
            linear,
            example: vec!["11"; linear].join("x"),
        });
    }
    Ok(counts)
}

/// The grid of `mtcal map`: `--grid` counts over the linear axes, at the `--at` rotary
/// positions or repeated at every `--orientations` combination.
pub fn map_grid(
    machine: &Machine,
    grid: Option<&str>,
    at: Option<&str>,
    orientations: Option<&str>,
) -> Result<Grid, AxisTextError> {
    let counts = grid_counts(machine, grid)?;
    let rotary = rotary_positions(machine, at.unwrap_or(""))?;
    let grid = Grid::with_counts(machine, &counts)
        .and_then(|g| g.with_rotary(&rotary))
        .map_err(AxisTextError::Grid)?;
    match orientations {
        None => Ok(grid),
        Some(text) => {
            let list = self::orientations(machine, text)?;
            grid.with_orientations(&list)
                .map_err(AxisTextError::Orientations)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::{Reading, nominal_machine, parse_code};

    fn machine(code: &str) -> Machine {
        nominal_machine(&parse_code(code, Reading::FromWorkpiece).unwrap(), code).unwrap()
    }

    /// The message with its causes, as the command line prints it.
    fn said(e: AxisTextError) -> String {
        let mut s = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            s.push_str(&format!(": {c}"));
            cause = c.source();
        }
        s
    }

    #[test]
    fn held_positions_replace_the_named_axes_in_file_units() {
        let m = machine("CAFYXZ");
        let defaults = vec![1.0; m.n_axes()];
        let q = held_positions(&m, defaults.clone(), " Z=-270, A=90 ,").unwrap();
        let z = m.axis_index('Z').unwrap();
        let a = m.axis_index('A').unwrap();
        for (k, v) in q.iter().enumerate() {
            let want = match k {
                _ if k == z => -0.27,
                _ if k == a => std::f64::consts::FRAC_PI_2,
                _ => 1.0,
            };
            assert!((v - want).abs() < 1e-15, "axis {k}: {v}");
        }
        assert_eq!(held_positions(&m, defaults.clone(), "").unwrap(), defaults);
    }

    #[test]
    fn held_positions_name_what_they_cannot_read() {
        let m = machine("ZFYX");
        let bad = |text: &str| said(held_positions(&m, vec![0.0; 3], text).unwrap_err());
        assert_eq!(bad("Z"), "--hold `Z`: expected LETTER=VALUE, e.g. Z=-270");
        assert_eq!(
            bad("Y=0,Z=low"),
            "--hold `Z=low`: `low` is not a number: invalid float literal"
        );
        assert_eq!(bad("C=0"), "--hold `C=0`: the machine has no axis C");
        assert_eq!(bad("=4"), "--hold `=4`: the machine has no axis ?");
    }

    #[test]
    fn rotary_positions_are_degrees_in_the_machines_order() {
        let m = machine("CAFYXZ");
        let q = rotary_positions(&m, "C=45,A=-30").unwrap();
        // Canonical order: A before C.
        assert_eq!(q, vec![(-30.0f64).to_radians(), 45.0f64.to_radians()]);
        assert_eq!(rotary_positions(&m, "").unwrap(), vec![0.0, 0.0]);
        let bad = |text: &str| said(rotary_positions(&m, text).unwrap_err());
        assert_eq!(bad("C45"), "--at `C45`: expected LETTER=DEGREES, e.g. C=45");
        assert_eq!(
            bad("C=x"),
            "--at `C=x`: `x` is not a number of degrees: invalid float literal"
        );
        assert_eq!(bad("X=5"), "--at `X=5`: the machine has no rotary axis X");
    }

    #[test]
    fn orientations_are_every_combination_first_axis_slowest() {
        let m = machine("CAFYXZ");
        let list = orientations(&m, "A=0..90/3,C=0..270/2").unwrap();
        let deg: Vec<Vec<f64>> = list
            .iter()
            .map(|o| o.iter().map(|v| v.to_degrees().round()).collect())
            .collect();
        assert_eq!(
            deg,
            vec![
                vec![0.0, 0.0],
                vec![0.0, 270.0],
                vec![45.0, 0.0],
                vec![45.0, 270.0],
                vec![90.0, 0.0],
                vec![90.0, 270.0],
            ]
        );
        // An axis not named stays at 0; a count of 1 is the first end.
        assert_eq!(
            orientations(&m, "C=30..60/1").unwrap(),
            vec![vec![0.0, 30.0f64.to_radians()]]
        );
    }

    #[test]
    fn orientations_name_what_they_cannot_read() {
        let m = machine("CAFYXZ");
        let form = "expected LETTER=FROM..TO/COUNT in degrees, e.g. C=0..270/4";
        for text in [
            "C",
            "C=0..270",
            "C=0-270/4",
            "C=0..x/4",
            "C=0..inf/4",
            "C=0..270/0",
        ] {
            assert_eq!(
                said(orientations(&m, text).unwrap_err()),
                format!("--orientations `{text}`: {form}")
            );
        }
        assert_eq!(
            said(orientations(&m, "B=0..90/2").unwrap_err()),
            "--orientations `B=0..90/2`: the machine has no rotary axis B"
        );
        assert_eq!(
            said(orientations(&machine("ZFYX"), "C=0..90/2").unwrap_err()),
            "--orientations: the machine has no rotary axis"
        );
    }

    #[test]
    fn grid_counts_one_per_linear_axis_or_source_004s() {
        let m = machine("ZFYX");
        assert_eq!(grid_counts(&m, None).unwrap(), vec![21, 22, 22]);
        assert_eq!(grid_counts(&m, Some("5x 6 x7")).unwrap(), vec![5, 6, 7]);
        assert_eq!(
            said(grid_counts(&m, Some("5x6xseven")).unwrap_err()),
            "--grid `5x6xseven`: expected counts like 21x22x22: invalid digit found in string"
        );
        for text in ["5x6", "5x6x7x8", "5x0x7"] {
            assert_eq!(
                said(grid_counts(&m, Some(text)).unwrap_err()),
                "--grid needs one count ≥ 1 per linear axis (3 here), e.g. 11x11x11"
            );
        }
    }

    #[test]
    fn a_map_grid_at_one_orientation_or_at_many() {
        let m = machine("CAFYXZ");
        let one = map_grid(&m, Some("3x4x5"), Some("C=90"), None).unwrap();
        assert_eq!(one.len(), 60);
        let many = map_grid(&m, Some("3x4x5"), None, Some("A=0..90/2,C=0..180/3")).unwrap();
        assert_eq!(many.len(), 60 * 6);
        assert!(matches!(
            map_grid(&m, Some("3x4"), None, None),
            Err(AxisTextError::CountPerAxis { linear: 3, .. })
        ));
    }
}
