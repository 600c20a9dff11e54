//! Commanded paths (SI, machine order), with the linear axes found by this crate's own nominal
//! inverse ([`Machine::follow_point`]).

use nalgebra::Vector3;

use crate::machine::{JointKind, Machine, MachineError};

/// Positions of the named axes (SI) over zeros: the held axes of a path.
fn base(machine: &Machine, hold: &[(char, f64)]) -> Result<Vec<f64>, MachineError> {
    let mut q = vec![0.0; machine.n_axes()];
    for &(c, v) in hold {
        let i = machine
            .index(c)
            .ok_or_else(|| MachineError::Structure(format!("no axis {c}")))?;
        q[i] = v;
    }
    Ok(q)
}

fn checked(machine: &Machine, q: Vec<f64>, what: &str) -> Result<Vec<f64>, MachineError> {
    if machine.within_limits(&q, 1e-9) {
        Ok(q)
    } else {
        Err(MachineError::Structure(format!(
            "{what}: a pose leaves the axis limits: {q:?}"
        )))
    }
}

/// R-test "follow the ball": the rotary axes in `sweep` run linearly from `from` to `to` (rad)
/// together, the others are held; at each sample the linear axes put the nominal tool point on
/// `ball` (m, workpiece frame).
pub fn follow_ball(
    machine: &Machine,
    ball: Vector3<f64>,
    sweep: &[(char, f64, f64)],
    hold: &[(char, f64)],
    samples: usize,
) -> Result<Vec<Vec<f64>>, MachineError> {
    let mut q = base(machine, hold)?;
    let mut out = Vec::with_capacity(samples);
    for k in 0..samples {
        let s = k as f64 / (samples - 1) as f64;
        for &(c, from, to) in sweep {
            let i = machine.index(c).expect("swept axis of the machine");
            q[i] = from + (to - from) * s;
        }
        q = machine.follow_point(&q, &Vector3::zeros(), &ball)?;
        out.push(checked(machine, q.clone(), "follow the ball")?);
    }
    Ok(out)
}

/// A circle of `radius` (m) about `centre` (workpiece frame) in the plane spanned by the
/// workpiece directions `e1`, `e2` (indices 0..3), starting on +e1; counter-clockwise (from e1
/// towards e2) when `ccw`. `samples` evenly spaced over one full turn, both ends included.
pub fn circle(
    machine: &Machine,
    centre: Vector3<f64>,
    radius: f64,
    (e1, e2): (usize, usize),
    ccw: bool,
    hold: &[(char, f64)],
    samples: usize,
) -> Result<Vec<Vec<f64>>, MachineError> {
    let mut q = base(machine, hold)?;
    let sign = if ccw { 1.0 } else { -1.0 };
    let mut out = Vec::with_capacity(samples);
    for k in 0..samples {
        let phi = sign * std::f64::consts::TAU * k as f64 / (samples - 1) as f64;
        let mut p = centre;
        p[e1] += radius * phi.cos();
        p[e2] += radius * phi.sin();
        q = machine.follow_point(&q, &Vector3::zeros(), &p)?;
        out.push(checked(machine, q.clone(), "circle")?);
    }
    Ok(out)
}

/// An arc of `radius` (m) about `centre` (workpiece frame) in the plane spanned by the
/// workpiece directions `e1`, `e2` (indices 0..3): the angle from e1 towards e2 runs linearly
/// from `from` to `to` (rad; increasing: counter-clockwise seen with e1 × e2 towards the
/// viewer), `samples` evenly spaced, both ends included. A ball bar's partial arc in a plane
/// where the spindle cannot pass below the pivot.
pub fn arc(
    machine: &Machine,
    centre: Vector3<f64>,
    radius: f64,
    (e1, e2): (usize, usize),
    (from, to): (f64, f64),
    hold: &[(char, f64)],
    samples: usize,
) -> Result<Vec<Vec<f64>>, MachineError> {
    let mut q = base(machine, hold)?;
    let mut out = Vec::with_capacity(samples);
    for k in 0..samples {
        let phi = from + (to - from) * k as f64 / (samples - 1) as f64;
        let mut p = centre;
        p[e1] += radius * phi.cos();
        p[e2] += radius * phi.sin();
        q = machine.follow_point(&q, &Vector3::zeros(), &p)?;
        out.push(checked(machine, q.clone(), "arc")?);
    }
    Ok(out)
}

/// One linear axis from `from` to `to` (m) in `points` steps, the others held.
pub fn line(
    machine: &Machine,
    axis: char,
    from: f64,
    to: f64,
    points: usize,
    hold: &[(char, f64)],
) -> Result<Vec<Vec<f64>>, MachineError> {
    let q0 = base(machine, hold)?;
    let i = machine
        .index(axis)
        .ok_or_else(|| MachineError::Structure(format!("no axis {axis}")))?;
    (0..points)
        .map(|k| {
            let mut q = q0.clone();
            q[i] = from + (to - from) * k as f64 / (points - 1) as f64;
            checked(machine, q, "line")
        })
        .collect()
}

