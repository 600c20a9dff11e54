//! How a SINUMERIK control reads and applies CYCLE800 swivel data (`$TC_CARR`), written from
//! the manuals (see `siemens_carr.rs`), not from the crate: shared by the format's tests and the
//! chain from the recordings to the control (`end_to_end.rs`).
#![allow(dead_code)]

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use std::collections::HashMap;

/// The record as the control reads it from the part program's text.
pub struct Record {
    pub kind: char,
    pub offsets: [Vector3<f64>; 4],
    pub vectors: [Vector3<f64>; 2],
    pub axes: [String; 2],
}

/// `$TC_CARRk[n]=value` assignments of the text (comments dropped), parsed on their own.
pub fn record_of(text: &str) -> Record {
    let mut fields: HashMap<u32, String> = HashMap::new();
    for line in text.lines() {
        let code = line.split(';').next().unwrap().trim();
        if code.is_empty() || code == "M30" {
            continue;
        }
        let rest = code.strip_prefix("$TC_CARR").expect(code);
        let (k, rest) = rest.split_once('[').unwrap();
        let (_, value) = rest.split_once("]=").unwrap();
        fields.insert(
            k.parse().unwrap(),
            value.trim().trim_matches('"').to_string(),
        );
    }
    let n = |k: u32| -> f64 { fields[&k].parse().unwrap() };
    let v = |k: u32| Vector3::new(n(k), n(k + 1), n(k + 2));
    Record {
        kind: fields[&23].chars().next().unwrap(),
        offsets: [v(1), v(4), v(15), v(18)],
        vectors: [v(7), v(10)],
        axes: [fields[&21].clone(), fields[&22].clone()],
    }
}

fn rot(v: &Vector3<f64>, deg: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Unit::new_normalize(*v), deg.to_radians()).into_inner()
}

impl Record {
    /// The tool point (mm) and the tool's turn relative to the workpiece, in machine
    /// coordinates of the workpiece at the initial setting, at axis positions `lin_mm` and
    /// rotary angles `deg` (axes 1 and 2).
    pub fn apply(&self, lin_mm: Vector3<f64>, deg: [f64; 2]) -> (Vector3<f64>, Matrix3<f64>) {
        let [i1, i2, i3, i4] = self.offsets;
        let r1 = rot(&self.vectors[0], deg[0]);
        let r2 = rot(&self.vectors[1], deg[1]);
        match self.kind {
            'T' => {
                let l = i1 + r1 * (i2 + r2 * i3);
                (lin_mm - l, r1 * r2)
            }
            'P' => {
                // Undo the table's turn: w = R2ᵀ(R1ᵀ(p − I2) − I3) − I4.
                let w = r2.transpose() * (r1.transpose() * (lin_mm - i2) - i3) - i4;
                (w, (r1 * r2).transpose())
            }
            'M' => {
                let tip = lin_mm - (i1 + r1 * i2);
                let w = r2.transpose() * (tip - i3) - i4;
                (w, r2.transpose() * r1)
            }
            other => panic!("kinematics type {other}"),
        }
    }
}
