//! `ecmc-dat`: the ISO 230-2 input tables of the EPICS ecmc motion test tools.
//!
//! ```text
//! TEST_DATA=# Input data file for ISO230-2 calcs derived from: …
//! # comments
//! UNIT=mm
//! CYCLES=5
//! POSITIONS=5
//! TGT_DATA[1]=-10
//! REF_DATA_FWD[1,1]=-10.0000990190
//! REF_DATA_BWD[1,1]=-10.0000810190
//! ```
//!
//! `TGT_DATA[i]` is target `i` (mm), `REF_DATA_FWD[i,j]` / `REF_DATA_BWD[i,j]` the reference
//! reading at target `i` in cycle `j` approached moving forward (positive) / backward (mm).
//! Other keys (`REF_PV`, `DEC`, …) are ignored. The producer's report generator swaps the two
//! blocks; mtcal takes the `.dat` labels as written (FWD = ↑), and the laser plugin decides
//! approach directions from the motion anyway.

use std::collections::BTreeMap;
use std::path::Path;

use mtcal_located::{Located, Source};

use crate::ImportError;
use crate::recording::Recording;
use crate::text::{Line, lines, number};

/// Targets closer than this (mm) are one target: the table would be ambiguous.
const SAME_TARGET_MM: f64 = 1e-9;

/// One `KEY[i]` or `KEY[i,j]` block as read: values by index, and the line of each.
#[derive(Default)]
struct Block {
    values: BTreeMap<(usize, usize), (f64, usize)>,
    last_line: usize,
}

#[derive(Default)]
struct Table {
    unit: Option<String>,
    cycles: Option<usize>,
    positions: Option<usize>,
    targets: Block,
    fwd: Block,
    bwd: Block,
}

/// Reads an ecmc ISO 230-2 `.dat` table: per cycle the targets ascending (the FWD readings),
/// then descending (BWD), as the standard test cycle visits them; the deviation is the
/// reference reading minus the target.
pub fn read_dat(path: &Path) -> Result<Recording, ImportError> {
    let src = Source::read(path)?;
    let table = parse(&src)?;
    Ok(recording(&src, &table)?)
}

fn parse(src: &Source) -> Result<Table, Located> {
    let mut table = Table::default();
    for line in lines(&src.text) {
        if line.number == 1 {
            check_first_line(src, &line)?;
            continue;
        }
        let text = line.text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let Some((key, value)) = line.text.split_once('=') else {
            return Err(src.at(
                line.offset..line.offset,
                format!("expected KEY=VALUE, found `{text}`"),
            ));
        };
        entry(src, &line, key.trim(), value, &mut table)?;
    }
    Ok(table)
}

fn check_first_line(src: &Source, line: &Line<'_>) -> Result<(), Located> {
    if line.text.starts_with("TEST_DATA=") {
        return Ok(());
    }
    Err(src.at(
        line.offset..line.offset,
        format!(
            "expected `TEST_DATA=#…` (the first line of an ecmc ISO 230-2 table), found `{}`",
            line.text.trim()
        ),
    ))
}

fn entry(
    src: &Source,
    line: &Line<'_>,
    key: &str,
    value: &str,
    table: &mut Table,
) -> Result<(), Located> {
    let count = |what: &str| -> Result<usize, Located> {
        let v = number(src, line, value, what)?;
        if v >= 1.0 && v.fract() == 0.0 && v <= 1e6 {
            Ok(v as usize)
        } else {
            Err(src.at(
                line.offset..line.offset,
                format!("expected {what}, found `{}`", value.trim()),
            ))
        }
    };
    match key {
        "UNIT" => table.unit = Some(value.trim().to_string()),
        "CYCLES" => table.cycles = Some(count("a number of cycles (1, 2, …)")?),
        "POSITIONS" => table.positions = Some(count("a number of positions (1, 2, …)")?),
        _ if key.starts_with("TGT_DATA[") => indexed(src, line, key, value, 1, &mut table.targets)?,
        _ if key.starts_with("REF_DATA_FWD[") => indexed(src, line, key, value, 2, &mut table.fwd)?,
        _ if key.starts_with("REF_DATA_BWD[") => indexed(src, line, key, value, 2, &mut table.bwd)?,
        // The producer's own keys (REF_PV, TEST_PV, TGT_SET_PV, DEC): not data.
        _ => {}
    }
    Ok(())
}

