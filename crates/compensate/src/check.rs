//! Reading a compensation file back and checking it against the control's limits before it is
//! loaded: a file mtcal wrote, or one a person edited. Each format's reader finds what is
//! malformed (file, line, column); its validator refuses what the control would refuse or
//! misread ([`check_compensation`]).

use crate::output::{Compensation, Settings};
use crate::pitch::PitchFormat;
use crate::{CompensateError, LINUXCNC_MAX_TRIPLETS, ParameterValue};
use mtcal_kinematics::Machine;
use std::fmt;
use std::path::Path;

/// What a file that passed its checks holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Checked {
    /// Tables (or parameters for a parameter file, records for swivel data).
    pub tables: usize,
    /// Interpolation points in all tables.
    pub points: usize,
}

impl fmt::Display for Checked {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} tables, {} points", self.tables, self.points)
    }
}

/// Reads `path` as the file `what` of `machine` and checks it with the limits in `settings`.
/// Every error names the file (and line and column where the fault is on one line).
pub fn check_compensation(
    machine: &Machine,
    what: Compensation,
    path: &Path,
    settings: &Settings,
) -> Result<Checked, CompensateError> {
    check_unlocated(machine, what, path, settings).map_err(|e| match e {
        CompensateError::Fanuc(_)
        | CompensateError::Heidenhain(_)
        | CompensateError::Siemens(_)
        | CompensateError::Carr(_)
        | CompensateError::TooManyNodes { .. } => CompensateError::Invalid {
            file: path.to_path_buf(),
            cause: Box::new(e),
        },
        located => located,
    })
}

