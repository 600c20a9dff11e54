//! Reading a compensation file back and checking it against the control's limits before it is
//! loaded: a file mtcal wrote, or one a person edited. Each format's reader finds what is
//! malformed (file, line, column); its validator refuses what the control would refuse or
//! misread ([`check_compensation`], [`crate::Request::check`]).

use crate::CompensateError;
use crate::exported::Checked;
use crate::output::Compensation;
use crate::settings::Settings;
use mtcal_kinematics::Machine;
use std::path::Path;

// The tests name the built-in pitch tables by their format.
#[cfg(test)]
use crate::pitch::PitchFormat;

/// Reads `path` as the file `what` of `machine` and checks it with the limits in `settings`.
/// Every error names the file (and line and column where the fault is on one line).
pub fn check_compensation(
    machine: &Machine,
    what: Compensation,
    path: &Path,
    settings: &Settings,
) -> Result<Checked, CompensateError> {
    what.request()?.check(machine, path, settings)
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
