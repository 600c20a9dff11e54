//! A simulated session held in memory is the session its folder holds: the run tables are what
//! reading the written run files gives back, and `Study::from_parts` on the session in memory
//! gives, bit for bit, the study `Study::load` gives on the written folder — and so the same
//! identification. Checked on the shipped example plans (R-test, ball-bar, laser tracer and
//! laser with the air logged, validation runs, planted effects, a context programme) and on a
//! hole plate (label columns) written with few decimals and a validation run without readings.

use mtcal_identify::Study;
use mtcal_session::{Location, RunColumns, RunTable, Session, read_run};
use mtcal_simulate::{Plan, simulate_session};
use mtcal_solve::{Options, Silent};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The plan at `plan` simulated in memory for the folder `out`, written there: the study from
/// memory, the study loaded from the folder, the tables held in memory.
fn both_ways(plan: &Path, out: &Path) -> (Study, Study, Vec<RunTable>) {
    let plan = Plan::read(plan).unwrap();
    let machine = plan.machine().unwrap();
    let session = simulate_session(&plan, machine, &[], out).unwrap();
    let written = session.write().unwrap();
    assert_eq!(written.samples, session.samples());
    let tables: Vec<RunTable> = session.runs.iter().map(|r| r.table.clone()).collect();
    let (session, machine, parts) = session.into_parts();
    let memory = Study::from_parts(session, machine, parts).unwrap();
    let disk = Study::load(out).unwrap();
    (memory, disk, tables)
}

