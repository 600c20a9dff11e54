//! A machine written back out as URDF.

use super::*;

/// Placeholder effort (N or N·m) and velocity (m/s or rad/s) for written `<limit>` elements:
/// URDF requires them; mtcal does not use them.
pub(super) const WRITTEN_EFFORT: f64 = 1000.0;
pub(super) const WRITTEN_VELOCITY: f64 = 1.0;

/// Writes a machine as a standard URDF that `check_urdf`, pinocchio and [`load_urdf_str`] read.
///
/// Links: the root `frame`, one link per axis (`x_slide` for linear axes, `c_table` for rotary
/// axes of the workpiece branch, `b_head` for rotary axes of the tool branch), `workpiece` and
/// `tool`, each hung on a fixed joint (`workpiece_mount`, `tool_mount`) carrying the branch's
/// end transform. Every link but the root gets a small placeholder `<inertial>`: some ROS tools
/// (KDL) reject links without mass, and KDL warns about a root link with one. Numbers are written
/// in Rust's shortest round-trip form, so loading the file gives back the same machine.
/// `comment` goes into an XML comment at the top (`--`, which XML comments forbid, is split).
pub fn write_urdf(machine: &Machine, comment: Option<&str>) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?>\n");
    if let Some(c) = comment {
        let _ = writeln!(out, "<!--\n{}\n-->", comment_safe(c));
    }
    let _ = writeln!(out, "<robot name=\"{}\">", xml_escape(machine.name()));
    out.push_str("  <link name=\"frame\"/>\n");
    for side in [Side::Workpiece, Side::Tool] {
        write_branch(&mut out, machine, side);
    }
    out.push_str("</robot>\n");
    out
}

pub(super) fn write_branch(out: &mut String, machine: &Machine, side: Side) {
    let branch = machine.branch(side);
    let mut parent = String::from("frame");
    for &i in branch.joints() {
        let axis = &machine.axes()[i];
        let child = axis_link_name(axis.letter(), axis.kind(), side);
        write_link(out, &child);
        write_joint(out, machine, i, &parent, &child);
        parent = child;
    }
    let (end, mount) = match side {
        Side::Workpiece => ("workpiece", "workpiece_mount"),
        Side::Tool => ("tool", "tool_mount"),
    };
    write_link(out, end);
    let _ = writeln!(out, "  <joint name=\"{mount}\" type=\"fixed\">");
    write_origin(out, branch.end());
    let _ = writeln!(
        out,
        "    <parent link=\"{parent}\"/>\n    <child link=\"{end}\"/>"
    );
    out.push_str("  </joint>\n");
}

pub(super) fn axis_link_name(letter: AxisLetter, kind: AxisKind, side: Side) -> String {
    let body = match (kind, side) {
        (AxisKind::Linear, _) => "slide",
        (AxisKind::Rotary, Side::Workpiece) => "table",
        (AxisKind::Rotary, Side::Tool) => "head",
    };
    format!("{}_{body}", letter.as_char().to_ascii_lowercase())
}

pub(super) fn write_link(out: &mut String, name: &str) {
    let _ = writeln!(
        out,
        "  <link name=\"{name}\">\n    <inertial>\n      <mass value=\"1\"/>\n      \
         <inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/>\n    \
         </inertial>\n  </link>"
    );
}

pub(super) fn write_joint(
    out: &mut String,
    machine: &Machine,
    i: usize,
    parent: &str,
    child: &str,
) {
    let axis = &machine.axes()[i];
    let kind = match (axis.kind(), axis.limits()) {
        (AxisKind::Linear, _) => "prismatic",
        (AxisKind::Rotary, Some(_)) => "revolute",
        (AxisKind::Rotary, None) => "continuous",
    };
    let _ = writeln!(out, "  <joint name=\"{}\" type=\"{kind}\">", axis.letter());
    write_origin(out, axis.origin());
    let _ = writeln!(
        out,
        "    <parent link=\"{parent}\"/>\n    <child link=\"{child}\"/>"
    );
    let _ = writeln!(out, "    <axis xyz=\"{}\"/>", vec3(axis.direction()));
    let (effort, velocity) = (num(WRITTEN_EFFORT), num(WRITTEN_VELOCITY));
    match axis.limits() {
        Some((lo, hi)) => {
            let (lo, hi) = (num(lo), num(hi));
            let _ = writeln!(
                out,
                "    <limit lower=\"{lo}\" upper=\"{hi}\" effort=\"{effort}\" velocity=\"{velocity}\"/>"
            );
        }
        None => {
            let _ = writeln!(
                out,
                "    <limit effort=\"{effort}\" velocity=\"{velocity}\"/>"
            );
        }
    }
    out.push_str("  </joint>\n");
}

pub(super) fn write_origin(out: &mut String, t: &Rigid) {
    let rpy = rpy_from_matrix(&t.r);
    let _ = writeln!(
        out,
        "    <origin xyz=\"{}\" rpy=\"{}\"/>",
        vec3(&t.t),
        vec3(&Vector3::from(rpy))
    );
}

/// URDF roll, pitch, yaw of a rotation `R = Rz(yaw)·Ry(pitch)·Rx(roll)`, accurate to rounding
/// everywhere, including near pitch = ±90° (a horizontal spindle) where the textbook
/// `asin` formula loses half the digits: pitch comes from `atan2`, and roll from what is left
/// after yaw and pitch are taken out, so an ill-determined yaw is compensated exactly.
pub fn rpy_from_matrix(r: &Matrix3<f64>) -> [f64; 3] {
    let cos_pitch = r[(0, 0)].hypot(r[(1, 0)]);
    let pitch = (-r[(2, 0)]).atan2(cos_pitch);
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    let taken_out = Rotation3::from_euler_angles(0.0, pitch, yaw);
    let rest = taken_out.matrix().transpose() * r;
    let roll = rest[(2, 1)].atan2(rest[(2, 2)]);
    [roll, pitch, yaw]
}

pub(super) fn vec3(v: &Vector3<f64>) -> String {
    format!("{} {} {}", num(v.x), num(v.y), num(v.z))
}

/// Shortest decimal that reads back to the same `f64`; exponent form for very small or large
/// magnitudes, which Rust's plain form would spell out digit by digit.
pub(super) fn num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-5..1e9).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

pub(super) fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// XML comments may not contain `--` nor end in `-`.
pub(super) fn comment_safe(s: &str) -> String {
    let mut t = s.to_string();
    while t.contains("--") {
        t = t.replace("--", "- -");
    }
    if t.ends_with('-') {
        t.push(' ');
    }
    t
}
