//! The effects of the volumetric thermal test by hand, on the unit tests' `SIMPLE` machine:
//! the tool point at machine `(0, Y, Z + 0.5 m)`, the workpiece frame's axes the machine's
//! (X moves the table), so a displacement of the tool relative to the workpiece reads
//! directly in the workpiece frame.

use nalgebra::{Matrix3, Vector3};

use super::*;
use crate::machine::{axis_angle, rotation_of, translation_of};
use crate::tests::SIMPLE;

const UM: f64 = 1e-6;

fn simple() -> Machine {
    Machine::from_urdf_text(SIMPLE).unwrap()
}

/// A temperature stepped up by `rise_k` from the start (a node of 1 ms).
fn stepped(rise_k: f64) -> TemperatureProgramme {
    TemperatureProgramme {
        ambient_c: 20.0,
        drift_k_per_h: 0.0,
        rises: vec![HeatSource {
            gain: rise_k,
            tau_s: 1e-3,
            power: Programme::constant(1.0),
        }],
    }
}

/// The actual tool pose in the workpiece frame at `q`, time `t`, with `effects`, and without.
fn poses(effects: &[Effect], q: &[f64], t: f64) -> (Matrix4<f64>, Matrix4<f64>) {
    let m = simple();
    let truth = Truth::zero(&m);
    let resolved = Resolved::new(&m, &[], effects).unwrap();
    let states = Timeline::new(&resolved).run(&[q.to_vec()], &[t]);
    (
        states[0].tool_in_workpiece(&m, &truth, q),
        m.tool_in_workpiece(q, Some(&truth)),
    )
}

#[test]
fn the_head_turns_about_its_line_by_the_drive_temperature() {
    // θ = 5 µrad/K · 10 K = 50 µrad about +X, the line at y = 0.1, z = 0.9 m.
    let effect = Effect::HeadRotationX {
        pivot_y: 0.1,
        pivot_z: 0.9,
        urad_per_k: 5.0,
        temperature: stepped(10.0),
        column: Some("T_ydrive".into()),
    };
    let theta = 50.0 * UM;
    for q in [[0.0, 0.2, -0.3], [0.15, -0.25, -0.45], [-0.3, 0.0, 0.0]] {
        let (with, without) = poses(std::slice::from_ref(&effect), &q, 100.0);
        // The tool point at machine (0, Y, Z + 0.5): its lever arm from the line.
        let arm = Vector3::new(0.0, q[1] - 0.1, q[2] + 0.5 - 0.9);
        let r = axis_angle(&Vector3::x(), theta);
        let moved = translation_of(&with) - translation_of(&without);
        let exact = (r - Matrix3::identity()) * arm;
        assert!((moved - exact).norm() < 1e-15, "{q:?}: {moved} vs {exact}");
        // First order: Δy = −θ·(p_z − z_line), Δz = θ·(p_y − y_line); a tool point below the
        // line moves towards +Y.
        // (second order: θ²/2 of the arm).
        let first = Vector3::new(0.0, -theta * arm.z, theta * arm.y);
        assert!(
            (moved - first).norm() <= theta * theta * arm.norm(),
            "{moved} vs {first}"
        );
        assert!(moved.y > 0.0);
        // The tool (and a nest on it) tilts by θ about X.
        let tilt = rotation_of(&with) * rotation_of(&without).transpose();
        assert!((tilt - r).norm() < 1e-15, "{tilt}");
    }
    // Before any rise, nothing turns: at t = 0 the temperature is its start.
    let (with, without) = poses(&[effect], &[0.0, 0.2, -0.3], 0.0);
    assert!((with - without).norm() < 1e-15);
    // The lever arm is what differs between points: two points 0.3 m apart in Z move 15 µm
    // apart in Y (50 µrad · 0.3 m).
    let e = Effect::HeadRotationX {
        pivot_y: 0.0,
        pivot_z: 1.0,
        urad_per_k: 5.0,
        temperature: stepped(10.0),
        column: None,
    };
    let dy = |z: f64| {
        let (w, n) = poses(std::slice::from_ref(&e), &[0.0, 0.0, z], 10.0);
        (translation_of(&w) - translation_of(&n)).y
    };
    assert!(((dy(-0.45) - dy(-0.15)) - 15.0 * UM).abs() < 1e-11);
}

#[test]
fn an_ambient_step_shifts_the_tool_uniformly_through_the_structures_node() {
    let effect = Effect::AmbientStep {
        ambient_c: 20.0,
        at_s: 100.0,
        step_k: -4.0,
        tau_s: 50.0,
        shift_per_k: [1.0 * UM, 0.0, 2.0 * UM],
        column: Some("T_air".into()),
    };
    let shift = |q: &[f64], t: f64| {
        let (w, n) = poses(std::slice::from_ref(&effect), q, t);
        translation_of(&w) - translation_of(&n)
    };
    // Before the step nothing; one time constant after it 1 − 1/e of −4 K's shift, the same
    // at every point.
    let x = 1.0 - (-1.0f64).exp();
    let want = Vector3::new(-4.0 * UM * x, 0.0, -8.0 * UM * x);
    for q in [[0.0, 0.0, -0.1], [0.3, -0.2, -0.4]] {
        assert!(shift(&q, 99.0).norm() < 1e-18);
        let got = shift(&q, 150.0);
        assert!((got - want).norm() < 1e-15, "{got} vs {want}");
    }
    // The air sensor steps at once.
    let m = simple();
    let resolved = Resolved::new(&m, &[], &[effect]).unwrap();
    let context = resolved.context("any", &[0.0, 99.9, 100.0, 500.0]);
    assert_eq!(context.len(), 1);
    assert_eq!(context[0].name, "T_air");
    assert!(context[0].sensed);
    assert_eq!(context[0].values, [20.0, 20.0, 16.0, 16.0]);
}

