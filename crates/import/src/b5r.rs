//! `renishaw-b5r`: Renishaw QC10/QC20 ball-bar runs (`.b5r`, XML) into ball-bar runs.
//!
//! No vendor specification and no real file are public. What public readers of the format
//! agree on, and what is read here (each element found by name anywhere in the document, so
//! their order and nesting do not matter):
//!
//! - `<READINGS>`: the run's readings, separated by blanks; one run per `<READINGS>`, its
//!   direction in the sibling `<RUN_DIRECTION>` (`CW`/`CCW`), its own results in sibling
//!   `<FEATURE NAME="…">` elements. A `DT` attribute on `<READINGS>` (`UT_LENGTH_UM`,
//!   `UT_LENGTH_MM`, `UT_LENGTH_NM`) gives their unit; a `COUNT` attribute or a sibling
//!   `<NUMBER_OF_READINGS>`, when present, their number, which must match.
//! - The plane: `<PLANE TEST_PLANE="XY" VIEW="+A+B">` (or `<TEST_PLANE>XY</TEST_PLANE>`), the
//!   axes `<A_AXIS_NAME>`/`<B_AXIS_NAME>`; the circle's angle runs from +A towards +B, signs
//!   flipped by `VIEW` (`+A-B`: from +A towards −B).
//! - `<NOMINAL_LENGTH>` (mm, the radius), `<PROGRAMMED_FEEDRATE>` (mm/min),
//!   `<MACHINE_TESTED NAME="…">`, `<DATE_STARTED>`.
//! - `<ANALYSIS NAME="RENISHAW_DIAGNOSTICS">` with `<FEATURE NAME="AF_…" DT="…">value</FEATURE>`:
//!   the software's diagnostics, kept in the run's `[run.b5r]` table for comparison.
//!
//! What the public readers do not settle is assumed, said on the card and overridable:
//! the readings' unit without `DT` (µm, `--reading-unit`), that they are the bar length minus
//! its nominal length (positive = longer), the angle of the first reading (0°, `--start-deg`),
//! the arc measured (360°, `--sweep-deg`), the overshoot arcs the readings include before and
//! after it (0°, `--overshoot-deg`), the spacing (the whole arc shared evenly among the
//! readings, the closing angle not repeated: `(sweep + 2·overshoot)/N`, `--step-deg`), the
//! radius and feed when the file lacks them (`--radius-mm`, required then; `--feed`, else the
//! readings are 1 s apart) and the circle's centre (the axis positions `--center`, default 0).
//!
//! Each run becomes a run of the instrument that records circle runs (the ball-bar; its plugin
//! declares the reading, the range and the set-up, `mtcal_instrument::capability::CircleRuns`):
//! the machine's axes along the circle (the linear axes
//! placing the tool point at `pivot + r·(cos φ·a + sin φ·b)`, rotary axes held at their
//! `--center` values), `dr` in µm, `t` = arc length / feed. Runs of one plane and radius share
//! a set-up `[setup.b5r-<plane>]` (the same pivot for the clockwise and counter-clockwise run).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mtcal_kinematics::AxisKind;
use mtcal_kinematics::ik::{follow_point, forward_kinematics};
use mtcal_located::{Located, Location, Source};
use mtcal_plugins::capability::{CircleRuns, declared_once};
use mtcal_session::{Manifest, ManifestRun, RunTable, RunUse, SetupRef};
use nalgebra::Vector3;
use roxmltree::{Document, Node};

use crate::ImportError;
use crate::session::{
    check_limits, entry_text, is_run_name, load_machine, machine_arg, machine_in_manifest,
    refuse_existing, write_all,
};

/// The unit of the raw readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadingUnit {
    Nm,
    Um,
    Mm,
}

impl ReadingUnit {
    /// µm per unit.
    pub fn to_um(self) -> f64 {
        match self {
            ReadingUnit::Nm => 1e-3,
            ReadingUnit::Um => 1.0,
            ReadingUnit::Mm => 1e3,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            ReadingUnit::Nm => "nm",
            ReadingUnit::Um => "um",
            ReadingUnit::Mm => "mm",
        }
    }

    /// `um`, `mm`, `nm` (`µm` too).
    pub fn parse(s: &str) -> Option<ReadingUnit> {
        match s.trim().to_ascii_lowercase().as_str() {
            "um" | "µm" | "micron" | "microns" => Some(ReadingUnit::Um),
            "mm" => Some(ReadingUnit::Mm),
            "nm" => Some(ReadingUnit::Nm),
            _ => None,
        }
    }

    /// The unit a `DT` attribute names.
    fn from_dt(dt: &str) -> Option<ReadingUnit> {
        match dt.trim().to_ascii_uppercase().as_str() {
            "UT_LENGTH_UM" => Some(ReadingUnit::Um),
            "UT_LENGTH_MM" => Some(ReadingUnit::Mm),
            "UT_LENGTH_NM" => Some(ReadingUnit::Nm),
            _ => None,
        }
    }
}

