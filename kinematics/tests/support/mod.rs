//! Random machines and random error models for property tests.
#![allow(dead_code)]

use mtcal_kinematics::model::default_stroke;
use mtcal_kinematics::{
    AxisKind, Basis, BranchSpec, Direction, JointSpec, Machine, MachineModel, MachineSpec,
    ParamConfig, ParamName, Setup,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

/// Which axes a random machine may have.
#[derive(Clone, Copy, Debug)]
pub enum Mix {
    Prismatic,
    Rotary,
    Mixed,
}

pub fn vec3(scale: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
        .prop_map(move |(a, b, c)| Vector3::new(a, b, c) * scale)
}

fn direction() -> impl Strategy<Value = Vector3<f64>> {
    vec3(1.0).prop_filter("non-degenerate axis", |v| v.norm() > 0.2)
}

fn origin() -> impl Strategy<Value = Isometry3<f64>> {
    (vec3(0.4), vec3(1.5)).prop_map(|(t, r)| {
        Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_scaled_axis(r))
    })
}

fn joint(letter: char) -> impl Strategy<Value = JointSpec> {
    let rotary = matches!(letter, 'A' | 'B' | 'C');
    (origin(), direction(), 0.1..0.6f64, any::<bool>()).prop_map(
        move |(origin, axis, half, unlimited)| JointSpec {
            letter,
            kind: if rotary {
                AxisKind::Rotary
            } else {
                AxisKind::Linear
            },
            origin,
            axis,
            limits: match (rotary, unlimited) {
                (true, true) => None,
                (true, false) => Some((-half * 5.0, half * 5.0)),
                (false, _) => Some((-half, half * 1.5)),
            },
        },
    )
}

/// A random machine: 1 to 6 axes with random letters, split at random between the branches, with
/// random joint origins (translation and rotation) and random axis directions.
pub fn machine(mix: Mix) -> impl Strategy<Value = Machine> {
    let letters: Vec<char> = match mix {
        Mix::Prismatic => "XYZUVW".chars().collect(),
        Mix::Rotary => "ABC".chars().collect(),
        Mix::Mixed => "XYZUVWABC".chars().collect(),
    };
    let max = letters.len().min(6);
    let pick = proptest::sample::subsequence(letters, 1..=max).prop_shuffle();
    (pick, origin(), origin())
        .prop_flat_map(|(letters, wp_end, tool_end)| {
            let joints: Vec<_> = letters.iter().map(|&c| joint(c)).collect();
            let n = letters.len();
            (joints, 0..=n, Just(wp_end), Just(tool_end))
        })
        .prop_map(|(mut joints, split, wp_end, tool_end)| {
            let tool = joints.split_off(split);
            let spec = MachineSpec {
                name: "random".into(),
                workpiece: BranchSpec {
                    joints,
                    end: wp_end,
                },
                tool: BranchSpec {
                    joints: tool,
                    end: tool_end,
                },
            };
            Machine::try_new(&spec).expect("random machine is valid")
        })
}

/// A random basis for a component error of an axis.
fn basis(kind: AxisKind, stroke: (f64, f64), pick: u8, n: usize) -> Basis {
    let (lo, hi) = stroke;
    match (kind, pick % 4) {
        (AxisKind::Rotary, 3) => {
            let min = (pick as usize / 4) % 3;
            Basis::fourier(min, n.clamp(1, 3).max(min)).unwrap()
        }
        (_, 0) | (AxisKind::Linear, 3) => {
            Basis::legendre(lo, hi, pick as usize % 2, n.clamp(1, 4)).unwrap()
        }
        (_, 1) => {
            let k = n.clamp(2, 6);
            let knots = (0..k)
                .map(|i| lo + (hi - lo) * i as f64 / (k - 1) as f64)
                .collect();
            Basis::table(knots, pick % 3 == 0, false).unwrap()
        }
        _ => Basis::bspline(lo, hi, n.clamp(4, 7), false, pick % 5 == 0).unwrap(),
    }
}

/// A random error model for `machine`: a random subset of component errors with random bases,
/// the allowed location errors, and set-up parameters.
pub fn config(machine: &Machine, seed: &[u8]) -> Vec<ParamConfig> {
    let mut bytes = seed.iter().copied().cycle();
    let mut next = move || bytes.next().unwrap_or(0);
    let mut out = Vec::new();
    for (i, ax) in machine.axes().iter().enumerate() {
        // Half the rotary axes have Fourier series only (the packed fast path of a turntable's
        // error motions); the others mix bases.
        let fourier_only = ax.kind() == AxisKind::Rotary && next() % 2 == 0;
        for d in Direction::ALL {
            let b = next();
            if b % 4 != 0 {
                let n = (next() % 5) as usize + 1;
                let pick = if fourier_only { 3 + 4 * (b % 3) } else { b };
                out.push(ParamConfig {
                    name: ParamName::component(d, ax.letter()),
                    basis: Some(basis(ax.kind(), default_stroke(machine, i), pick, n)),
                });
            }
            let allowed = match ax.kind() {
                AxisKind::Rotary => true,
                AxisKind::Linear => d.is_rotation() && d.cartesian() != ax.own_cartesian(),
            };
            if allowed && next() % 3 != 0 {
                out.push(ParamConfig {
                    name: ParamName::location(d, ax.letter()),
                    basis: None,
                });
            }
        }
    }
    for d in Direction::ALL {
        if !d.is_rotation() && next() % 2 == 0 {
            out.push(ParamConfig {
                name: ParamName::Setup(Setup::Tool(d)),
                basis: None,
            });
        }
        if next() % 2 == 0 {
            out.push(ParamConfig {
                name: ParamName::Setup(Setup::Workpiece(d)),
                basis: None,
            });
        }
    }
    out
}

/// Axis positions within limits (one turn for unlimited rotary axes), from unit-interval draws.
pub fn positions(machine: &Machine, u: &[f64]) -> Vec<f64> {
    machine
        .axes()
        .iter()
        .zip(u.iter().cycle())
        .map(|(a, &t)| {
            let (lo, hi) = a.limits().unwrap_or((-PI, PI));
            lo + (hi - lo) * (0.05 + 0.9 * t)
        })
        .collect()
}

/// A machine with a random error model, axis positions and coefficients of size `scale`.
pub fn case(mix: Mix) -> impl Strategy<Value = (MachineModel, Vec<f64>, Vec<f64>)> {
    (
        machine(mix),
        proptest::collection::vec(any::<u8>(), 64),
        proptest::collection::vec(0.0..1.0f64, 9),
        proptest::collection::vec(-1.0..1.0f64, 256),
    )
        .prop_map(|(m, seed, u, c)| {
            let cfg = config(&m, &seed);
            let q = positions(&m, &u);
            let model = MachineModel::new(m, &cfg).expect("random config is valid");
            let coeffs: Vec<f64> = c
                .iter()
                .cycle()
                .take(model.n_coeffs())
                .map(|v| v * 2e-5)
                .collect();
            (model, q, coeffs)
        })
}
