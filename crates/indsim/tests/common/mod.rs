//! How the agreement tests read a session this crate wrote with mtcal's own code: the plugins'
//! set-ups, the truth's model and parameter files, each run's recorded and noise-free files.

#![allow(dead_code)] // each test binary uses a different part

use mtcal_instrument::{Setup, SetupContext};
use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use mtcal_session::{RunColumns, RunSpec, RunTable, Session, read_run};
use std::path::Path;

/// mtcal's set-up of `instrument` from its table, through the plugin's own loader.
pub fn load_mtcal_setup(
    instrument: &str,
    table: &toml::Table,
    machine: &Machine,
) -> Box<dyn Setup> {
    let ctx = SetupContext { machine };
    let r = match instrument {
        "rtest" => mtcal_rtest::load_setup(table, &ctx),
        "ballbar" => mtcal_ballbar::load_setup(table, &ctx),
        "laser" => mtcal_laser::load_setup(table, &ctx),
        "tracer" => mtcal_tracer::load_setup(table, &ctx),
        "displacement" => mtcal_displacement::load_setup(table, &ctx),
        "artefact" => mtcal_artefact::load_setup(table, &ctx),
        other => panic!("no plugin {other}"),
    };
    r.unwrap_or_else(|e| panic!("mtcal rejects the {instrument} set-up {table:?}: {e}"))
}

/// mtcal's model of the truth in `dir/truth` (its error configuration) on machine `m`, and the
/// truth's coefficients (its parameter file).
pub fn truth_model(dir: &Path, m: &Machine) -> (MachineModel, Vec<f64>) {
    let errors_path = dir.join("truth/errors.toml");
    let config = mtcal_machine::config::parse_config(
        &std::fs::read_to_string(&errors_path).unwrap(),
        &errors_path,
        m,
    )
    .unwrap();
    let model = MachineModel::new(m.clone(), &config).unwrap();
    let params_path = dir.join("truth/params.toml");
    let coeffs = mtcal_machine::params::parse_params(
        &std::fs::read_to_string(&params_path).unwrap(),
        &params_path,
        model.errors(),
    )
    .unwrap();
    (model, coeffs)
}

/// One run of the session in `dir` as mtcal reads it.
pub struct MtcalRun {
    pub setup: Box<dyn Setup>,
    /// The run file.
    pub recorded: RunTable,
    /// The noise-free copy this crate keeps in `truth/`.
    pub clean: RunTable,
}

/// `run` of `session` (in `dir`) on machine `m`, read with its plugin's set-up and columns.
pub fn read_mtcal_run(dir: &Path, session: &Session, run: &RunSpec, m: &Machine) -> MtcalRun {
    let setup = load_mtcal_setup(&run.instrument, session.setup_of(run), m);
    let letters: Vec<char> = m.letters().chars().collect();
    let names: Vec<&str> = setup.channels().iter().map(|c| c.name.as_str()).collect();
    let cols = RunColumns {
        axes: &letters,
        readings: &names,
        readings_optional: false,
        labels: setup.label_columns(),
    };
    let recorded = read_run(&run.file, &cols).unwrap();
    let clean = read_run(&dir.join("truth").join(&run.file_as_written), &cols).unwrap();
    MtcalRun {
        setup,
        recorded,
        clean,
    }
}

/// Every sample's axis positions of `table` in SI (m, rad), machine order.
pub fn positions_si(table: &RunTable, m: &Machine) -> Vec<Vec<f64>> {
    (0..table.len())
        .map(|k| {
            table
                .q_row(k)
                .iter()
                .zip(m.axes())
                .map(|(&v, a)| match a.kind() {
                    AxisKind::Linear => v * 1e-3,
                    AxisKind::Rotary => v.to_radians(),
                })
                .collect()
        })
        .collect()
}
