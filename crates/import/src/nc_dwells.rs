//! The dwell sequence of the NC program that drove a measuring cycle (`rtest-stream`).
//!
//! What is read (ISO G-code as Fanuc-, LinuxCNC- and Heidenhain-ISO-style controls write it):
//! words are a letter and a number (`X100.`, `X-.5`, `X+10`, `G01`), blanks optional; comments
//! `( … )` (closed on the line) and `; …`; a Heidenhain block end `*` ends the line's words; a
//! leading block delete `/` is skipped (the block runs); lines starting with `%` (tape marks,
//! Heidenhain's `%NAME G71 *`) are skipped. Positions are absolute (`G90`, the default; `G91`
//! and inch `G20` are refused) and taken as the machine's axis positions (work offsets
//! `G54`…`G59` and `G43` as zero: a wrong guess makes the dwell sit on no ball, which is
//! refused). Axis words of the machine's letters set the modal position on any motion line
//! (`G0`, `G1`, modal or not); `G4 P<s>` or `G4 X<s>` is a dwell in **seconds** (LinuxCNC's
//! reading; Fanuc's `P` in ms must be converted). `M2`, `M30`, `M99` end the program. Anything
//! the cycle's positions would depend on and that is not followed (arcs, `G28`, `G92`,
//! subprogram calls `M98`, macro words) is refused at its line and column.

use std::path::Path;

use mtcal_located::{Located, Source};

use crate::ImportError;
use crate::text::{Line, lines, offset_of};

/// G codes that leave the commanded axis positions as the axis words say: motion, dwell,
/// planes, mm, cancellations, machine/work coordinates (offsets taken as zero), exact stop and
/// path modes, absolute, feed per minute, and a few cancellations controls add.
const ACCEPTED_G: &[u32] = &[
    0, 1, 4, 15, 17, 18, 19, 21, 40, 43, 49, 53, 54, 55, 56, 57, 58, 59, 61, 64, 69, 80, 90, 94,
];

/// Words that do not move an axis: block number, program number, feed, spindle, tool, offset
/// numbers.
const INERT_WORDS: &[char] = &['N', 'O', 'F', 'S', 'T', 'D', 'H'];

/// M codes that end the program.
const END_M: &[u32] = &[2, 30, 99];

/// M codes that call a subprogram (its moves would not be seen).
const CALL_M: &[u32] = &[97, 98, 198];

/// One ball visit the program commands: a dwell at the axes commanded when it starts.
#[derive(Debug, Clone, PartialEq)]
pub struct Dwell {
    /// 1-based line of the `G4` word.
    pub line: usize,
    /// 1-based column (characters) of the `G4` word.
    pub column: usize,
    /// Commanded position of every machine axis in canonical order, mm or degrees.
    pub axes: Vec<f64>,
    /// Dwell time, s (dwells with no move between them summed).
    pub dwell_s: f64,
}

/// The program's dwells and what was assumed reading them.
#[derive(Debug, Clone, PartialEq)]
pub struct Dwells {
    pub dwells: Vec<Dwell>,
    /// Machine axes the program never commands: held at 0.
    pub never_commanded: Vec<char>,
    /// Dwells merged into the one before (no move between them: one visit).
    pub merged: usize,
    /// The line of `M2`/`M30`/`M99`, if the program has one.
    pub end_line: Option<usize>,
}

/// One word as read: upper-case letter, value, byte offset of the letter in the file.
#[derive(Debug, Clone, Copy)]
struct Word {
    letter: char,
    value: f64,
    offset: usize,
}

/// Reads the program at `path` for a machine whose axes are `letters` (canonical order).
pub fn read_dwells(path: &Path, letters: &[char]) -> Result<Dwells, ImportError> {
    let src = Source::read(path)?;
    Ok(parse_dwells(&src, letters)?)
}

/// The modal state while reading: the last commanded position of each axis, whether an axis
/// moved since the last dwell, and the dwells so far.
struct State<'a> {
    letters: &'a [char],
    axes: Vec<Option<f64>>,
    /// The line each axis is first commanded on (for the message when a dwell comes first).
    first_line: Vec<Option<usize>>,
    moved: bool,
    /// Dwells with the axes as known then (`None`: not commanded yet).
    dwells: Vec<(Dwell, Vec<Option<f64>>)>,
    merged: usize,
}

