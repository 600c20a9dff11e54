//! The instruments by their physics: what each one reads at a pose of the actual machine.
//!
//! Readings come out in SI (m); the session writer turns them into the file's µm. Each
//! instrument sees the machine only through the actual and nominal tool poses in the workpiece
//! frame, and its own set-up: the manifest's nominal geometry plus the [`SetupOffsets`] by
//! which the real set-up differs from it.

use nalgebra::{Matrix4, Vector3};

use crate::machine::{Machine, rotation_of, translation_of};
use crate::truth::Truth;

/// How an R-test is mounted (FORMATS.md `setup.mount`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mount {
    /// Ball fixed to the table at `setup.ball` (workpiece frame), nest on the tool point with
    /// the tool frame's axes (FORMATS.md's default).
    BallOnTable,
    /// Ball on the tool point, nest fixed to the table at `setup.ball` with the workpiece
    /// frame's axes.
    BallInSpindle,
}

/// What a laser optic reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaserMode {
    /// Displacement of the moving optic along the beam.
    Linear,
    /// Displacement of the moving optic across the beam, along `sense`.
    Straightness,
}

/// An instrument and its nominal set-up, as the manifest states it (mm, workpiece frame).
#[derive(Clone, Debug, PartialEq)]
pub enum Instrument {
    RTest {
        ball_mm: [f64; 3],
        mount: Mount,
        /// Write `mount = "…"` into the manifest. `false` for a plugin that predates the key
        /// (it then means ball-in-spindle to mtcal's current R-test plugin, whatever FORMATS.md
        /// says about files without it): see the crate docs.
        write_mount_key: bool,
    },
    BallBar {
        pivot_mm: [f64; 3],
        length_mm: f64,
    },
    /// Beam fixed in the workpiece frame, moving optic on the tool side (`optic = "tool"`).
    Laser {
        mode: LaserMode,
        /// Beam (= travel) direction, workpiece frame (normalised when read).
        direction: [f64; 3],
        /// Straightness only: the direction the deviation is read in, across the beam.
        sense: [f64; 3],
        /// Moving optic relative to the tool point, tool frame, mm.
        optic_offset_mm: [f64; 3],
    },
    Tracer {
        station_mm: [f64; 3],
        reflector_mm: [f64; 3],
    },
}

/// How the real set-up differs from the manifest's (SI): the ball / nest / pivot / station
/// position (workpiece frame) and the tool length (positive: longer, the tool-side ball moves
/// back along the tool axis).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SetupOffsets {
    pub position: Vector3<f64>,
    pub tool_length: f64,
}