#[test]
fn a_sensor_follows_a_step_with_its_lag_and_moves_nothing() {
    let temperature = TemperatureProgramme {
        ambient_c: 21.0,
        drift_k_per_h: 0.0,
        rises: vec![HeatSource::after_step(1000.0, -4.0, 600.0)],
    };
    let effect = Effect::TemperatureSensor {
        column: "T_znut".into(),
        temperature,
    };
    let m = simple();
    let resolved = Resolved::new(&m, &[], std::slice::from_ref(&effect)).unwrap();
    let context = resolved.context("any", &[500.0, 1000.0, 1600.0]);
    let want = [21.0, 21.0, 21.0 - 4.0 * (1.0 - (-1.0f64).exp())];
    for (got, want) in context[0].values.iter().zip(want) {
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    }
    let (with, without) = poses(&[effect], &[0.1, 0.1, -0.2], 1600.0);
    assert_eq!(with, without);
}

#[test]
fn the_volumetric_effects_are_written_down_and_checked() {
    let m = simple();
    let text = effects_toml(
        &m,
        &[
            Effect::HeadRotationX {
                pivot_y: 0.2,
                pivot_z: 1.1,
                urad_per_k: 3.0,
                temperature: stepped(5.0),
                column: None,
            },
            Effect::AmbientStep {
                ambient_c: 20.0,
                at_s: 14400.0,
                step_k: -4.0,
                tau_s: 2400.0,
                shift_per_k: [0.5e-6, 1.5e-6, 2.5e-6],
                column: Some("T_ambient".into()),
            },
            Effect::TemperatureSensor {
                column: "T_spindle".into(),
                temperature: TemperatureProgramme::constant(20.5),
            },
        ],
    );
    let t: toml::Table = text.parse().unwrap();
    let list = t["effect"].as_array().unwrap();
    let kinds: Vec<&str> = list.iter().map(|e| e["kind"].as_str().unwrap()).collect();
    assert_eq!(
        kinds,
        ["head-rotation-x", "ambient-step", "temperature-sensor"]
    );
    assert_eq!(list[0]["pivot_y_mm"].as_float(), Some(200.0));
    assert_eq!(list[0]["pivot_z_mm"].as_float(), Some(1100.0));
    assert_eq!(list[0]["urad_per_k"].as_float(), Some(3.0));
    assert!(list[0].get("column").is_none());
    assert_eq!(
        list[0]["temperature"]["rise"][0]["gain_k"].as_float(),
        Some(5.0)
    );
    let shift: Vec<f64> = list[1]["shift_um_per_k"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_float().unwrap())
        .collect();
    assert!((shift[2] - 2.5).abs() < 1e-9, "{shift:?}");
    assert_eq!(list[1]["column"].as_str(), Some("T_ambient"));
    assert_eq!(list[2]["column"].as_str(), Some("T_spindle"));

    let cases: Vec<(Vec<Effect>, &str)> = vec![
        (
            vec![Effect::HeadRotationX {
                pivot_y: 0.0,
                pivot_z: f64::NAN,
                urad_per_k: 1.0,
                temperature: stepped(1.0),
                column: None,
            }],
            "pivot_z = NaN is not a finite number",
        ),
        (
            vec![Effect::AmbientStep {
                ambient_c: 20.0,
                at_s: 10.0,
                step_k: -4.0,
                tau_s: 0.0,
                shift_per_k: [0.0; 3],
                column: None,
            }],
            "tau_s = 0: expected a positive number",
        ),
        (
            vec![Effect::TemperatureSensor {
                column: "spindle".into(),
                temperature: TemperatureProgramme::constant(20.0),
            }],
            "a temperature column is T_<name>",
        ),
        (
            vec![
                Effect::ThermalScale {
                    axis: 'Y',
                    ppm_per_k: 1.0,
                    reference: 0.0,
                    temperature: stepped(1.0),
                    column: "T_ydrive".into(),
                },
                Effect::HeadRotationX {
                    pivot_y: 0.0,
                    pivot_z: 1.0,
                    urad_per_k: 1.0,
                    temperature: stepped(1.0),
                    column: Some("T_ydrive".into()),
                },
            ],
            "context column T_ydrive is written by two effects",
        ),
    ];
    for (effects, want) in cases {
        let err = Resolved::new(&m, &[], &effects).unwrap_err().to_string();
        assert!(err.contains(want), "{err:?} lacks {want:?}");
    }
}
