//! Axis letters and ISO 230-1:2012 error parameter names.
//!
//! Names are the public vocabulary of mtcal: they appear in configuration files, parameter files
//! and the `identify` JSON. Parsing accepts the seed literature's letter `O` for the digit zero
//! (`EXOC`); formatting always writes the digit (`EX0C`).

use std::fmt;
use std::str::FromStr;

/// One of the six machine directions: translations along X, Y, Z and rotations about them.
///
/// The first letter after `E` in an ISO 230-1 name is a direction (`EXX`: along X).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Direction {
    X,
    Y,
    Z,
    A,
    B,
    C,
}

impl Direction {
    pub const ALL: [Direction; 6] = [
        Direction::X,
        Direction::Y,
        Direction::Z,
        Direction::A,
        Direction::B,
        Direction::C,
    ];

    /// 0..3 for translations X, Y, Z; 3..6 for rotations A, B, C (the row in a pose error).
    pub fn index(self) -> usize {
        self as usize
    }

    /// Whether this is a rotation (A, B, C).
    pub fn is_rotation(self) -> bool {
        self.index() >= 3
    }

    /// The Cartesian component 0, 1, 2 this direction acts along or about.
    pub fn cartesian(self) -> usize {
        self.index() % 3
    }

    pub fn letter(self) -> char {
        ['X', 'Y', 'Z', 'A', 'B', 'C'][self.index()]
    }

    pub fn from_letter(c: char) -> Option<Self> {
        Some(match c {
            'X' => Direction::X,
            'Y' => Direction::Y,
            'Z' => Direction::Z,
            'A' => Direction::A,
            'B' => Direction::B,
            'C' => Direction::C,
            _ => return None,
        })
    }

    /// The translation along, or rotation about, Cartesian axis `i` (0, 1, 2).
    pub fn from_parts(rotation: bool, i: usize) -> Self {
        Self::ALL[i + if rotation { 3 } else { 0 }]
    }
}

/// A machine axis, named by its letter (ISO 841): linear X Y Z U V W, rotary A B C.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct AxisLetter(char);

/// Axis letters in mtcal's canonical order: the order of axis positions in every `q` slice.
pub const AXIS_ORDER: [char; 9] = ['X', 'Y', 'Z', 'U', 'V', 'W', 'A', 'B', 'C'];

impl AxisLetter {
    /// `None` unless `c` is one of X Y Z U V W A B C.
    pub fn new(c: char) -> Option<Self> {
        AXIS_ORDER.contains(&c).then_some(Self(c))
    }

    pub fn as_char(self) -> char {
        self.0
    }

    /// A, B and C are rotary; X Y Z U V W are linear.
    pub fn is_rotary(self) -> bool {
        matches!(self.0, 'A' | 'B' | 'C')
    }

    /// Position in [`AXIS_ORDER`].
    pub fn order(self) -> usize {
        AXIS_ORDER
            .iter()
            .position(|&c| c == self.0)
            .unwrap_or(usize::MAX)
    }

    /// The Cartesian direction the letter nominally moves along (X, U → 0) or about (A → 0).
    pub fn nominal_cartesian(self) -> usize {
        match self.0 {
            'X' | 'U' | 'A' => 0,
            'Y' | 'V' | 'B' => 1,
            _ => 2,
        }
    }
}

impl fmt::Display for AxisLetter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Set-up parameters: where the tool point sits on the tool link and where the workpiece sits on
/// the workpiece link. Not ISO 230-1; mtcal's own names (`TOOL_DZ`, `WP_DA`…).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Setup {
    /// Offset of the tool point in the tool link's frame (`TOOL_DX`, `TOOL_DY`, `TOOL_DZ`;
    /// `TOOL_DZ` is along the tool axis, so a tool longer by ℓ has `TOOL_DZ = -ℓ`).
    Tool(Direction),
    /// Pose of the actual workpiece frame in the nominal one (`WP_DX` … `WP_DC`).
    Workpiece(Direction),
}

/// An error parameter name: ISO 230-1 component (`EXX`), location (`EX0C`, squareness `EC0Y`)
/// or mtcal set-up (`TOOL_DZ`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ParamName {
    /// Component error of `axis` in `direction`, a function of the axis position.
    Component {
        direction: Direction,
        axis: AxisLetter,
    },
    /// Position-independent location error of `axis` in `direction`.
    Location {
        direction: Direction,
        axis: AxisLetter,
    },
    Setup(Setup),
}

impl ParamName {
    pub fn component(direction: Direction, axis: AxisLetter) -> Self {
        ParamName::Component { direction, axis }
    }

