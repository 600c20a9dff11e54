//! A control format is its own module and one registration line (ARCHITECTURE.md, "Where to
//! add things"): this file defines a format of its own, registers it with one
//! `inventory::submit!`, and the library finds it by name, lists it, writes and checks its
//! file through the same `Request` the command line uses, and refuses what it does not take.
//! Had a format needed any change outside its own file (an enum variant, a field, a name in
//! a list), this test could not register one.

use mtcal_compensate::{
    Checked, CompensateError, ControlFormat, ControlOption, ConventionCard, Exported, Quantity,
    Registered, Request, Settings, Written, control_formats, find_format, pitch_table,
};
use mtcal_kinematics::{Machine, MachineModel};
use std::path::Path;

/// A stub control: one line per linear axis, `letter compensation_um` at its lower end.
struct StubFormat;

impl ControlFormat for StubFormat {
    fn name(&self) -> &'static str {
        "stub-control"
    }

    fn about(&self) -> &'static str {
        "a test's own control: one line per linear axis (no --axis)"
    }

    fn options(&self) -> &'static [ControlOption] {
        &[ControlOption {
            key: "decimals",
            about: "decimals of each value, default 3",
        }]
    }

    fn accepts_axis(&self, axis: Option<char>) -> Result<(), CompensateError> {
        match axis {
            Some(a) => Err(CompensateError::AxisUse(format!(
                "--format stub-control is of every axis; drop --axis {a}"
            ))),
            None => Ok(()),
        }
    }

    fn write(
        &self,
        model: &MachineModel,
        coeffs: &[f64],
        path: &Path,
        _: Option<char>,
        settings: &Settings,
    ) -> Result<Exported, CompensateError> {
        let decimals: usize = settings.control_options.parsed("decimals")?.unwrap_or(3);
        let machine = model.machine();
        let mut text = String::new();
        for axis in ['X', 'Y', 'Z'] {
            let table = pitch_table(model, coeffs, axis, settings.spacing_mm, &settings.hold_q)?;
            text.push_str(&format!("{axis} {:.decimals$}\n", table.forward_um[0]));
        }
        std::fs::write(path, &text).map_err(|cause| CompensateError::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        let card = ConventionCard {
            quantity: Quantity::Correction,
            ..ConventionCard::mtcal_parameters(machine)
        };
        Ok(Exported {
            written: Written::ControlTables {
                file: "stub control file",
                tables: 1,
                points: text.lines().count(),
            },
            card,
            beside: Vec::new(),
        })
    }

    fn check(
        &self,
        _: &Machine,
        path: &Path,
        _: Option<char>,
        _: &Settings,
    ) -> Result<Checked, CompensateError> {
        let text = std::fs::read_to_string(path).map_err(|cause| CompensateError::Io {
            path: path.to_path_buf(),
            cause,
        })?;
        Ok(Checked {
            tables: 1,
            points: text.lines().count(),
        })
    }
}

inventory::submit!(Registered(&StubFormat));

/// The three-axis topology's model with small errors everywhere.
fn model() -> (MachineModel, Vec<f64>) {
    use mtcal_machine::topology::Reading;
    let m = mtcal_machine::load_machine("ZFYX", Reading::FromWorkpiece).unwrap();
    let model = MachineModel::new(m.machine, &m.config).unwrap();
    let coeffs = (0..model.n_coeffs())
        .map(|i| 1e-6 * (i as f64 * 0.7).sin())
        .collect();
    (model, coeffs)
}

#[test]
fn a_format_registered_in_a_test_is_found_listed_written_and_checked() {
    let format = find_format("stub-control").unwrap();
    assert_eq!(format.about(), StubFormat.about());
    let names: Vec<&str> = control_formats().iter().map(|f| f.name()).collect();
    assert!(names.contains(&"stub-control"), "{names:?}");
    assert!(names.is_sorted(), "{names:?}");

    let dir = tempfile::tempdir().unwrap();
    let (model, coeffs) = model();
    let mut settings = Settings::new(model.machine(), 50.0, 10.0);
    let path = dir.path().join("stub.txt");
    let request = Request::new("stub-control", None).unwrap();
    let exported = request.write(&model, &coeffs, &path, &settings).unwrap();
    assert_eq!(
        exported.written.to_string(),
        "stub control file: 1 tables, 3 points"
    );
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.starts_with("X ") && text.lines().count() == 3,
        "{text}"
    );
    let checked = request.check(model.machine(), &path, &settings).unwrap();
    assert_eq!(checked.points, 3);

    // Its own option, read and checked by the format.
    settings.control_options.set("decimals", "1");
    request.write(&model, &coeffs, &path, &settings).unwrap();
    let one_decimal = std::fs::read_to_string(&path).unwrap();
    assert!(
        one_decimal
            .lines()
            .all(|l| l.split('.').nth(1).is_some_and(|d| d.len() == 1)),
        "{one_decimal}"
    );
    settings.control_options.set("decimals", "many");
    let e = request
        .write(&model, &coeffs, &path, &settings)
        .unwrap_err()
        .to_string();
    assert!(e.contains("decimals=many"), "{e}");
}

#[test]
fn what_a_format_does_not_take_is_refused_by_name() {
    let e = Request::new("stub-contorl", None).unwrap_err().to_string();
    assert!(e.contains("`stub-contorl`"), "{e}");
    for name in control_formats().iter().map(|f| f.name()) {
        assert!(e.contains(name), "{name} not in: {e}");
    }
    let e = Request::new("stub-control", Some('X'))
        .unwrap_err()
        .to_string();
    assert!(e.contains("drop --axis X"), "{e}");

    let dir = tempfile::tempdir().unwrap();
    let (model, coeffs) = model();
    let mut settings = Settings::new(model.machine(), 50.0, 10.0);
    settings.control_options.set("colour", "blue");
    let path = dir.path().join("stub.txt");
    let request = Request::new("stub-control", None).unwrap();
    let e = request
        .write(&model, &coeffs, &path, &settings)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`colour`") && e.contains("decimals"), "{e}");
    assert!(!path.exists());
    // A built-in format takes no option at all and says so.
    let e = Request::new("csv", None)
        .unwrap()
        .write(&model, &coeffs, &path, &settings)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`colour`"), "{e}");
}

/// Every built-in format is registered under the name users type.
#[test]
fn the_built_in_formats_are_registered() {
    let names: Vec<&str> = control_formats().iter().map(|f| f.name()).collect();
    for name in [
        "csv",
        "etalon",
        "fanuc",
        "heidenhain-com",
        "heidenhain-kinematicscomp",
        "isg",
        "linuxcnc",
        "linuxcnc-trt",
        "siemens-carr",
        "siemens-cec",
        "siemens-eec",
    ] {
        assert!(names.contains(&name), "{name} not in {names:?}");
    }
}