/// What to import, and into which session; every `Option` the file or an assumption fills.
#[derive(Debug, Clone)]
pub struct B5rOptions<'a> {
    pub files: &'a [PathBuf],
    /// The session folder; created with its manifest when it has no `session.toml`.
    pub session: &'a Path,
    /// A URDF path or topology code; required for a new session, refused for an existing one.
    pub machine: Option<&'a str>,
    /// A prefix of the run names, `<name>-<plane>-<cw|ccw>` (default: each file's stem, with
    /// `-cw`/`-ccw` when a file holds several runs).
    pub name: Option<&'a str>,
    /// The axis positions at the circle's centre, `X=0,Y=0,Z=-200` (mm / degrees; default 0).
    pub center: Option<&'a str>,
    pub radius_mm: Option<f64>,
    pub reading_unit: Option<ReadingUnit>,
    pub start_deg: Option<f64>,
    pub sweep_deg: Option<f64>,
    pub overshoot_deg: Option<f64>,
    pub step_deg: Option<f64>,
    pub feed_mm_per_min: Option<f64>,
}

/// A `<FEATURE>`: its `NAME`, its value (a number, or the text when it is not one) and `DT`.
#[derive(Debug, Clone, PartialEq)]
pub struct Feature {
    pub name: String,
    pub value: FeatureValue,
    pub unit: Option<String>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum FeatureValue {
    Number(f64),
    Text(String),
}

impl std::fmt::Display for Feature {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.value {
            FeatureValue::Number(v) => write!(f, "{} = {v}", self.name)?,
            FeatureValue::Text(t) => write!(f, "{} = \"{t}\"", self.name)?,
        }
        match &self.unit {
            Some(u) => write!(f, " {u}"),
            None => Ok(()),
        }
    }
}

/// One `<READINGS>` with what its siblings say.
#[derive(Debug, Clone, PartialEq)]
pub struct B5rRun {
    /// Counter-clockwise (from +A towards +B).
    pub ccw: bool,
    /// As written in the file, in the file's (or the assumed) unit.
    pub readings: Vec<f64>,
    /// The unit its `DT` attribute names.
    pub dt_unit: Option<ReadingUnit>,
    /// The run's own `<FEATURE>`s.
    pub features: Vec<Feature>,
    /// Where each reading is (for messages): its location in the file.
    pub at: Vec<Location>,
}

/// The plane a file names: its axes `a`, `b` (letters) and the view's signs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct B5rPlane {
    pub a: char,
    pub b: char,
    /// +1 or −1: the angle runs from `sign_a`·A towards `sign_b`·B.
    pub sign_a: f64,
    pub sign_b: f64,
    /// Whether `VIEW` gave the signs (else +A+B is assumed).
    pub view_read: bool,
}

impl B5rPlane {
    /// `XY`, `ZX`… as the file's axes give it.
    pub fn name(&self) -> String {
        format!("{}{}", self.a, self.b)
    }

    fn view(&self) -> String {
        let s = |v: f64| if v > 0.0 { '+' } else { '-' };
        format!("{}A{}B", s(self.sign_a), s(self.sign_b))
    }
}

/// A `.b5r` file as read.
#[derive(Debug, Clone, PartialEq)]
pub struct B5rFile {
    pub path: PathBuf,
    pub plane: B5rPlane,
    pub radius_mm: Option<f64>,
    pub feed_mm_per_min: Option<f64>,
    pub machine_tested: Option<String>,
    pub date_started: Option<String>,
    /// `<ANALYSIS NAME="RENISHAW_DIAGNOSTICS">`'s features.
    pub diagnostics: Vec<Feature>,
    pub runs: Vec<B5rRun>,
}

/// Reads a `.b5r` file (nothing is assumed yet: see [`import_b5r`]).
pub fn read_b5r(path: &Path) -> Result<B5rFile, ImportError> {
    let src = Source::read(path)?;
    let doc = Document::parse(&src.text).map_err(|e| {
        let pos = e.pos();
        // roxmltree appends the position; the location already says it.
        let message = e.to_string().replace(&format!(" at {pos}"), "");
        ImportError::Invalid(Located {
            at: Location::at(path, pos.row as usize, pos.col as usize),
            message: format!("expected XML (a ball-bar .b5r file), found: {message}"),
        })
    })?;
    read_document(&src, &doc)
}

fn read_document(src: &Source, doc: &Document<'_>) -> Result<B5rFile, ImportError> {
    let root = doc.root_element();
    let plane = plane(src, root)?;
    let radius_mm = positive_number(src, find(root, "NOMINAL_LENGTH"), "a bar length in mm")?;
    let feed_mm_per_min = positive_number(
        src,
        find(root, "PROGRAMMED_FEEDRATE"),
        "a feed rate in mm/min",
    )?;
    let machine_tested = find(root, "MACHINE_TESTED").and_then(|n| {
        n.attribute("NAME")
            .or_else(|| n.text())
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_string)
    });
    let date_started = find(root, "DATE_STARTED")
        .and_then(|n| n.text())
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_string);
    let diagnostics = root
        .descendants()
        .filter(|n| n.has_tag_name("ANALYSIS"))
        .filter(|n| n.attribute("NAME") == Some("RENISHAW_DIAGNOSTICS"))
        .flat_map(|n| n.children().filter(|c| c.has_tag_name("FEATURE")))
        .map(feature)
        .collect();
    let readings: Vec<Node<'_, '_>> = root
        .descendants()
        .filter(|n| n.has_tag_name("READINGS"))
        .collect();
    if readings.is_empty() {
        return Err(src
            .at(
                root.range(),
                format!(
                    "expected a <READINGS> element (the ball-bar's readings), found none in \
                     <{}>",
                    root.tag_name().name()
                ),
            )
            .into());
    }
    let runs = readings
        .into_iter()
        .map(|n| run(src, n))
        .collect::<Result<_, _>>()?;
    Ok(B5rFile {
        path: src.path.clone(),
        plane,
        radius_mm,
        feed_mm_per_min,
        machine_tested,
        date_started,
        diagnostics,
        runs,
    })
}

