//! The instruments by their physics: what each one reads at a pose of the actual machine.
//!
//! Readings come out in SI (m); the session writer turns them into the file's µm. Each
//! instrument sees the machine only through the actual and nominal tool poses in the workpiece
//! frame, and its own set-up: the manifest's nominal geometry plus the [`SetupOffsets`] by
//! which the real set-up differs from it.

use nalgebra::{Matrix3, Matrix4, Vector3};

use crate::machine::{Machine, log_rotation, rotation_of, translation_of};
use crate::truth::Truth;

/// The actual tool pose at sample `k` of a run commanded to `q`: what an instrument reads. The
/// physical effects' state at each sample gives it (`crate::effects`); without effects it is
/// the machine with its truth's geometric errors ([`GeometricOnly`]).
pub trait ActualPoses {
    fn actual_pose(&self, machine: &Machine, truth: &Truth, k: usize, q: &[f64]) -> Matrix4<f64>;
}

/// No physical effects: the truth's geometric errors only.
#[derive(Clone, Copy, Debug)]
pub struct GeometricOnly;

impl ActualPoses for GeometricOnly {
    fn actual_pose(&self, machine: &Machine, truth: &Truth, _k: usize, q: &[f64]) -> Matrix4<f64> {
        machine.tool_in_workpiece(q, Some(truth))
    }
}

/// A shared set-up of the manifest (`[setup.<name>]`).
#[derive(Clone, Debug)]
pub struct SetupPlan {
    pub name: String,
    pub instrument: Instrument,
}

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

/// What a laser optic reads (the plugin's `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaserMode {
    /// Displacement of the moving optic along the beam, one axis moving (ISO 230-2).
    Linear,
    /// Displacement of the moving optic across the beam, along `across` (the key `sense`).
    Straightness,
    /// Angular optics (pitch / yaw): the rotation of the tool relative to the workpiece, beyond
    /// the commanded one, about `across` (the key `about`), in rad (µrad in the file). The
    /// interferometer reads the difference of two parallel beams' path lengths over the spacing
    /// of the moving optic's two reflectors: the optic's turn about the axis across both beams.
    /// Modelled as that component of the rotation vector of the actual tool orientation
    /// relative to the nominal one, in the workpiece frame where the beams are fixed (for
    /// error motions of some 10 µrad the sine of the path difference differs from it by parts
    /// in 10¹¹); where on the tool the optic sits does not matter.
    Angular,
    /// Displacement of the moving optic along a beam through the work volume, several linear
    /// axes moving together (ISO 230-6 body / face diagonal): what [`LaserMode::Linear`] reads,
    /// along a beam that no single axis follows.
    Diagonal,
    /// The same beam and reading, the machine moving one axis at a time between the targets
    /// (ISO 230-6 step diagonal): the optic also moves across the beam, and reads the
    /// deviations of each axis' steps along the diagonal.
    StepDiagonal,
}

impl LaserMode {
    /// The plugin's `mode` value.
    pub fn key(self) -> &'static str {
        match self {
            LaserMode::Linear => "linear",
            LaserMode::Straightness => "straightness",
            LaserMode::Angular => "angular",
            LaserMode::Diagonal => "diagonal",
            LaserMode::StepDiagonal => "step-diagonal",
        }
    }

    /// Whether the mode reads a length along the beam (`linear`, `diagonal`, `step-diagonal`).
    pub fn is_length(self) -> bool {
        matches!(
            self,
            LaserMode::Linear | LaserMode::Diagonal | LaserMode::StepDiagonal
        )
    }
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
        /// A direction across the beam (workpiece frame, normalised when read): the straightness
        /// deviation's `sense`, the angular optics' axis `about`; unused (and not written) in
        /// the length modes.
        across: [f64; 3],
        /// Moving optic relative to the tool point, tool frame, mm (not written in angular
        /// mode, which does not depend on it).
        optic_offset_mm: [f64; 3],
    },
    Tracer {
        station_mm: [f64; 3],
        reflector_mm: [f64; 3],
    },
    /// Fixed displacement sensors in a fixture on the table against a mandrel (or ball) on the
    /// tool point, the machine held at one position (ISO 230-3 thermal tests). Each sensor
    /// reads how far the point of the mandrel it touches is from where the sensor was set
    /// (zeroed), along its direction: the nominal mandrel at `position_mm` with the nominal tool
    /// orientation of the run's first sample.
    Displacement {
        /// The nominal tool point where the sensors touch it, mm, workpiece frame.
        position_mm: [f64; 3],
        /// The sensors, in the order given (the file's columns follow it).
        sensors: Vec<DisplacementSensor>,
    },
    /// A ball or hole plate probed by the machine: each sample is one feature of one placement
    /// (its label), the reading the axis positions X, Y, Z at which the machine's actual tool
    /// point sits on the feature's true centre (the measured centre, machine coordinates).
    Artefact {
        /// Feature names and calibrated positions in the plate's own frame, mm: `[x, y]` (a 2-D
        /// plate: only X, Y are measured) or `[x, y, z]`.
        features: Vec<(String, Vec<f64>)>,
        placements: Vec<PlatePlacement>,
        probed: Probed,
    },
}

