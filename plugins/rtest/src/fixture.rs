//! A representative set-up and path on a given machine, for the conformance harness and tests.

use crate::path::{check_machine, path};
use crate::setup::{Mount, load};
use mtcal_instrument::{Fixture, PathSpec, SetupContext};
use mtcal_kinematics::{AxisKind, Machine, Rigid, Side};
use nalgebra::Vector3;
use std::f64::consts::{FRAC_PI_2, TAU};

/// Samples of a fixture's sweep.
const SAMPLES: i64 = 25;
/// Ball positions tried before giving up.
const ATTEMPTS: u64 = 64;
/// Positions of the held rotary axis, degrees, cycling with the seed.
const TILTS_DEG: [f64; 4] = [0.0, 20.0, -20.0, 30.0];

/// A set-up and poses on `machine`: the ball 50–150 mm from the swept rotary axis' line (a
/// workpiece-side C axis when there is one), the linear axes following it over an xyc-like sweep
/// of 25 samples, the other rotary axis held at a tilt cycling with the seed; even seeds use
/// the ideal head, odd seeds the three-sensor head; the mount is [`fixture_mount`]'s. `None`
/// for machines without a rotary axis (or with other than three linear axes), or if no ball
/// position within reach is found.
pub fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    fixture_with_mount(machine, seed, fixture_mount(seed))
}

/// The mount [`fixture`] uses for a seed: `ball-in-spindle` where bit 1 and bit 2 of the seed
/// differ. Seeds 0..8 then give each (head, mount) pair twice, and the sensor-geometry
/// variants (seeds 3 and 7) one on each mount.
pub fn fixture_mount(seed: u64) -> Mount {
    if ((seed >> 1) ^ (seed >> 2)) & 1 == 1 {
        Mount::BallInSpindle
    } else {
        Mount::BallOnTable
    }
}

/// [`fixture`] with a given mount (written into the set-up as `mount`); the rest as the seed
/// says.
pub fn fixture_with_mount(machine: &Machine, seed: u64, mount: Mount) -> Option<Fixture> {
    check_machine(machine).ok()?;
    let axes = machine.axes();
    let rotary: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| axes[i].kind() == AxisKind::Rotary)
        .collect();
    let on_table: Vec<usize> = rotary
        .iter()
        .copied()
        .filter(|&i| axes[i].side() == Side::Workpiece)
        .collect();
    let pick = |list: &[usize]| {
        list.iter()
            .copied()
            .find(|&i| axes[i].letter().as_char() == 'C')
            .or(list.first().copied())
    };
    let swept = pick(&on_table).or_else(|| pick(&rotary))?;
    let (from, to) = match axes[swept].limits() {
        None => (0.0, TAU),
        Some((lo, hi)) => (lo.max(-FRAC_PI_2), hi.min(FRAC_PI_2)),
    };
    let tilt = TILTS_DEG[(seed / 2 % TILTS_DEG.len() as u64) as usize].to_radians();
    let held: Vec<(usize, f64)> = rotary
        .iter()
        .copied()
        .filter(|&i| i != swept)
        .map(|i| {
            let v = match axes[i].limits() {
                None => tilt,
                Some((lo, hi)) => tilt.clamp(lo, hi),
            };
            (i, (v.to_degrees() * 1e3).round() / 1e3)
        })
        .collect();

    let mut q0: Vec<f64> = axes
        .iter()
        .map(|a| match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some((lo, hi))) => 0.5 * (lo + hi),
            _ => 0.0,
        })
        .collect();
    q0[swept] = from;
    for &(i, deg) in &held {
        q0[i] = deg.to_radians();
    }
    let mid = machine.tool_in_workpiece(&q0).t;
    let line = (axes[swept].side() == Side::Workpiece).then(|| axis_line(machine, swept, &q0));

    let mut setup = setup_table(seed);
    setup.insert("mount".into(), mount.as_str().into());
    let mut rng = SplitMix(seed.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ 0x5eed);
    for _ in 0..ATTEMPTS {
        let ball = match line {
            Some((point, dir)) => {
                let foot = point + dir * dir.dot(&(mid - point));
                let e1 = dir
                    .cross(&Vector3::z())
                    .try_normalize(1e-9)
                    .unwrap_or_else(|| dir.cross(&Vector3::x()).normalize());
                let e2 = dir.cross(&e1);
                let r = 0.05 + 0.1 * rng.unit();
                let phi = TAU * rng.unit();
                let h = 0.1 * (rng.unit() - 0.5);
                foot + (e1 * phi.cos() + e2 * phi.sin()) * r + dir * h
            }
            None => mid + Vector3::from_fn(|_, _| 0.2 * (rng.unit() - 0.5)),
        };
        let ball_mm = ball.map(|v| (v * 1e4).round() / 10.0);
        let mut setup = setup.clone();
        setup.insert(
            "ball".into(),
            toml::Value::Array(ball_mm.iter().map(|&v| v.into()).collect()),
        );
        let Ok(loaded) = load(&setup, &SetupContext { machine }) else {
            continue;
        };
        for shrink in [1.0, 0.5, 0.25] {
            let centre = 0.5 * (from + to);
            let half = 0.5 * (to - from) * shrink;
            let range =
                [centre - half, centre + half].map(|v| (v.to_degrees() * 1e3).round() / 1e3);
            let path_table = path_table(machine, swept, range, &held);
            let spec = PathSpec {
                path: &path_table,
                setup: &loaded,
                machine,
            };
            if let Ok(poses) = path(&spec) {
                return Some(Fixture {
                    setup,
                    poses,
                    labels: Vec::new(),
                });
            }
        }
    }
    None
}