/// The first element named `name` in document order.
fn find<'a, 'i>(root: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    root.descendants().find(|n| n.has_tag_name(name))
}

/// The element's text as a number above 0 (`None` when there is no element).
fn positive_number(
    src: &Source,
    node: Option<Node<'_, '_>>,
    expected: &str,
) -> Result<Option<f64>, Located> {
    let Some(node) = node else { return Ok(None) };
    let text = node.text().unwrap_or("").trim();
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(Some(v)),
        _ => Err(src.at(
            text_range(src, node),
            format!(
                "<{}>: expected {expected} above 0, found `{text}`",
                node.tag_name().name()
            ),
        )),
    }
}

/// The byte range of an element's text in the file (its start tag when it has none).
fn text_range(src: &Source, node: Node<'_, '_>) -> std::ops::Range<usize> {
    match node.first_child().filter(Node::is_text) {
        Some(t) => {
            let r = t.range();
            let raw = &src.text[r.clone()];
            let lead = raw.len() - raw.trim_start().len();
            r.start + lead..r.end
        }
        None => node.range(),
    }
}

fn feature(node: Node<'_, '_>) -> Feature {
    let text = node.text().unwrap_or("").trim();
    Feature {
        name: node.attribute("NAME").unwrap_or("").to_string(),
        value: match text.parse::<f64>() {
            Ok(v) if v.is_finite() => FeatureValue::Number(v),
            _ => FeatureValue::Text(text.to_string()),
        },
        unit: node.attribute("DT").map(str::to_string),
    }
}

/// The plane: `TEST_PLANE` (attribute of `<PLANE>`, or an element), the axis names, `VIEW`.
fn plane(src: &Source, root: Node<'_, '_>) -> Result<B5rPlane, Located> {
    let plane_node = find(root, "PLANE");
    let named: Option<(String, std::ops::Range<usize>)> = plane_node
        .and_then(|n| {
            n.attribute_node("TEST_PLANE")
                .map(|a| (a.value().to_string(), a.range_value()))
        })
        .or_else(|| {
            find(root, "TEST_PLANE")
                .map(|n| (n.text().unwrap_or("").to_string(), text_range(src, n)))
        })
        .or_else(|| {
            plane_node
                .filter(|n| n.text().is_some_and(|t| !t.trim().is_empty()))
                .map(|n| (n.text().unwrap_or("").to_string(), text_range(src, n)))
        });
    let axis = |tag: &str| -> Result<Option<char>, Located> {
        let Some(n) = find(root, tag) else {
            return Ok(None);
        };
        let t = n.text().unwrap_or("").trim();
        match axis_letter(t) {
            Some(c) => Ok(Some(c)),
            None => Err(src.at(
                text_range(src, n),
                format!("<{tag}>: expected a linear axis X, Y or Z, found `{t}`"),
            )),
        }
    };
    let (a_axis, b_axis) = (axis("A_AXIS_NAME")?, axis("B_AXIS_NAME")?);
    let from_name = match &named {
        Some((text, range)) => Some(plane_letters(text).ok_or_else(|| {
            src.at(
                range.clone(),
                format!(
                    "unknown plane `{}`: expected two of the linear axes X, Y, Z (XY, YZ, ZX, \
                     YX, ZY, XZ)",
                    text.trim()
                ),
            )
        })?),
        None => None,
    };
    let (a, b) = match (from_name, a_axis, b_axis) {
        (Some((p, q)), Some(a), Some(b)) => {
            if !((a == p && b == q) || (a == q && b == p)) || a == b {
                let (text, range) = named.expect("a plane was read");
                return Err(src.at(
                    range,
                    format!(
                        "plane `{}` does not hold the axes <A_AXIS_NAME> {a} and \
                         <B_AXIS_NAME> {b}",
                        text.trim()
                    ),
                ));
            }
            (a, b)
        }
        (Some(pq), None, None) => pq,
        (_, Some(a), Some(b)) if a != b => (a, b),
        (_, Some(a), Some(_)) => {
            return Err(src.at(
                find(root, "B_AXIS_NAME").map_or(0..0, |n| text_range(src, n)),
                format!("<B_AXIS_NAME>: expected an axis other than <A_AXIS_NAME> {a}"),
            ));
        }
        _ => {
            return Err(src.at(
                root.range(),
                "expected the test plane (<PLANE TEST_PLANE=\"XY\"> or <A_AXIS_NAME> and \
                 <B_AXIS_NAME>), found neither",
            ));
        }
    };
    let (sign_a, sign_b, view_read) = match plane_node.and_then(|n| n.attribute_node("VIEW")) {
        None => (1.0, 1.0, false),
        Some(v) => {
            let t = v.value().trim().to_ascii_uppercase();
            let c: Vec<char> = t.chars().collect();
            let sign = |ch: char| match ch {
                '+' => Some(1.0),
                '-' => Some(-1.0),
                _ => None,
            };
            match c.as_slice() {
                [sa, 'A', sb, 'B'] if sign(*sa).is_some() && sign(*sb).is_some() => {
                    (sign(*sa).unwrap(), sign(*sb).unwrap(), true)
                }
                _ => {
                    return Err(src.at(
                        v.range_value(),
                        format!(
                            "VIEW: expected the signs of the axes as seen, e.g. `+A+B`, found `{}`",
                            v.value()
                        ),
                    ));
                }
            }
        }
    };
    Ok(B5rPlane {
        a,
        b,
        sign_a,
        sign_b,
        view_read,
    })
}

