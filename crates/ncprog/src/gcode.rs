//! The G-code reader and writer: see the crate documentation for the dialect.

use std::ops::Range;

/// The six axis letters of a program, in mtcal's canonical order.
pub const AXIS_LETTERS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

/// mm per inch.
pub const MM_PER_INCH: f64 = 25.4;

/// A line that cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line}, column {column}: expected {expected}, found {found}")]
pub struct ParseError {
    /// 1-based line number.
    pub line: usize,
    /// 1-based column (characters).
    pub column: usize,
    pub expected: &'static str,
    pub found: String,
}

/// One word: a letter and a number.
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    /// Upper case.
    pub letter: char,
    pub value: f64,
    /// Digits after the decimal point in the input (0 without a point).
    pub decimals: usize,
    /// Byte range of the whole word (letter and number) in [`Line::text`].
    pub span: Range<usize>,
}

/// One line of a program.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// The text without its line terminator.
    pub text: String,
    /// The terminator as read: `"\n"`, `"\r\n"` or `""` (last line without one).
    pub eol: String,
    /// The words in order (comments, `%` and `/` are not words).
    pub words: Vec<Word>,
}

impl Line {
    /// The first word with `letter`.
    pub fn word(&self, letter: char) -> Option<&Word> {
        self.words.iter().find(|w| w.letter == letter)
    }

    /// Whether the line has a `G` word with this number.
    pub fn has_g(&self, number: f64) -> bool {
        self.words
            .iter()
            .any(|w| w.letter == 'G' && w.value == number)
    }

    /// Whether the line has any axis word (X Y Z A B C).
    pub fn has_axis_word(&self) -> bool {
        self.words.iter().any(|w| AXIS_LETTERS.contains(&w.letter))
    }
}

/// A program: its lines, in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub lines: Vec<Line>,
}

/// Modal motion mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// `G0`: rapid.
    Rapid,
    /// `G1`: linear feed.
    Linear,
    /// `G2`/`G3`: arcs.
    Arc,
}

/// The modal state after a line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modal {
    pub motion: Option<Motion>,
    /// `G90` (true, the default) or `G91`.
    pub absolute: bool,
    /// `G20` (true) or `G21` (false, the default).
    pub inch: bool,
    /// Axis positions X Y Z (mm) A B C (degrees) after the line; `None` until first given.
    pub axes: [Option<f64>; 6],
}

impl Default for Modal {
    fn default() -> Self {
        Self {
            motion: None,
            absolute: true,
            inch: false,
            axes: [None; 6],
        }
    }
}

impl Modal {
    /// The factor from program units to mm (linear) or degrees (rotary) for axis `a` (0..6).
    pub fn to_mm_deg(&self, a: usize) -> f64 {
        if a < 3 && self.inch { MM_PER_INCH } else { 1.0 }
    }

    /// The state after `line`, starting from `self`.
    pub fn step(&self, line: &Line) -> Modal {
        let mut m = *self;
        for w in line.words.iter().filter(|w| w.letter == 'G') {
            match w.value {
                0.0 => m.motion = Some(Motion::Rapid),
                1.0 => m.motion = Some(Motion::Linear),
                2.0 | 3.0 => m.motion = Some(Motion::Arc),
                90.0 => m.absolute = true,
                91.0 => m.absolute = false,
                20.0 => m.inch = true,
                21.0 => m.inch = false,
                _ => {}
            }
        }
        if line.has_g(53.0) || line.has_g(92.0) || line.has_g(28.0) || line.has_g(30.0) {
            // Non-modal coordinate lines: their axis words do not set the modal position.
            return m;
        }
        for w in &line.words {
            if let Some(a) = AXIS_LETTERS.iter().position(|&l| l == w.letter) {
                let v = w.value * m.to_mm_deg(a);
                m.axes[a] = Some(if m.absolute {
                    v
                } else {
                    m.axes[a].unwrap_or(0.0) + v
                });
            }
        }
        m
    }
}

impl Program {
    /// Reads a program. Never panics; the first bad word is reported with its line and column.
    pub fn parse(text: &str) -> Result<Program, ParseError> {
        if text.starts_with('\u{feff}') {
            // Kept out rather than stripped: the corrected program is the input byte for byte
            // but its poses, and many controllers read a byte-order mark as text.
            return Err(ParseError {
                line: 1,
                column: 1,
                expected: "G-code text without a byte-order mark (save the program as UTF-8 \
                           without BOM or as ASCII)",
                found: "a UTF-8 byte-order mark".to_string(),
            });
        }
        let lines = text
            .split_inclusive('\n')
            .enumerate()
            .map(|(i, chunk)| parse_line(i + 1, chunk))
            .collect::<Result<_, _>>()?;
        Ok(Program { lines })
    }

    /// The program text: every line as read (byte-identical round trip).
    pub fn text(&self) -> String {
        let mut s = String::new();
        for l in &self.lines {
            s.push_str(&l.text);
            s.push_str(&l.eol);
        }
        s
    }

