//! On every shipped five-axis machine: R-test runs (the plugin's own fixtures: one rotary axis
//! swept, the other held at several tilts) identify the rotary location errors and the
//! squareness errors, and the identified model predicts a run it never saw within the noise.

use mtcal_conformance::shipped_machines;
use mtcal_identify::identify_session;
use mtcal_instrument::At;
use mtcal_kinematics::model::Role;
use mtcal_kinematics::{AxisKind, MachineModel};
use mtcal_session::{Manifest, ManifestRun, RunTable, RunUse, SetupRef, write_run, write_session};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const NOISE_UM: f64 = 0.5;

#[test]
fn validation_runs_are_predicted_within_the_noise_on_every_five_axis_machine() {
    check_every_machine(NOISE_UM);
}

#[test]
fn noise_free_validation_runs_are_predicted_exactly_on_every_five_axis_machine() {
    check_every_machine(0.0);
}

fn check_every_machine(noise_um: f64) {
    let rtest = mtcal_instrument::find("rtest").expect("rtest registered");
    let mut checked = 0;
    for (name, machine) in shipped_machines() {
        let rotary = machine
            .axes()
            .iter()
            .filter(|a| a.kind() == AxisKind::Rotary)
            .count();
        if rotary != 2 {
            continue;
        }
        let config = mtcal_machine::config::default_config(&machine);
        let model = MachineModel::new(machine.clone(), &config).unwrap();
        // Truth: location and squareness errors of about 10 µm / 10 µrad, the rest zero.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(checked as u64 + 5);
        let normal = Normal::new(0.0, 10e-6).unwrap();
        let mut truth = vec![0.0; model.n_coeffs()];
        let mut names = Vec::new();
        for p in model.errors().params() {
            if matches!(p.role, Role::Location { .. }) {
                truth[p.offset] = normal.sample(&mut rng);
                names.push(toml::Value::String(p.name.to_string()));
            }
        }
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("machine.urdf"),
            mtcal_machine::urdf::write_urdf(&machine, None),
        )
        .unwrap();
        let mut ws = model.workspace();
        let mut runs = Vec::new();
        let seeds = 0..7u64;
        for seed in seeds.clone() {
            let fixture = (rtest.fixture)(&machine, seed).expect("rtest fits a five-axis machine");
            let mut table = fixture.setup.clone();
            table.insert("ball_free".into(), false.into());
            table.insert("tool_length_free".into(), false.into());
            if table.get("head").and_then(|h| h.as_str()) == Some("three-sensor") {
                table.insert("sensor_geometry_free".into(), false.into());
            }
            let ctx = mtcal_instrument::SetupContext { machine: &machine };
            let setup = (rtest.load_setup)(&table, &ctx).unwrap();
            let nch = setup.channels().len();
            let mut pred = vec![0.0; nch];
            let mut values = Vec::new();
            let mut positions = Vec::new();
            let mut t = Vec::new();
            let nuis = vec![0.0; setup.nuisance().len()];
            for (i, q) in fixture.poses.iter().enumerate() {
                let pose = model.tool_pose(q, &truth, &mut ws);
                let at = At {
                    q,
                    t: i as f64,
                    w_t_t: &pose,
                    label: 0,
                };
                setup.predict(&at, &nuis, &mut pred);
                for p in &pred {
                    let e = if noise_um > 0.0 {
                        Normal::new(0.0, noise_um * 1e-6).unwrap().sample(&mut rng)
                    } else {
                        0.0
                    };
                    values.push((p + e) * 1e6);
                }
                for (v, ax) in q.iter().zip(machine.axes()) {
                    positions.push(ax.kind().to_file(*v));
                }
                t.push(seed as f64 * 1000.0 + i as f64);
            }
            let run = format!("run{seed}");
            let file = dir.path().join(format!("{run}.csv"));
            let axes = machine
                .axes()
                .iter()
                .map(|a| a.letter().as_char())
                .collect();
            let readings = setup.channels().iter().map(|c| c.name.clone()).collect();
            write_run(
                &file,
                &RunTable {
                    path: file.clone(),
                    columns: Vec::new(),
                    t,
                    axes,
                    positions,
                    readings,
                    values: Some(values),
                    context: Vec::new(),
                    labels: Vec::new(),
                },
            )
            .unwrap();
            runs.push(ManifestRun {
                name: run.clone(),
                instrument: "rtest".into(),
                file: format!("{run}.csv"),
                use_: if seed == 6 {
                    RunUse::Validate
                } else {
                    RunUse::Fit
                },
                setup: SetupRef::Own(table),
                extra: toml::Table::new(),
            });
        }
        let mut identify = toml::Table::new();
        identify.insert("parameters".into(), toml::Value::Array(names));
        write_session(
            dir.path(),
            &Manifest {
                machine: "machine.urdf".into(),
                setups: Default::default(),
                runs,
                identify,
            },
        )
        .unwrap();
        let (_, id) = identify_session(dir.path()).unwrap();
        assert_eq!(id.validation.len(), 1, "{name}");
        let v = id.validation[0].rms_um;
        let bound = if noise_um > 0.0 { 1.5 * noise_um } else { 1e-6 };
        assert!(
            v < bound,
            "{name}: validation run predicted to {v} um rms with {noise_um} um noise; \
             unidentifiable: {:?}\n{}",
            id.unidentifiable,
            id.summary()
        );
        assert!(
            id.fit.rms_um < 1.2 * noise_um + 1e-6,
            "{name}: fit rms {}",
            id.fit.rms_um
        );
        checked += 1;
    }
    assert_eq!(checked, 5, "five shipped five-axis machines");
}
