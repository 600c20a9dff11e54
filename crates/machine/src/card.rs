//! The convention card: what the numbers of one compensation file mean, said the same way for
//! every format so a user can check it against the control's documentation before loading.
//!
//! A mistake in a compensation file either silently does nothing or moves the machine the
//! wrong way, and the usual mistakes are conventions, not arithmetic: a table of errors loaded
//! where the control expects corrections, a squareness measured as "angle − 90°" read as
//! "90° − angle", a rotary table in the opposite direction, the wrong axis number, µm read as
//! the detection unit. The card names each of these for the file it comes with. Writers put it
//! in the file as comments where the format has comments, the command line prints it beside the
//! file, and the identification JSON and report carry [`ConventionCard::mtcal_parameters`].

use mtcal_kinematics::Machine;
use std::fmt::Write as _;

/// What a file's values are.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// The machine's error, actual − nominal; the control negates it itself.
    Error,
    /// The correction, `−error`: what the control adds to the command.
    Correction,
    /// Geometry the control's own model uses (pivot positions, axis vectors): nominal plus the
    /// identified location errors.
    Geometry,
}

impl Quantity {
    /// In words, for the card.
    pub fn describe(self) -> &'static str {
        match self {
            Quantity::Error => "errors (actual − nominal); the control applies −error itself",
            Quantity::Correction => "corrections (−error); the control adds them to the command",
            Quantity::Geometry => "kinematic geometry (nominal + identified location errors)",
        }
    }
}

/// One axis of mtcal's model and what the control calls it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AxisMap {
    /// mtcal's axis letter.
    pub mtcal: char,
    /// The control's name or index for it (e.g. `X`, `axis 1`, `AX1`).
    pub control: String,
}

/// What one compensation file's numbers mean, and what the control will do with them.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ConventionCard {
    /// The format, as its documentation names it.
    pub format: String,
    /// Errors, corrections or geometry.
    pub quantity: Quantity,
    /// How a positive value moves the machine, in the control's words.
    pub sign: String,
    /// The squareness definition, or that this file does not carry squareness.
    pub squareness: String,
    /// Positive rotation of rotary axes.
    pub rotary_direction: String,
    /// mtcal's axes and the control's names for them.
    pub axis_mapping: Vec<AxisMap>,
    /// Units of positions (arguments) and values.
    pub units: String,
    /// What the control will do with the file: how it applies it, how to activate it, what it
    /// cannot hold. One sentence each.
    pub control_will: Vec<String>,
    /// What the numbers were made from, when an identification gave them: what went in, what
    /// it could not determine and left out, what became of its discoveries. One line each.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub made_from: Vec<String>,
}

/// mtcal's squareness definition (ISO 230-1 signs), shared by the cards of files that carry
/// squareness as an error.
pub const SQUARENESS_ISO: &str = "C0Y > 0 rotates Y's motion about +Z, opening the angle between \
     +X and +Y beyond 90° (likewise B0Z about +Y for X–Z, A0Z about +X for Y–Z); µrad";

/// mtcal's rotary direction (ISO 841: right-hand about the axis' positive direction).
pub const ROTARY_RIGHT_HAND: &str =
    "positive A, B, C turn right-handed about +X, +Y, +Z (ISO 841), as the tool sees the workpiece";

impl ConventionCard {
    /// The identity mapping of `machine`'s axes (the control names them as mtcal does).
    pub fn same_letters(machine: &Machine) -> Vec<AxisMap> {
        machine
            .axes()
            .iter()
            .map(|a| AxisMap {
                mtcal: a.letter().as_char(),
                control: a.letter().as_char().to_string(),
            })
            .collect()
    }

    /// The card of mtcal's own parameters (identification JSON, report, parameter files).
    pub fn mtcal_parameters(machine: &Machine) -> ConventionCard {
        ConventionCard {
            made_from: Vec::new(),
            format: "mtcal ISO 230-1 error parameters".into(),
            quantity: Quantity::Error,
            sign: "ISO 230-1: a component error is the tool's deviation relative to the \
                   workpiece caused by the axis, in machine X/Y/Z; a location error is the \
                   deviation of an axis line or a squareness"
                .into(),
            squareness: SQUARENESS_ISO.into(),
            rotary_direction: ROTARY_RIGHT_HAND.into(),
            axis_mapping: Self::same_letters(machine),
            units: "translations µm, rotations µrad; positions mm (linear) and degrees (rotary)"
                .into(),
            control_will: vec![
                "not for a control directly: `cargo xtask compensate --format …` converts them \
                 into the file a control reads"
                    .into(),
            ],
        }
    }

    /// The card as lines of text, each starting with `prefix` (a comment marker, or "" for the
    /// terminal).
    pub fn lines(&self, prefix: &str) -> String {
        let mut text = String::new();
        for (key, value) in self.rows() {
            let _ = writeln!(text, "{prefix}{key:<KEY_WIDTH$}{value}");
        }
        text
    }

    /// The card as (key, value) rows, in the order of [`Self::lines`]; the sentences after the
    /// first of `control_will` have an empty key.
    pub fn rows(&self) -> Vec<(&'static str, String)> {
        let mapping: Vec<String> = self
            .axis_mapping
            .iter()
            .map(|m| format!("{} → {}", m.mtcal, m.control))
            .collect();
        let mut rows = vec![
            ("format", self.format.clone()),
            ("values are", self.quantity.describe().to_string()),
            ("sign", self.sign.clone()),
            ("squareness", self.squareness.clone()),
            ("rotary direction", self.rotary_direction.clone()),
            (
                "axis mapping",
                format!("{} (mtcal → control)", mapping.join(", ")),
            ),
            ("units", self.units.clone()),
        ];
        for (k, sentence) in self.control_will.iter().enumerate() {
            rows.push((
                if k == 0 { "the control will" } else { "" },
                sentence.clone(),
            ));
        }
        let made_from = self
            .made_from
            .iter()
            .flat_map(|l| wrapped(l, MADE_FROM_WIDTH));
        for (k, line) in made_from.enumerate() {
            rows.push((if k == 0 { "made from" } else { "" }, line));
        }
        rows
    }

