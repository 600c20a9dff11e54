//! Unit tests: escaping, the content of each plot, the parameter table's rule (no number for
//! what the data cannot separate), the page's sections and the atomic write.

use super::*;
use crate::page::SECTIONS;
use crate::plots::{self, MEASURED, MODEL};

/// Every `<tag …/>` element of `svg` with its attributes.
fn elements<'a>(svg: &'a str, tag: &str) -> Vec<Vec<(&'a str, &'a str)>> {
    let open = format!("<{tag} ");
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(k) = rest.find(&open) {
        let after = &rest[k + open.len()..];
        let end = after.find('>').expect("the tag closes");
        let mut attrs = Vec::new();
        let mut body = &after[..end];
        while let Some(eq) = body.find("=\"") {
            let name = body[..eq].trim();
            let value_end = body[eq + 2..].find('"').expect("the value closes");
            attrs.push((name, &body[eq + 2..eq + 2 + value_end]));
            body = &body[eq + 2 + value_end + 1..];
        }
        out.push(attrs);
        rest = &after[end..];
    }
    out
}

fn attr<'a>(e: &[(&'a str, &'a str)], name: &str) -> Option<&'a str> {
    e.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
}

fn points(value: &str) -> Vec<(i32, i32)> {
    value
        .split_whitespace()
        .map(|p| {
            let (x, y) = p.split_once(',').expect("x,y");
            (x.parse().expect("x"), y.parse().expect("y"))
        })
        .collect()
}

