//! A machine described for a reader (`mtcal describe`, the head of `mtcal map`): its axes
//! with their branch, stroke and direction, and the size of its error model.

use crate::LoadedMachine;
use mtcal_kinematics::{AxisKind, MachineModel, ParamName, Side};
use std::fmt::Write as _;

/// The machine of `loaded`, one line per axis, and `model`'s error parameters by kind.
pub fn describe(loaded: &LoadedMachine, model: &MachineModel) -> String {
    let m = &loaded.machine;
    let mut s = String::new();
    let _ = writeln!(s, "machine     {} ({})", m.name(), loaded.source);
    let _ = writeln!(s, "topology    {}", m.topology_code());
    let _ = writeln!(
        s,
        "axis  kind     branch     stroke                      direction"
    );
    for ax in m.axes() {
        let (unit, scale) = match ax.kind() {
            AxisKind::Linear => ("mm", 1e3),
            AxisKind::Rotary => ("deg", 180.0 / std::f64::consts::PI),
        };
        let stroke = match ax.limits() {
            Some((lo, hi)) => format!("{:9.3} … {:9.3} {unit}", lo * scale, hi * scale),
            None => "unlimited".to_string(),
        };
        let branch = match ax.side() {
            Side::Workpiece => "workpiece",
            Side::Tool => "tool",
        };
        let kind = match ax.kind() {
            AxisKind::Linear => "linear",
            AxisKind::Rotary => "rotary",
        };
        let d = ax.zero_rotation() * ax.direction();
        let _ = writeln!(
            s,
            "{:<5} {kind:<8} {branch:<10} {stroke:<27} ({:+.3}, {:+.3}, {:+.3})",
            ax.letter().to_string(),
            d.x,
            d.y,
            d.z
        );
    }
    let params = model.errors().params();
    let count = |f: &dyn Fn(&ParamName) -> bool| params.iter().filter(|p| f(&p.name)).count();
    let rotary = |n: &ParamName| n.axis().is_some_and(|a| a.is_rotary());
    let _ = writeln!(
        s,
        "errors      {} parameters, {} coefficients ({}): {} component, {} rotary location, {} squareness, {} set-up",
        params.len(),
        model.n_coeffs(),
        loaded.config_source,
        count(&|n| matches!(n, ParamName::Component { .. })),
        count(&|n| matches!(n, ParamName::Location { .. }) && rotary(n)),
        count(&|n| matches!(n, ParamName::Location { .. }) && !rotary(n)),
        count(&|n| matches!(n, ParamName::Setup(_))),
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::Reading;

    #[test]
    fn a_three_axis_machine_line_by_line() {
        let loaded = crate::load_machine("ZFYX", Reading::FromTool).unwrap();
        let model = MachineModel::new(loaded.machine.clone(), &loaded.config).unwrap();
        let text = describe(&loaded, &model);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 7, "{text}");
        assert_eq!(
            lines[0],
            format!("machine     {} ({})", loaded.machine.name(), loaded.source)
        );
        assert_eq!(
            lines[1],
            format!("topology    {}", loaded.machine.topology_code())
        );
        assert!(
            lines[2].starts_with("axis  kind     branch     stroke"),
            "{text}"
        );
        // One line per axis, in canonical order, with its stroke in mm.
        for (line, letter) in lines[3..6].iter().zip(["X", "Y", "Z"]) {
            assert!(
                line.starts_with(&format!("{letter:<5} linear   ")),
                "{line}"
            );
            assert!(line.contains(" mm "), "{line}");
        }
        // The full ISO model of three linear axes: 18 component errors, 3 squareness.
        assert_eq!(
            lines[6],
            format!(
                "errors      21 parameters, {} coefficients ({}): 18 component, 0 rotary location, \
                 3 squareness, 0 set-up",
                model.n_coeffs(),
                loaded.config_source
            )
        );
    }
}
