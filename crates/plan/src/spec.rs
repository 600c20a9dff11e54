//! The planning file (`planning.toml`), read with the line and column of every value.

use crate::PlanError;
use crate::sizes::GeometryConfig;
use mtcal_located::Location;
use mtcal_located::toml::SerdeMessages;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// `wanted = "all"` or a list of parameter names.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum Wanted {
    All(String),
    Names(Vec<String>),
}

/// A grid of candidate positions: every combination of the listed coordinates, mm.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
}

/// One run done at every candidate position of a group.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroupRun {
    pub name: Spanned<String>,
    #[serde(default)]
    pub path: toml::Table,
    pub feed_mm_min: Option<Spanned<f64>>,
    #[serde(rename = "use")]
    pub use_: Option<Spanned<String>>,
}

/// `[[candidates]]`: positions to choose from for one instrument.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Group {
    pub name: Spanned<String>,
    pub instrument: Spanned<String>,
    pub choose: Spanned<usize>,
    /// The set-up key that takes the position (default: the one the instrument's plugin names,
    /// `ball` for the R-test, `pivot` for the ball-bar, `origin` for an artefact).
    pub position: Option<Spanned<String>>,
    #[serde(default)]
    pub setup: toml::Table,
    pub grid: Option<Spanned<Grid>>,
    pub points: Option<Spanned<Vec<[f64; 3]>>>,
    /// Fixture limits: the fixture must stand within this radius of the workpiece origin
    /// (x, y), mm.
    pub max_radius_mm: Option<Spanned<f64>>,
    /// Fixture limits: the height of the position above the table top, `[min, max]` mm.
    pub height_mm: Option<Spanned<[f64; 2]>>,
    pub runs: Spanned<Vec<GroupRun>>,
}

/// The whole planning file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanningFile {
    pub machine: Spanned<String>,
    pub wanted: Spanned<Wanted>,
    pub tool_length_mm: Option<Spanned<f64>>,
    pub clearance_mm: Option<Spanned<f64>>,
    pub move_step: Option<Spanned<f64>>,
    pub feed_mm_min: Option<Spanned<f64>>,
    pub compare: Option<Spanned<String>>,
    pub random_trials: Option<usize>,
    pub seed: Option<u64>,
    #[serde(default)]
    pub identify: toml::Table,
    /// Sizes, mm by key: the planner's and the instruments' (read into [`Source::geometry`]).
    #[serde(default)]
    pub geometry: BTreeMap<Spanned<String>, Spanned<toml::Value>>,
    #[serde(default)]
    pub setup: toml::Table,
    #[serde(default)]
    pub run: Vec<Spanned<toml::Table>>,
    #[serde(default)]
    pub candidates: Vec<Spanned<Group>>,
}

/// The read planning file and where it is.
#[derive(Debug)]
pub struct Source {
    pub path: PathBuf,
    pub text: String,
    pub file: PlanningFile,
    /// `[geometry]`, read and checked.
    pub geometry: GeometryConfig,
}

impl Source {
    pub fn read(path: &Path) -> Result<Source, PlanError> {
        let text = std::fs::read_to_string(path).map_err(|e| PlanError::Io {
            path: path.to_path_buf(),
            cause: e,
        })?;
        Self::parse(path, text)
    }

    pub fn parse(path: &Path, text: String) -> Result<Source, PlanError> {
        let file: PlanningFile =
            mtcal_located::toml::from_str(&text, &SerdeMessages).map_err(|p| PlanError::Spec {
                at: Location::of_offset(path, &text, p.span.start),
                message: p.message,
            })?;
        let mut source = Source {
            path: path.to_path_buf(),
            text,
            file,
            geometry: GeometryConfig::default(),
        };
        source.geometry = source.check()?;
        Ok(source)
    }

    /// An error at a value's position.
    pub fn at<T>(&self, value: &Spanned<T>, message: impl Into<String>) -> PlanError {
        PlanError::Spec {
            at: Location::of_offset(&self.path, &self.text, value.span().start),
            message: message.into(),
        }
    }

