//! The reference numbers of python/tests/test_machine.py, from Rust and not through the Python
//! binding: reads `{"machine": "...", "params": "..." | null, "q": [[...], ...]}` on standard
//! input and prints `{"nominal": [...], "actual": [...], "error": [...]}` for every row.
//!
//! It takes the slow route on purpose: the nominal pose from `Machine::tool_in_workpiece`
//! (the nominal chain of 4 × 4 products), the actual pose from `MachineModel::tool_pose`, and
//! the error as their difference and `log(R·R₀ᵀ)` — not `MachineModel::pose_error`, which the
//! binding calls. The coefficients come from the parameter file read here.

use mtcal_kinematics::rigid::{log_so3, mm};
use mtcal_kinematics::{MachineModel, Rigid};
use mtcal_machine::topology::Reading;
use serde_json::{Value, json};
use std::io::Read;
use std::path::Path;

fn matrix(p: &Rigid) -> Value {
    let rows: Vec<Value> = (0..4)
        .map(|i| {
            if i == 3 {
                json!([0.0, 0.0, 0.0, 1.0])
            } else {
                json!([p.r[(i, 0)], p.r[(i, 1)], p.r[(i, 2)], p.t[i]])
            }
        })
        .collect();
    Value::Array(rows)
}

fn main() {
    let mut input = String::new();
    std::io::stdin()
        .read_to_string(&mut input)
        .expect("a request on standard input");
    let request: Value = serde_json::from_str(&input).expect("a JSON request");
    let arg = request["machine"].as_str().expect("machine: a string");
    let loaded = mtcal_machine::load_machine(arg, Reading::default()).expect("a machine");
    let model = MachineModel::new(loaded.machine.clone(), &loaded.config).expect("a model");
    let coeffs = match request["params"].as_str() {
        Some(path) => mtcal_machine::params::load_params(Path::new(path), model.errors())
            .expect("a parameter file"),
        None => vec![0.0; model.n_coeffs()],
    };
    let mut ws = model.workspace();
    let (mut nominal, mut actual, mut error) = (Vec::new(), Vec::new(), Vec::new());
    for row in request["q"].as_array().expect("q: rows") {
        let q: Vec<f64> = row
            .as_array()
            .expect("a row")
            .iter()
            .map(|v| v.as_f64().expect("a number"))
            .collect();
        let nom = loaded.machine.tool_in_workpiece(&q);
        let act = model.tool_pose(&q, &coeffs, &mut ws);
        let t = act.t - nom.t;
        let r = log_so3(&mm(&act.r, &nom.r.transpose()));
        nominal.push(matrix(&nom));
        actual.push(matrix(&act));
        error.push(json!([t.x, t.y, t.z, r.x, r.y, r.z]));
    }
    let out = json!({"nominal": nominal, "actual": actual, "error": error, "coeffs": coeffs});
    println!("{out}");
}
