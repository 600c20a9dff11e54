//! The effects written into the session's truth files as tables, for people and other tools.

use super::*;

pub(super) fn effect_table(machine: &Machine, e: &Effect) -> toml::Table {
    let mut t = toml::Table::new();
    let mut put = |k: &str, v: toml::Value| {
        t.insert(k.into(), v);
    };
    put("kind", kind_name(e).into());
    let rotary = |axis: char| {
        machine
            .index(axis)
            .is_some_and(|i| machine.joints[i].kind == JointKind::Rotary)
    };
    // Deviations in µm or µrad, positions in mm or degrees.
    let small = |v: f64| v * 1e6;
    let small_unit = |axis: char| if rotary(axis) { "urad" } else { "um" };
    let place = |axis: char, v: f64| {
        if rotary(axis) {
            v.to_degrees()
        } else {
            v * 1e3
        }
    };
    let place_unit = |axis: char| if rotary(axis) { "deg" } else { "mm" };
    match e {
        Effect::Backlash { axis, lost_motion } => {
            put("axis", axis.to_string().into());
            put(
                &format!("lost_motion_{}", small_unit(*axis)),
                small(*lost_motion).into(),
            );
        }
        Effect::Thermal { direction, sources } => {
            put("direction", floats(direction));
            put("source", sources_value(sources, "gain_um", 1e6));
        }
        Effect::ScrewError {
            axis,
            pitch,
            harmonics,
        } => {
            put("axis", axis.to_string().into());
            put(
                &format!("pitch_{}", place_unit(*axis)),
                place(*axis, *pitch).into(),
            );
            let rows = harmonics
                .iter()
                .map(|&(k, a, phase)| {
                    let mut h = toml::Table::new();
                    h.insert("order".into(), i64::from(k).into());
                    h.insert(format!("amplitude_{}", small_unit(*axis)), small(a).into());
                    h.insert("phase_rad".into(), phase.into());
                    toml::Value::Table(h)
                })
                .collect();
            put("harmonic", toml::Value::Array(rows));
        }
        Effect::ThermalScale {
            axis,
            ppm_per_k,
            reference,
            temperature,
            column,
        } => {
            put("axis", axis.to_string().into());
            put("ppm_per_k", (*ppm_per_k).into());
            put(
                &format!("reference_{}", place_unit(*axis)),
                place(*axis, *reference).into(),
            );
            put("column", column.clone().into());
            put("temperature", temperature_value(temperature));
        }
        Effect::Twist { per_m2 } => put("um_per_m2", (per_m2 * 1e6).into()),
        Effect::Sag {
            axis,
            direction,
            per_m2,
        } => {
            put("axis", axis.to_string().into());
            put("direction", direction.to_string().into());
            put("um_per_m2", (per_m2 * 1e6).into());
        }
        Effect::BallBarThermal {
            setup,
            ppm_per_k,
            temperature,
            column,
        } => {
            put("setup", setup.clone().into());
            put("ppm_per_k", (*ppm_per_k).into());
            if let Some(c) = column {
                put("column", c.clone().into());
            }
            put("temperature", temperature_value(temperature));
        }
        Effect::ServoLag { axis, lag_s } => {
            put("axis", axis.to_string().into());
            put("lag_ms", (lag_s * 1e3).into());
        }
        Effect::SetupCreep {
            setup,
            settle,
            tau_s,
        } => {
            put("setup", setup.clone().into());
            put("settle_um", floats(&settle.map(|v| v * 1e6)));
            put("tau_s", (*tau_s).into());
        }
        Effect::SpindleSpeed { rpm } => put("rpm", programme_value(rpm)),
        Effect::LostMotion {
            axis,
            lost_motion_low,
            lost_motion_high,
            approach,
        } => {
            put("axis", axis.to_string().into());
            let unit = small_unit(*axis);
            put(
                &format!("lost_motion_low_{unit}"),
                small(*lost_motion_low).into(),
            );
            put(
                &format!("lost_motion_high_{unit}"),
                small(*lost_motion_high).into(),
            );
            match approach {
                Approach::Carried => put("approach", "carried".into()),
                Approach::RandomPerRun { seed } => {
                    put("approach", "random-per-run".into());
                    // A TOML integer is an i64: the seed's bits.
                    put("seed", i64::from_ne_bytes(seed.to_ne_bytes()).into());
                }
            }
        }
        Effect::LateralPlay {
            axis,
            across,
            play,
            take_up,
        } => {
            put("axis", axis.to_string().into());
            put("across", floats(across));
            put("play_um", small(*play).into());
            put(
                &format!("take_up_{}", place_unit(*axis)),
                place(*axis, *take_up).into(),
            );
        }
        Effect::ReversalSpike {
            axis,
            height,
            recovery_s,
        } => {
            put("axis", axis.to_string().into());
            put(
                &format!("height_{}", small_unit(*axis)),
                small(*height).into(),
            );
            put("recovery_ms", (recovery_s * 1e3).into());
        }
        Effect::StickSlip {
            axis,
            height,
            slip_travel,
        } => {
            put("axis", axis.to_string().into());
            put(
                &format!("height_{}", small_unit(*axis)),
                small(*height).into(),
            );
            put(
                &format!("slip_travel_{}", place_unit(*axis)),
                place(*axis, *slip_travel).into(),
            );
        }
        Effect::GuidewayBump {
            axis,
            direction,
            centre,
            width,
            height,
        } => {
            put("axis", axis.to_string().into());
            put("direction", floats(direction));
            put("centre_mm", (centre * 1e3).into());
            put("width_mm", (width * 1e3).into());
            put("height_um", small(*height).into());
        }
        Effect::SpindleGrowth { sources } => {
            put("source", sources_value(sources, "gain_um", 1e6));
        }
        Effect::AxisLineDrift {
            parameter,
            per_k,
            temperature,
            column,
        } => {
            put("parameter", parameter.clone().into());
            let unit = if parameter
                .as_bytes()
                .get(1)
                .is_some_and(|b| b"ABC".contains(b))
            {
                "urad"
            } else {
                "um"
            };
            put(&format!("{unit}_per_k"), small(*per_k).into());
            if let Some(c) = column {
                put("column", c.clone().into());
            }
            put("temperature", temperature_value(temperature));
        }
        Effect::HeadRotationX {
            pivot_y,
            pivot_z,
            urad_per_k,
            temperature,
            column,
        } => {
            put("pivot_y_mm", (pivot_y * 1e3).into());
            put("pivot_z_mm", (pivot_z * 1e3).into());
            put("urad_per_k", (*urad_per_k).into());
            if let Some(c) = column {
                put("column", c.clone().into());
            }
            put("temperature", temperature_value(temperature));
        }
        Effect::AmbientStep {
            ambient_c,
            at_s,
            step_k,
            tau_s,
            shift_per_k,
            column,
        } => {
            put("ambient_c", (*ambient_c).into());
            put("at_s", (*at_s).into());
            put("step_k", (*step_k).into());
            put("tau_s", (*tau_s).into());
            put("shift_um_per_k", floats(&shift_per_k.map(|v| v * 1e6)));
            if let Some(c) = column {
                put("column", c.clone().into());
            }
        }
        Effect::TemperatureSensor {
            column,
            temperature,
        } => {
            put("column", column.clone().into());
            put("temperature", temperature_value(temperature));
        }
    }
    t
}