/// `KEY[i]=v` (`dims` 1) or `KEY[i,j]=v` (`dims` 2) into `block`; indices 1-based.
fn indexed(
    src: &Source,
    line: &Line<'_>,
    key: &str,
    value: &str,
    dims: usize,
    block: &mut Block,
) -> Result<(), Located> {
    let name = &key[..key.find('[').unwrap_or(0)];
    let form = if dims == 1 { "[i]" } else { "[i,j]" };
    let bad_index = || {
        src.at(
            line.offset..line.offset,
            format!("expected {name}{form} with indices 1, 2, …, found `{key}`"),
        )
    };
    let inner = key[name.len()..]
        .strip_prefix('[')
        .and_then(|k| k.strip_suffix(']'))
        .ok_or_else(bad_index)?;
    let idx: Vec<usize> = inner
        .split(',')
        .map(|s| s.trim().parse::<usize>().ok().filter(|&i| i >= 1))
        .collect::<Option<_>>()
        .ok_or_else(bad_index)?;
    if idx.len() != dims {
        return Err(bad_index());
    }
    let v = number(src, line, value, &format!("a position in mm for {key}"))?;
    let at = (idx[0], idx.get(1).copied().unwrap_or(1));
    if let Some((_, first)) = block.values.insert(at, (v, line.number)) {
        return Err(src.at(
            line.offset..line.offset,
            format!("{key} repeated (first given at line {first})"),
        ));
    }
    block.last_line = line.number;
    Ok(())
}

fn recording(src: &Source, table: &Table) -> Result<Recording, Located> {
    let unit = table.unit.clone().unwrap_or_else(|| "mm".to_string());
    if unit != "mm" {
        return Err(at_line(
            src,
            1,
            format!("expected UNIT=mm, found UNIT={unit}"),
        ));
    }
    let m = table.positions.unwrap_or(table.targets.values.len());
    let cycles = table
        .cycles
        .unwrap_or_else(|| table.fwd.values.keys().map(|&(_, j)| j).max().unwrap_or(0));
    let targets = column(src, &table.targets, "TGT_DATA", m, 1)?;
    let fwd = column(src, &table.fwd, "REF_DATA_FWD", m, cycles)?;
    let bwd = column(src, &table.bwd, "REF_DATA_BWD", m, cycles)?;
    let order = ascending(src, table, &targets)?;
    let (mut positions_mm, mut deviations_um) = (Vec::new(), Vec::new());
    for j in 0..cycles {
        let up = order.iter().map(|&i| (i, &fwd));
        let down = order.iter().rev().map(|&i| (i, &bwd));
        for (i, block) in up.chain(down) {
            positions_mm.push(targets[i]);
            // mm to µm: the deviation is what the reference read beyond the target.
            deviations_um.push((block[i * cycles + j] - targets[i]) * 1e3);
        }
    }
    Ok(Recording {
        axis: None,
        positions_mm: Some(positions_mm),
        deviations_um,
        t_s: None,
        context: Vec::new(),
        targets: m,
        cycles,
        unit,
    })
}

/// Every value of `block` for indices `1..=m` × `1..=cycles`, row-major by target; a missing
/// or extra entry is an error at the block's last line.
fn column(
    src: &Source,
    block: &Block,
    name: &str,
    m: usize,
    cycles: usize,
) -> Result<Vec<f64>, Located> {
    let dims2 = name != "TGT_DATA";
    let show = |i: usize, j: usize| {
        if dims2 {
            format!("{name}[{i},{j}]")
        } else {
            format!("{name}[{i}]")
        }
    };
    let line = block.last_line.max(1);
    let mut out = Vec::with_capacity(m * cycles);
    for i in 1..=m {
        for j in 1..=cycles {
            let Some(&(v, _)) = block.values.get(&(i, j)) else {
                return Err(at_line(
                    src,
                    line,
                    format!(
                        "expected {} ({m} positions × {cycles} cycles), found none in the file",
                        show(i, j)
                    ),
                ));
            };
            out.push(v);
        }
    }
    if let Some((&(i, j), &(_, l))) = block.values.iter().find(|(k, _)| k.0 > m || k.1 > cycles) {
        return Err(at_line(
            src,
            l,
            format!(
                "{} is beyond the table's {m} positions × {cycles} cycles",
                show(i, j)
            ),
        ));
    }
    Ok(out)
}

/// Target indices in ascending order of position; targets too close together are an error.
fn ascending(src: &Source, table: &Table, targets: &[f64]) -> Result<Vec<usize>, Located> {
    let mut order: Vec<usize> = (0..targets.len()).collect();
    order.sort_by(|&a, &b| targets[a].total_cmp(&targets[b]));
    for w in order.windows(2) {
        if targets[w[1]] - targets[w[0]] <= SAME_TARGET_MM {
            let line = table.targets.values[&(w[1] + 1, 1)].1;
            return Err(at_line(
                src,
                line,
                format!(
                    "TGT_DATA[{}] = {} repeats TGT_DATA[{}]: expected distinct targets",
                    w[1] + 1,
                    targets[w[1]],
                    w[0] + 1
                ),
            ));
        }
    }
    Ok(order)
}

/// An error at column 1 of line `line`.
fn at_line(src: &Source, line: usize, message: String) -> Located {
    Located {
        at: mtcal_located::Location::at(&src.path, line, 1),
        message,
    }
}
