//! One compensation file of an identified machine named by type ([`Compensation`]: the
//! built-in files, for Rust callers), written and checked through the registered format of
//! its name ([`crate::Request`]), as `mtcal compensate` writes any registered format.

use crate::exported::Exported;
use crate::parameters::ParameterFormat;
use crate::registry::Request;
use crate::settings::Settings;
use crate::{CompensateError, PitchFormat};
use mtcal_kinematics::MachineModel;
use std::path::Path;

// The tests say what was written with the built-in files' own sentences.
#[cfg(test)]
use crate::exported::Written;

/// Which built-in compensation file. Any registered format, these included, is a
/// [`Request`]; this enum names the built-in ones by type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compensation {
    /// A pitch table of one linear axis (positioning along its own direction).
    PitchTable { axis: char, format: PitchFormat },
    /// A 3-D grid of tool-point error vectors (CSV).
    Grid,
    /// The machine's ISO 230-1 error parameters, for a controller that models the machine.
    Parameters(ParameterFormat),
    /// HAL settings of the rotary pivots of LinuxCNC's xyzac/xyzbc table-table kinematics.
    TrtPivots,
    /// SINUMERIK 840D sl measuring-system error compensation (`%_N_AX_EEC_INI`): the table of
    /// linear axis `axis`, or of every linear axis.
    SiemensEec { axis: Option<char> },
    /// SINUMERIK 840D sl sag / cross-axis compensation (`%_N_NC_CEC_INI`): a table for every
    /// ordered pair of linear axes, or those whose input axis is `input`.
    SiemensCec { input: Option<char> },
    /// SINUMERIK 840D sl CYCLE800 swivel data (`$TC_CARR`) of a machine with two rotary axes.
    SiemensCarr,
    /// Fanuc pitch error compensation (3620–3627 and the pitch data) of axis `axis` or of every
    /// axis, with the values table beside it (`FILE.values.csv`, which holds the card).
    Fanuc { axis: Option<char> },
    /// Heidenhain nonlinear axis error compensation: the `.CMA` file at the path and its
    /// `.COM` tables beside it.
    HeidenhainCom,
    /// Heidenhain KinematicsComp: the listing (`.TAB`) at the path and its `.COM` tables.
    HeidenhainKinematicsComp,
}

impl Compensation {
    /// The registered format's name and the `--axis` that ask for this file.
    fn named(self) -> (&'static str, Option<char>) {
        match self {
            Compensation::PitchTable { axis, format } => (format.name(), Some(axis)),
            Compensation::Grid => ("csv", None),
            Compensation::Parameters(format) => (format.name(), None),
            Compensation::TrtPivots => ("linuxcnc-trt", None),
            Compensation::SiemensEec { axis } => ("siemens-eec", axis),
            Compensation::SiemensCec { input } => ("siemens-cec", input),
            Compensation::SiemensCarr => ("siemens-carr", None),
            Compensation::Fanuc { axis } => ("fanuc", axis),
            Compensation::HeidenhainCom => ("heidenhain-com", None),
            Compensation::HeidenhainKinematicsComp => ("heidenhain-kinematicscomp", None),
        }
    }

    /// The request of the registered format that writes this file.
    pub fn request(self) -> Result<Request, CompensateError> {
        let (name, axis) = self.named();
        Request::new(name, axis)
    }

    /// Whether the file can hold a reversal of linear axis `axis` (a bidirectional table of
    /// it: a pitch table of the axis, or Fanuc's of the axis or of every axis).
    pub fn holds_reversal_of(&self, axis: char) -> bool {
        self.request().is_ok_and(|r| r.holds_reversal_of(axis))
    }
}

