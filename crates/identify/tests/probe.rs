//! Scratch probe (not to commit).
use mtcal_identify::search::{SearchOptions, search};
use mtcal_identify::{Study, base};
use mtcal_indsim::effects::{Effect, HeatSource, Programme, TemperatureProgramme};
use mtcal_indsim::{Campaign, JointKind, Machine, Realism, Truth, shipped_machine};
use mtcal_plugins as _;
use mtcal_solve::Options;
use rand::SeedableRng;
use std::path::Path;

fn bare(dir: &Path) {
    let manifest = dir.join("session.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let line = text.lines().find(|l| l.starts_with("machine")).unwrap();
    let rel = line.split('"').nth(1).unwrap();
    std::fs::copy(dir.join(rel), dir.join("machine.urdf")).unwrap();
    let text = text.replace(line, "machine = \"machine.urdf\"");
    std::fs::write(&manifest, text).unwrap();
}

fn effects(name: &str) -> Vec<Effect> {
    let mut out = Vec::new();
    for part in name.split('+') {
        out.push(match part {
            "drift" => Effect::Thermal {
                direction: [0.0, 0.0, 1.0],
                sources: vec![
                    HeatSource {
                        gain: 8e-6,
                        tau_s: 600.0,
                        power: Programme::steps(&[(0.0, 1.0), (1200.0, 0.0)]),
                    },
                    HeatSource {
                        gain: 4e-6,
                        tau_s: 2400.0,
                        power: Programme::constant(1.0),
                    },
                ],
            },
            "smalldrift" => Effect::Thermal {
                direction: [0.0, 0.0, 1.0],
                sources: vec![HeatSource {
                    gain: 0.8e-6,
                    tau_s: 900.0,
                    power: Programme::constant(1.0),
                }],
            },
            "backlash" => Effect::Backlash {
                axis: 'X',
                lost_motion: 3e-6,
            },
            "screw" => Effect::ScrewError {
                axis: 'X',
                pitch: 7e-3,
                harmonics: vec![(1, 1e-6, 0.3), (2, 0.4e-6, 1.0), (3, 0.2e-6, 2.0)],
            },
            "scale" => Effect::ThermalScale {
                axis: 'X',
                ppm_per_k: 11.5,
                reference: 0.0,
                temperature: TemperatureProgramme {
                    ambient_c: 20.0,
                    drift_k_per_h: 0.0,
                    rises: vec![HeatSource {
                        gain: 2.0,
                        tau_s: 900.0,
                        power: Programme::constant(1.0),
                    }],
                },
                column: "T_xscale".into(),
            },
            "twist" => Effect::Twist { per_m2: 2.2e-4 },
            "sag" => Effect::Sag {
                axis: 'X',
                direction: 'Z',
                per_m2: 1.33e-4,
            },
            "bar" => Effect::BallBarThermal {
                setup: "bar1".into(),
                ppm_per_k: 11.5,
                temperature: TemperatureProgramme {
                    ambient_c: 20.0,
                    drift_k_per_h: 0.0,
                    rises: vec![HeatSource {
                        gain: 1.5,
                        tau_s: 1200.0,
                        power: Programme::constant(1.0),
                    }],
                },
                column: Some("T_bar".into()),
            },
            "clean" => continue,
            other => panic!("unknown {other}"),
        });
    }
    out
}

fn run(name: &str, seed: u64) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    let machine = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let mut truth = Truth::random(
        &machine,
        &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed),
        1.0,
    );
    for (axis, joint) in truth.axes.iter_mut().zip(&machine.joints) {
        if joint.kind == JointKind::Rotary {
            axis.component = [[0.0; 4]; 6];
        }
    }
    let realism = Realism::realistic(1000 + seed);
    Campaign::trunnion_thermal_check(&dir, &truth, &effects(name), &realism).unwrap();
    bare(&dir);
    let t0 = std::time::Instant::now();
    let (study, _b) =
        base::identifiable_study(Study::load(&dir).unwrap(), &Options::default()).unwrap();
    let result = search(study, &SearchOptions::default()).unwrap();
    eprintln!(
        "=== {name} seed {seed} ({:.1} s)\n{}",
        t0.elapsed().as_secs_f64(),
        result
            .initial
            .summary()
            .lines()
            .take(4)
            .collect::<Vec<_>>()
            .join("\n")
    );
    eprintln!("{}", result.identification.search_summary());
    for v in &result.identification.validation {
        eprintln!(
            "validation {} rms {:.3}",
            v.name,
            v.channels.iter().map(|c| c.rms).fold(0.0, f64::max)
        );
    }
}

#[test]
fn probe() {
    let which = std::env::var("PROBE").unwrap_or_default();
    let seed = std::env::var("SEED").map_or(3, |s| s.parse().unwrap());
    for name in which.split(',').filter(|s| !s.is_empty()) {
        run(name, seed);
    }
}

#[test]
fn write_only() {
    let name = std::env::var("PROBE").unwrap_or_default();
    let seed = std::env::var("SEED").map_or(3, |s| s.parse().unwrap());
    let dir = std::path::PathBuf::from(std::env::var("OUT").unwrap());
    let machine = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let mut truth = Truth::random(
        &machine,
        &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed),
        1.0,
    );
    for (axis, joint) in truth.axes.iter_mut().zip(&machine.joints) {
        if joint.kind == JointKind::Rotary {
            axis.component = [[0.0; 4]; 6];
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    Campaign::trunnion_thermal_check(
        &dir,
        &truth,
        &effects(&name),
        &Realism::realistic(1000 + seed),
    )
    .unwrap();
    bare(&dir);
}
