//! The grid of `mtcal tolerance --grid 11x11x11`: points on X, Y and Z, at least three each
//! (the grid maximum needs an inside point on every axis).

use std::num::ParseIntError;

/// Why a `--grid` text could not be read.
#[derive(Debug, thiserror::Error)]
pub enum GridTextError {
    #[error("--grid `{text}`: expected three counts like 11x11x11")]
    NotCounts {
        text: String,
        #[source]
        source: ParseIntError,
    },
    #[error("--grid `{text}`: expected three counts >= 3 (X, Y, Z), e.g. 11x11x11")]
    Counts { text: String },
}

/// The X, Y and Z counts of `11x11x11`.
pub fn parse_grid(text: &str) -> Result<Vec<usize>, GridTextError> {
    let counts: Vec<usize> = text
        .split('x')
        .map(|s| s.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|source| GridTextError::NotCounts {
            text: text.to_string(),
            source,
        })?;
    if counts.len() != 3 || counts.iter().any(|&n| n < 3) {
        return Err(GridTextError::Counts {
            text: text.to_string(),
        });
    }
    Ok(counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_counts_of_at_least_three() {
        assert_eq!(parse_grid("11x 7 x3").unwrap(), vec![11, 7, 3]);
        let e = parse_grid("11xelevenx11").unwrap_err();
        assert_eq!(
            e.to_string(),
            "--grid `11xelevenx11`: expected three counts like 11x11x11"
        );
        assert_eq!(
            std::error::Error::source(&e).unwrap().to_string(),
            "invalid digit found in string"
        );
        for text in ["11x2x11", "11x11", "11x11x11x11"] {
            assert_eq!(
                parse_grid(text).unwrap_err().to_string(),
                format!("--grid `{text}`: expected three counts >= 3 (X, Y, Z), e.g. 11x11x11")
            );
        }
    }
}