/// Writes the compensation file `what` of `model` with coefficients `coeffs` to `path`
/// (atomically), its convention card in it or beside it; says what it wrote
/// ([`Request::write`] of its registered format).
pub fn write_compensation(
    model: &MachineModel,
    coeffs: &[f64],
    path: &Path,
    what: Compensation,
    settings: &Settings,
) -> Result<Exported, CompensateError> {
    what.request()?.write(model, coeffs, path, settings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_machine::topology::Reading;

    /// The nominal machine of a topology code, its full ISO error model, coefficients zero.
    fn model(code: &str) -> (MachineModel, Vec<f64>) {
        let m = mtcal_machine::load_machine(code, Reading::FromWorkpiece).unwrap();
        let model = MachineModel::new(m.machine, &m.config).unwrap();
        let coeffs = vec![0.0; model.n_coeffs()];
        (model, coeffs)
    }

    fn settings(model: &MachineModel) -> Settings {
        Settings::new(model.machine(), 100.0, 30.0)
    }

    /// The file at `path` is ASCII and holds the card line `line` (the readers skip it).
    fn assert_card_in(path: &Path, line: &str) {
        let text = std::fs::read_to_string(path).unwrap();
        assert!(text.is_ascii(), "{text}");
        assert!(text.lines().any(|l| l.starts_with(line)), "{line}\n{text}");
    }

    #[test]
    fn what_was_written_is_said_in_one_sentence() {
        let said = |w: Written| w.to_string();
        assert_eq!(
            said(Written::PitchTable {
                format: PitchFormat::LinuxCnc,
                axis: 'X',
                nodes: 13,
                bidirectional: true
            }),
            "linuxcnc pitch table of X, 13 nodes, bidirectional"
        );
        assert_eq!(
            said(Written::Grid { nodes: [5, 4, 3] }),
            "a 5 × 4 × 3 grid of tool-point errors"
        );
        assert_eq!(
            said(Written::Parameters {
                format: ParameterFormat::Etalon,
                tables: 18,
                locations: 3
            }),
            "etalon error parameters: 18 component-error tables, 3 location errors"
        );
        assert_eq!(
            said(Written::TrtPivots {
                kinematics: "xyzac-trt-kins",
                not_representable: 2
            }),
            "HAL settings of LinuxCNC's xyzac-trt-kins; 2 identified errors it cannot hold are \
             listed in it"
        );
    }

    #[test]
    fn each_kind_writes_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let mut s = settings(&model);
        let path = dir.path().join("x.csv");
        let what = Compensation::PitchTable {
            axis: 'X',
            format: PitchFormat::Csv,
        };
        let w = write_compensation(&model, &coeffs, &path, what, &s)
            .unwrap()
            .written;
        let table = crate::read_pitch_csv(&path, 'X').unwrap();
        assert_card_in(&path, "# values are              corrections (-error)");
        assert_eq!(
            w,
            Written::PitchTable {
                format: PitchFormat::Csv,
                axis: 'X',
                nodes: table.len(),
                bidirectional: false
            }
        );
        // A reversal value makes the table bidirectional.
        s.reversal_um = Some(-2.0);
        let path = dir.path().join("x.comp");
        let what = Compensation::PitchTable {
            axis: 'X',
            format: PitchFormat::LinuxCnc,
        };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let w = exported.written;
        // LinuxCNC's file takes no comments: the card is beside it.
        let (beside, _) = exported
            .beside
            .first()
            .cloned()
            .expect("a card file beside the LinuxCNC file");
        let card_text = std::fs::read_to_string(&beside).unwrap();
        assert!(card_text.contains("COMP_FILE_TYPE = 1"), "{card_text}");
        assert!(
            matches!(
                w,
                Written::PitchTable {
                    bidirectional: true,
                    ..
                }
            ),
            "{w:?}"
        );
        assert!(crate::read_linuxcnc_comp(&path, 'X').is_ok());

        let path = dir.path().join("g.csv");
        let w = write_compensation(&model, &coeffs, &path, Compensation::Grid, &s)
            .unwrap()
            .written;
        let grid = crate::read_grid_csv(&path).unwrap();
        assert_card_in(&path, "# values are              errors (actual - nominal)");
        assert_eq!(
            w,
            Written::Grid {
                nodes: [grid.x_mm.len(), grid.y_mm.len(), grid.z_mm.len()]
            }
        );

        let path = dir.path().join("p.txt");
        let what = Compensation::Parameters(ParameterFormat::Etalon);
        let w = write_compensation(&model, &coeffs, &path, what, &s)
            .unwrap()
            .written;
        let read = crate::read_error_parameters(&path, ParameterFormat::Etalon).unwrap();
        assert_card_in(
            &path,
            "// squareness              C0Y > 0 rotates Y's motion",
        );
        let Written::Parameters {
            tables, locations, ..
        } = w
        else {
            panic!("{w:?}")
        };
        assert_eq!(tables + locations, read.params.len());
        assert!(tables > 0);
    }

    #[test]
    fn siemens_files_hold_every_axis_or_the_one_asked_for() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let s = settings(&model);
        let path = dir.path().join("eec.ini");
        let what = Compensation::SiemensEec { axis: None };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let eec = crate::read_siemens_eec(&path, &s.siemens).unwrap();
        let names: Vec<&str> = eec.iter().map(|t| t.axis.as_str()).collect();
        assert_eq!(names, ["X1", "Y1", "Z1"]);
        let expected = Written::ControlTables {
            file: crate::EEC_FILE_NAME,
            tables: 3,
            points: eec.iter().map(|t| t.positions.len()).sum(),
        };
        assert_eq!(exported.written, expected);
        assert_card_in(&path, "; values are");

        let path = dir.path().join("cec.ini");
        let what = Compensation::SiemensCec { input: Some('Y') };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let cec = crate::read_siemens_cec(&path, &s.siemens).unwrap();
        let inputs: Vec<(usize, &str)> = cec
            .iter()
            .map(|t| (t.index, t.input_axis.as_str()))
            .collect();
        assert_eq!(inputs, [(0, "Y1"), (1, "Y1")]);
        assert!(matches!(
            exported.written,
            Written::ControlTables { tables: 2, .. }
        ));
    }

    /// A rotary axis without limits gets a modulo table over 0…360° whose ends are one value;
    /// a limited one a plain table.
    #[test]
    fn siemens_rotary_axes_get_their_positioning_tables() {
        let dir = tempfile::tempdir().unwrap();
        let (model, mut coeffs) = model("CAFYXZ");
        for (k, c) in coeffs.iter_mut().enumerate() {
            *c = 2e-6 * ((k as f64) * 1.3).sin();
        }
        let mut s = settings(&model);
        s.spacing_deg = 25.0;
        let path = dir.path().join("eec.ini");
        let what = Compensation::SiemensEec { axis: None };
        write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let eec = crate::read_siemens_eec(&path, &s.siemens).unwrap();
        let c = eec.iter().find(|t| t.axis == "C1").expect("a table of C");
        assert!(c.is_modulo);
        assert_eq!(c.positions.first(), Some(&0.0));
        assert_eq!(c.positions.last(), Some(&360.0));
        assert_eq!(c.values.first(), c.values.last());
        assert!(c.values.iter().any(|v| v.abs() > 1e-6), "{:?}", c.values);
        let a = eec.iter().find(|t| t.axis == "A1").expect("a table of A");
        assert!(!a.is_modulo);
        // The value is the error: the control's correction −value turns C onto the command;
        // zero at 0° (K3's reference point).
        let table = crate::rotary_table(&model, &coeffs, 'C', 360.0 / 15.0, &s.hold_q).unwrap();
        let error_deg = |p: f64| (-table.correction_at_urad(p) * 1e-6).to_degrees();
        for (p, v) in c.positions.iter().zip(&c.values) {
            let expected_deg = error_deg(*p) - error_deg(0.0);
            assert!(
                (v - expected_deg).abs() < 1e-6,
                "{p}: {v} vs {expected_deg}"
            );
        }
    }

    /// K3 asks for the value 0 at the reference point: each linear axis' table is the
    /// absolute error less its value at `reference_mm` (a constant shift the work offset
    /// absorbs), zero there as the control interpolates it, and the card says where and how
    /// much was removed.
    #[test]
    fn siemens_eec_tables_are_zero_at_the_reference_point() {
        let dir = tempfile::tempdir().unwrap();
        let (model, mut coeffs) = model("ZFYX");
        for (k, c) in coeffs.iter_mut().enumerate() {
            *c = 3e-6 * ((k as f64) * 0.9).cos();
        }
        let mut s = settings(&model);
        s.spacing_mm = 40.0;
        let names = crate::siemens_axis_names(model.machine());
        let absolute =
            crate::siemens_eec_table(&model, &coeffs, 'X', s.spacing_mm, &s.hold_q, &names)
                .unwrap();
        let reference_mm = absolute.positions[1] + 13.0;
        let at = absolute.value_at(reference_mm);
        assert!(
            at.abs() > 1e-4,
            "an error to remove at the reference: {at} mm"
        );
        s.reference_mm = reference_mm;
        let path = dir.path().join("eec.ini");
        let what = Compensation::SiemensEec { axis: Some('X') };
        write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let read = crate::read_siemens_eec(&path, &s.siemens).unwrap();
        assert_eq!(read[0].positions, absolute.positions);
        for (v, a) in read[0].values.iter().zip(&absolute.values) {
            assert!((v - (a - at)).abs() <= 1e-6, "{v} vs {a} − {at}");
        }
        assert!(read[0].value_at(reference_mm).abs() <= 1e-6);
        let text = std::fs::read_to_string(&path).unwrap();
        let said = format!(
            "$AA_ENC_COMP[0,N,X1] zero at {reference_mm} mm ({:+.3} um removed)",
            at * 1e3
        );
        assert!(text.contains(&said), "{said}\n{text}");
    }

    #[test]
    fn a_five_axis_machine_gets_its_swivel_data() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("CAFYXZ");
        let path = dir.path().join("carr.mpf");
        let exported = write_compensation(
            &model,
            &coeffs,
            &path,
            Compensation::SiemensCarr,
            &settings(&model),
        )
        .unwrap();
        let data = crate::read_carr(&path).unwrap();
        assert_eq!(
            exported.written,
            Written::SiemensCarr {
                kind: data.kind.letter(),
                not_representable: 0
            }
        );
        assert_eq!(exported.card.quantity, crate::Quantity::Geometry);
    }

    #[test]
    fn a_fanuc_record_holds_every_axis_numbered_x_y_z_then_rotary() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("CAFYXZ");
        let s = settings(&model);
        let path = dir.path().join("pitch.txt");
        let what = Compensation::Fanuc { axis: None };
        let exported = write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let axes: Vec<crate::FanucAxis> = [('X', false), ('Y', false), ('Z', false)]
            .into_iter()
            .chain([('A', true), ('C', true)])
            .zip(1..)
            .map(|((letter, rotary), n)| crate::FanucAxis::new(letter, n, rotary))
            .collect();
        let tables = crate::read_fanuc_parameters(&path, &s.fanuc, &axes).unwrap();
        assert_eq!(tables.len(), 5);
        let (values, _) = exported.beside[0].clone();
        assert_card_in(&values, "# values are");
        let Written::ControlTables { tables: n, .. } = exported.written else {
            panic!("{:?}", exported.written)
        };
        assert_eq!(n, 5);
        // One axis alone keeps its number.
        let what = Compensation::Fanuc { axis: Some('Z') };
        write_compensation(&model, &coeffs, &path, what, &s).unwrap();
        let z = crate::read_fanuc_parameters(&path, &s.fanuc, &axes[2..3]).unwrap();
        assert_eq!(z[0].axis.number, 3);
    }

    #[test]
    fn heidenhain_files_come_as_a_set_with_their_card() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let s = settings(&model);
        let path = dir.path().join("CONFIG.CMA");
        let exported =
            write_compensation(&model, &coeffs, &path, Compensation::HeidenhainCom, &s).unwrap();
        let set = crate::read_heidenhain_com(&path).unwrap();
        let names: Vec<String> = exported
            .beside
            .iter()
            .map(|(p, _)| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["X.COM", "Y.COM", "Z.COM", "CONFIG.CMA.card.txt"]);
        assert_eq!(
            exported.written,
            Written::ControlFiles {
                what: "Heidenhain .CMA and .COM tables",
                files: 5,
                tables: set.tables.len(),
                points: set.total_points()
            }
        );

        let (five_axis, coeffs) = self::model("CAFYXZ");
        let path = dir.path().join("KC.TAB");
        let what = Compensation::HeidenhainKinematicsComp;
        let s = settings(&five_axis);
        let exported = write_compensation(&five_axis, &coeffs, &path, what, &s).unwrap();
        let kc = crate::read_kinematics_comp(&path).unwrap();
        let Written::ControlFiles { tables, .. } = exported.written else {
            panic!("{:?}", exported.written)
        };
        assert_eq!(tables, kc.tables.len());
        assert!(
            exported
                .beside
                .iter()
                .any(|(p, _)| p.ends_with("KC.TAB.card.txt"))
        );
    }

    #[test]
    fn a_machine_without_table_table_kinematics_has_no_pivots_and_nothing_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("ZFYX");
        let path = dir.path().join("pivots.hal");
        let w = write_compensation(
            &model,
            &coeffs,
            &path,
            Compensation::TrtPivots,
            &settings(&model),
        );
        assert!(w.is_err(), "{w:?}");
        assert!(!path.exists());
    }

    #[test]
    fn a_rotary_axis_has_no_pitch_table() {
        let dir = tempfile::tempdir().unwrap();
        let (model, coeffs) = model("CAFYXZ");
        let what = Compensation::PitchTable {
            axis: 'C',
            format: PitchFormat::Csv,
        };
        let path = dir.path().join("c.csv");
        let e = write_compensation(&model, &coeffs, &path, what, &settings(&model)).unwrap_err();
        assert!(
            matches!(e, CompensateError::NotLinear { letter: 'C' }),
            "{e}"
        );
        assert!(!path.exists());
    }
}
