//! LinuxCNC's table-table kinematics as its source describes them (see `trt.rs`), and the pivot
//! parameters read from the HAL lines mtcal writes: shared by the format's tests and the chain
//! from the recordings to the control (`end_to_end.rs`).
#![allow(dead_code)]

use mtcal_compensate::{TrtKind, TrtPivots};
use nalgebra::Vector3;

/// LinuxCNC xyzac-trt forward kinematics: joints (mm, deg) → workpiece coordinates (mm).
pub fn xyzac_forward(p: &TrtPivots, j: [f64; 5]) -> Vector3<f64> {
    let [x, y, z, a, c] = j;
    let (a, c) = (a.to_radians(), c.to_radians());
    let (ya, za) = (
        p.y_rot_point_mm + p.y_offset_mm,
        p.z_rot_point_mm + p.z_offset_mm + p.tool_offset_mm,
    );
    // The table tilted by A carries the workpiece: the tool relative to it turns by −A about
    // the A line.
    let (dy, dz) = (y - ya, z - za);
    let y1 = a.cos() * dy + a.sin() * dz + ya;
    let z1 = -a.sin() * dy + a.cos() * dz + za;
    // Then by −C about the C line.
    let (dx, dy) = (x - p.x_rot_point_mm, y1 - p.y_rot_point_mm);
    Vector3::new(
        c.cos() * dx + c.sin() * dy + p.x_rot_point_mm,
        -c.sin() * dx + c.cos() * dy + p.y_rot_point_mm,
        z1,
    )
}

/// LinuxCNC xyzbc-trt forward kinematics: joints (mm, deg) → workpiece coordinates (mm): undo
/// the B tilt about its line (parallel to Y), then the C turn about its line.
pub fn xyzbc_forward(p: &TrtPivots, j: [f64; 5]) -> Vector3<f64> {
    let [x, y, z, b, c] = j;
    let (b, c) = (b.to_radians(), c.to_radians());
    let (xb, zb) = (
        p.x_rot_point_mm + p.x_offset_mm,
        p.z_rot_point_mm + p.z_offset_mm + p.tool_offset_mm,
    );
    let (u, w) = (x - xb, z - zb);
    let x1 = b.cos() * u - b.sin() * w + xb;
    let z1 = b.sin() * u + b.cos() * w + zb;
    let (dx, dy) = (x1 - p.x_rot_point_mm, y - p.y_rot_point_mm);
    Vector3::new(
        c.cos() * dx + c.sin() * dy + p.x_rot_point_mm,
        -c.sin() * dx + c.cos() * dy + p.y_rot_point_mm,
        z1,
    )
}

/// The pivots of the `setp <kins>.<pin> value` lines of a HAL text.
pub fn pivots_of_hal(text: &str) -> TrtPivots {
    let mut p = TrtPivots {
        kind: TrtKind::Xyzac,
        x_rot_point_mm: 0.0,
        y_rot_point_mm: 0.0,
        z_rot_point_mm: 0.0,
        x_offset_mm: 0.0,
        y_offset_mm: 0.0,
        z_offset_mm: 0.0,
        tool_offset_mm: 0.0,
        nominal: Box::new(None),
        not_representable: Vec::new(),
    };
    for line in text.lines() {
        let Some(rest) = line.strip_prefix("setp ") else {
            continue;
        };
        let (pin, value) = rest.split_once(' ').unwrap();
        let (kins, pin) = pin.split_once('.').unwrap();
        p.kind = match kins {
            "xyzac-trt-kins" => TrtKind::Xyzac,
            "xyzbc-trt-kins" => TrtKind::Xyzbc,
            other => panic!("kinematics {other}"),
        };
        let v: f64 = value.trim().parse().unwrap();
        match pin {
            "x-rot-point" => p.x_rot_point_mm = v,
            "y-rot-point" => p.y_rot_point_mm = v,
            "z-rot-point" => p.z_rot_point_mm = v,
            "x-offset" => p.x_offset_mm = v,
            "y-offset" => p.y_offset_mm = v,
            "z-offset" => p.z_offset_mm = v,
            "tool-offset" => p.tool_offset_mm = v,
            other => panic!("pin {other}"),
        }
    }
    p
}