    /// The card as comment lines for a control's file, each starting with `prefix`, in ASCII
    /// only (controls read their files as ASCII or a code page; `µ`, `°`, `→` would arrive
    /// garbled).
    pub fn file_lines(&self, prefix: &str) -> String {
        ascii(&self.lines(prefix))
    }
}

/// The widest line of an account on a card (characters after the key): a list of a hundred
/// parameters left out is folded, not written as one line of a kilobyte a control's editor or
/// its block length may not take.
const MADE_FROM_WIDTH: usize = 100;

/// `line` folded at spaces into lines of at most `width` characters (a word longer stays
/// whole), each continuation indented two spaces more than the line.
fn wrapped(line: &str, width: usize) -> Vec<String> {
    let indent = line.len() - line.trim_start().len();
    let mut out: Vec<String> = Vec::new();
    let mut current = line[..indent].to_string();
    for word in line.split_whitespace() {
        let bare = current.trim_start().is_empty();
        if !bare && current.chars().count() + 1 + word.chars().count() > width {
            out.push(std::mem::replace(&mut current, " ".repeat(indent + 2)));
        }
        if !current.trim_start().is_empty() {
            current.push(' ');
        }
        current.push_str(word);
    }
    out.push(current);
    out
}

/// `text` with the card's non-ASCII signs spelled in ASCII and anything else left replaced
/// by `?`.
pub fn ascii(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '→' => out.push_str("->"),
            'µ' | 'μ' => out.push('u'),
            '°' => out.push_str(" deg"),
            '−' | '–' | '—' => out.push('-'),
            '≤' => out.push_str("<="),
            '≥' => out.push_str(">="),
            '×' => out.push('x'),
            '·' => out.push('*'),
            '±' => out.push_str("+/-"),
            '≈' => out.push('~'),
            '↑' => out.push_str("(+)"),
            '↓' => out.push_str("(-)"),
            // A combining mark (the bar of x̄) over the letter before it: the letter alone.
            '\u{0304}' => {}
            '²' => out.push_str("^2"),
            '’' | '‘' => out.push('\''),
            '“' | '”' => out.push('"'),
            '…' => out.push_str("..."),
            c if c.is_ascii() => out.push(c),
            _ => out.push('?'),
        }
    }
    out
}

/// Width of the card's key column: the longest key and two spaces.
const KEY_WIDTH: usize = 24;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Reading;

    #[test]
    fn the_card_names_every_convention_on_its_own_line() {
        let m = crate::load_machine("ZFYX", Reading::FromWorkpiece).unwrap();
        let mut card = ConventionCard::mtcal_parameters(&m.machine);
        card.control_will.push("second sentence".into());
        let text = card.lines("// ");
        let keys = [
            "format",
            "values are",
            "sign",
            "squareness",
            "rotary direction",
            "axis mapping",
            "units",
            "the control will",
        ];
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), keys.len() + 1, "{text}");
        for (line, key) in lines.iter().zip(keys) {
            assert!(line.starts_with(&format!("// {key}")), "{line}");
        }
        for letter in ["X → X", "Y → Y", "Z → Z"] {
            assert!(lines[5].contains(letter), "{}", lines[5]);
            assert!(lines[5].ends_with("(mtcal → control)"), "{}", lines[5]);
        }
        assert!(lines[8].trim_start_matches("// ").trim() == "second sentence");
        assert!(lines[1].contains("errors (actual − nominal)"));
        let ascii_text = card.file_lines("; ");
        assert!(ascii_text.is_ascii(), "{ascii_text}");
        assert!(ascii_text.contains("X -> X") && ascii_text.contains("translations um"));
        assert_eq!(ascii_text.lines().count(), lines.len());
    }

    /// ISO 230-2's `x̄↑ − x̄↓` (a combining bar over the x) reads as `x(+) - x(-)`, no `?`.
    #[test]
    fn a_barred_letter_keeps_its_letter_in_ascii() {
        assert_eq!(
            ascii("B = x̄↑ − x̄↓, ± 0.1 µm"),
            "B = x(+) - x(-), +/- 0.1 um"
        );
    }

    /// An account line longer than the card's width folds at spaces, keeping every word, each
    /// continuation indented under it.
    #[test]
    fn a_long_account_line_folds_at_spaces() {
        let names: Vec<String> = (0..60).map(|k| format!("EXX.K{k}")).collect();
        let line = format!("  left at zero: {}", names.join(", "));
        let folded = wrapped(&line, 40);
        assert!(folded.len() > 5, "{folded:?}");
        assert!(folded.iter().all(|l| l.chars().count() <= 40), "{folded:?}");
        assert!(folded[0].starts_with("  left at zero: EXX.K0,"));
        assert!(
            folded[1..].iter().all(|l| l.starts_with("    EXX.K")),
            "{folded:?}"
        );
        let words: Vec<&str> = folded.iter().flat_map(|l| l.split_whitespace()).collect();
        assert_eq!(words, line.split_whitespace().collect::<Vec<_>>());
        assert_eq!(wrapped("short", 40), vec!["short".to_string()]);
    }
}