    pub fn base(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new("."))
    }

    fn positive(
        &self,
        v: &Option<Spanned<f64>>,
        key: &str,
        zero_ok: bool,
    ) -> Result<(), PlanError> {
        if let Some(v) = v {
            let x = *v.get_ref();
            let ok = x.is_finite() && (x > 0.0 || (zero_ok && x == 0.0));
            if !ok {
                let what = if zero_ok { "≥ 0" } else { "> 0" };
                return Err(self.at(v, format!("`{key}` must be a number {what}, found {x}")));
            }
        }
        Ok(())
    }

    /// Checks every value a type cannot; returns `[geometry]` read.
    fn check(&self) -> Result<GeometryConfig, PlanError> {
        let f = &self.file;
        self.positive(&f.tool_length_mm, "tool_length_mm", true)?;
        self.positive(&f.clearance_mm, "clearance_mm", true)?;
        self.positive(&f.move_step, "move_step", true)?;
        self.positive(&f.feed_mm_min, "feed_mm_min", false)?;
        if let Wanted::All(s) = f.wanted.get_ref() {
            if s != "all" {
                return Err(self.at(
                    &f.wanted,
                    format!("`wanted` must be \"all\" or a list of parameter names, found \"{s}\""),
                ));
            }
        }
        let geometry = self.read_geometry()?;
        let mut names: Vec<&str> = Vec::new();
        for g in &f.candidates {
            let group = g.get_ref();
            let name = group.name.get_ref();
            if name.is_empty()
                || !name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
            {
                return Err(self.at(
                    &group.name,
                    format!("group name \"{name}\": use ASCII letters, digits, - and _"),
                ));
            }
            if names.contains(&name.as_str()) {
                return Err(self.at(&group.name, format!("group name \"{name}\" is used twice")));
            }
            names.push(name);
            if *group.choose.get_ref() == 0 {
                return Err(self.at(&group.choose, "`choose` must be at least 1"));
            }
            match (&group.grid, &group.points) {
                (None, None) => {
                    return Err(self.at(
                        g,
                        format!(
                            "group `{name}` has no positions: give `grid = {{ x = [..], y = [..], \
                             z = [..] }}` or `points = [[x, y, z], ..]` (mm)"
                        ),
                    ));
                }
                (Some(grid), Some(_)) => {
                    return Err(self.at(grid, "give `grid` or `points`, not both"));
                }
                (Some(grid), None) => {
                    let gr = grid.get_ref();
                    if gr.x.is_empty() || gr.y.is_empty() || gr.z.is_empty() {
                        return Err(self.at(grid, "`grid` needs at least one value in x, y and z"));
                    }
                    if !gr.x.iter().chain(&gr.y).chain(&gr.z).all(|v| v.is_finite()) {
                        return Err(self.at(grid, "`grid` values must be finite"));
                    }
                }
                (None, Some(p)) => {
                    if p.get_ref().is_empty()
                        || !p.get_ref().iter().flatten().all(|v| v.is_finite())
                    {
                        return Err(
                            self.at(p, "`points` must be a non-empty list of finite [x, y, z]")
                        );
                    }
                }
            }
            self.positive(&group.max_radius_mm, "max_radius_mm", false)?;
            if let Some(h) = &group.height_mm {
                let [lo, hi] = *h.get_ref();
                if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                    return Err(self.at(h, "`height_mm` must be [min, max] with min ≤ max"));
                }
            }
            if group.runs.get_ref().is_empty() {
                return Err(self.at(&group.runs, "`runs` must name at least one run"));
            }
            for r in group.runs.get_ref() {
                self.positive(&r.feed_mm_min, "feed_mm_min", false)?;
                if let Some(u) = &r.use_ {
                    if !["fit", "validate"].contains(&u.get_ref().as_str()) {
                        return Err(self.at(u, "`use` must be \"fit\" or \"validate\""));
                    }
                }
            }
        }
        Ok(geometry)
    }
}

impl Source {
    /// `[geometry]`: each key the planner's or a registered instrument's, each value one it
    /// takes; an error is located at the value.
    fn read_geometry(&self) -> Result<GeometryConfig, PlanError> {
        let g = &self.file.geometry;
        let given = g.iter().map(|(k, v)| (k.get_ref().as_str(), v.get_ref()));
        GeometryConfig::read(given).map_err(|e| {
            // An unknown key is located at the key, a refused value at the value.
            match g.iter().find(|(k, _)| *k.get_ref() == e.key) {
                Some((k, _)) if e.unknown => self.at(k, e.message),
                Some((_, v)) => self.at(v, e.message),
                None => PlanError::Spec {
                    at: Location::at(&self.path, 1, 1),
                    message: e.message,
                },
            }
        })
    }
}

impl Group {
    /// The candidate positions, mm, in grid order (x fastest).
    pub fn positions(&self) -> Vec<[f64; 3]> {
        if let Some(p) = &self.points {
            return p.get_ref().clone();
        }
        let Some(g) = &self.grid else {
            return Vec::new();
        };
        let g = g.get_ref();
        let mut out = Vec::new();
        for &z in &g.z {
            for &y in &g.y {
                for &x in &g.x {
                    out.push([x, y, z]);
                }
            }
        }
        out
    }
}
