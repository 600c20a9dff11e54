//! `[record]`: the decimals the files hold, as a controller and an instrument write them.

use crate::SimulateError;
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
    const KEYS: [&str; 4] = ["positions", "readings", "time", "context"];

    pub(crate) fn from_plan(plan: &toml::Table, file: &Path) -> Result<Record, SimulateError> {
        let err = |message: String| SimulateError::Plan {
            file: file.to_path_buf(),
            message,
        };
        let Some(v) = plan.get("record") else {
            return Ok(Record::default());
        };
        let table = v
            .as_table()
            .ok_or_else(|| err(format!("`record` must be a table, found {v}")))?;
        let mut record = Record::default();
        for (k, v) in table {
            let decimals = v
                .as_integer()
                .filter(|d| (0..=9).contains(d))
                .ok_or_else(|| {
                    err(format!(
                        "[record] `{k}` must be a number of decimals from 0 to 9, found {v}"
                    ))
                })? as usize;
            match k.as_str() {
                "positions" => record.positions = Some(decimals),
                "readings" => record.readings = Some(decimals),
                "time" => record.time = Some(decimals),
                "context" => record.context = Some(decimals),
                _ => {
                    return Err(err(format!(
                        "[record] unknown key `{k}`; it has {}",
                        Record::KEYS.join(", ")
                    )));
                }
            }
        }
        Ok(record)
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
