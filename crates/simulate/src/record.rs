//! `[record]`: the decimals the files hold, as a controller and an instrument write them.

use crate::SimulateError;
use crate::keys::RecordKeys;
use mtcal_kinematics::AxisKind;
use std::path::Path;

/// `[record]`: how many decimals the files hold (`None`: every digit).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Record {
    pub positions: Option<usize>,
    pub readings: Option<usize>,
    pub time: Option<usize>,
    pub context: Option<usize>,
}

impl Record {
    /// `[record]` as read (`None`: no table), its decimals checked, in the order of their
    /// names.
    pub(crate) fn from_plan(
        keys: Option<&RecordKeys>,
        file: &Path,
    ) -> Result<Record, SimulateError> {
        let Some(keys) = keys else {
            return Ok(Record::default());
        };
        let decimals = |key: &str, value: Option<i64>| match value {
            None => Ok(None),
            Some(d) if (0..=9).contains(&d) => Ok(Some(d as usize)),
            Some(d) => Err(SimulateError::Plan {
                file: file.to_path_buf(),
                message: format!(
                    "[record] `{key}` must be a number of decimals from 0 to 9, found {d}"
                ),
            }),
        };
        let context = decimals("context", keys.context)?;
        let positions = decimals("positions", keys.positions)?;
        let readings = decimals("readings", keys.readings)?;
        let time = decimals("time", keys.time)?;
        Ok(Record {
            positions,
            readings,
            time,
            context,
        })
    }

    /// `v` as written with `decimals` and read back (a written `-0.000` reads as 0).
    pub(crate) fn round(v: f64, decimals: Option<usize>) -> f64 {
        match decimals {
            None => v,
            Some(d) => {
                let r: f64 = format!("{v:.d$}").parse().expect("a formatted f64 parses");
                if r == 0.0 { 0.0 } else { r }
            }
        }
    }

    /// The poses the controller is given: each axis rounded in its file unit (mm, degrees),
    /// then converted back as `identify` converts the file.
    pub(crate) fn positions_of(
        &self,
        machine: &mtcal_kinematics::Machine,
        mut poses: Vec<Vec<f64>>,
    ) -> Vec<Vec<f64>> {
        if self.positions.is_none() {
            return poses;
        }
        for q in &mut poses {
            for (v, ax) in q.iter_mut().zip(machine.axes()) {
                *v = match ax.kind() {
                    AxisKind::Linear => Record::round(*v * 1e3, self.positions) * 1e-3,
                    AxisKind::Rotary => Record::round(v.to_degrees(), self.positions).to_radians(),
                };
            }
        }
        poses
    }
}