impl Instrument {
    pub fn plugin_name(&self) -> &'static str {
        match self {
            Instrument::RTest { .. } => "rtest",
            Instrument::BallBar { .. } => "ballbar",
            Instrument::Laser { .. } => "laser",
            Instrument::Tracer { .. } => "tracer",
        }
    }

    /// The reading columns FORMATS.md gives the instrument.
    pub fn channels(&self) -> &'static [&'static str] {
        match self {
            Instrument::RTest { .. } => &["dx", "dy", "dz"],
            Instrument::BallBar { .. } => &["dr"],
            Instrument::Laser { .. } | Instrument::Tracer { .. } => &["d"],
        }
    }

    /// The noise-free readings (SI) of one run over `poses` (SI, machine order).
    ///
    /// Laser and tracer are relative instruments: they are zeroed at the run's first sample,
    /// so their readings are the change since then minus the nominal change.
    pub fn readings(
        &self,
        machine: &Machine,
        truth: &Truth,
        poses: &[Vec<f64>],
        off: &SetupOffsets,
    ) -> Vec<Vec<f64>> {
        let actual: Vec<Matrix4<f64>> = poses
            .iter()
            .map(|q| machine.tool_in_workpiece(q, Some(truth)))
            .collect();
        let nominal = || poses.iter().map(|q| machine.tool_in_workpiece(q, None));
        // The tool-side ball (spindle ball, nest centre) for a tool longer by δℓ.
        let spindle_point =
            |m: &Matrix4<f64>| translation_of(m) - rotation_of(m) * Vector3::z() * off.tool_length;
        match self {
            Instrument::RTest { ball_mm, mount, .. } => {
                let fixed = mm(ball_mm) + off.position;
                actual
                    .iter()
                    .map(|m| {
                        let d = match mount {
                            // Ball on the table, nest in the spindle: along the nest's axes,
                            // which are the tool frame's.
                            Mount::BallOnTable => {
                                rotation_of(m).transpose() * (fixed - spindle_point(m))
                            }
                            // Ball in the spindle, nest on the table with the workpiece axes.
                            Mount::BallInSpindle => spindle_point(m) - fixed,
                        };
                        vec![d.x, d.y, d.z]
                    })
                    .collect()
            }
            Instrument::BallBar {
                pivot_mm,
                length_mm,
            } => {
                let pivot = mm(pivot_mm) + off.position;
                actual
                    .iter()
                    .map(|m| vec![(spindle_point(m) - pivot).norm() - length_mm * 1e-3])
                    .collect()
            }
            Instrument::Laser {
                mode,
                direction,
                sense,
                optic_offset_mm,
            } => {
                let a = mm(optic_offset_mm);
                let read_along = match mode {
                    LaserMode::Linear => Vector3::from(*direction).normalize(),
                    LaserMode::Straightness => {
                        // The sense as the instrument aligns it: across the beam.
                        let n = Vector3::from(*direction).normalize();
                        let s = Vector3::from(*sense);
                        (s - n * n.dot(&s)).normalize()
                    }
                };
                // Deviation of the optic from its nominal position, read along the measuring
                // direction, relative to the datum (first sample).
                let dev: Vec<f64> = actual
                    .iter()
                    .zip(nominal())
                    .map(|(m, n)| {
                        let p_minus_p0 = (translation_of(m) - translation_of(&n))
                            + (rotation_of(m) - rotation_of(&n)) * a;
                        read_along.dot(&p_minus_p0)
                    })
                    .collect();
                dev.iter().map(|d| vec![d - dev[0]]).collect()
            }
            Instrument::Tracer {
                station_mm,
                reflector_mm,
            } => {
                let s0 = mm(station_mm);
                let r = mm(reflector_mm);
                // |x − s| − |x₀ − s₀| from the small differences, so that the µm keep their
                // digits although both distances are about a metre.
                let dev: Vec<f64> = actual
                    .iter()
                    .zip(nominal())
                    .map(|(m, n)| {
                        let x_minus_x0 = (translation_of(m) - translation_of(&n))
                            + (rotation_of(m) - rotation_of(&n)) * r;
                        let b = translation_of(&n) + rotation_of(&n) * r - s0;
                        let a = b + x_minus_x0 - off.position;
                        (a - b).dot(&(a + b)) / (a.norm() + b.norm())
                    })
                    .collect();
                dev.iter().map(|d| vec![d - dev[0]]).collect()
            }
        }
    }

    /// The set-up table of the manifest (TOML lines), `sigma` the σ to state (channel units,
    /// `None`: the plugin's default).
    pub fn setup_toml(&self, sigma_um: Option<f64>) -> String {
        let v = |x: &[f64; 3]| format!("[{:?}, {:?}, {:?}]", x[0], x[1], x[2]);
        let mut s = match self {
            Instrument::RTest {
                ball_mm,
                mount,
                write_mount_key,
            } => {
                let mut s = format!("ball = {}\n", v(ball_mm));
                if *write_mount_key {
                    let m = match mount {
                        Mount::BallOnTable => "ball-on-table",
                        Mount::BallInSpindle => "ball-in-spindle",
                    };
                    s.push_str(&format!("mount = \"{m}\"\n"));
                }
                s
            }
            Instrument::BallBar {
                pivot_mm,
                length_mm,
            } => format!("pivot = {}\nlength = {length_mm:?}\n", v(pivot_mm)),
            Instrument::Laser {
                mode,
                direction,
                sense,
                optic_offset_mm,
            } => {
                let mut s = format!(
                    "mode = \"{}\"\ndirection = {}\noptic_offset = {}\n",
                    match mode {
                        LaserMode::Linear => "linear",
                        LaserMode::Straightness => "straightness",
                    },
                    v(direction),
                    v(optic_offset_mm)
                );
                if *mode == LaserMode::Straightness {
                    s.push_str(&format!("sense = {}\n", v(sense)));
                }
                s
            }
            Instrument::Tracer {
                station_mm,
                reflector_mm,
            } => format!(
                "station = {}\nreflector = {}\n",
                v(station_mm),
                v(reflector_mm)
            ),
        };
        if let Some(sig) = sigma_um {
            s.push_str(&format!("sigma_um = {sig:?}\n"));
        }
        s
    }
}

fn mm(v: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0] * 1e-3, v[1] * 1e-3, v[2] * 1e-3)
}