fn axis_letter(t: &str) -> Option<char> {
    let mut c = t.chars();
    match (c.next().map(|c| c.to_ascii_uppercase()), c.next()) {
        (Some(l @ ('X' | 'Y' | 'Z')), None) => Some(l),
        _ => None,
    }
}

fn plane_letters(t: &str) -> Option<(char, char)> {
    let c: Vec<char> = t.trim().chars().collect();
    match c.as_slice() {
        [p, q] => {
            let (p, q) = (axis_letter(&p.to_string())?, axis_letter(&q.to_string())?);
            (p != q).then_some((p, q))
        }
        _ => None,
    }
}

/// One `<READINGS>` element and its siblings.
fn run(src: &Source, node: Node<'_, '_>) -> Result<B5rRun, Located> {
    let parent = node.parent_element();
    let siblings = || parent.into_iter().flat_map(|p| p.children());
    let Some(dir) = siblings().find(|n| n.has_tag_name("RUN_DIRECTION")) else {
        return Err(src.at(
            node.range(),
            "expected a <RUN_DIRECTION> (CW or CCW) beside <READINGS>, found none",
        ));
    };
    let dir_text = dir.text().unwrap_or("").trim();
    let ccw = match dir_text
        .to_ascii_uppercase()
        .replace(['-', '_', ' '], "")
        .as_str()
    {
        "CCW" | "ANTICLOCKWISE" | "COUNTERCLOCKWISE" => true,
        "CW" | "CLOCKWISE" => false,
        _ => {
            return Err(src.at(
                text_range(src, dir),
                format!("<RUN_DIRECTION>: expected CW or CCW, found `{dir_text}`"),
            ));
        }
    };
    let dt_unit = match node.attribute_node("DT") {
        None => None,
        Some(a) => Some(ReadingUnit::from_dt(a.value()).ok_or_else(|| {
            src.at(
                a.range_value(),
                format!(
                    "DT: expected UT_LENGTH_UM, UT_LENGTH_MM or UT_LENGTH_NM, found `{}` \
                     (give --reading-unit)",
                    a.value()
                ),
            )
        })?),
    };
    let (readings, at) = numbers(src, node)?;
    let declared: Option<(f64, std::ops::Range<usize>, &str)> = match node.attribute_node("COUNT") {
        Some(a) => Some((
            a.value().trim().parse().unwrap_or(f64::NAN),
            a.range_value(),
            "COUNT",
        )),
        None => siblings()
            .find(|n| n.has_tag_name("NUMBER_OF_READINGS"))
            .map(|n| {
                (
                    n.text().unwrap_or("").trim().parse().unwrap_or(f64::NAN),
                    text_range(src, n),
                    "<NUMBER_OF_READINGS>",
                )
            }),
    };
    if let Some((n, range, what)) = declared
        && n != readings.len() as f64
    {
        return Err(src.at(
            range,
            format!(
                "{what}: the header says {} readings, <READINGS> holds {}",
                if n.is_nan() {
                    "a non-number of".to_string()
                } else {
                    n.to_string()
                },
                readings.len()
            ),
        ));
    }
    if readings.len() < 3 {
        return Err(src.at(
            text_range(src, node),
            format!(
                "<READINGS>: expected at least 3 readings around the circle, found {}",
                readings.len()
            ),
        ));
    }
    let features = siblings()
        .filter(|n| n.has_tag_name("FEATURE"))
        .map(feature)
        .collect();
    Ok(B5rRun {
        ccw,
        readings,
        dt_unit,
        features,
        at,
    })
}

/// The blank-separated numbers of `<READINGS>`, each with its location.
fn numbers(src: &Source, node: Node<'_, '_>) -> Result<(Vec<f64>, Vec<Location>), Located> {
    let mut values = Vec::new();
    let mut at = Vec::new();
    for child in node.children() {
        if child.is_element() {
            return Err(src.at(
                child.range(),
                format!(
                    "<READINGS>: expected numbers separated by blanks, found an element <{}>",
                    child.tag_name().name()
                ),
            ));
        }
        if !child.is_text() {
            continue;
        }
        let decoded = child.text().unwrap_or("");
        let range = child.range();
        // The raw text is the decoded one unless it holds entities; then locate at its start.
        let raw = &src.text[range.clone()];
        let exact = raw == decoded;
        let base = range.start;
        let mut offset = 0;
        for token in decoded.split(|c: char| c.is_whitespace()) {
            let start = offset;
            offset += token.len() + 1;
            if token.is_empty() {
                continue;
            }
            let pos = if exact { base + start } else { base };
            match token.parse::<f64>() {
                Ok(v) if v.is_finite() => {
                    values.push(v);
                    at.push(src.locate(pos));
                }
                _ => {
                    return Err(src.at(
                        pos..pos,
                        format!(
                            "<READINGS>: expected a number (reading {}), found `{token}`",
                            values.len() + 1
                        ),
                    ));
                }
            }
        }
    }
    Ok((values, at))
}

// ---------------------------------------------------------------------------------------------
// Into the session