pub(super) fn floats(v: &[f64]) -> toml::Value {
    toml::Value::Array(v.iter().map(|&x| x.into()).collect())
}

pub(super) fn programme_value(p: &Programme) -> toml::Value {
    match p {
        Programme::Steps(steps) => {
            toml::Value::Array(steps.iter().map(|&(t, v)| floats(&[t, v])).collect())
        }
        Programme::SpindleKrpm => "spindle_krpm".into(),
    }
}

/// Heat sources as a list of tables, the gain under `gain_key` scaled by `scale`.
pub(super) fn sources_value(sources: &[HeatSource], gain_key: &str, scale: f64) -> toml::Value {
    toml::Value::Array(
        sources
            .iter()
            .map(|s| {
                let mut t = toml::Table::new();
                t.insert(gain_key.into(), (s.gain * scale).into());
                t.insert("tau_s".into(), s.tau_s.into());
                t.insert("power".into(), programme_value(&s.power));
                toml::Value::Table(t)
            })
            .collect(),
    )
}

pub(super) fn temperature_value(p: &TemperatureProgramme) -> toml::Value {
    let mut t = toml::Table::new();
    t.insert("ambient_c".into(), p.ambient_c.into());
    t.insert("drift_k_per_h".into(), p.drift_k_per_h.into());
    t.insert("rise".into(), sources_value(&p.rises, "gain_k", 1.0));
    toml::Value::Table(t)
}