/// Reads a program from text: see the module documentation for the dialect.
pub fn parse_dwells(src: &Source, letters: &[char]) -> Result<Dwells, Located> {
    let mut state = State {
        letters,
        axes: vec![None; letters.len()],
        first_line: vec![None; letters.len()],
        moved: false,
        dwells: Vec::new(),
        merged: 0,
    };
    let mut end_line = None;
    for line in lines(&src.text) {
        if line.text.trim_start().starts_with('%') {
            continue;
        }
        let words = words(src, &line)?;
        if block(src, &line, &words, &mut state)? {
            end_line = Some(line.number);
            break;
        }
    }
    finish(src, state, end_line)
}

/// The words of one line; comments, `/` and what follows `;` or `*` skipped.
fn words(src: &Source, line: &Line<'_>) -> Result<Vec<Word>, Located> {
    let text = line.text;
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let rest = &text[i..];
        let Some(c) = rest.chars().next() else { break };
        let at = offset_of(line, rest);
        match c {
            _ if c.is_whitespace() => i += c.len_utf8(),
            '/' if out.is_empty() => i += 1,
            ';' | '*' => break,
            '(' => match rest.find(')') {
                Some(close) => i += close + 1,
                None => {
                    return Err(src.at(
                        at..at,
                        "expected `)` closing the comment on this line, found the line's end",
                    ));
                }
            },
            _ if c.is_ascii_alphabetic() => {
                let (value, len) = number(src, line, i + 1)?;
                out.push(Word {
                    letter: c.to_ascii_uppercase(),
                    value,
                    offset: at,
                });
                i += 1 + len;
            }
            _ => {
                return Err(src.at(
                    at..at,
                    format!(
                        "expected a word (a letter and a number), a comment `( )` or `;`, \
                         found `{c}`"
                    ),
                ));
            }
        }
    }
    Ok(out)
}

/// The number starting at byte `start` of the line: `[+-]digits[.digits]` or `[+-].digits`;
/// its value and length in bytes.
fn number(src: &Source, line: &Line<'_>, start: usize) -> Result<(f64, usize), Located> {
    let bytes = line.text.as_bytes();
    let mut end = start;
    if end < bytes.len() && (bytes[end] == b'+' || bytes[end] == b'-') {
        end += 1;
    }
    let digits_from = end;
    while end < bytes.len() && (bytes[end].is_ascii_digit() || bytes[end] == b'.') {
        end += 1;
    }
    let body = &line.text[digits_from..end];
    let digits = body.bytes().filter(u8::is_ascii_digit).count();
    let points = body.len() - digits;
    if digits == 0 || points > 1 {
        let found: String = line.text[start..]
            .chars()
            .take_while(|c| !c.is_whitespace())
            .take(12)
            .collect();
        let letter = &line.text[start - 1..start];
        return Err(src.at(
            line.offset + start..line.offset + start,
            format!("expected a number after `{letter}`, found `{found}`"),
        ));
    }
    let value: f64 = line.text[start..end]
        .trim_start_matches('+')
        .parse()
        .map_err(|_| {
            src.at(
                line.offset + start..line.offset + start,
                "expected a number",
            )
        })?;
    Ok((value, end - start))
}

/// Applies one block to the state; `Ok(true)` when it ends the program.
fn block(
    src: &Source,
    line: &Line<'_>,
    words: &[Word],
    state: &mut State<'_>,
) -> Result<bool, Located> {
    let dwell = check_g_words(src, words)?;
    let mut ends = false;
    for w in words.iter().filter(|w| w.letter == 'M') {
        let m = whole(w.value);
        if m.is_some_and(|m| CALL_M.contains(&m)) {
            return Err(at_word(
                src,
                w,
                &format!(
                    "the cycle's moves in this program, found a subprogram call M{} (its \
                     moves are not followed)",
                    w.value
                ),
            ));
        }
        ends |= m.is_some_and(|m| END_M.contains(&m));
    }
    match dwell {
        Some(g4) => dwell_block(src, line, words, g4, state)?,
        None => motion_block(src, line, words, state)?,
    }
    Ok(ends)
}