/// What one run became.
#[derive(Debug, Clone)]
pub struct B5rWritten {
    pub name: String,
    pub file: PathBuf,
    /// Index into [`B5rImported::files`] and into that file's runs.
    pub source: (usize, usize),
    pub setup: String,
    pub unit: ReadingUnit,
    pub unit_from: &'static str,
    pub step_deg: f64,
    pub radius_mm: f64,
    pub feed_mm_per_min: Option<f64>,
    /// The readings written, µm.
    pub dr_um: Vec<f64>,
    /// The commanded angles, degrees, from +A towards +B.
    pub angles_deg: Vec<f64>,
}

/// What [`import_b5r`] read, assumed and wrote.
#[derive(Debug, Clone)]
pub struct B5rImported {
    pub files: Vec<B5rFile>,
    pub runs: Vec<B5rWritten>,
    /// The set-ups written: name, pivot (mm, workpiece frame), length (mm).
    pub setups: Vec<(String, [f64; 3], f64)>,
    /// The axis positions at the circle's centre (mm / degrees), by letter.
    pub center: Vec<(char, f64)>,
    pub manifest: PathBuf,
    pub created: bool,
    /// The `[[run]]` entries written, as TOML.
    pub entries: String,
    /// The instrument's measuring range the readings were checked against (±, µm).
    range_um: f64,
    start_deg: (f64, bool),
    sweep_deg: (f64, bool),
    overshoot_deg: (f64, bool),
    step_given: bool,
    center_given: bool,
}

