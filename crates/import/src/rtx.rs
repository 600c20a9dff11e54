//! `renishaw-rtx`: Renishaw CARTO dynamic capture (`.rtx`, XL-80).
//!
//! ```text
//! HEADER::␍␊
//! Owner: CARTO-Dynamic␍␊
//! Sample rate: 50000␍␊
//! Sample no: 1000001␍␊
//! Actual sample rate: 50000␍␊
//! Axis: X␍␊
//! …␍␊
//! Data:␍␊
//! <Sample no × 8 bytes: little-endian f64>EOF::␍␊
//! ```
//!
//! No vendor specification is public; the layout is what two independent public readers
//! agree on. Assumed (docs/FORMATS.md, "Imports"): the samples are the laser's linear
//! displacement in **mm** (a capture in angular mode, mrad, cannot be told from the header
//! and must not be imported); the axis was **held** at one position while the laser recorded
//! (a capture of settling, vibration or drift), so the run's commanded position is the
//! axis' `--hold` value and the reading is the change since the first sample, µm; sample `k`
//! is at `t = k / rate` (`Actual sample rate`, else `Sample rate`, Hz).

use std::path::Path;

use mtcal_located::{Located, Source};

use crate::ImportError;
use crate::recording::Recording;
use crate::text::{Line, lines, number};

const MAGIC: &[u8] = b"HEADER::";
const TRAILER: &[u8] = b"EOF::";

/// Reads a CARTO dynamic capture.
pub fn read_rtx(path: &Path) -> Result<Recording, ImportError> {
    let bytes = std::fs::read(path).map_err(|cause| ImportError::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    let binary = |offset: usize, message: String| ImportError::Binary {
        path: path.to_path_buf(),
        offset,
        message,
    };
    if !bytes.starts_with(MAGIC) {
        return Err(binary(0, "expected `HEADER::` (a CARTO .rtx file)".into()));
    }
    let data_start = data_start(&bytes).ok_or_else(|| {
        binary(
            bytes.len(),
            "expected a header line `Data:`, found none".into(),
        )
    })?;
    let header = Source::from_bytes(path, bytes[..data_start].to_vec())?;
    let (samples, rate, axis) = header_values(&header)?;
    let data = samples_of(&bytes, data_start, samples).map_err(|(o, m)| binary(o, m))?;
    Ok(recording(&data, rate, axis))
}

/// The byte offset after the `Data:` line's end.
fn data_start(bytes: &[u8]) -> Option<usize> {
    let mut start = 0;
    while let Some(n) = bytes[start..].iter().position(|&b| b == b'\n') {
        let line = &bytes[start..start + n];
        if line.strip_suffix(b"\r").unwrap_or(line) == b"Data:" {
            return Some(start + n + 1);
        }
        start += n + 1;
    }
    None
}

/// `Sample no`, the sample rate (Hz) and the axis letter from the header text.
fn header_values(src: &Source) -> Result<(usize, f64, Option<char>), Located> {
    let all: Vec<Line<'_>> = lines(&src.text).collect();
    let find = |key: &str| {
        all.iter().find_map(|l| {
            let (k, v) = l.text.split_once(':')?;
            (k.trim() == key).then_some((*l, v))
        })
    };
    let end = src.text.len();
    let missing = |key: &str| {
        src.at(
            end..end,
            format!("expected a header line `{key}: …`, found none"),
        )
    };
    let (line, value) = find("Sample no").ok_or_else(|| missing("Sample no"))?;
    let n = number(src, &line, value, "a sample count")?;
    if n < 2.0 || n.fract() != 0.0 {
        return Err(src.at(
            line.offset..line.offset,
            format!("expected at least 2 samples, found `{}`", value.trim()),
        ));
    }
    let rate = match find("Actual sample rate") {
        Some((l, v)) if number(src, &l, v, "a rate in Hz")? > 0.0 => number(src, &l, v, "")?,
        _ => {
            let (l, v) = find("Sample rate").ok_or_else(|| missing("Sample rate"))?;
            let rate = number(src, &l, v, "a rate in Hz")?;
            if rate <= 0.0 {
                return Err(src.at(
                    l.offset..l.offset,
                    format!("expected a rate in Hz above 0, found `{}`", v.trim()),
                ));
            }
            rate
        }
    };
    let axis = find("Axis").and_then(|(_, v)| {
        let v = v.trim();
        (v.len() == 1 && v.chars().all(|c| c.is_ascii_alphabetic()))
            .then(|| v.chars().next().unwrap().to_ascii_uppercase())
    });
    Ok((n as usize, rate, axis))
}

/// The `n` samples after `start`, then the trailer; `Err((byte offset, message))`.
fn samples_of(bytes: &[u8], start: usize, n: usize) -> Result<Vec<f64>, (usize, String)> {
    let body = &bytes[start..];
    let trailer_at = [&b"EOF::\r\n"[..], b"EOF::\n", TRAILER]
        .iter()
        .find_map(|t| body.ends_with(t).then(|| body.len() - t.len()))
        .ok_or_else(|| {
            (
                bytes.len(),
                "expected the trailer `EOF::` at the end, found none (a truncated file?)"
                    .to_string(),
            )
        })?;
    if trailer_at != 8 * n {
        return Err((
            start,
            format!(
                "expected {n} samples (Sample no) of 8 bytes = {} bytes before `EOF::`, found {trailer_at} bytes",
                8 * n
            ),
        ));
    }
    body[..trailer_at]
        .chunks_exact(8)
        .enumerate()
        .map(|(k, c)| {
            let v = f64::from_le_bytes(c.try_into().expect("chunks of 8"));
            if v.is_finite() {
                Ok(v)
            } else {
                Err((
                    start + 8 * k,
                    format!("expected a finite sample (number {}), found {v}", k + 1),
                ))
            }
        })
        .collect()
}

fn recording(data_mm: &[f64], rate_hz: f64, axis: Option<char>) -> Recording {
    let first = data_mm[0];
    Recording {
        axis,
        positions_mm: None,
        // The change since the first sample (the capture's datum), mm to µm.
        deviations_um: data_mm.iter().map(|v| (v - first) * 1e3).collect(),
        t_s: Some((0..data_mm.len()).map(|k| k as f64 / rate_hz).collect()),
        context: Vec::new(),
        targets: 1,
        cycles: 1,
        unit: "mm".to_string(),
    }
}