fn hex(c: plotters::style::RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// Polylines of `svg` drawn in `color`, as point lists.
fn polylines(svg: &str, color: plotters::style::RGBColor) -> Vec<Vec<(i32, i32)>> {
    elements(svg, "polyline")
        .into_iter()
        .filter(|e| attr(e, "stroke") == Some(hex(color).as_str()))
        .map(|e| points(attr(&e, "points").unwrap_or("")))
        .collect()
}

fn circle_run(n: usize) -> PolarRun {
    let angles: Vec<f64> = (0..n).map(|k| 360.0 * k as f64 / (n - 1) as f64).collect();
    let measured: Vec<f64> = angles
        .iter()
        .map(|a| 3.0 * a.to_radians().cos() + 0.5 * (7.0 * a.to_radians()).sin())
        .collect();
    let model: Vec<f64> = angles.iter().map(|a| 3.0 * a.to_radians().cos()).collect();
    PolarRun {
        name: "ballbar-xy-ccw".into(),
        instrument: "ballbar".into(),
        plane: "XY".into(),
        radius_mm: 100.0,
        angles_deg: angles,
        measured_um: measured,
        model_um: model.clone(),
        model_before_um: Some(model.iter().map(|v| v + 1.0).collect()),
        metrics: vec![("circular deviation G (ISO 230-4)".into(), 7.8, "um".into())],
    }
}

fn curve(name: &str) -> ComponentCurve {
    ComponentCurve {
        name: name.into(),
        position_unit: "mm".into(),
        value_unit: "um".into(),
        samples: (0..11)
            .map(|k| {
                let x = -500.0 + 100.0 * k as f64;
                CurvePoint {
                    position: x,
                    value: 4.0 * (x / 500.0).powi(2) - 1.0,
                    u95: 0.3 + 0.2 * (x / 500.0).abs(),
                }
            })
            .collect(),
    }
}

fn slice(nx: usize, ny: usize) -> MapSlice {
    let xs: Vec<f64> = (0..nx)
        .map(|i| -300.0 + 600.0 * i as f64 / (nx - 1) as f64)
        .collect();
    let ys: Vec<f64> = (0..ny).map(|j| 50.0 * j as f64).collect();
    let values = ys
        .iter()
        .flat_map(|y| xs.iter().map(move |x| (x * x + y * y).sqrt() / 50.0))
        .collect();
    MapSlice {
        title: "X–Y at Z = −250 mm".into(),
        x_label: "X (mm)".into(),
        y_label: "Y (mm)".into(),
        xs,
        ys,
        values_um: values,
    }
}

/// A report with something in every section.
fn sample() -> Report {
    Report {
        title: "mtcal identification — <test> & co".into(),
        summary: Summary {
            session: "examples/<odd>&session".into(),
            machine: "mcu630".into(),
            facts: vec!["fit: rms 0.730 µm".into()],
            runs: vec![RunRow {
                name: "ballbar-xy-ccw".into(),
                instrument: "ballbar".into(),
                role: "fit".into(),
                rms_before_um: Some(1.788),
                rms_um: 0.988,
            }],
        },
        polar: vec![circle_run(181), circle_run(91)],
        diagnostics: vec![DiagnosisTable {
            instrument: "ballbar".into(),
            title: "ballbar XY: <ccw> + cw".into(),
            circularity_um: 7.0,
            rows: vec![
                DiagnosisRow {
                    rank: Some(1),
                    name: "backlash X+".into(),
                    about: "the step".into(),
                    value: 3.06,
                    u95: 0.73,
                    unit: "um".into(),
                    share_of_circularity: 0.44,
                    model: 3.09,
                    behind: "reversal X (X) 100 %".into(),
                },
                DiagnosisRow {
                    rank: None,
                    name: "servo mismatch".into(),
                    about: "lag".into(),
                    value: 0.01,
                    u95: 0.1,
                    unit: "ms".into(),
                    share_of_circularity: 0.01,
                    model: 0.0,
                    behind: String::new(),
                },
            ],
            notes: vec!["cyclic error Y: too sparse".into()],
        }],
        residuals: vec![ResidualPlot {
            variable: "t".into(),
            description: "time since the session started".into(),
            unit: "s".into(),
            residual_unit: "um".into(),
            after: (0..300)
                .map(|i| (i as f64, 0.1 * (i as f64).sin()))
                .collect(),
            before: Some((0..300).map(|i| (i as f64, 0.01 * i as f64)).collect()),
        }],
        components: vec![curve("EXX"), curve("EYX")],
        volumetric: Volumetric {
            slices: vec![slice(5, 4)],
            note: "First-order model.".into(),
        },
        parameters: vec![
            ParameterRow {
                name: "EC0Y".into(),
                group: "machine".into(),
                unit: "urad".into(),
                estimate: Estimate::Value {
                    value: 11.4121,
                    u95: 1.2677,
                },
            },
            ParameterRow {
                name: "EX0C".into(),
                group: "machine".into(),
                unit: "um".into(),
                estimate: Estimate::NotIdentifiable,
            },
            ParameterRow {
                name: "bar.<pivot_z>".into(),
                group: "bar".into(),
                unit: "um".into(),
                estimate: Estimate::NotIdentifiable,
            },
        ],
        identifiability: Identifiability {
            combinations: vec![Combination {
                parameters: vec!["EX0C".into(), "bar.<pivot_z>".into()],
                why: "moving EX0C and bar.<pivot_z> in the ratio 1 : 2 changes nothing".into(),
            }],
            concealed: vec![ConcealedEffect {
                effect: "ECZ (omitted-parameter)".into(),
                hides_behind: vec!["bar.pivot_x".into(), "EC0Y".into()],
                measurement: "a second ball height".into(),
            }],
            weakly_determined: vec![Combination {
                parameters: vec!["EY0A".into()],
                why: "its 95 % interval, ±929 um, is more than 10 % of its plausible range".into(),
            }],
        },
        search: Some(SearchOutcome {
            candidates: 171,
            stopped: "no further candidate is significant".into(),
            discoveries: vec![DiscoveryText {
                label: "reversal X (X)".into(),
                explanation: "a reversal error (backlash) of X of 2.91 ± 0.16 um".into(),
                rms_before_um: 1.004,
                rms_after_um: 0.756,
                heldout_rms_before_um: 1.058,
                heldout_rms_after_um: 0.766,
                validation_rms_um: Some((2.41, 2.36)),
            }],
            not_kept: vec!["servo-lag X: another candidate predicts better".into()],
        }),
        acceptance: None,
        conventions: vec![
            ("values are".into(), "errors (actual − nominal)".into()),
            (
                "squareness".into(),
                "C0Y > 0 opens the angle <X, Y> beyond 90°".into(),
            ),
        ],
        location_series: Vec::new(),
    }
}

fn acceptance_section() -> AcceptanceSection {
    let row =
        |item: &str, run: &str, value: Option<f64>, verdict: &str, note: &str| AcceptanceRow {
            item: item.into(),
            run: run.into(),
            value,
            uncertainty: value.map(|_| 1.0234),
            tolerance: "≤ 12".into(),
            unit: "um".into(),
            verdict: verdict.into(),
            note: note.into(),
        };
    AcceptanceSection {
        file: "acc <1>.toml".into(),
        rule: "ISO 14253-1".into(),
        verdict: "fail".into(),
        rows: vec![
            row("E (ISO 230-2) X", "laser-x", Some(8.6391), "pass", ""),
            row("G (ISO 230-4) XY", "bb", Some(14.5), "fail", ""),
            row(
                "EZ0A",
                "",
                None,
                "cannot decide",
                "only their sum is observed <z>",
            ),
        ],
    }
}

#[test]
fn the_acceptance_section_is_there_only_with_a_tolerance_file() {
    let plain = render(&sample()).unwrap();
    assert!(!plain.contains("id=\"acceptance\"") && !plain.contains("#acceptance"));
    let mut r = sample();
    r.acceptance = Some(acceptance_section());
    let page = render(&r).unwrap();
    // After the summary, before the ball-bar circles, in the contents too.
    let at = |id: &str| page.find(&format!("<section id=\"{id}\">")).unwrap();
    assert!(at("summary") < at("acceptance") && at("acceptance") < at("ballbar"));
    assert!(page.contains("<a href=\"#acceptance\">Acceptance</a>"));
    let s = section(&page, "acceptance");
    assert!(s.contains("<code>acc &lt;1&gt;.toml</code>"), "{s}");
    assert!(
        s.contains("data-verdict=\"fail\" style=\"color:#b00020\">FAIL</b>"),
        "{s}"
    );
    assert_eq!(s.matches("<tr data-verdict=").count(), 3);
    // Values rounded to U's second significant digit; no number where there is no value.
    assert!(
        s.contains("<td class=\"n\">8.6</td><td class=\"n\">1.0</td>"),
        "{s}"
    );
    assert!(
        s.contains("<td class=\"nid\" colspan=\"2\">no value</td>"),
        "{s}"
    );
    assert!(s.contains("<td>≤ 12 µm</td>"), "{s}");
    assert!(s.contains("only their sum is observed &lt;z&gt;"), "{s}");
    // Everything else is as without it.
    let start = at("acceptance");
    let end = start + page[start..].find("</section>\n").unwrap() + "</section>\n".len();
    let without = format!("{}{}", &page[..start], &page[end..])
        .replace("<a href=\"#acceptance\">Acceptance</a>", "");
    assert_eq!(without, plain);
}

/// The text between `<section id="id">` and its `</section>`.
fn section<'a>(page: &'a str, id: &str) -> &'a str {
    let start = page
        .find(&format!("<section id=\"{id}\">"))
        .unwrap_or_else(|| panic!("no section {id}"));
    let end = page[start..].find("</section>").expect("section closes");
    &page[start..start + end]
}