/// Reads every file and writes their runs into the session together (or nothing).
pub fn import_b5r(options: &B5rOptions<'_>) -> Result<B5rImported, ImportError> {
    if options.files.is_empty() {
        return Err(ImportError::Options("no .b5r file given".into()));
    }
    let files: Vec<B5rFile> = options
        .files
        .iter()
        .map(|f| read_b5r(f))
        .collect::<Result<_, _>>()?;
    let instrument = declared_once::<CircleRuns>()?;
    let (mut manifest, machine_text, created) = target(options)?;
    let machine = load_machine(&machine_text)?;
    let center_si = match options.center {
        Some(text) => {
            mtcal_machine::axis_text::held_positions(&machine, vec![0.0; machine.n_axes()], text)
                .map_err(|e| ImportError::Options(e.to_string().replace("--hold", "--center")))?
        }
        None => vec![0.0; machine.n_axes()],
    };
    let angles = Angles::of(options)?;
    let letters: Vec<char> = machine
        .axes()
        .iter()
        .map(|a| a.letter().as_char())
        .collect();
    let mut runs = Vec::new();
    let mut tables = Vec::new();
    let mut setups: Vec<(String, [f64; 3], f64)> = Vec::new();
    let mut setup_of: BTreeMap<(String, u64), String> = BTreeMap::new();
    let mut names: Vec<String> = Vec::new();
    for (fi, file) in files.iter().enumerate() {
        for letter in [file.plane.a, file.plane.b] {
            match machine.axis_index(letter) {
                Some(k) if machine.axes()[k].kind() == AxisKind::Linear => {}
                _ => {
                    return Err(ImportError::Options(format!(
                        "{}: plane {} names axis {letter}, which the machine (axes {}) has not \
                         as a linear axis",
                        file.path.display(),
                        file.plane.name(),
                        machine.letters()
                    )));
                }
            }
        }
        let radius_mm = match (options.radius_mm, file.radius_mm) {
            (Some(r), _) if r > 0.0 && r.is_finite() => r,
            (Some(r), _) => {
                return Err(ImportError::Options(format!(
                    "--radius-mm {r}: expected a radius above 0 (mm)"
                )));
            }
            (None, Some(r)) => r,
            (None, None) => {
                return Err(ImportError::Options(format!(
                    "{}: the file gives no <NOMINAL_LENGTH> (the circle's radius): give \
                     --radius-mm",
                    file.path.display()
                )));
            }
        };
        let feed = match options.feed_mm_per_min {
            Some(f) if f > 0.0 && f.is_finite() => Some(f),
            Some(f) => {
                return Err(ImportError::Options(format!(
                    "--feed {f}: expected a feed above 0 (mm/min)"
                )));
            }
            None => file.feed_mm_per_min,
        };
        let pivot_m = forward_kinematics(&machine, &center_si).0;
        let pivot_mm = pivot_m.map(|v| (v * 1e9).round() / 1e6);
        let key = (file.plane.name(), radius_mm.to_bits());
        let setup = match setup_of.get(&key) {
            Some(s) => s.clone(),
            None => {
                let base = format!("b5r-{}", file.plane.name().to_ascii_lowercase());
                let mut name = base.clone();
                let mut k = 2;
                while manifest.setups.contains_key(&name) {
                    name = format!("{base}-{k}");
                    k += 1;
                }
                let table = (instrument.setup)([pivot_mm.x, pivot_mm.y, pivot_mm.z], radius_mm);
                manifest.setups.insert(name.clone(), table);
                setups.push((
                    name.clone(),
                    [pivot_mm.x, pivot_mm.y, pivot_mm.z],
                    radius_mm,
                ));
                setup_of.insert(key, name.clone());
                name
            }
        };
        let a_unit = unit(file.plane.a) * file.plane.sign_a;
        let b_unit = unit(file.plane.b) * file.plane.sign_b;
        for (ri, run) in file.runs.iter().enumerate() {
            let (unit, unit_from) = match (options.reading_unit, run.dt_unit) {
                (Some(u), _) => (u, "--reading-unit"),
                (None, Some(u)) => (u, "DT"),
                (None, None) => (ReadingUnit::Um, "assumed"),
            };
            let dr_um: Vec<f64> = run.readings.iter().map(|v| v * unit.to_um()).collect();
            let range_um = instrument.range_um;
            if let Some(k) = dr_um.iter().position(|d| d.abs() > range_um) {
                return Err(ImportError::Invalid(Located {
                    at: run.at[k].clone(),
                    message: format!(
                        "reading {} is {} µm as {}, beyond the ball-bar's ±{range_um} µm: the \
                         readings are in another unit (give --reading-unit) or are bar lengths, \
                         not deviations from the nominal length",
                        k + 1,
                        dr_um[k],
                        unit.name()
                    ),
                }));
            }
            let n = dr_um.len();
            let step = angles.step(n);
            let sign = if run.ccw { 1.0 } else { -1.0 };
            let angles_deg: Vec<f64> = (0..n)
                .map(|k| angles.start + sign * (-angles.overshoot + step * k as f64))
                .collect();
            let mut positions = Vec::with_capacity(n * letters.len());
            for phi in &angles_deg {
                let phi = phi.to_radians();
                let tip = pivot_m + (a_unit * phi.cos() + b_unit * phi.sin()) * radius_mm * 1e-3;
                let mut q = center_si.clone();
                follow_point(&machine, &mut q, &tip).map_err(|e| {
                    ImportError::Options(format!(
                        "{}: cannot place the tool on the circle: {e}",
                        file.path.display()
                    ))
                })?;
                positions.extend(
                    machine
                        .axes()
                        .iter()
                        .zip(&q)
                        .map(|(a, &v)| a.kind().to_file(v)),
                );
            }
            check_limits(&machine, &positions).map_err(|e| {
                ImportError::Options(format!(
                    "{}: {e} (the circle's centre is --center)",
                    file.path.display()
                ))
            })?;
            let dt_s = match feed {
                Some(f) => radius_mm * step.to_radians() / (f / 60.0),
                None => 1.0,
            };
            let name = run_name(options, file, run)?;
            if names.contains(&name) {
                return Err(ImportError::Options(format!(
                    "two runs would be named `{name}`: give --name (runs are then named \
                     <name>-<plane>-<cw|ccw>) or import the files one by one with their own names"
                )));
            }
            let csv = format!("{name}.csv");
            refuse_existing(options.session, &manifest, &name, &csv)?;
            let path = options.session.join(&csv);
            tables.push(RunTable {
                path: path.clone(),
                columns: Vec::new(),
                t: (0..n).map(|k| k as f64 * dt_s).collect(),
                axes: letters.clone(),
                positions,
                readings: vec![instrument.reading.to_string()],
                values: Some(dr_um.clone()),
                context: Vec::new(),
                labels: Vec::new(),
            });
            manifest.runs.push(ManifestRun {
                name: name.clone(),
                instrument: instrument.instrument.into(),
                file: csv,
                use_: RunUse::Fit,
                setup: SetupRef::Shared(setup.clone()),
                extra: run_metadata(file, run, feed, unit, radius_mm),
            });
            names.push(name.clone());
            runs.push(B5rWritten {
                name,
                file: path,
                source: (fi, ri),
                setup: setup.clone(),
                unit,
                unit_from,
                step_deg: step,
                radius_mm,
                feed_mm_per_min: feed,
                dr_um,
                angles_deg,
            });
        }
    }
    let entries = manifest
        .runs
        .iter()
        .filter(|r| names.contains(&r.name))
        .map(entry_text)
        .collect::<Vec<_>>()
        .join("\n");
    let manifest_path = write_all(options.session, &tables, &manifest)?;
    Ok(B5rImported {
        center: letters
            .iter()
            .zip(machine.axes())
            .zip(&center_si)
            .map(|((&l, a), &q)| (l, a.kind().to_file(q)))
            .collect(),
        files,
        runs,
        setups,
        manifest: manifest_path,
        created,
        entries,
        range_um: instrument.range_um,
        start_deg: (angles.start, options.start_deg.is_some()),
        sweep_deg: (angles.sweep, options.sweep_deg.is_some()),
        overshoot_deg: (angles.overshoot, options.overshoot_deg.is_some()),
        step_given: options.step_deg.is_some(),
        center_given: options.center.is_some(),
    })
}

/// The unit vector of a linear axis letter in the workpiece frame.
fn unit(letter: char) -> Vector3<f64> {
    match letter {
        'X' => Vector3::x(),
        'Y' => Vector3::y(),
        _ => Vector3::z(),
    }
}

/// The angles the options give (degrees).
struct Angles {
    start: f64,
    sweep: f64,
    overshoot: f64,
    step: Option<f64>,
}

