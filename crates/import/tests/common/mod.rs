//! What the import tests share: the three-axis example machine, a run read back, the fit.

#![allow(dead_code)]

use mtcal_import::{Format, ImportOptions, Imported};
use std::path::{Path, PathBuf};

/// The three-axis example's machine (`examples/three-axis/machine/zfyx.urdf`).
pub fn three_axis_machine() -> PathBuf {
    mtcal_testkit::repo().join("examples/three-axis/machine/zfyx.urdf")
}

/// Imports `file` into a new session `dir` on the three-axis example machine, Z held at
/// −200 mm (inside its stroke).
pub fn import_new(format: Format, file: &Path, dir: &Path, axis: Option<char>) -> Imported {
    let machine = three_axis_machine();
    let machine = machine.to_str().unwrap();
    mtcal_import::import(&ImportOptions {
        format,
        file,
        session: dir,
        machine: Some(machine),
        axis,
        name: None,
        hold: Some("Z=-200"),
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

/// The imported run's commanded positions along `axis` (mm) and readings `d` (µm).
pub fn read_back(imported: &Imported) -> (Vec<f64>, Vec<f64>) {
    let axes = ['X', 'Y', 'Z'];
    let table = mtcal_session::read_run(
        &imported.run_file,
        &mtcal_session::RunColumns {
            axes: &axes,
            readings: &["d"],
            readings_optional: false,
            labels: &[],
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let k = axes.iter().position(|&a| a == imported.axis).unwrap();
    let travel = (0..table.len()).map(|i| table.q_row(i)[k]).collect();
    (travel, table.values.clone().unwrap())
}

/// Identifies the session in `dir`; returns the run's fit RMS (µm) and its metrics by name.
pub fn identify(dir: &Path) -> (f64, Vec<(String, f64)>) {
    let (_, id) = mtcal_identify::identify_session(dir).unwrap_or_else(|e| panic!("{e}"));
    let run = &id.fit.runs[0];
    let metrics = run
        .metrics
        .iter()
        .map(|m| (m.name.clone(), m.value))
        .collect();
    (run.rms_um, metrics)
}