#[test]
fn escape_replaces_every_markup_character() {
    assert_eq!(
        escape(r#"<a href="x" title='y'>&µ</a>"#),
        "&lt;a href=&quot;x&quot; title=&#39;y&#39;&gt;&amp;µ&lt;/a&gt;"
    );
    assert_eq!(escape("EX0C"), "EX0C");
}

#[test]
fn names_are_escaped_in_the_page_and_in_the_plots() {
    let page = render(&sample()).unwrap();
    assert!(page.contains("examples/&lt;odd&gt;&amp;session"));
    assert!(page.contains("<title>mtcal identification — &lt;test&gt; &amp; co</title>"));
    assert!(page.contains("<td>bar.&lt;pivot_z&gt;</td>"));
    assert!(!page.contains("<pivot_z>") && !page.contains("<odd>") && !page.contains("<test>"));
    // plotters writes the curve's name into the SVG as its caption, escaped.
    let svg = plots::component(&curve("E<&>")).unwrap();
    assert!(svg.contains("E&lt;&amp;&gt;"), "{svg}");
    assert!(!svg.contains("E<&>"));
}

#[test]
fn a_polar_plot_has_one_point_per_sample_in_each_trace() {
    for n in [91, 361] {
        let run = circle_run(n);
        let svg = plots::polar(&run).unwrap();
        let measured = polylines(&svg, MEASURED);
        let model = polylines(&svg, MODEL);
        assert_eq!(measured.len(), 1, "one measured trace");
        assert_eq!(measured[0].len(), n);
        assert_eq!(model.len(), 1);
        assert_eq!(model[0].len(), n);
        assert_eq!(polylines(&svg, plots::BEFORE)[0].len(), n);
    }
    // A sample that is not a number is left out, not drawn at a made-up place.
    let mut run = circle_run(91);
    run.measured_um[10] = f64::NAN;
    let svg = plots::polar(&run).unwrap();
    assert_eq!(polylines(&svg, MEASURED)[0].len(), 90);
}

#[test]
fn a_polar_plot_magnifies_dr_about_the_reference_circle() {
    // dr = 3 cos φ: the trace is farther from the centre at 0° than at 180°.
    let mut run = circle_run(181);
    run.model_before_um = None;
    let svg = plots::polar(&run).unwrap();
    let model = &polylines(&svg, MODEL)[0];
    // The centre: the mean of a reference ring's points (181 of them, the last the first).
    let rings = polylines(&svg, plotters::style::RGBColor(0xBB, 0xBB, 0xBB));
    let ring = rings
        .iter()
        .find(|r| r.len() == 181)
        .expect("a reference ring");
    let mean = |f: &dyn Fn(&(i32, i32)) -> i32| {
        ring[..180].iter().map(|p| f64::from(f(p))).sum::<f64>() / 180.0
    };
    let (cx, cy) = (mean(&|p| p.0), mean(&|p| p.1));
    let r = |p: (i32, i32)| (f64::from(p.0) - cx).hypot(f64::from(p.1) - cy);
    assert!(
        r(model[0]) > r(model[90]) + 20.0,
        "{:?} {:?}",
        model[0],
        model[90]
    );
    // Angles run counter-clockwise: 90° is above the centre (SVG y grows downwards).
    assert!(f64::from(model[45].1) < cy);
}

#[test]
fn the_band_contains_the_curve() {
    let c = curve("EXX");
    let svg = plots::component(&c).unwrap();
    let line = polylines(&svg, MODEL);
    assert_eq!(line.len(), 1);
    let line = &line[0];
    assert_eq!(line.len(), c.samples.len());
    let polygons = elements(&svg, "polygon");
    assert_eq!(polygons.len(), 1, "one band");
    let band = points(attr(&polygons[0], "points").unwrap());
    let n = c.samples.len();
    assert_eq!(band.len(), 2 * n);
    for (i, &(x, y)) in line.iter().enumerate() {
        let upper = band[i];
        let lower = band[2 * n - 1 - i];
        assert_eq!((upper.0, lower.0), (x, x), "sample {i}");
        // SVG y grows downwards: the upper edge has the smaller y.
        assert!(
            upper.1 < y && y < lower.1,
            "sample {i}: {upper:?} {y} {lower:?}"
        );
    }
    // Wider where u95 is larger (the ends).
    let width = |i: usize| band[2 * n - 1 - i].1 - band[i].1;
    assert!(width(0) > width(n / 2));
}

#[test]
fn a_map_slice_colours_every_grid_point() {
    let s = slice(7, 5);
    let svg = plots::map_slice(&s, 10.0).unwrap();
    let rects = elements(&svg, "rect");
    let filled: Vec<_> = rects
        .iter()
        .filter(|r| attr(r, "fill").is_some_and(|f| f != "#FFFFFF" && f != "none"))
        .collect();
    // 35 cells and the 48 steps of the colour bar.
    assert_eq!(filled.len(), 35 + 48);
    // The largest value gets the top of the scale, the smallest the bottom.
    let lo = hex(plots::colour(0.0));
    assert!(filled.iter().any(|r| attr(r, "fill") == Some(lo.as_str())));
}

#[test]
fn unidentifiable_parameters_have_no_number() {
    let page = render(&sample()).unwrap();
    let table = section(&page, "parameters");
    for name in ["EX0C", "bar.&lt;pivot_z&gt;"] {
        let row_start = table
            .find(&format!("<tr data-param=\"{name}\">"))
            .unwrap_or_else(|| panic!("no row {name}"));
        let row = &table[row_start..row_start + table[row_start..].find("</tr>").unwrap()];
        assert!(row.contains("not identifiable"), "{row}");
        // The text of every cell after the name (attributes such as colspan aside).
        for cell in row.split("<td").skip(2) {
            let text = &cell[cell.find('>').unwrap() + 1..cell.find("</td>").unwrap()];
            assert!(
                !text.chars().any(|c| c.is_ascii_digit()),
                "a number for {name}: {row}"
            );
        }
    }
    // The identified one has its value and interval, rounded to the interval.
    assert!(
        table.contains("<td class=\"n\">11.4</td><td class=\"n\">1.3</td>"),
        "{table}"
    );
    let notes = section(&page, "identifiability");
    assert!(
        notes.contains("<b>EX0C and bar.&lt;pivot_z&gt;</b>"),
        "{notes}"
    );
    assert!(notes.contains("a second ball height"));
    // A weakly determined parameter keeps its number in the table and is named in the notes.
    assert!(
        notes.contains("barely determine") && notes.contains("<b>EY0A</b>"),
        "{notes}"
    );
}

#[test]
fn the_page_has_every_section_in_order_and_one_svg_per_plot() {
    let r = sample();
    let page = render(&r).unwrap();
    let mut at = 0;
    for (id, _) in SECTIONS {
        let k = page
            .find(&format!("<section id=\"{id}\">"))
            .unwrap_or_else(|| panic!("no section {id}"));
        assert!(k > at, "{id} out of order");
        at = k;
    }
    let count = |s: &str| s.matches("<svg ").count();
    assert_eq!(count(section(&page, "ballbar")), r.polar.len());
    assert_eq!(count(section(&page, "residuals")), r.residuals.len());
    assert_eq!(count(section(&page, "components")), r.components.len());
    assert_eq!(count(section(&page, "volumetric")), 1);
    assert_eq!(
        count(&page),
        r.polar.len() + r.residuals.len() + r.components.len() + 1
    );
    assert!(section(&page, "discoveries").contains("reversal X (X)"));
    assert!(section(&page, "discoveries").contains("1.004 → 0.756 µm"));
    // Nothing to fetch: the only address is the SVG namespace.
    let addresses = page.matches("http").count();
    assert_eq!(
        addresses,
        page.matches("http://www.w3.org/2000/svg").count() + 1
    );
    assert!(page.contains("http-equiv=\"Content-Security-Policy\""));
}

#[test]
fn empty_sections_say_why() {
    let page = render(&Report::default()).unwrap();
    assert!(section(&page, "ballbar").contains("No ball-bar circle runs"));
    assert!(section(&page, "components").contains("No component error"));
    assert!(section(&page, "discoveries").contains("did not run"));
    assert_eq!(page.matches("<svg ").count(), 0);
}

#[test]
fn bad_input_is_an_error_and_writes_nothing() {
    let mut r = sample();
    r.polar[0].model_um.pop();
    let err = render(&r).unwrap_err();
    assert!(matches!(err, ReportError::Invalid { .. }), "{err}");
    assert!(err.to_string().contains("ballbar-xy-ccw"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    assert!(write(&out, &r).is_err());
    assert!(!out.exists(), "nothing written on error");

    let mut r = sample();
    r.volumetric.slices[0].values_um.pop();
    assert!(matches!(render(&r), Err(ReportError::Invalid { .. })));
    let mut r = sample();
    r.components[0].samples.truncate(1);
    assert!(matches!(render(&r), Err(ReportError::Invalid { .. })));
}

#[test]
fn write_creates_the_folder_and_replaces_the_page() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a/b");
    let path = write(&out, &sample()).unwrap();
    assert_eq!(path, out.join("index.html"));
    let first = std::fs::read_to_string(&path).unwrap();
    assert!(first.starts_with("<!DOCTYPE html>"));
    let mut r = sample();
    r.title = "second".into();
    write(&out, &r).unwrap();
    let names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["index.html"], "no temporary file left");
    assert!(
        std::fs::read_to_string(&path)
            .unwrap()
            .contains("<title>second</title>")
    );
}

#[test]
fn intervals_round_to_two_significant_digits() {
    use crate::escape::with_interval;
    assert_eq!(
        with_interval(-3.2509, 1.0002),
        ("−3.3".into(), "1.0".into())
    );
    assert_eq!(
        with_interval(2.91494, 0.15710),
        ("2.91".into(), "0.16".into())
    );
    assert_eq!(with_interval(327.78, 256.09), ("328".into(), "256".into()));
}

#[test]
fn nice_scales() {
    assert_eq!(plots::nice_ceil(3.2), 5.0);
    assert_eq!(plots::nice_ceil(0.7), 1.0);
    assert_eq!(plots::nice_ceil(20.0), 20.0);
    assert_eq!(plots::stride(1500), 1);
    assert_eq!(plots::stride(1501), 2);
}

#[test]
fn a_path_plot_has_one_vertex_per_point_and_a_tilt_panel_when_given() {
    let points: Vec<PathPoint> = (0..37)
        .map(|k| PathPoint {
            along_mm: 2.5 * k as f64,
            error_um: 3.0 + (k as f64 * 0.3).sin(),
            tilt_urad: Some(10.0 + k as f64),
        })
        .collect();
    let svg = path_error_svg("path <a&b>", &points).unwrap();
    let lines = polylines(&svg, MODEL);
    assert_eq!(lines.len(), 2, "error and tilt panels");
    for l in &lines {
        assert_eq!(l.len(), points.len());
    }
    // The tool-tip error rises and falls with the data: its highest vertex is the largest error.
    let k = (0..points.len())
        .max_by(|&a, &b| points[a].error_um.total_cmp(&points[b].error_um))
        .unwrap();
    let top = lines[0].iter().map(|p| p.1).min().unwrap();
    assert_eq!(lines[0][k].1, top);
    // Without tilts, one panel; too few points is an error, never a panic.
    let flat: Vec<PathPoint> = points
        .iter()
        .map(|p| PathPoint {
            tilt_urad: None,
            ..*p
        })
        .collect();
    assert_eq!(
        polylines(&path_error_svg("p", &flat).unwrap(), MODEL).len(),
        1
    );
    assert!(path_error_svg("p", &flat[..1]).is_err());
}

#[test]
fn the_convention_card_is_under_the_parameter_table_escaped() {
    let page = crate::render(&sample()).unwrap();
    let at = page.find("<table id=\"conventions\">").expect("the card");
    assert!(at > page.find("<table id=\"parameter-table\">").unwrap());
    assert!(page[at..].contains("<th>squareness</th><td>C0Y &gt; 0 opens the angle &lt;X, Y&gt;"));
}

#[test]
fn diagnostics_are_tabled_under_the_ball_bar_plots_ranked_with_the_model_behind_them() {
    let page = crate::page::page(&sample()).unwrap();
    let ballbar = section(&page, "ballbar");
    let table = ballbar
        .split("<table class=\"diagnostics\" id=\"diagnostics-0\">")
        .nth(1)
        .expect("the pair's table in the ball-bar section")
        .split("</table>")
        .next()
        .unwrap();
    assert!(ballbar.contains("ballbar XY: &lt;ccw&gt; + cw (circularity 7.00 µm)"));
    let rows: Vec<&str> = table.split("<tr data-determined=").skip(1).collect();
    assert_eq!(rows.len(), 2);
    assert!(rows[0].starts_with("\"true\""), "{}", rows[0]);
    assert!(rows[0].contains("backlash X+") && rows[0].contains("reversal X (X) 100 %"));
    assert!(rows[0].contains(">44 %<"), "{}", rows[0]);
    assert!(rows[1].starts_with("\"false\"") && rows[1].contains("not in the model"));
    assert!(rows[1].contains(">–<"), "unranked: {}", rows[1]);
    assert!(ballbar.contains("not evaluated: cyclic error Y: too sparse"));
}

#[test]
fn the_series_section_is_there_only_with_series_and_draws_each_cycle() {
    let plain = render(&sample()).unwrap();
    assert!(!plain.contains("id=\"series\""));
    let cycle = |t_h: f64, value: Option<f64>, validation: bool| SeriesPoint {
        t_h,
        value,
        u95: value.map(|_| 0.3),
        model: 0.5 * t_h,
        validation,
    };
    let mut r = sample();
    r.location_series = vec![LocationSeriesPlot {
        name: "EY0A".into(),
        unit: "um".into(),
        caption: "EY0A (a thermal model) <moving>".into(),
        cycles: vec![
            cycle(0.0, Some(0.1), false),
            cycle(1.0, None, false),
            cycle(2.0, Some(1.2), false),
            cycle(3.0, Some(1.4), true),
        ],
    }];
    let page = render(&r).unwrap();
    let at = |id: &str| page.find(&format!("<section id=\"{id}\">")).unwrap();
    assert!(at("components") < at("series") && at("series") < at("volumetric"));
    assert!(page.contains("<a href=\"#series\">Location errors cycle by cycle</a>"));
    let s = section(&page, "series");
    assert!(s.contains("EY0A (a thermal model) &lt;moving&gt;"), "{s}");
    // A dot per cycle with a value (the withheld one hollow), none for the one without.
    let circles = elements(s, "circle");
    assert_eq!(circles.len(), 3, "{s}");
    let hollow = circles
        .iter()
        .filter(|c| attr(c, "fill") == Some("none"))
        .count();
    assert_eq!(hollow, 1, "{s}");
    // The model's line through every cycle.
    assert!(
        polylines(s, crate::plots::MODEL)
            .iter()
            .any(|l| l.len() == 4),
        "{s}"
    );
    // Everything else is as without it.
    let start = at("series");
    let end = start + page[start..].find("</section>\n").unwrap() + "</section>\n".len();
    let without = format!("{}{}", &page[..start], &page[end..])
        .replace("<a href=\"#series\">Location errors cycle by cycle</a>", "");
    assert_eq!(without, plain);
}

// A second instrument that draws its runs on circles (declared only in these tests).
inventory::submit! {
    mtcal_instrument::capability::PolarSection {
        instrument: "dial-circle",
        heading: "Dial circles",
        none: "No dial circles in this session.",
    }
}

#[test]
fn each_instrument_s_circles_are_under_its_own_heading() {
    let mut r = sample();
    let mut dial = circle_run(61);
    dial.name = "dial-xy".into();
    dial.instrument = "dial-circle".into();
    r.polar.push(dial);
    let mut table = r.diagnostics[0].clone();
    table.instrument = "dial-circle".into();
    table.title = "dial-circle XY: dial-xy".into();
    r.diagnostics.push(table);
    let page = render(&r).unwrap();
    let (bar, dial) = (section(&page, "ballbar"), section(&page, "dial-circle"));
    assert!(dial.contains("<h2>Dial circles</h2>"), "{dial}");
    assert_eq!(dial.matches("<svg ").count(), 1);
    assert!(dial.contains("dial-xy") && dial.contains("dial-circle XY"));
    assert_eq!(bar.matches("<svg ").count(), r.polar.len() - 1);
    assert!(!bar.contains("dial-xy") && !bar.contains("dial-circle XY"));
    // Without its runs, the section says so in its own words.
    let page = render(&sample()).unwrap();
    assert!(section(&page, "dial-circle").contains("No dial circles in this session."));
}