impl Angles {
    fn of(o: &B5rOptions<'_>) -> Result<Angles, ImportError> {
        let finite = |v: Option<f64>, option: &str, default: f64| match v {
            Some(x) if !x.is_finite() => Err(ImportError::Options(format!(
                "{option} {x}: expected a number of degrees"
            ))),
            Some(x) => Ok(x),
            None => Ok(default),
        };
        let start = finite(o.start_deg, "--start-deg", 0.0)?;
        let sweep = finite(o.sweep_deg, "--sweep-deg", 360.0)?;
        let overshoot = finite(o.overshoot_deg, "--overshoot-deg", 0.0)?;
        if sweep <= 0.0 || sweep > 360.0 {
            return Err(ImportError::Options(format!(
                "--sweep-deg {sweep}: expected an arc above 0° and at most 360°"
            )));
        }
        if overshoot < 0.0 {
            return Err(ImportError::Options(format!(
                "--overshoot-deg {overshoot}: expected 0° or more"
            )));
        }
        let step = match o.step_deg {
            Some(s) if s.is_finite() && s > 0.0 => Some(s),
            Some(s) => {
                return Err(ImportError::Options(format!(
                    "--step-deg {s}: expected a spacing above 0°"
                )));
            }
            None => None,
        };
        Ok(Angles {
            start,
            sweep,
            overshoot,
            step,
        })
    }

    /// The spacing of `n` readings (degrees).
    fn step(&self, n: usize) -> f64 {
        self.step
            .unwrap_or((self.sweep + 2.0 * self.overshoot) / n as f64)
    }
}

/// The run's name: `<name>-<plane>-<dir>` with `--name`, else the file's stem (with `-<dir>`
/// when the file holds several runs).
fn run_name(options: &B5rOptions<'_>, file: &B5rFile, run: &B5rRun) -> Result<String, ImportError> {
    let dir = if run.ccw { "ccw" } else { "cw" };
    let name = match options.name {
        Some(prefix) => {
            let name = format!("{prefix}-{}-{dir}", file.plane.name().to_ascii_lowercase());
            if !is_run_name(&name) {
                return Err(ImportError::Options(format!(
                    "--name `{prefix}`: expected letters, digits, `-`, `_` and `.` (it names the \
                     CSV files)"
                )));
            }
            return Ok(name);
        }
        None => {
            let stem = file
                .path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let stem = crate::session::file_safe(&stem);
            if file.runs.len() > 1 {
                format!("{stem}-{dir}")
            } else {
                stem
            }
        }
    };
    if !is_run_name(&name) {
        return Err(ImportError::Options(format!(
            "{}: cannot name a run after the file: give --name",
            file.path.display()
        )));
    }
    Ok(name)
}

/// The run's `[run.b5r]` table: where it came from and what the ball-bar software said.
fn run_metadata(
    file: &B5rFile,
    run: &B5rRun,
    feed: Option<f64>,
    unit: ReadingUnit,
    radius_mm: f64,
) -> toml::Table {
    let mut b5r = toml::Table::new();
    let source = file
        .path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    b5r.insert("source".into(), source.into());
    b5r.insert("plane".into(), file.plane.name().into());
    b5r.insert(
        "direction".into(),
        if run.ccw { "ccw" } else { "cw" }.into(),
    );
    b5r.insert("radius_mm".into(), radius_mm.into());
    if let Some(f) = feed {
        b5r.insert("feed_mm_per_min".into(), f.into());
    }
    b5r.insert("reading_unit".into(), unit.name().into());
    if let Some(m) = &file.machine_tested {
        b5r.insert("machine_tested".into(), m.clone().into());
    }
    if let Some(d) = &file.date_started {
        b5r.insert("date_started".into(), d.clone().into());
    }
    let features = |list: &[Feature]| -> toml::Table {
        list.iter()
            .filter(|f| !f.name.is_empty())
            .map(|f| {
                let mut t = toml::Table::new();
                t.insert(
                    "value".into(),
                    match &f.value {
                        FeatureValue::Number(v) => (*v).into(),
                        FeatureValue::Text(s) => s.clone().into(),
                    },
                );
                if let Some(u) = &f.unit {
                    t.insert("unit".into(), u.clone().into());
                }
                (f.name.clone(), toml::Value::Table(t))
            })
            .collect()
    };
    if !file.diagnostics.is_empty() {
        b5r.insert(
            "diagnostics".into(),
            toml::Value::Table(features(&file.diagnostics)),
        );
    }
    if !run.features.is_empty() {
        b5r.insert(
            "run_features".into(),
            toml::Value::Table(features(&run.features)),
        );
    }
    let mut extra = toml::Table::new();
    extra.insert("b5r".into(), toml::Value::Table(b5r));
    extra
}

/// The manifest to extend (or a new one), the machine to load, whether it is new.
fn target(options: &B5rOptions<'_>) -> Result<(Manifest, String, bool), ImportError> {
    let dir = options.session;
    if dir.join(mtcal_session::MANIFEST_NAME).is_file() {
        if let Some(m) = options.machine {
            return Err(ImportError::Options(format!(
                "--machine {m}: the session {} names its machine already; leave --machine out",
                dir.display()
            )));
        }
        let session = mtcal_session::load_session_to_extend(dir)?;
        return Ok((session.to_manifest(), machine_arg(&session), false));
    }
    let Some(machine) = options.machine else {
        return Err(ImportError::Options(format!(
            "{} has no session.toml: give --machine (a URDF or a topology code) to create the \
             session",
            dir.display()
        )));
    };
    Ok((
        Manifest {
            machine: machine_in_manifest(machine, dir),
            ..Manifest::default()
        },
        machine.to_string(),
        true,
    ))
}

// ---------------------------------------------------------------------------------------------
// The card