/// The set-up keys of a fixture, varied with the seed (the ball is added per attempt).
fn setup_table(seed: u64) -> toml::Table {
    let mut t = toml::Table::new();
    t.insert("sigma_um".into(), (0.5 + 0.25 * (seed % 3) as f64).into());
    if seed % 3 == 2 {
        t.insert("ball_free".into(), false.into());
    }
    if seed % 5 == 4 {
        t.insert("tool_length_free".into(), false.into());
    }
    if seed % 2 == 1 {
        t.insert("head".into(), "three-sensor".into());
        if seed % 4 == 3 {
            t.insert("sensor_geometry_free".into(), true.into());
            t.insert("sensor_elevation_deg".into(), 40.0.into());
            t.insert("ball_diameter_mm".into(), 25.4.into());
        }
        if seed % 8 == 7 {
            t.insert("sensor_gain_u_ppm".into(), 500.0.into());
            t.insert("sensor_angle_u_urad".into(), 2000.0.into());
        }
    }
    t
}

fn path_table(
    machine: &Machine,
    swept: usize,
    range: [f64; 2],
    held: &[(usize, f64)],
) -> toml::Table {
    let letter = |i: usize| machine.axes()[i].letter().to_string();
    let mut sweep = toml::Table::new();
    sweep.insert(
        letter(swept),
        toml::Value::Array(range.iter().map(|&v| v.into()).collect()),
    );
    let mut hold = toml::Table::new();
    for &(i, deg) in held {
        hold.insert(letter(i), deg.into());
    }
    let mut t = toml::Table::new();
    t.insert("kind".into(), "rotary".into());
    t.insert("sweep".into(), toml::Value::Table(sweep));
    t.insert("hold".into(), toml::Value::Table(hold));
    t.insert("samples".into(), toml::Value::Integer(SAMPLES));
    t
}

/// A workpiece-side rotary axis' line in the workpiece frame at `q`: a point and the unit
/// direction.
pub fn axis_line(machine: &Machine, axis: usize, q: &[f64]) -> (Vector3<f64>, Vector3<f64>) {
    let branch = machine.branch(Side::Workpiece);
    let mut f_t_j = Rigid::IDENTITY;
    let mut found = Rigid::IDENTITY;
    for &i in branch.joints() {
        let a = &machine.axes()[i];
        f_t_j = f_t_j.compose(a.origin());
        if i == axis {
            found = f_t_j;
        }
        f_t_j = f_t_j.compose(&a.motion(q[i]));
    }
    let w_t_f = machine.branch_pose(Side::Workpiece, q).inverse();
    let w_t_j = w_t_f.compose(&found);
    let dir = w_t_j.r * machine.axes()[axis].direction();
    (w_t_j.t, dir.normalize())
}

/// SplitMix64: deterministic per seed.
#[derive(Debug)]
struct SplitMix(u64);

impl SplitMix {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}