/// Refuses the G codes not followed; returns the `G4` word if the block dwells.
fn check_g_words<'w>(src: &Source, words: &'w [Word]) -> Result<Option<&'w Word>, Located> {
    let mut dwell = None;
    for w in words.iter().filter(|w| w.letter == 'G') {
        match whole(w.value) {
            Some(4) => dwell = Some(w),
            Some(g) if ACCEPTED_G.contains(&g) => {}
            Some(91) => {
                return Err(at_word(
                    src,
                    w,
                    "G90 (absolute positions), found G91: incremental positions are not read \
                     (each dwell's axes would depend on where the cycle started)",
                ));
            }
            Some(20) => {
                return Err(at_word(
                    src,
                    w,
                    "G21 (mm), found G20: inch programs are not read",
                ));
            }
            _ => {
                return Err(at_word(
                    src,
                    w,
                    &format!(
                        "one of G0 G1 G4 (moves and dwells) or a G code that leaves the \
                         positions alone ({}), found G{}",
                        accepted_list(),
                        w.value
                    ),
                ));
            }
        }
    }
    Ok(dwell)
}

fn accepted_list() -> String {
    ACCEPTED_G
        .iter()
        .filter(|&&g| !matches!(g, 0 | 1 | 4))
        .map(|g| format!("G{g}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A block without `G4`: axis words set the modal position.
fn motion_block(
    src: &Source,
    line: &Line<'_>,
    words: &[Word],
    state: &mut State<'_>,
) -> Result<(), Located> {
    for w in words {
        if let Some(k) = state.letters.iter().position(|&a| a == w.letter) {
            state.axes[k] = Some(w.value);
            state.first_line[k].get_or_insert(line.number);
            state.moved = true;
        } else if w.letter == 'P' {
            return Err(at_word(
                src,
                w,
                "P only with G4 (a dwell); a P elsewhere calls or sets something not followed",
            ));
        } else {
            other_word(src, w, state.letters)?;
        }
    }
    Ok(())
}

/// Any word but an axis word and `P`: `G` and `M` (checked before), the inert ones, else an
/// error naming what a block may hold.
fn other_word(src: &Source, w: &Word, letters: &[char]) -> Result<(), Located> {
    if matches!(w.letter, 'G' | 'M') || INERT_WORDS.contains(&w.letter) {
        return Ok(());
    }
    let axes: String = letters.iter().collect();
    let message = if "XYZUVWABC".contains(w.letter) {
        format!(
            "an axis of the machine ({axes}), found axis word {}",
            w.letter
        )
    } else {
        format!(
            "a word of G, M, N, O, F, S, T, D, H, P (with G4) or the machine's axes {axes}, \
             found `{}{}`",
            w.letter, w.value
        )
    };
    Err(at_word(src, w, &message))
}

/// A `G4` block: its time from `P` or `X`, no other axis word; merged into the dwell before
/// when nothing moved between them.
fn dwell_block(
    src: &Source,
    line: &Line<'_>,
    words: &[Word],
    g4: &Word,
    state: &mut State<'_>,
) -> Result<(), Located> {
    let mut time: Option<&Word> = None;
    for w in words {
        let is_time = matches!(w.letter, 'P' | 'X');
        if is_time && time.is_some() {
            return Err(at_word(src, w, "one dwell time (P or X) in a G4 block"));
        }
        if is_time {
            time = Some(w);
        } else if state.letters.contains(&w.letter) {
            return Err(at_word(
                src,
                w,
                "no axis word in a G4 block (a dwell does not move; put the move on a line \
                 of its own)",
            ));
        } else {
            other_word(src, w, state.letters)?;
        }
    }
    let Some(time) = time else {
        return Err(at_word(src, g4, "a dwell time, G4 P<s> or G4 X<s>"));
    };
    if time.value <= 0.0 {
        return Err(at_word(
            src,
            time,
            &format!("a dwell time above 0 s, found {}", time.value),
        ));
    }
    let column = src.locate(g4.offset).column;
    push_dwell(state, line.number, column, time.value);
    Ok(())
}

fn push_dwell(state: &mut State<'_>, line: usize, column: usize, dwell_s: f64) {
    if !state.moved
        && let Some((last, _)) = state.dwells.last_mut()
    {
        // The head never left the ball: one visit, one plateau in the stream.
        last.dwell_s += dwell_s;
        state.merged += 1;
        return;
    }
    state.moved = false;
    let dwell = Dwell {
        line,
        column,
        axes: Vec::new(),
        dwell_s,
    };
    state.dwells.push((dwell, state.axes.clone()));
}

/// The dwells with every axis known: never-commanded axes at 0, an axis commanded only after
/// a dwell refused at that dwell.
fn finish(src: &Source, state: State<'_>, end_line: Option<usize>) -> Result<Dwells, Located> {
    if state.dwells.is_empty() {
        let end = src.text.len();
        return Err(src.at(
            end..end,
            "expected G4 dwells (one per ball visit), found none in the program",
        ));
    }
    let never: Vec<bool> = state.first_line.iter().map(Option::is_none).collect();
    let mut dwells = Vec::with_capacity(state.dwells.len());
    for (mut dwell, axes) in state.dwells {
        for (k, a) in axes.iter().enumerate() {
            if a.is_none() && !never[k] {
                return Err(Located {
                    at: mtcal_located::Location::at(&src.path, dwell.line, dwell.column),
                    message: format!(
                        "expected every axis commanded before the first dwell, found axis {} \
                         first commanded at line {}",
                        state.letters[k],
                        state.first_line[k].unwrap_or(0)
                    ),
                });
            }
        }
        dwell.axes = axes.iter().map(|a| a.unwrap_or(0.0)).collect();
        dwells.push(dwell);
    }
    Ok(Dwells {
        dwells,
        never_commanded: state
            .letters
            .iter()
            .zip(&never)
            .filter(|(_, n)| **n)
            .map(|(&l, _)| l)
            .collect(),
        merged: state.merged,
        end_line,
    })
}

/// `value` as a whole code number (`G01` → 1); `None` for `G54.1` and the like.
fn whole(value: f64) -> Option<u32> {
    (value >= 0.0 && value.fract() == 0.0 && value < 10_000.0).then_some(value as u32)
}

fn at_word(src: &Source, w: &Word, expected: &str) -> Located {
    src.at(w.offset..w.offset, format!("expected {expected}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Dwells, Located> {
        parse_dwells(
            &Source::new(Path::new("p.nc"), text.to_string()),
            &['X', 'Y', 'Z', 'A', 'C'],
        )
    }

    fn message(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    #[test]
    fn a_fanuc_style_cycle_gives_its_dwells_at_the_modal_axes() {
        let program = "%\nO1000 (THERMAL CYCLE)\nN10 G21 G17 G40 G49 G80 G90\n\
             N20 G0 X100. Y-50.5 Z200 A0 C0 ; safe\nN30 G1 Z150 F2000\n\
             N40 G04 X2.5\nN50 G0 Z200\nN60 X-.5 C90.\nN70 Z150.25\nN80 G4 P2 (visit 2)\n\
             N90 M30\nN100 G0 X999\n%\n";
        let d = parse(program).unwrap();
        assert_eq!(d.dwells.len(), 2);
        assert_eq!(d.dwells[0].axes, vec![100.0, -50.5, 150.0, 0.0, 0.0]);
        assert_eq!(d.dwells[0].dwell_s, 2.5);
        assert_eq!((d.dwells[0].line, d.dwells[0].column), (6, 5));
        assert_eq!(d.dwells[1].axes, vec![-0.5, -50.5, 150.25, 0.0, 90.0]);
        assert_eq!(d.dwells[1].dwell_s, 2.0);
        assert_eq!(
            d.end_line,
            Some(11),
            "M30 ends it: line 12's X999 is not read"
        );
        assert!(d.never_commanded.is_empty());
    }

    #[test]
    fn heidenhain_iso_blocks_with_signs_and_star_ends_read_the_same() {
        let program = "%CYCLE G71 *\nN10 G90 G00 X+100 Y-50.5 Z+150 *\nN20 G04 P+2 *\n\
             N30 G00 Z+200 *\nN40 X-0.5 Z+150.25 * ; ball 2\nN50 G04 P2 *\nN60 M99 *\n";
        let d = parse(program).unwrap();
        assert_eq!(d.dwells.len(), 2);
        assert_eq!(d.dwells[1].axes, vec![-0.5, -50.5, 150.25, 0.0, 0.0]);
        assert_eq!(d.never_commanded, vec!['A', 'C']);
        assert_eq!(d.end_line, Some(7));
    }

    #[test]
    fn words_need_no_blanks_and_block_delete_runs() {
        let d = parse("N1G1X10Y20Z30F500\n/N2G4P1.5\n").unwrap();
        assert_eq!(d.dwells[0].axes[..3], [10.0, 20.0, 30.0]);
        assert_eq!(d.dwells[0].dwell_s, 1.5);
    }

    #[test]
    fn consecutive_dwells_without_a_move_are_one_visit() {
        let d = parse("G0 X1 Y2 Z3\nG4 P1\nM5\nG4 P0.5\nG0 Z10\nG4 P2\n").unwrap();
        assert_eq!(d.dwells.len(), 2);
        assert_eq!(d.dwells[0].dwell_s, 1.5);
        assert_eq!(d.merged, 1);
        assert_eq!(d.dwells[1].axes[2], 10.0);
    }

    #[test]
    fn incremental_inch_arcs_and_calls_are_refused_where_they_are() {
        assert_eq!(
            message("G0 X1 Y2 Z3\n  G91 G0 X5\nG4 P1\n"),
            "p.nc:2:3: expected G90 (absolute positions), found G91: incremental positions \
             are not read (each dwell's axes would depend on where the cycle started)"
        );
        assert!(message("G20\n").starts_with("p.nc:1:1: expected G21 (mm), found G20"));
        assert!(message("G0 X0\nG2 X1 Y1 R1\n").contains("p.nc:2:1: expected one of G0 G1 G4"));
        assert!(message("G0 X0\nM98 P1000\n").starts_with(
            "p.nc:2:1: expected the cycle's moves in this program, found a subprogram call M98"
        ));
        assert!(message("G0 X0\nG28 Z0\n").ends_with("found G28"));
    }

    #[test]
    fn bad_words_are_located_by_line_and_column() {
        assert_eq!(
            message("N10 G0 X10\nN20 G1 Y1,5 Z3\n"),
            "p.nc:2:10: expected a word (a letter and a number), a comment `( )` or `;`, found `,`"
        );
        assert_eq!(
            message("G0 X#100\n"),
            "p.nc:1:5: expected a number after `X`, found `#100`"
        );
        assert_eq!(
            message("G0 X1.2.3\n"),
            "p.nc:1:5: expected a number after `X`, found `1.2.3`"
        );
        assert_eq!(
            message("G0 B10\n"),
            "p.nc:1:4: expected an axis of the machine (XYZAC), found axis word B"
        );
        assert!(message("G0 X0 (open\n").starts_with("p.nc:1:7: expected `)`"));
        assert!(message("G0 Q5\n").contains("found `Q5`"));
    }

    #[test]
    fn dwells_need_a_positive_time_and_no_move() {
        assert_eq!(
            message("G0 X0\nG4\n"),
            "p.nc:2:1: expected a dwell time, G4 P<s> or G4 X<s>"
        );
        assert!(message("G0 X0\nG4 P0\n").starts_with("p.nc:2:4: expected a dwell time above 0"));
        assert!(message("G0 X0\nG4 P1 Z5\n").starts_with("p.nc:2:7: expected no axis word"));
        assert!(message("G0 X0\nG4 P1 X2\n").starts_with("p.nc:2:7: expected one dwell time"));
        assert!(message("G0 X0\nG1 P1\n").starts_with("p.nc:2:4: expected P only with G4"));
    }

    #[test]
    fn a_program_without_dwells_or_commanding_an_axis_after_one_is_refused() {
        assert_eq!(
            message("G0 X0\nM30\n"),
            "p.nc:3:1: expected G4 dwells (one per ball visit), found none in the program"
        );
        assert_eq!(
            message("G0 X0 Y0 Z0\nG4 P1\nG0 C90\nG4 P1\n"),
            "p.nc:2:1: expected every axis commanded before the first dwell, found axis C \
             first commanded at line 3"
        );
    }
}