impl B5rImported {
    /// What was read, assumed and written, for the command line.
    pub fn card(&self) -> String {
        let mut out = String::new();
        for (fi, file) in self.files.iter().enumerate() {
            let p = &file.plane;
            let _ = writeln!(
                out,
                "read {}: plane {} (A = {}, B = {}, view {}{}), {} run{}",
                file.path.display(),
                p.name(),
                p.a,
                p.b,
                p.view(),
                if p.view_read { "" } else { ", assumed" },
                file.runs.len(),
                if file.runs.len() == 1 { "" } else { "s" }
            );
            let _ = writeln!(
                out,
                "  machine tested: {}; started: {}",
                file.machine_tested.as_deref().unwrap_or("(not given)"),
                file.date_started.as_deref().unwrap_or("(not given)")
            );
            for w in self.runs.iter().filter(|w| w.source.0 == fi) {
                let run = &file.runs[w.source.1];
                let _ = writeln!(
                    out,
                    "  run {}: {}, {} readings ({}), radius {} mm ({}), feed {}, set-up {}",
                    w.name,
                    if run.ccw { "ccw" } else { "cw" },
                    run.readings.len(),
                    match w.unit_from {
                        "DT" => format!("{}, DT", w.unit.name()),
                        "--reading-unit" => format!("{}, --reading-unit", w.unit.name()),
                        _ => format!("{}, assumed", w.unit.name()),
                    },
                    w.radius_mm,
                    if file.radius_mm == Some(w.radius_mm) {
                        "NOMINAL_LENGTH"
                    } else {
                        "--radius-mm"
                    },
                    match (w.feed_mm_per_min, file.feed_mm_per_min) {
                        (Some(f), Some(g)) if f == g => {
                            format!("{f} mm/min (PROGRAMMED_FEEDRATE)")
                        }
                        (Some(f), _) => format!("{f} mm/min (--feed)"),
                        (None, _) => "not given (readings 1 s apart)".to_string(),
                    },
                    w.setup
                );
                if !run.features.is_empty() {
                    let list: Vec<String> = run.features.iter().map(Feature::to_string).collect();
                    let _ = writeln!(out, "    the run's results: {}", list.join(", "));
                }
            }
            if file.diagnostics.is_empty() {
                out.push_str("  no RENISHAW_DIAGNOSTICS analysis in the file\n");
            } else {
                out.push_str("  RENISHAW_DIAGNOSTICS (kept in [run.b5r.diagnostics]):\n");
                for f in &file.diagnostics {
                    let _ = writeln!(out, "    {f}");
                }
            }
        }
        out.push_str(&self.assumptions());
        for (name, pivot, length) in self.setups.iter() {
            let _ = writeln!(
                out,
                "set-up {name}: pivot [{}, {}, {}] mm, length {length} mm",
                pivot[0], pivot[1], pivot[2]
            );
        }
        let files: Vec<String> = self
            .runs
            .iter()
            .map(|w| w.file.display().to_string())
            .collect();
        let _ = write!(
            out,
            "wrote {} and {} {}:\n{}",
            files.join(", "),
            if self.created {
                "created"
            } else {
                "appended to"
            },
            self.manifest.display(),
            self.entries
        );
        out
    }

    /// Every assumption made, with its value and the option that overrides it.
    fn assumptions(&self) -> String {
        let mut lines: Vec<String> = Vec::new();
        let tag = |given: bool, option: &str| {
            if given {
                format!("given: {option}")
            } else {
                format!("assumed; {option} overrides")
            }
        };
        if self.runs.iter().any(|w| w.unit_from == "assumed") {
            lines.push(
                "readings in µm where <READINGS> has no DT (assumed; --reading-unit overrides)"
                    .into(),
            );
        }
        lines.push(format!(
            "readings are the bar length minus its nominal length, positive = longer \
             (assumed; checked within the ball-bar's ±{} µm)",
            self.range_um
        ));
        lines.push(format!(
            "first reading at {}° from +A towards +B, minus the overshoot ({})",
            self.start_deg.0,
            tag(self.start_deg.1, "--start-deg")
        ));
        lines.push(format!(
            "arc measured {}° ({})",
            self.sweep_deg.0,
            tag(self.sweep_deg.1, "--sweep-deg")
        ));
        lines.push(format!(
            "overshoot arcs in the readings: {}° before and after ({})",
            self.overshoot_deg.0,
            tag(self.overshoot_deg.1, "--overshoot-deg")
        ));
        let mut steps: Vec<String> = Vec::new();
        for w in self.runs.iter() {
            let s = format!("{}°", w.step_deg);
            if !steps.contains(&s) {
                steps.push(s);
            }
        }
        lines.push(format!(
            "readings {} apart{} ({})",
            steps.join(" / "),
            if self.step_given {
                ""
            } else {
                ": (sweep + 2 × overshoot) / number of readings, the closing angle not repeated"
            },
            tag(self.step_given, "--step-deg")
        ));
        let centre: Vec<String> = self
            .center
            .iter()
            .map(|(l, v)| format!("{l}={v}"))
            .collect();
        lines.push(format!(
            "circle centre at axes {} ({})",
            centre.join(","),
            tag(self.center_given, "--center")
        ));
        if self.runs.iter().any(|w| w.feed_mm_per_min.is_none()) {
            lines
                .push("no feed in the file: readings 1 s apart (assumed; --feed overrides)".into());
        } else {
            lines.push("t = arc length / feed, from 0 s in each run".into());
        }
        let mut out = String::from("assumed (what the file does not settle):\n");
        for l in lines {
            let _ = writeln!(out, "  {l}");
        }
        out
    }
}