/// [`check_compensation`], its limit errors not yet naming the file.
fn check_unlocated(
    machine: &Machine,
    what: Compensation,
    path: &Path,
    settings: &Settings,
) -> Result<Checked, CompensateError> {
    let single = |points| Checked { tables: 1, points };
    match what {
        Compensation::PitchTable { axis, format } => {
            crate::linear_axis(machine, axis)?;
            let table = match format {
                PitchFormat::LinuxCnc => crate::read_linuxcnc_comp(path, axis)?,
                PitchFormat::Csv => crate::read_pitch_csv(path, axis)?,
            };
            if format == PitchFormat::LinuxCnc && table.len() > LINUXCNC_MAX_TRIPLETS {
                return Err(CompensateError::TooManyNodes {
                    what: format!("LinuxCNC compensation file for axis {axis}"),
                    nodes: table.len(),
                    max: LINUXCNC_MAX_TRIPLETS,
                });
            }
            Ok(single(table.len()))
        }
        Compensation::Grid => Ok(single(crate::read_grid_csv(path)?.error_um.len())),
        Compensation::Parameters(format) => {
            let params = crate::read_error_parameters(path, format)?;
            let points = params
                .params
                .iter()
                .map(|p| match &p.value {
                    ParameterValue::Table { args, .. } => args.len(),
                    ParameterValue::Constant(_) => 1,
                })
                .sum();
            Ok(Checked {
                tables: params.params.len(),
                points,
            })
        }
        Compensation::TrtPivots => Err(CompensateError::NoReader {
            format: "LinuxCNC HAL settings",
        }),
        Compensation::SiemensEec { .. } => {
            let tables = crate::read_siemens_eec(path, &settings.siemens)?;
            let points = tables.iter().map(|t| t.positions.len()).sum();
            Ok(Checked {
                tables: tables.len(),
                points,
            })
        }
        Compensation::SiemensCec { .. } => {
            let tables = crate::read_siemens_cec(path, &settings.siemens)?;
            let points = tables.iter().map(|t| t.positions.len()).sum();
            Ok(Checked {
                tables: tables.len(),
                points,
            })
        }
        Compensation::SiemensCarr => {
            crate::read_carr(path)?;
            Ok(single(0))
        }
        Compensation::Fanuc { axis } => {
            let axes = crate::output::fanuc_axes(machine, axis)?;
            let tables = crate::read_fanuc_parameters(path, &settings.fanuc, &axes)?;
            crate::validate_fanuc(&settings.fanuc, &tables)?;
            let points = tables.iter().map(|t| t.node_points().count()).sum();
            Ok(Checked {
                tables: tables.len(),
                points,
            })
        }
        Compensation::HeidenhainCom => {
            let set = crate::read_heidenhain_com(path)?;
            crate::validate_heidenhain_com(&set, &settings.heidenhain)?;
            Ok(Checked {
                tables: set.tables.len(),
                points: set.total_points(),
            })
        }
        Compensation::HeidenhainKinematicsComp => {
            let kc = crate::read_kinematics_comp(path)?;
            crate::validate_kinematics_comp(&kc, &crate::KcLimits::default())?;
            Ok(Checked {
                tables: kc.tables.len(),
                points: kc.tables.iter().map(|t| t.positions.len()).sum(),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ParameterFormat;
    use mtcal_kinematics::MachineModel;
    use mtcal_machine::topology::Reading;

    fn model(code: &str) -> (MachineModel, Vec<f64>) {
        let m = mtcal_machine::load_machine(code, Reading::FromWorkpiece).unwrap();
        let model = MachineModel::new(m.machine, &m.config).unwrap();
        // Small errors everywhere, so the tables are not all zero.
        let coeffs = (0..model.n_coeffs())
            .map(|i| 1e-6 * ((i as f64 * 0.7).sin()))
            .collect();
        (model, coeffs)
    }

    fn settings(machine: &Machine) -> Settings {
        Settings {
            fanuc: crate::FanucControl::new(
                crate::FanucSeries::Series30i,
                crate::IncrementSystem::IsB,
            ),
            ..Settings::new(machine, 50.0, 30.0)
        }
    }

    /// Every file mtcal writes (but the HAL settings) passes its own check, and the check
    /// counts what was written.
    #[test]
    fn every_written_file_passes_its_check() {
        let dir = tempfile::tempdir().unwrap();
        let pitch = |format| Compensation::PitchTable { axis: 'X', format };
        let cases = [
            ("ZFYX", pitch(PitchFormat::LinuxCnc), "x.comp"),
            ("ZFYX", pitch(PitchFormat::Csv), "x.csv"),
            ("ZFYX", Compensation::Grid, "g.csv"),
            (
                "ZFYX",
                Compensation::Parameters(ParameterFormat::IsgCsv),
                "i.csv",
            ),
            (
                "ZFYX",
                Compensation::Parameters(ParameterFormat::Etalon),
                "e.txt",
            ),
            ("ZFYX", Compensation::SiemensEec { axis: None }, "eec.ini"),
            ("ZFYX", Compensation::SiemensCec { input: None }, "cec.ini"),
            ("CAFYXZ", Compensation::SiemensCarr, "carr.mpf"),
            ("CAFYXZ", Compensation::Fanuc { axis: None }, "fanuc.txt"),
            (
                "ZFYX",
                Compensation::Fanuc { axis: Some('Y') },
                "fanuc-y.txt",
            ),
            ("ZFYX", Compensation::HeidenhainCom, "CONFIG.CMA"),
            ("CAFYXZ", Compensation::HeidenhainKinematicsComp, "KC.TAB"),
        ];
        for (code, what, name) in cases {
            let (model, coeffs) = model(code);
            let s = settings(model.machine());
            let path = dir.path().join(name);
            let exported = crate::write_compensation(&model, &coeffs, &path, what, &s)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let checked = check_compensation(model.machine(), what, &path, &s)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            use crate::Written as W;
            match exported.written {
                W::ControlTables { tables, points, .. }
                | W::ControlFiles { tables, points, .. } => {
                    assert_eq!(checked, Checked { tables, points }, "{name}")
                }
                W::PitchTable { nodes, .. } => assert_eq!(checked.points, nodes, "{name}"),
                W::Grid { nodes: [x, y, z] } => assert_eq!(checked.points, x * y * z, "{name}"),
                W::Parameters {
                    tables, locations, ..
                } => assert_eq!(checked.tables, tables + locations, "{name}"),
                W::SiemensCarr { .. } => assert_eq!(checked.tables, 1, "{name}"),
                W::TrtPivots { .. } => unreachable!(),
            }
        }
    }

    /// A Siemens table edited beyond the control's point limit is refused by the check.
    #[test]
    fn a_table_beyond_the_controls_limit_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let mut s = settings(model.machine());
        let path = dir.path().join("eec.ini");
        let what = Compensation::SiemensEec { axis: Some('X') };
        crate::write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        s.siemens.enc_comp_max_points = 5;
        let e = check_compensation(model.machine(), what, &path, &s)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(&format!("{}:", path.display())), "{e}");
        assert!(e.contains("allows 5"), "{e}");
        let trt = check_compensation(model.machine(), Compensation::TrtPivots, &path, &s);
        assert!(matches!(trt, Err(CompensateError::NoReader { .. })));
    }
}