/// `session` without what only a manifest's text has: where things are written in it.
fn without_locations(session: &Session) -> Session {
    let nowhere = Location {
        file: PathBuf::new(),
        line: 0,
        column: 0,
    };
    let mut s = session.clone();
    s.machine_at = nowhere.clone();
    s.identify_at.clear();
    s.setup_at.clear();
    for r in &mut s.runs {
        r.location = nowhere.clone();
    }
    s
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Every run table held in memory is what reading its written file gives.
fn assert_tables_read_back(study: &Study, tables: &[RunTable]) {
    let axes: Vec<char> = study.model.machine().letters().chars().collect();
    for (run, table) in study.runs.iter().zip(tables) {
        let setup = &study.setups[run.setup].setup;
        let channels: Vec<&str> = setup.channels().iter().map(|c| c.name.as_str()).collect();
        let columns = RunColumns {
            axes: &axes,
            readings: &channels,
            readings_optional: !run.fit,
            labels: setup.label_columns(),
        };
        let read = read_run(&table.path, &columns).unwrap();
        assert_eq!(&read, table, "{}", run.name);
    }
}

/// The two studies hold the same session, machine, set-ups and samples, bit for bit.
fn assert_same_study(a: &Study, b: &Study) {
    assert_eq!(without_locations(&a.session), without_locations(&b.session));
    assert_eq!(a.machine.source, b.machine.source);
    assert_eq!(a.machine.config_source, b.machine.config_source);
    assert_eq!(
        format!("{:?}", (&a.machine.machine, &a.machine.config)),
        format!("{:?}", (&b.machine.machine, &b.machine.config))
    );
    assert_eq!(bits(&a.base_coeffs), bits(&b.base_coeffs));
    assert_eq!((a.layout(), &a.coeff_labels), (b.layout(), &b.coeff_labels));
    assert_eq!(a.effects().len(), b.effects().len());
    assert_eq!(a.setups.len(), b.setups.len());
    for (s, t) in a.setups.iter().zip(b.setups.iter()) {
        assert_eq!(
            (&s.name, s.plugin.name, &s.table),
            (&t.name, t.plugin.name, &t.table)
        );
    }
    assert_eq!(a.runs.len(), b.runs.len());
    for (r, s) in a.runs.iter().zip(b.runs.iter()) {
        assert_eq!((&r.name, r.fit, r.setup), (&s.name, s.fit, s.setup));
        assert_eq!(
            format!("{:?}", r.file),
            format!("{:?}", s.file),
            "{}",
            r.name
        );
        assert_eq!(bits(&r.t.raw_vec()), bits(&s.t.raw_vec()), "{}", r.name);
        assert_eq!(bits(&r.q.raw_row_major()), bits(&s.q.raw_row_major()));
        assert_eq!(bits(&r.q.to_row_major()), bits(&s.q.to_row_major()));
        let readings = |r: &mtcal_identify::study::RunSlot| {
            r.readings.as_ref().map(|c| bits(&c.to_row_major()))
        };
        assert_eq!(readings(r), readings(s), "{}", r.name);
        assert_eq!(r.context.len(), s.context.len());
        for ((n, c), (m, d)) in r.context.iter().zip(&s.context) {
            assert_eq!((n, bits(&c.raw_vec())), (m, bits(&d.raw_vec())));
        }
        assert_eq!(r.labels, s.labels, "{}", r.name);
    }
}

/// The identifications of the two studies, bit for bit.
fn assert_same_identification(a: &Study, b: &Study) {
    let options = Options::default();
    let (id_a, sol_a) = mtcal_identify::identify_with_solution(a, &options, &mut Silent).unwrap();
    let (id_b, sol_b) = mtcal_identify::identify_with_solution(b, &options, &mut Silent).unwrap();
    assert_eq!(bits(&sol_a.x), bits(&sol_b.x));
    assert_eq!(
        mtcal_identify::report::IdentifyJson::of(&id_a).to_json(),
        mtcal_identify::report::IdentifyJson::of(&id_b).to_json()
    );
}

#[test]
fn the_example_sessions_in_memory_are_the_written_ones() {
    for example in ["five-axis", "five-axis-warm", "three-axis"] {
        let dir = tempfile::tempdir().unwrap();
        let plan = repo().join("examples").join(example).join("plan.toml");
        let (memory, disk, tables) = both_ways(&plan, &dir.path().join("s"));
        assert_tables_read_back(&disk, &tables);
        assert_same_study(&memory, &disk);
        if example == "five-axis" {
            assert_same_identification(&memory, &disk);
        }
    }
}

/// A 3 × 3 hole plate on the three-axis machine, probed at two placements (one only
/// validated, written without readings), files with few decimals.
const PLATE_PLAN: &str = r#"machine = "MACHINE"
seed = 5

[record]
positions = 4
readings = 4
time = 3

[identify]
parameters = ["EC0Y"]

[setup.plate]
sigma_um = 0.5
[setup.plate.features]
h00 = [-50.0, -50.0]
h01 = [-50.0, 0.0]
h02 = [-50.0, 50.2]
h10 = [0.0, -50.0]
h11 = [0.1, 0.0]
h12 = [0.0, 50.0]
h20 = [50.0, -50.0]
h21 = [50.0, 0.3]
h22 = [50.0, 50.0]
[setup.plate.placements]
A = { origin = [0.0, 0.0, -300.0] }
B = { origin = [0.0, 0.0, -300.0], rotation_deg = 90.0 }

[[run]]
name = "plate-A"
instrument = "artefact"
setup = "plate"
noise = 0.0005
path = { placements = ["A"] }

[[run]]
name = "plate-B"
instrument = "artefact"
setup = "plate"
use = "validate"
readings = false
path = { placements = ["B"] }
"#;

#[test]
fn a_plate_with_labels_and_a_run_without_readings_in_memory_is_the_written_one() {
    let dir = tempfile::tempdir().unwrap();
    let machine = repo().join("machines/mcv754-zfyx.urdf");
    let plan = PLATE_PLAN.replace("MACHINE", &machine.display().to_string().replace('\\', "/"));
    std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
    let (memory, disk, tables) = both_ways(&dir.path().join("plan.toml"), &dir.path().join("s"));
    assert!(tables[0].labels.iter().all(|(_, v)| !v.is_empty()));
    assert!(tables[1].values.is_none());
    assert_tables_read_back(&disk, &tables);
    assert_same_study(&memory, &disk);
}

#[test]
fn a_session_in_memory_reads_no_run_file_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let plan = Plan::read(&repo().join("examples/five-axis/plan.toml")).unwrap();
    let out = dir.path().join("never-written");
    let session = simulate_session(&plan, plan.machine().unwrap(), &[], &out).unwrap();
    let (session, machine, tables) = session.into_parts();
    let study = Study::from_parts(session, machine, tables).unwrap();
    assert!(!out.exists(), "nothing is written");
    assert_eq!(study.runs.len(), 10);
    assert!(study.runs.iter().all(|r| r.file.path.starts_with(&out)));
}

#[test]
fn from_parts_refuses_tables_that_do_not_match_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let plan = Plan::read(&repo().join("examples/five-axis/plan.toml")).unwrap();
    let out = dir.path().join("s");
    let parts = || {
        simulate_session(&plan, plan.machine().unwrap(), &[], &out)
            .unwrap()
            .into_parts()
    };
    let (session, machine, mut tables) = parts();
    tables.pop();
    let e = Study::from_parts(session, machine, tables).unwrap_err();
    assert!(
        e.to_string()
            .ends_with("9 run tables for the manifest's 10 runs: one per run, in its order"),
        "{e}"
    );
    let (session, machine, mut tables) = parts();
    tables[0].positions[3] = f64::NAN;
    let e = Study::from_parts(session, machine, tables).unwrap_err();
    let file = out.join("rtest-xyc-a0.csv");
    assert_eq!(
        e.to_string(),
        format!("{}: `positions` holds NaN at index 3", file.display())
    );
    let (session, machine, mut tables) = parts();
    tables[0].readings.pop();
    let e = Study::from_parts(session, machine, tables).unwrap_err();
    assert!(
        e.to_string().contains("the table's reading columns are"),
        "{e}"
    );
}
