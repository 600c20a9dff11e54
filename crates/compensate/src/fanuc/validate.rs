//! What a Fanuc control refuses or misreads in pitch error compensation data ([`validate_fanuc`]).

use super::{FanucControl, FanucError, FanucReverse, FanucTable, MAX_MAGNIFICATION};
use crate::{CompensateError, Travel};
use std::collections::BTreeMap;

/// Checks one table against the control's limits.
fn validate_table(control: &FanucControl, t: &FanucTable) -> Result<(), FanucError> {
    let axis = t.axis.letter;
    let layout = |message: String| FanucError::Layout { axis, message };
    if !(1..=MAX_MAGNIFICATION).contains(&t.magnification) {
        let magnification = t.magnification;
        return Err(FanucError::BadMagnification {
            axis,
            magnification,
        });
    }
    if t.interval_units <= 0 {
        return Err(layout(format!(
            "the interval (3624) must be positive, got {} detection units",
            t.interval_units
        )));
    }
    let (first, last, reference) = (
        t.first_point as i64,
        t.last_point as i64,
        t.reference_point as i64,
    );
    if last - first + 1 > control.axis_points as i64 {
        return Err(FanucError::TooManyAxisPoints {
            axis,
            points: last - first + 1,
            max: control.axis_points,
        });
    }
    if last < first || t.values.len() as i64 != last - first + 1 {
        return Err(layout(format!(
            "3621 = {first} to 3622 = {last} needs {} values, the table has {}",
            (last - first + 1).max(0),
            t.values.len()
        )));
    }
    if reference < first - 1 || reference > last {
        return Err(layout(format!(
            "the reference point 3620 = {reference} must lie on the table: from 3621 − 1 = {} \
             to 3622 = {last}",
            first - 1
        )));
    }
    check_values(control, t, &t.values, first)?;
    if let Some(rev) = t.revolution_units {
        check_turn(t, rev, &t.values, first)?;
    }
    if let Some(r) = &t.reverse {
        check_reverse(control, t, r)?;
    }
    for (from, to, _) in t.blocks() {
        check_pool(control, axis, from, to)?;
    }
    Ok(())
}

fn check_reverse(
    control: &FanucControl,
    t: &FanucTable,
    r: &FanucReverse,
) -> Result<(), FanucError> {
    let axis = t.axis.letter;
    if t.magnification != 1 {
        let magnification = t.magnification;
        return Err(FanucError::BidirectionalMagnification {
            axis,
            magnification,
        });
    }
    if r.values.len() != t.values.len() {
        let message = format!(
            "the negative-direction set has {} values, the positive one {}",
            r.values.len(),
            t.values.len()
        );
        return Err(FanucError::Layout { axis, message });
    }
    let first = r.first_point as i64;
    check_values(control, t, &r.values, first)?;
    if let Some(rev) = t.revolution_units {
        check_turn(t, rev, &r.values, first)?;
    }
    Ok(())
}

/// Every value within the control's range; `first` numbers `values[0]`.
fn check_values(
    control: &FanucControl,
    t: &FanucTable,
    values: &[i64],
    first: i64,
) -> Result<(), FanucError> {
    match values
        .iter()
        .enumerate()
        .find(|(_, v)| v.abs() > control.value_limit)
    {
        Some((i, &value)) => Err(FanucError::ValueOutOfRange {
            axis: t.axis.letter,
            point: first + i as i64,
            value,
            limit: control.value_limit,
            magnification: t.magnification,
        }),
        None => Ok(()),
    }
}

/// The rules of a rotary axis with a revolution (B-63980EN example 2) for one set of values
/// numbered from `first` (its reference point).
fn check_turn(
    t: &FanucTable,
    revolution: i64,
    values: &[i64],
    first: i64,
) -> Result<(), FanucError> {
    let axis = t.axis.letter;
    if revolution % t.interval_units != 0 {
        return Err(FanucError::RevolutionNotWhole {
            axis,
            interval_units: t.interval_units,
            revolution_units: revolution,
        });
    }
    let n = revolution / t.interval_units;
    if t.first_point != t.reference_point || values.len() as i64 != n + 1 {
        let message = format!(
            "on a rotary axis 3621 must equal 3620 and 3622 be 3620 + 3625/3624 = 3620 + {n}; \
             got 3620 = {}, 3621 = {}, 3622 = {}",
            t.reference_point, t.first_point, t.last_point
        );
        return Err(FanucError::Layout { axis, message });
    }
    let last = values.len() - 1;
    if values[0] != values[last] {
        return Err(FanucError::RotaryEndsDiffer {
            axis,
            reference: first,
            last: first + last as i64,
            reference_value: values[0],
            last_value: values[last],
        });
    }
    let sum: i64 = values[1..].iter().sum();
    if sum != 0 {
        return Err(FanucError::RevolutionSumNotZero {
            axis,
            from: first + 1,
            to: first + last as i64,
            sum,
        });
    }
    Ok(())
}

fn check_pool(control: &FanucControl, axis: char, from: i64, to: i64) -> Result<(), FanucError> {
    let pool = control.pool_size;
    if to - from + 1 > pool as i64 {
        let points = to - from + 1;
        return Err(FanucError::TooManyPoints { axis, points, pool });
    }
    if from < 0 || to >= pool as i64 {
        let last = pool as i64 - 1;
        return Err(FanucError::PoolOverflow {
            axis,
            from,
            to,
            last,
        });
    }
    Ok(())
}

/// Checks tables against the control: each table's limits, one control axis number per axis,
/// and no point used by two sets.
pub fn validate_fanuc(
    control: &FanucControl,
    tables: &[FanucTable],
) -> Result<(), CompensateError> {
    let mut numbers: BTreeMap<u32, char> = BTreeMap::new();
    let mut blocks = Vec::new();
    for t in tables {
        validate_table(control, t)?;
        if let Some(&first) = numbers.get(&t.axis.number) {
            return Err(FanucError::DuplicateAxisNumber {
                number: t.axis.number,
                first,
                second: t.axis.letter,
            }
            .into());
        }
        numbers.insert(t.axis.number, t.axis.letter);
        for (from, to, travel) in t.blocks() {
            let set = match travel {
                Travel::Forward => "positive-direction",
                Travel::Reverse => "negative-direction",
            };
            blocks.push((from, to, format!("axis {} ({set} set)", t.axis.letter)));
        }
    }
    blocks.sort_by_key(|b| b.0);
    for w in blocks.windows(2) {
        if w[1].0 <= w[0].1 {
            return Err(FanucError::PointsOverlap {
                from: w[1].0,
                to: w[0].1.min(w[1].1),
                first: w[0].2.clone(),
                second: w[1].2.clone(),
            }
            .into());
        }
    }
    Ok(())
}
