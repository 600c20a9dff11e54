//! A representative set-up and path on a given machine, for the conformance harness and tests.

use crate::path::path;
use crate::setup::{load, perpendicular_basis};
use mtcal_instrument::{Fixture, PathSpec, SetupContext};
use mtcal_kinematics::{AxisKind, Machine};
use nalgebra::Vector3;

const MODES: [&str; 5] = [
    "linear",
    "straightness",
    "angular",
    "diagonal",
    "step-diagonal",
];

/// Rounded to 0.1 mm (or 0.001°), as a user would write it.
fn round_mm(x_m: f64) -> f64 {
    (x_m * 1e4).round() / 10.0
}

/// A direction value: a signed letter when the vector is a workpiece axis exactly, else the
/// vector.
fn direction_value(v: &Vector3<f64>) -> toml::Value {
    for (i, l) in ["X", "Y", "Z"].iter().enumerate() {
        let mut e = Vector3::zeros();
        e[i] = 1.0;
        if *v == e {
            return (*l).into();
        }
        if *v == -e {
            return format!("-{l}").into();
        }
    }
    toml::Value::Array(v.iter().map(|&x| x.into()).collect())
}

/// A set-up and poses on `machine`, varying with the seed: every mode (seed mod 5), the moving
/// axis cycling over the linear axes, the optic on the tool or on the table, an optic offset,
/// uncompensated readings with fixed air values (length modes, some seeds), ISO 230-2 cycles
/// with and without overrun. `None` if the machine has no linear axis with limits (or fewer
/// than two for the diagonals).
pub fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    let linear: Vec<usize> = machine
        .axes()
        .iter()
        .enumerate()
        .filter(|(_, a)| a.kind() == AxisKind::Linear && a.limits().is_some())
        .map(|(i, _)| i)
        .collect();
    if linear.is_empty() {
        return None;
    }
    let mode = MODES[(seed % 5) as usize];
    let diagonal = mode.ends_with("diagonal");
    if diagonal && linear.len() < 2 {
        return None;
    }
    // Held positions: linear axes mid-stroke, rotary axes at 0 (clamped to their limits).
    let mut hold_q = vec![0.0; machine.n_axes()];
    let mut hold_v = vec![toml::Value::Float(0.0); machine.n_axes()];
    for (i, a) in machine.axes().iter().enumerate() {
        match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some((lo, hi))) => {
                let v = round_mm(0.5 * (lo + hi) + 0.1 * (hi - lo) * ((seed % 3) as f64 - 1.0));
                hold_q[i] = v * 1e-3;
                hold_v[i] = v.into();
            }
            (AxisKind::Linear, None) => {}
            (AxisKind::Rotary, limits) => {
                let v = limits.map_or(0.0, |(lo, hi)| 0.0f64.clamp(lo, hi));
                let deg = (v.to_degrees() * 1e3).round() / 1e3;
                hold_q[i] = deg.to_radians();
                hold_v[i] = deg.into();
            }
        }
    }
    let span = |i: usize, f: f64| {
        let (lo, hi) = machine.axes()[i].limits().expect("filtered");
        round_mm(lo + f * (hi - lo))
    };
    let mut path_t = toml::Table::new();
    let mut hold = toml::Table::new();
    let (qa, qb) = if diagonal {
        let mut from = toml::Table::new();
        let mut to = toml::Table::new();
        let (mut qa, mut qb) = (hold_q.clone(), hold_q.clone());
        for &i in linear.iter().take(3) {
            let l = machine.axes()[i].letter().to_string();
            let (a, b) = (span(i, 0.2), span(i, 0.8));
            from.insert(l.clone(), a.into());
            to.insert(l, b.into());
            qa[i] = a * 1e-3;
            qb[i] = b * 1e-3;
        }
        for (i, a) in machine.axes().iter().enumerate() {
            if !linear.iter().take(3).any(|&j| j == i) {
                hold.insert(a.letter().to_string(), hold_v[i].clone());
            }
        }
        path_t.insert("from".into(), toml::Value::Table(from));
        path_t.insert("to".into(), toml::Value::Table(to));
        path_t.insert("points".into(), 4.into());
        (qa, qb)
    } else {
        let axis = linear[(seed / 5) as usize % linear.len()];
        let l = machine.axes()[axis].letter().to_string();
        let (a, b) = (span(axis, 0.1), span(axis, 0.9));
        path_t.insert("axis".into(), l.into());
        path_t.insert("from".into(), a.into());
        path_t.insert("to".into(), b.into());
        path_t.insert("points".into(), 4.into());
        if seed % 2 == 0 {
            path_t.insert("overrun".into(), 2.5.into());
        }
        for (i, ax) in machine.axes().iter().enumerate() {
            if i != axis {
                hold.insert(ax.letter().to_string(), hold_v[i].clone());
            }
        }
        let (mut qa, mut qb) = (hold_q.clone(), hold_q.clone());
        qa[axis] = a * 1e-3;
        qb[axis] = b * 1e-3;
        (qa, qb)
    };
    path_t.insert("cycles".into(), 2.into());
    if !hold.is_empty() {
        path_t.insert("hold".into(), toml::Value::Table(hold));
    }
    let d = machine.tool_in_workpiece(&qb).t - machine.tool_in_workpiece(&qa).t;
    let n = d.normalize();
    let mut setup = toml::Table::new();
    setup.insert("mode".into(), mode.into());
    setup.insert("direction".into(), direction_value(&n));
    let (e1, e2) = perpendicular_basis(&n);
    if mode == "straightness" {
        setup.insert(
            "sense".into(),
            direction_value(if seed % 2 == 0 { &e1 } else { &e2 }),
        );
    }
    if mode == "angular" {
        setup.insert(
            "about".into(),
            direction_value(if seed % 2 == 0 { &e2 } else { &e1 }),
        );
    }
    if seed % 2 == 1 {
        setup.insert("optic".into(), "table".into());
    }
    match seed % 3 {
        1 => {
            setup.insert(
                "optic_offset".into(),
                toml::Value::Array(vec![0.0.into(), 0.0.into(), 80.0.into()]),
            );
        }
        2 => {
            setup.insert(
                "optic_offset".into(),
                toml::Value::Array(vec![30.0.into(), (-20).into(), 100.0.into()]),
            );
        }
        _ => {}
    }
    if mode == "angular" {
        setup.insert("sigma_urad".into(), 0.5.into());
    } else if seed % 4 != 0 {
        setup.insert("sigma_um".into(), (0.2 * (1 + seed % 4) as f64).into());
    }
    if seed % 7 == 3 {
        setup.insert("offset_free".into(), false.into());
    }
    let length = matches!(mode, "linear" | "diagonal" | "step-diagonal");
    if length && seed % 4 == 3 {
        setup.insert("tilt_prior_urad".into(), 50.0.into());
        setup.insert("tilt_free".into(), true.into());
    }
    if mode == "straightness" && seed % 4 == 1 {
        setup.insert("slope_free".into(), true.into());
    }
    if length && seed % 3 == 0 {
        setup.insert("wavelength_compensated".into(), false.into());
        setup.insert("air_temperature_c".into(), 21.5.into());
        setup.insert("air_pressure_hpa".into(), 985.0.into());
        setup.insert("air_humidity_pct".into(), 45.0.into());
        setup.insert("expansion_ppm_per_k".into(), 11.5.into());
        setup.insert("material_temperature_c".into(), 20.8.into());
    }
    let loaded = load(&setup, &SetupContext { machine }).ok()?;
    let poses = path(&PathSpec {
        path: &path_t,
        setup: &loaded,
        machine,
    })
    .ok()?;
    Some(Fixture {
        setup,
        poses,
        labels: Vec::new(),
    })
}