    /// The modal state after every line, starting from the defaults (`G90 G21`, no motion mode,
    /// positions unknown).
    pub fn modal_states(&self) -> Vec<Modal> {
        let mut m = Modal::default();
        self.lines
            .iter()
            .map(|l| {
                m = m.step(l);
                m
            })
            .collect()
    }
}

fn parse_line(number: usize, chunk: &str) -> Result<Line, ParseError> {
    let (body, eol) = match chunk.strip_suffix('\n') {
        Some(b) => match b.strip_suffix('\r') {
            Some(b2) => (b2, "\r\n"),
            None => (b, "\n"),
        },
        None => (chunk, ""),
    };
    let words = scan_words(number, body)?;
    Ok(Line {
        text: body.to_string(),
        eol: eol.to_string(),
        words,
    })
}

fn error(line: usize, text: &str, at: usize, expected: &'static str) -> ParseError {
    let found = match text[at..].chars().next() {
        Some(c) => format!("`{c}`"),
        None => "the end of the line".to_string(),
    };
    ParseError {
        line,
        column: text[..at].chars().count() + 1,
        expected,
        found,
    }
}

fn scan_words(line: usize, text: &str) -> Result<Vec<Word>, ParseError> {
    let bytes = text.as_bytes();
    let mut words = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        match c {
            b' ' | b'\t' | b'%' | b'/' => i += 1,
            b';' => break,
            b'(' => match text[i..].find(')') {
                Some(end) => i += end + 1,
                None => return Err(error(line, text, text.len(), "`)` closing the comment")),
            },
            c if c.is_ascii_alphabetic() => {
                let (value, decimals, end) = scan_number(line, text, i + 1)?;
                words.push(Word {
                    letter: (c as char).to_ascii_uppercase(),
                    value,
                    decimals,
                    span: i..end,
                });
                i = end;
            }
            _ => {
                return Err(error(
                    line,
                    text,
                    i,
                    "a word (letter and number), a comment `(…)` or `;…`, or the end of the line",
                ));
            }
        }
    }
    Ok(words)
}

/// A number `[+-]digits[.digits]` or `[+-].digits` at byte `start`: value, decimals, end.
fn scan_number(line: usize, text: &str, start: usize) -> Result<(f64, usize, usize), ParseError> {
    let bytes = text.as_bytes();
    let mut i = start;
    if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
        i += 1;
    }
    let int_start = i;
    while i < bytes.len() && bytes[i].is_ascii_digit() {
        i += 1;
    }
    let mut digits = i - int_start;
    let mut decimals = 0;
    if i < bytes.len() && bytes[i] == b'.' {
        i += 1;
        let frac_start = i;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
        decimals = i - frac_start;
        digits += decimals;
    }
    if digits == 0 {
        return Err(error(line, text, i, "a number after the word's letter"));
    }
    match text[start..i].parse::<f64>() {
        Ok(v) if v.is_finite() => Ok((v, decimals, i)),
        _ => Err(error(line, text, start, "a finite number")),
    }
}

/// How many decimals the writer uses for the axis words it changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decimals {
    /// Fixed: `linear_mm` for X Y Z in mm (`G21`), `linear_inch` in inches (`G20`), `rotary_deg`
    /// for A B C.
    Fixed {
        linear_mm: usize,
        linear_inch: usize,
        rotary_deg: usize,
    },
    /// As many as the replaced word had in the input, but at least the default's (so that a
    /// correction is never rounded away: `Z-10` becomes `Z-10.0123`); words the writer adds use
    /// the default.
    AsInput,
}

impl Default for Decimals {
    /// 4 for mm (0.1 µm), 5 for inches (0.25 µm), 4 for degrees (1.7 µrad).
    fn default() -> Self {
        Decimals::Fixed {
            linear_mm: 4,
            linear_inch: 5,
            rotary_deg: 4,
        }
    }
}

impl Decimals {
    /// Decimals for axis `a` (0..6) in units `inch`, replacing `old` (if any).
    pub fn for_axis(&self, a: usize, inch: bool, old: Option<&Word>) -> usize {
        match (self, old) {
            (Decimals::AsInput, Some(w)) => {
                w.decimals.max(Decimals::default().for_axis(a, inch, None))
            }
            (Decimals::AsInput, None) => Decimals::default().for_axis(a, inch, None),
            (
                Decimals::Fixed {
                    linear_mm,
                    linear_inch,
                    rotary_deg,
                },
                _,
            ) => match (a < 3, inch) {
                (true, false) => *linear_mm,
                (true, true) => *linear_inch,
                (false, _) => *rotary_deg,
            },
        }
    }
}

/// `v` with `decimals` decimals, never `-0.000…`.
pub fn format_fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// `v` rounded as [`format_fixed`] writes it.
pub fn round_fixed(v: f64, decimals: usize) -> f64 {
    format_fixed(v, decimals).parse().unwrap_or(v)
}