/// Where a displacement sensor reads (FORMATS.md `setup.sensors.<sensor>`), in the workpiece
/// frame, in which the sensor fixture on the table is fixed.
#[derive(Clone, Debug, PartialEq)]
pub enum SensorDirection {
    /// An axis of the workpiece frame, written as a letter (`"X"`, `"-Y"`).
    Axis { letter: char, negative: bool },
    /// A vector, written as given, normalised for the physics.
    Vector([f64; 3]),
    /// No known direction (`{}`): a sensor the model treats on its own. It reads nothing of the
    /// machine here (its zero offset is 0).
    Unknown,
}

/// One fixed displacement sensor (eddy-current or capacitive probe) against the mandrel.
#[derive(Clone, Debug, PartialEq)]
pub struct DisplacementSensor {
    /// The column is `d_<name>`.
    pub name: String,
    /// The direction in which a displacement of the touched point reads positive.
    pub direction: SensorDirection,
    /// Where the sensor touches the mandrel, from the tool point in the tool frame, mm
    /// (`None`: at the tool point, the key is not written).
    pub at_mm: Option<[f64; 3]>,
}

impl DisplacementSensor {
    /// Unit measuring direction, workpiece frame (`None` without one).
    fn unit(&self) -> Option<Vector3<f64>> {
        match &self.direction {
            SensorDirection::Axis { letter, negative } => {
                let mut n = match letter {
                    'X' => Vector3::x(),
                    'Y' => Vector3::y(),
                    'Z' => Vector3::z(),
                    other => panic!("sensor {}: no axis {other}", self.name),
                };
                if *negative {
                    n = -n;
                }
                Some(n)
            }
            SensorDirection::Vector(v) => Some(Vector3::from(*v).normalize()),
            SensorDirection::Unknown => None,
        }
    }

    /// The manifest value of the sensor.
    fn toml_value(&self) -> String {
        let dir = match &self.direction {
            SensorDirection::Axis { letter, negative } => {
                Some(format!("\"{}{letter}\"", if *negative { "-" } else { "" }))
            }
            SensorDirection::Vector(v) => Some(format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])),
            SensorDirection::Unknown => None,
        };
        match (dir, self.at_mm) {
            (Some(d), None) => d,
            (None, _) => "{}".into(),
            (Some(d), Some(a)) => {
                format!(
                    "{{ direction = {d}, at = [{:?}, {:?}, {:?}] }}",
                    a[0], a[1], a[2]
                )
            }
        }
    }
}

/// One placement of an artefact plate on the table.
#[derive(Clone, Debug, PartialEq)]
pub struct PlatePlacement {
    pub name: String,
    /// Where the plate's origin sits, in axis coordinates (mm): the point the nominal tool point
    /// reaches with X, Y, Z at these values and every other axis at zero.
    pub origin_mm: [f64; 3],
    /// The plate turned about the workpiece frame's +Z, degrees.
    pub rotation_deg: f64,
    /// The plate turned over about its own X axis.
    pub flipped: bool,
}

