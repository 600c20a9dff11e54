//! Source 004's postprocessor: a constant offset (the zero point's `−d_k*`) added to every
//! absolute X/Y/Z word of a program.

use crate::gcode::{Decimals, MM_PER_INCH, Modal, Program, format_fixed, rewrite_line};

/// Why a program cannot be offset.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum OffsetError {
    #[error(
        "line {line}: G92 redefines the coordinate system; offset the G92 values by hand or \
         remove it"
    )]
    CoordinateSetting { line: usize },
    #[error("the offset ({0:?} mm) is not finite")]
    NotFinite([f64; 3]),
}

/// Adds `offset_mm` (X, Y, Z; in mm, converted to inches where `G20` is in effect) to every X/Y/Z
/// word written in absolute mode (`G90`), on any line: motions `G0 G1 G2 G3` and `G28`/`G30`
/// intermediate points alike. Unchanged: incremental words (`G91`: a constant translation leaves
/// increments alone), arc centres `I J K` (relative), rotary words, lines with `G53` (machine
/// coordinates) or `G10` (offset tables), and every line without X/Y/Z words, byte for byte.
/// Refused: `G92`. Changed words are written with `decimals` ([`Decimals`]).
///
/// The offset is in program coordinates, which on a three-axis machine following the CNC
/// convention are the workpiece frame's X, Y, Z: source 004's `−d_k*` (µm) divided by 1000.
pub fn offset_program(
    program: &Program,
    offset_mm: [f64; 3],
    decimals: Decimals,
) -> Result<String, OffsetError> {
    if !offset_mm.iter().all(|v| v.is_finite()) {
        return Err(OffsetError::NotFinite(offset_mm));
    }
    let mut modal = Modal::default();
    let mut out = String::new();
    for (i, line) in program.lines.iter().enumerate() {
        modal = modal.step(line);
        if line.has_g(92.0) && line.has_axis_word() {
            return Err(OffsetError::CoordinateSetting { line: i + 1 });
        }
        let skip = !modal.absolute || line.has_g(53.0) || line.has_g(10.0);
        let values: Vec<(usize, String)> = if skip {
            Vec::new()
        } else {
            (0..3)
                .filter_map(|a| {
                    let w = line.word(['X', 'Y', 'Z'][a])?;
                    let unit = if modal.inch { MM_PER_INCH } else { 1.0 };
                    let v = w.value + offset_mm[a] / unit;
                    Some((
                        a,
                        format_fixed(v, decimals.for_axis(a, modal.inch, Some(w))),
                    ))
                })
                .collect()
        };
        if values.is_empty() {
            out.push_str(&line.text);
        } else {
            out.push_str(&rewrite_line(line, &values));
        }
        out.push_str(&line.eol);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absolute_words_move_increments_and_centres_do_not() {
        let text = "%\nG90 G21\nN10 G0 X10.0 Y-5 Z2.5 (start)\nN20 G2 X20 Y0 I5 J0 F300\n\
                    G91\nG1 X1.0 Y1.0\nG90 G20\nG1 X1.00000\nG53 Z0\nM30\n";
        let p = Program::parse(text).unwrap();
        let out = offset_program(&p, [0.0254, -0.001, 0.5], Decimals::default()).unwrap();
        let expect = "%\nG90 G21\nN10 G0 X10.0254 Y-5.0010 Z3.0000 (start)\n\
                      N20 G2 X20.0254 Y-0.0010 I5 J0 F300\nG91\nG1 X1.0 Y1.0\nG90 G20\n\
                      G1 X1.00100\nG53 Z0\nM30\n";
        assert_eq!(out, expect);
    }

    #[test]
    fn decimals_as_input_and_a_zero_offset_reproduce_the_file() {
        let text = "G90\r\nN1 G1 X1.50000 Y-2.2500 Z3.123456 ; c\r\nX-0.0000\r\n";
        let p = Program::parse(text).unwrap();
        let out = offset_program(&p, [0.0; 3], Decimals::AsInput).unwrap();
        assert_eq!(out, text.replace("X-0.0000", "X0.0000"));
        let p2 = Program::parse("G1 Z-10\n").unwrap();
        let out = offset_program(&p2, [0.0, 0.0, 0.0123], Decimals::AsInput).unwrap();
        assert_eq!(out, "G1 Z-9.9877\n");
        let out = offset_program(&p, [0.0; 3], Decimals::default()).unwrap();
        assert!(out.contains("X1.5000 Y-2.2500 Z3.1235 ; c\r\n"), "{out}");
    }

    #[test]
    fn g92_is_refused() {
        let p = Program::parse("G1 X0\nG92 X0 Y0\n").unwrap();
        assert_eq!(
            offset_program(&p, [0.0; 3], Decimals::default()),
            Err(OffsetError::CoordinateSetting { line: 2 })
        );
    }
}