/// Rewrites `line` with new axis values: `(axis index 0..6, text of the number)`. A word present
/// on the line gets its number replaced in place (its first occurrence); a missing one is
/// inserted, in the order given, after the line's last axis word (else after its last `G` word,
/// else after its `N` word, else at the start), each preceded by a space.
pub fn rewrite_line(line: &Line, values: &[(usize, String)]) -> String {
    let mut edits: Vec<(Range<usize>, String)> = Vec::new();
    let mut inserted = String::new();
    for (a, number) in values {
        let letter = AXIS_LETTERS[*a];
        match line.word(letter) {
            Some(w) => edits.push((w.span.clone(), format!("{letter}{number}"))),
            None => inserted.push_str(&format!(" {letter}{number}")),
        }
    }
    if !inserted.is_empty() {
        let anchor = insertion_point(line);
        if anchor == 0 {
            inserted = format!("{} ", inserted.trim_start());
        }
        edits.push((anchor..anchor, inserted));
    }
    // Stable: an insertion at a replaced word's end sorts after that word.
    edits.sort_by_key(|(r, _)| (r.start, r.end == r.start));
    let mut out = String::with_capacity(line.text.len() + 16 * values.len());
    let mut at = 0;
    for (r, text) in &edits {
        out.push_str(&line.text[at..r.start]);
        out.push_str(text);
        at = r.end;
    }
    out.push_str(&line.text[at..]);
    out
}

fn insertion_point(line: &Line) -> usize {
    let last = |pred: &dyn Fn(&Word) -> bool| line.words.iter().rev().find(|w| pred(w));
    last(&|w| AXIS_LETTERS.contains(&w.letter))
        .or_else(|| last(&|w| w.letter == 'G'))
        .or_else(|| last(&|w| w.letter == 'N'))
        .map_or(0, |w| w.span.end)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "%\r\n(MTCAL TEST)\r\nG90 G21 G94\r\nN10 G01 X250.0000 Y0.0 Z-150 F500.0 ; first\r\nN20 X251.5 (only x)\r\n/N30 G0 Z10 M05\r\nM30\r\n%";

    #[test]
    fn a_round_trip_reproduces_the_file() {
        let p = Program::parse(SAMPLE).unwrap();
        assert_eq!(p.text(), SAMPLE);
        assert_eq!(p.lines.len(), 8);
        assert_eq!(p.lines[7].eol, "");
        let w = p.lines[3].word('X').unwrap();
        assert_eq!((w.value, w.decimals), (250.0, 4));
    }

    #[test]
    fn modal_state_keeps_words_not_on_a_line() {
        let p = Program::parse("G91 G20\nG1 X1 Y2\nX1\nG90 G21 Z5\n").unwrap();
        let m = p.modal_states();
        assert_eq!(m[2].axes[0], Some(2.0 * MM_PER_INCH));
        assert_eq!(m[2].axes[1], Some(2.0 * MM_PER_INCH));
        assert_eq!(m[3].axes[2], Some(5.0));
        assert!(m[3].absolute && !m[3].inch);
        assert_eq!(m[3].motion, Some(Motion::Linear));
    }

    #[test]
    fn errors_name_line_column_and_what_was_expected() {
        let e = Program::parse("G1 X1\nG1 Y\n").unwrap_err();
        assert_eq!((e.line, e.column), (2, 5));
        assert!(e.to_string().contains("expected a number"), "{e}");
        let e = Program::parse("G1 (open\n").unwrap_err();
        assert_eq!((e.line, e.column), (1, 9));
        let e = Program::parse("G1 X1 #5\n").unwrap_err();
        assert_eq!((e.line, e.column, e.found.as_str()), (1, 7, "`#`"));
    }

    #[test]
    fn rewriting_replaces_in_place_and_inserts_after_the_last_axis_word() {
        let p = Program::parse("N20 G1 X1.0 F100 (c)\nN30 M3\n").unwrap();
        let out = rewrite_line(&p.lines[0], &[(0, "2.5000".into()), (1, "3.0000".into())]);
        assert_eq!(out, "N20 G1 X2.5000 Y3.0000 F100 (c)");
        let out = rewrite_line(&p.lines[1], &[(2, "1.0".into())]);
        assert_eq!(out, "N30 Z1.0 M3");
    }

    #[test]
    fn formatting_never_writes_negative_zero() {
        assert_eq!(format_fixed(-0.00001, 4), "0.0000");
        assert_eq!(format_fixed(-1.23456, 4), "-1.2346");
    }

    proptest::proptest! {
        #[test]
        fn parsing_never_panics(s in "[ -~\\n]{0,80}") {
            if let Ok(p) = Program::parse(&s) {
                proptest::prop_assert_eq!(p.text(), s);
            }
        }
    }
}