/// A serpentine grid over the centred `fraction` of the linear axes' strokes, `counts` points
/// per linear axis (machine order), the rotary axes held.
pub fn grid(
    machine: &Machine,
    fraction: f64,
    counts: [usize; 3],
    hold: &[(char, f64)],
) -> Result<Vec<Vec<f64>>, MachineError> {
    let q0 = base(machine, hold)?;
    let lin: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| machine.joints[i].kind == JointKind::Linear)
        .collect();
    if lin.len() != 3 {
        return Err(MachineError::Structure(
            "a grid needs three linear axes".into(),
        ));
    }
    let value = |a: usize, k: usize| {
        let (lo, hi) = machine.joints[lin[a]].stroke();
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo) * fraction);
        if counts[a] == 1 {
            mid
        } else {
            mid - half + 2.0 * half * k as f64 / (counts[a] - 1) as f64
        }
    };
    let mut out = Vec::new();
    for k2 in 0..counts[2] {
        for k1s in 0..counts[1] {
            let k1 = if k2 % 2 == 0 {
                k1s
            } else {
                counts[1] - 1 - k1s
            };
            for k0s in 0..counts[0] {
                let row = k2 * counts[1] + k1s;
                let k0 = if row % 2 == 0 {
                    k0s
                } else {
                    counts[0] - 1 - k0s
                };
                let mut q = q0.clone();
                q[lin[0]] = value(0, k0);
                q[lin[1]] = value(1, k1);
                q[lin[2]] = value(2, k2);
                out.push(checked(machine, q, "grid")?);
            }
        }
    }
    Ok(out)
}

/// A diagonal of the work volume (ISO 230-6): the centred `fraction` of the three linear axes'
/// strokes (machine order), from the corner at `mid − signs·half` to the one at
/// `mid + signs·half` (`signs` ±1 per linear axis: which of the four body diagonals), `points`
/// targets evenly spaced, the rotary axes held. With `steps` (a step diagonal), the machine
/// moves one linear axis at a time from one target to the next, in the machine's axis order,
/// and a sample is recorded after every step (the last step lands on the target): between two
/// targets the nominal tool point leaves the diagonal along each axis in turn.
pub fn diagonal(
    machine: &Machine,
    fraction: f64,
    signs: [f64; 3],
    points: usize,
    steps: bool,
    hold: &[(char, f64)],
) -> Result<Vec<Vec<f64>>, MachineError> {
    let q0 = base(machine, hold)?;
    let lin: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| machine.joints[i].kind == JointKind::Linear)
        .collect();
    if lin.len() != 3 {
        return Err(MachineError::Structure(
            "a volume diagonal needs three linear axes".into(),
        ));
    }
    let target = |k: usize| {
        let s = 2.0 * k as f64 / (points - 1) as f64 - 1.0;
        let mut q = q0.clone();
        for (a, &i) in lin.iter().enumerate() {
            let (lo, hi) = machine.joints[i].stroke();
            q[i] = 0.5 * (lo + hi) + s * signs[a] * 0.5 * (hi - lo) * fraction;
        }
        q
    };
    let mut out = vec![checked(machine, target(0), "diagonal")?];
    for k in 1..points {
        let next = target(k);
        if steps {
            let mut q = out.last().expect("a first target").clone();
            for &i in &lin[..2] {
                q[i] = next[i];
                out.push(checked(machine, q.clone(), "step diagonal")?);
            }
        }
        out.push(checked(machine, next, "diagonal")?);
    }
    Ok(out)
}

/// An ISO 230-2 positioning run of one linear axis: `points` targets evenly spaced from `from`
/// to `to` (m, ascending), `cycles` bidirectional cycles, the other axes held. Each pass
/// starts `overrun` (m) beyond its first target — a recorded sample there, as the laser
/// plugin's path records it — so that every target is approached from the side of its pass;
/// the run ends with the overrun below the first target. Without overrun (`0`) the reversal
/// point is recorded twice (last ascending, first descending reading).
#[allow(clippy::too_many_arguments)]
pub fn bidirectional(
    machine: &Machine,
    axis: char,
    from: f64,
    to: f64,
    points: usize,
    cycles: usize,
    overrun: f64,
    hold: &[(char, f64)],
) -> Result<Vec<Vec<f64>>, MachineError> {
    if points < 2 || from >= to || overrun < 0.0 {
        return Err(MachineError::Structure(format!(
            "ISO 230-2 run of {axis}: two or more targets ascending from {from} to {to} m and \
             an overrun ≥ 0 expected"
        )));
    }
    let q0 = base(machine, hold)?;
    let i = machine
        .index(axis)
        .ok_or_else(|| MachineError::Structure(format!("no axis {axis}")))?;
    let target = |k: usize| from + (to - from) * k as f64 / (points - 1) as f64;
    let mut along = Vec::new();
    for _ in 0..cycles {
        if overrun > 0.0 {
            along.push(from - overrun);
        }
        along.extend((0..points).map(target));
        if overrun > 0.0 {
            along.push(to + overrun);
        }
        along.extend((0..points).rev().map(target));
    }
    if overrun > 0.0 {
        along.push(from - overrun);
    }
    along
        .into_iter()
        .map(|v| {
            let mut q = q0.clone();
            q[i] = v;
            checked(machine, q, "ISO 230-2 run")
        })
        .collect()
}
