//! The predicted error along CL data as `mtcal cl-error` reports it: every point's axis
//! positions and error with their summary ([`PathErrors`]), the two summary lines, the CSV of
//! every point and the distance along the path for a plot.

use crate::cl::{
    AxisPoint, ClData, ClOptions, ErrorSummary, PointError, all_axis_positions, check_units,
    predicted_errors, summarize,
};
use crate::files::FileError;
use mtcal_kinematics::{AxisKind, Machine, MachineModel};
use std::fmt::Write as _;
use std::path::Path;

/// The predicted error along CL data: each point's axis positions (the nominal inverse
/// kinematics) and the identified machine's error there.
#[derive(Clone, Debug, PartialEq)]
pub struct PathErrors {
    pub points: Vec<AxisPoint>,
    pub errors: Vec<PointError>,
    pub summary: ErrorSummary,
}

impl PathErrors {
    /// The errors of `model` with `coeffs` along `cl`, read from the file `path` (which the
    /// errors name): refused when the tool tips look like metres, when a point has no axis
    /// positions, or without points.
    pub fn new(
        model: &MachineModel,
        coeffs: &[f64],
        cl: &ClData,
        path: &Path,
    ) -> Result<Self, FileError> {
        check_units(model.machine(), cl)
            .map_err(|e| FileError::at(path, e.line, e.column, e.expected, &e.found))?;
        let points =
            all_axis_positions(model.machine(), cl, &ClOptions::default()).map_err(|failures| {
                FileError::NoAxisPositions {
                    path: path.to_path_buf(),
                    failures,
                }
            })?;
        let qs: Vec<Vec<f64>> = points.iter().map(|p| p.q.clone()).collect();
        let errors = predicted_errors(model, coeffs, &qs);
        let summary = summarize(&errors).ok_or(FileError::NoPoints)?;
        Ok(Self {
            points,
            errors,
            summary,
        })
    }

    /// The two lines `mtcal cl-error` prints about the CL data of the file `path`: its points
    /// (and how many were singular) and the summary of the errors.
    pub fn report(&self, path: &Path) -> String {
        let s = &self.summary;
        let singular = self.points.iter().filter(|p| p.singular.is_some()).count();
        format!(
            "cl data     {}: {} points{}\n\
             |error|     max {:.3} um at line {}, RMS {:.3} um, P90 {:.3} um; tool-axis tilt max \
             {:.3} urad\n",
            path.display(),
            s.points,
            if singular > 0 {
                format!(" ({singular} singular: free rotary axis held at the previous position)")
            } else {
                String::new()
            },
            s.max_um,
            self.points[s.max_index].line,
            s.rms_um,
            s.p90_um,
            s.max_tilt_urad
        )
    }

    /// Every point as a CSV row: the tool tip of `cl` (mm), the axis positions of `machine`
    /// (mm / degrees), the predicted error (µm) and its magnitude, the tool-axis tilt (µrad).
    pub fn csv(&self, machine: &Machine, cl: &ClData) -> String {
        let axes = machine.axes();
        let mut csv = String::from("x,y,z");
        for a in axes {
            let unit = match a.kind() {
                AxisKind::Linear => "mm",
                AxisKind::Rotary => "deg",
            };
            let _ = write!(csv, ",{}_{unit}", a.letter().as_char());
        }
        csv.push_str(",dx_um,dy_um,dz_um,e_um,tilt_urad\n");
        for ((p, ap), e) in cl.points.iter().zip(&self.points).zip(&self.errors) {
            let _ = write!(csv, "{},{},{}", p.tip_mm.x, p.tip_mm.y, p.tip_mm.z);
            for (a, &q) in axes.iter().zip(&ap.q) {
                let v = a.kind().to_file(q);
                let _ = write!(csv, ",{v:.6}");
            }
            let t = e.translation_um;
            let _ = writeln!(
                csv,
                ",{:.4},{:.4},{:.4},{:.4},{:.3}",
                t.x, t.y, t.z, e.magnitude_um, e.tilt_urad
            );
        }
        csv
    }
}