/// The axis positions an artefact run's file gives for each probed feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Probed {
    /// The commanded positions of the plan (e.g. the features' nominal centres).
    Commanded,
    /// The position the probing cycle reports: the measured centre itself.
    Reported,
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
            Instrument::Displacement { .. } => "displacement",
            Instrument::Artefact { .. } => "artefact",
        }
    }

    /// The reading columns FORMATS.md gives the instrument.
    pub fn channels(&self) -> Vec<String> {
        let fixed: &[&str] = match self {
            Instrument::RTest { .. } => &["dx", "dy", "dz"],
            Instrument::BallBar { .. } => &["dr"],
            Instrument::Laser { .. } | Instrument::Tracer { .. } => &["d"],
            Instrument::Displacement { sensors, .. } => {
                return sensors.iter().map(|s| format!("d_{}", s.name)).collect();
            }
            Instrument::Artefact { features, .. } => {
                let dim = features.first().map_or(2, |f| f.1.len());
                &["x", "y", "z"][..dim]
            }
        };
        fixed.iter().map(|c| c.to_string()).collect()
    }

    /// The text columns of a run (FORMATS.md: the artefact's `feature`).
    pub fn label_columns(&self) -> &'static [&'static str] {
        match self {
            Instrument::Artefact { .. } => &["feature"],
            _ => &[],
        }
    }

    /// File units per SI unit of the readings: µm (1e6), or mm (1e3) for the artefact, whose
    /// readings are positions.
    pub fn file_per_si(&self) -> f64 {
        match self {
            Instrument::Artefact { .. } => 1e3,
            _ => 1e6,
        }
    }

    /// The axis positions (SI) the run file gives: the commanded `poses`, except for an
    /// artefact whose probing cycle reports the measured centre ([`Probed::Reported`]) on the
    /// actual machine `states` gives ([`GeometricOnly`] without effects).
    pub fn recorded_poses<P: ActualPoses + ?Sized>(
        &self,
        machine: &Machine,
        truth: &Truth,
        poses: &[Vec<f64>],
        labels: &[String],
        off: &SetupOffsets,
        states: &P,
    ) -> Vec<Vec<f64>> {
        match self {
            Instrument::Artefact {
                probed: Probed::Reported,
                ..
            } => self.probe_centres(machine, truth, poses, labels, off, states),
            _ => poses.to_vec(),
        }
    }

    /// The noise-free readings (SI) of one run over `poses` (SI, machine order), the actual
    /// pose of every sample the one `states` gives: the effects' ([`crate::effects`]), which
    /// every instrument reads alike, or [`GeometricOnly`] without effects.
    ///
    /// Laser and tracer are relative instruments: they are zeroed at the run's first sample,
    /// so their readings are the change since then minus the nominal change.
    pub fn readings<P: ActualPoses + ?Sized>(
        &self,
        machine: &Machine,
        truth: &Truth,
        poses: &[Vec<f64>],
        labels: &[String],
        off: &SetupOffsets,
        states: &P,
    ) -> Vec<Vec<f64>> {
        let actual: Vec<Matrix4<f64>> = poses
            .iter()
            .enumerate()
            .map(|(k, q)| states.actual_pose(machine, truth, k, q))
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
                across,
                optic_offset_mm,
            } => {
                let a = mm(optic_offset_mm);
                let n = Vector3::from(*direction).normalize();
                // The across-beam direction as the instrument is aligned: perpendicular to it
                // (straightness and angular modes only).
                let across = || {
                    let s = Vector3::from(*across);
                    (s - n * n.dot(&s)).normalize()
                };
                // Deviation from nominal, relative to the datum (first sample).
                let dev: Vec<f64> = actual
                    .iter()
                    .zip(nominal())
                    .map(|(m, n0)| {
                        if *mode == LaserMode::Angular {
                            // The tool's rotation beyond the commanded one, in the workpiece
                            // frame (where the beam and the fixed optic are), about `about`.
                            let r_rel = rotation_of(m) * rotation_of(&n0).transpose();
                            return across().dot(&log_rotation(&r_rel));
                        }
                        // The optic's deviation from its nominal position, read along the beam
                        // (length modes) or across it (straightness).
                        let read_along = if mode.is_length() { n } else { across() };
                        let p_minus_p0 = (translation_of(m) - translation_of(&n0))
                            + (rotation_of(m) - rotation_of(&n0)) * a;
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
            Instrument::Displacement {
                position_mm,
                sensors,
            } => {
                // Where each sensor reads zero: the touched point of the nominal mandrel at the
                // stated position, oriented as the nominal tool at the held position, moved with
                // the fixture by its misplacement.
                let r_set = poses.first().map_or_else(Matrix3::identity, |q| {
                    rotation_of(&machine.tool_in_workpiece(q, None))
                });
                // Per sensor with a direction: (direction, touched point on the mandrel, where
                // it reads zero).
                type Zeroed = Option<(Vector3<f64>, Vector3<f64>, Vector3<f64>)>;
                let zero: Vec<Zeroed> = sensors
                    .iter()
                    .map(|s| {
                        s.unit().map(|n| {
                            let a = s.at_mm.as_ref().map_or_else(Vector3::zeros, mm);
                            (n, a, mm(position_mm) + off.position + r_set * a)
                        })
                    })
                    .collect();
                actual
                    .iter()
                    .map(|m| {
                        let tip = spindle_point(m);
                        zero.iter()
                            .map(|z| match z {
                                Some((n, a, set)) => n.dot(&((tip - set) + rotation_of(m) * a)),
                                None => 0.0,
                            })
                            .collect()
                    })
                    .collect()
            }
            Instrument::Artefact { .. } => {
                let centres = self.probe_centres(machine, truth, poses, labels, off, states);
                let dim = self.channels().len();
                let xyz = xyz_indices(machine);
                centres
                    .iter()
                    .map(|q| xyz[..dim].iter().map(|&i| q[i]).collect())
                    .collect()
            }
        }
    }

    /// Artefact: for each sample, the axis positions (the sample's other axes kept) at which the
    /// actual tool point sits on the true centre of the labelled feature, in the measured
    /// coordinates (X, Y on a 2-D plate, Z kept; X, Y, Z on a 3-D one). Newton on the actual
    /// chain with the nominal chain's Jacobian; with effects, the actual chain of the sample's
    /// state (lost motion as the approach to the commanded position left it).
    fn probe_centres<P: ActualPoses + ?Sized>(
        &self,
        machine: &Machine,
        truth: &Truth,
        poses: &[Vec<f64>],
        labels: &[String],
        off: &SetupOffsets,
        states: &P,
    ) -> Vec<Vec<f64>> {
        let Instrument::Artefact {
            features,
            placements,
            ..
        } = self
        else {
            return poses.to_vec();
        };
        assert_eq!(poses.len(), labels.len(), "one feature label per sample");
        let dim = self.channels().len();
        let xyz = xyz_indices(machine);
        let n = machine.n_axes();
        let tool_point = |q: &[f64], k: usize| {
            let m = states.actual_pose(machine, truth, k, q);
            translation_of(&m) - rotation_of(&m) * Vector3::z() * off.tool_length
        };
        // The nominal tool point's motion per metre of X, Y, Z (other axes at 0).
        let zero = vec![0.0; n];
        let p0 = translation_of(&machine.tool_in_workpiece(&zero, None));
        let mut jac = Matrix3::zeros();
        for c in 0..3 {
            let mut q = zero.clone();
            q[xyz[c]] = 0.1;
            jac.set_column(
                c,
                &((translation_of(&machine.tool_in_workpiece(&q, None)) - p0) / 0.1),
            );
        }
        // The plate's pose in the workpiece frame, per placement.
        let frames: Vec<(Vector3<f64>, Matrix3<f64>)> = placements
            .iter()
            .map(|p| {
                let mut q = zero.clone();
                for c in 0..3 {
                    q[xyz[c]] = p.origin_mm[c] * 1e-3;
                }
                let origin = translation_of(&machine.tool_in_workpiece(&q, None));
                let turn = crate::machine::axis_angle(&Vector3::z(), p.rotation_deg.to_radians());
                let over = if p.flipped {
                    Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
                } else {
                    Matrix3::identity()
                };
                (origin + off.position, turn * over)
            })
            .collect();
        poses
            .iter()
            .zip(labels)
            .enumerate()
            .map(|(k, (q0, label))| {
                let (pi, fname) = match label.split_once('/') {
                    Some((p, f)) => (
                        placements
                            .iter()
                            .position(|x| x.name == p)
                            .unwrap_or_else(|| panic!("no placement {p}")),
                        f,
                    ),
                    None => (0, label.as_str()),
                };
                let f = &features
                    .iter()
                    .find(|(name, _)| name == fname)
                    .unwrap_or_else(|| panic!("no feature {fname}"))
                    .1;
                let f_plate = Vector3::new(f[0], f[1], f.get(2).copied().unwrap_or(0.0)) * 1e-3;
                let (origin, r) = &frames[pi];
                let centre = origin + r * f_plate;
                let mut q = q0.clone();
                for _ in 0..30 {
                    let miss = centre - tool_point(&q, k);
                    // Only the measured coordinates are solved for: X, Y (and Z on a 3-D plate).
                    let step = if dim == 3 {
                        jac.try_inverse().expect("X, Y, Z span space") * miss
                    } else {
                        let j2 = jac.fixed_view::<2, 2>(0, 0).into_owned();
                        let s2 = j2.try_inverse().expect("X, Y span the plane")
                            * miss.fixed_rows::<2>(0).into_owned();
                        Vector3::new(s2.x, s2.y, 0.0)
                    };
                    for c in 0..dim {
                        q[xyz[c]] += step[c];
                    }
                    if step.norm() < 1e-17 {
                        break;
                    }
                }
                q
            })
            .collect()
    }

    /// The set-up table of the manifest (TOML lines), `sigma` the σ to state (channel units,
    /// `None`: the plugin's default): `sigma_um`, or `sigma_urad` for angular laser optics.
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
                across,
                optic_offset_mm,
            } => {
                let mut s = format!("mode = \"{}\"\ndirection = {}\n", mode.key(), v(direction));
                match mode {
                    LaserMode::Straightness => s.push_str(&format!("sense = {}\n", v(across))),
                    LaserMode::Angular => s.push_str(&format!("about = {}\n", v(across))),
                    _ => {}
                }
                if *mode != LaserMode::Angular {
                    s.push_str(&format!("optic_offset = {}\n", v(optic_offset_mm)));
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
            Instrument::Displacement {
                position_mm,
                sensors,
            } => {
                let list: Vec<String> = sensors
                    .iter()
                    .map(|s| format!("{} = {}", toml_key(&s.name), s.toml_value()))
                    .collect();
                format!(
                    "position = {}\nsensors = {{ {} }}\n",
                    v(position_mm),
                    list.join(", ")
                )
            }
            Instrument::Artefact {
                features,
                placements,
                ..
            } => {
                let feats: Vec<String> = features
                    .iter()
                    .map(|(name, p)| {
                        let xs: Vec<String> = p.iter().map(|x| format!("{x:?}")).collect();
                        format!("{} = [{}]", toml_key(name), xs.join(", "))
                    })
                    .collect();
                let places: Vec<String> = placements
                    .iter()
                    .map(|p| {
                        format!(
                            "{} = {{ origin = {}, rotation_deg = {:?}, flipped = {} }}",
                            toml_key(&p.name),
                            v(&p.origin_mm),
                            p.rotation_deg,
                            p.flipped
                        )
                    })
                    .collect();
                format!(
                    "features = {{ {} }}\nplacements = {{ {} }}\n",
                    feats.join(", "),
                    places.join(", ")
                )
            }
        };
        if let Some(sig) = sigma_um {
            // An angular reading's σ is stated in its own unit (µrad), the others' in µm.
            let key = match self {
                Instrument::Laser {
                    mode: LaserMode::Angular,
                    ..
                } => "sigma_urad",
                _ => "sigma_um",
            };
            s.push_str(&format!("{key} = {sig:?}\n"));
        }
        s
    }
}

/// A TOML key: bare when it can be (letters, digits, `_`, `-`), quoted otherwise (a feature
/// name such as `c.5` would otherwise be a dotted key).
fn toml_key(name: &str) -> String {
    if !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        name.to_string()
    } else {
        format!("{name:?}")
    }
}

/// The indices of the linear axes X, Y, Z in the machine's order.
fn xyz_indices(machine: &Machine) -> [usize; 3] {
    ['X', 'Y', 'Z'].map(|l| {
        machine
            .index(l)
            .unwrap_or_else(|| panic!("an artefact needs an {l} axis"))
    })
}

fn mm(v: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0] * 1e-3, v[1] * 1e-3, v[2] * 1e-3)
}