    pub fn location(direction: Direction, axis: AxisLetter) -> Self {
        ParamName::Location { direction, axis }
    }

    /// The axis the parameter belongs to (None for set-up parameters).
    pub fn axis(&self) -> Option<AxisLetter> {
        match *self {
            ParamName::Component { axis, .. } | ParamName::Location { axis, .. } => Some(axis),
            ParamName::Setup(_) => None,
        }
    }

    /// The direction the parameter acts along or about.
    pub fn direction(&self) -> Direction {
        match *self {
            ParamName::Component { direction, .. } | ParamName::Location { direction, .. } => {
                direction
            }
            ParamName::Setup(Setup::Tool(d)) | ParamName::Setup(Setup::Workpiece(d)) => d,
        }
    }

    /// Unit of the value as written in files: `"um"` for translations, `"urad"` for rotations.
    pub fn unit(&self) -> &'static str {
        if self.direction().is_rotation() {
            "urad"
        } else {
            "um"
        }
    }
}

impl fmt::Display for ParamName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ParamName::Component { direction, axis } => {
                write!(f, "E{}{}", direction.letter(), axis)
            }
            ParamName::Location { direction, axis } => {
                write!(f, "E{}0{}", direction.letter(), axis)
            }
            ParamName::Setup(Setup::Tool(d)) => write!(f, "TOOL_D{}", d.letter()),
            ParamName::Setup(Setup::Workpiece(d)) => write!(f, "WP_D{}", d.letter()),
        }
    }
}

/// Why a string is not a parameter name.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "`{text}` is not an error parameter name: expected an ISO 230-1 name such as EXX (component), \
     EX0C (location; EXOC is accepted), EC0Y (squareness), or a set-up name TOOL_DX..TOOL_DZ, WP_DX..WP_DC"
)]
pub struct ParseNameError {
    pub text: String,
}

impl FromStr for ParamName {
    type Err = ParseNameError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = || ParseNameError {
            text: s.to_string(),
        };
        let t = s.trim();
        if let Some(rest) = t.strip_prefix("TOOL_D") {
            return single_direction(rest)
                .filter(|d| !d.is_rotation())
                .map(|d| ParamName::Setup(Setup::Tool(d)))
                .ok_or_else(err);
        }
        if let Some(rest) = t.strip_prefix("WP_D") {
            return single_direction(rest)
                .map(|d| ParamName::Setup(Setup::Workpiece(d)))
                .ok_or_else(err);
        }
        let chars: Vec<char> = t.chars().collect();
        let direction = || chars.get(1).and_then(|&c| Direction::from_letter(c));
        match chars.as_slice() {
            ['E', _, a] => Ok(ParamName::Component {
                direction: direction().ok_or_else(err)?,
                axis: AxisLetter::new(*a).ok_or_else(err)?,
            }),
            ['E', _, '0' | 'O', a] => Ok(ParamName::Location {
                direction: direction().ok_or_else(err)?,
                axis: AxisLetter::new(*a).ok_or_else(err)?,
            }),
            _ => Err(err()),
        }
    }
}

fn single_direction(s: &str) -> Option<Direction> {
    let mut it = s.chars();
    let d = Direction::from_letter(it.next()?)?;
    it.next().is_none().then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, expect: Option<&str>) {
        let got = text.parse::<ParamName>().ok().map(|n| n.to_string());
        assert_eq!(got.as_deref(), expect, "parsing {text:?}");
    }

    #[test]
    fn parses_and_formats_names() {
        check("EXX", Some("EXX"));
        check("ECC", Some("ECC"));
        check("EX0C", Some("EX0C"));
        check("EXOC", Some("EX0C"));
        check("EC0Y", Some("EC0Y"));
        check("EBOZ", Some("EB0Z"));
        check("TOOL_DZ", Some("TOOL_DZ"));
        check("WP_DC", Some("WP_DC"));
        check("TOOL_DA", None);
        check("EQX", None);
        check("EXQ", None);
        check("EX1C", None);
        check("EXXX", None);
        check("", None);
    }

    #[test]
    fn units_follow_direction() {
        assert_eq!("EXX".parse::<ParamName>().unwrap().unit(), "um");
        assert_eq!("EAX".parse::<ParamName>().unwrap().unit(), "urad");
        assert_eq!("EC0Y".parse::<ParamName>().unwrap().unit(), "urad");
    }

    #[test]
    fn axis_order_is_canonical() {
        let x = AxisLetter::new('X').unwrap();
        let c = AxisLetter::new('C').unwrap();
        assert!(x.order() < c.order());
        assert!(c.is_rotary() && !x.is_rotary());
        assert!(AxisLetter::new('Q').is_none());
    }
}