/// The distance of every point of `cl` along the path of the tool tip from the first, mm.
pub fn along_mm(cl: &ClData) -> Vec<f64> {
    let mut along = 0.0;
    cl.points
        .iter()
        .enumerate()
        .map(|(k, p)| {
            if k > 0 {
                along += (p.tip_mm - cl.points[k - 1].tip_mm).norm();
            }
            along
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_machine::topology::{Reading, nominal_machine, parse_code};

    fn model(code: &str) -> MachineModel {
        let reading = Reading::FromWorkpiece;
        let m = nominal_machine(&parse_code(code, reading).unwrap(), code).unwrap();
        let config = mtcal_machine::config::default_config(&m);
        MachineModel::new(m, &config).unwrap()
    }

    /// CL data of tool tips along X at the middle of the machine's Y and Z strokes.
    fn line_along_x(machine: &Machine) -> ClData {
        let mid = |letter| {
            let (lo, hi) = machine.axes()[machine.axis_index(letter).unwrap()]
                .limits()
                .unwrap();
            0.5 * (lo + hi) * 1e3
        };
        let (y, z) = (mid('Y'), mid('Z'));
        let nominal = machine.tool_in_workpiece(&[0.0, y * 1e-3, z * 1e-3]).t * 1e3;
        let text = format!(
            "x,y,z\n{x0},{y0},{z0}\n{x1},{y0},{z0}\n{x2},{y0},{z0}\n",
            x0 = nominal.x,
            x1 = nominal.x + 30.0,
            x2 = nominal.x + 70.0,
            y0 = nominal.y,
            z0 = nominal.z
        );
        ClData::parse(&text).unwrap()
    }

    #[test]
    fn distances_add_up_along_the_path() {
        let cl = ClData::parse("x,y,z\n0,0,0\n3,4,0\n3,4,12\n").unwrap();
        assert_eq!(along_mm(&cl), vec![0.0, 5.0, 17.0]);
    }

    #[test]
    fn one_row_per_point_and_a_summary_of_two_lines() {
        let model = model("ZFYX");
        let cl = line_along_x(model.machine());
        let mut coeffs = vec![0.0; model.n_coeffs()];
        // Some error everywhere: every coefficient 1 µm (µrad).
        coeffs.iter_mut().for_each(|c| *c = 1e-6);
        let path = Path::new("cl/path.csv");
        let errors = PathErrors::new(&model, &coeffs, &cl, path).unwrap();
        assert_eq!(errors.points.len(), 3);
        let csv = errors.csv(model.machine(), &cl);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "x,y,z,X_mm,Y_mm,Z_mm,dx_um,dy_um,dz_um,e_um,tilt_urad"
        );
        assert_eq!(lines.len(), 4, "{csv}");
        for (row, e) in lines[1..].iter().zip(&errors.errors) {
            let fields: Vec<&str> = row.split(',').collect();
            assert_eq!(fields.len(), 11, "{row}");
            assert_eq!(fields[9], format!("{:.4}", e.magnitude_um), "{row}");
        }
        let report = errors.report(path);
        let lines: Vec<&str> = report.lines().collect();
        assert_eq!(lines.len(), 2, "{report}");
        assert_eq!(lines[0], "cl data     cl/path.csv: 3 points");
        let s = &errors.summary;
        assert!(
            lines[1].starts_with(&format!(
                "|error|     max {:.3} um at line {}, RMS {:.3} um",
                s.max_um, errors.points[s.max_index].line, s.rms_um
            )),
            "{report}"
        );
    }

    #[test]
    fn tool_tips_in_metres_are_refused_with_the_file_and_line() {
        let model = model("ZFYX");
        let cl = ClData::parse("x,y,z\n0.1,0.2,0.3\n0.2,0.2,0.3\n").unwrap();
        let coeffs = vec![0.0; model.n_coeffs()];
        let e = PathErrors::new(&model, &coeffs, &cl, Path::new("m.csv")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("m.csv:3:1: expected tool tips in mm"),
            "{e}"
        );
    }
}
