//! `mtcal identify --report DIR`, looked at as a person would: the page is rendered by headless
//! Chromium and its DOM checked for the sections, the plots each section should have (counted
//! from the session files and the JSON of the same run, not from the page) and no script error.
//!
//! Without `/usr/bin/chromium` (Debian package `chromium`; `.ci/run` installs it) the tests
//! say so on standard error and pass — unless `MTCAL_REQUIRE_CHROMIUM=1` (as `.ci/run` sets
//! it), when they fail: CI must not pass a page nobody looked at.

use mtcal_testkit::repo;
use std::collections::BTreeSet;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const CHROMIUM: &str = "/usr/bin/chromium";

fn have_chromium() -> bool {
    if Path::new(CHROMIUM).exists() {
        return true;
    }
    assert!(
        std::env::var("MTCAL_REQUIRE_CHROMIUM").as_deref() != Ok("1"),
        "chromium not installed ({CHROMIUM}) and MTCAL_REQUIRE_CHROMIUM=1"
    );
    eprintln!("skipped: chromium not installed ({CHROMIUM}; apt-get install chromium)");
    false
}

/// Runs `mtcal identify ARGS --quiet --json J --report R` in the repository; returns the
/// report folder's page, the JSON and standard output.
fn identify(args: &[&str], tmp: &Path) -> (PathBuf, serde_json::Value, String) {
    let report = tmp.join("report dir <&>");
    let json = tmp.join("id.json");
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .arg("identify")
        .args(args)
        .arg("--quiet")
        .arg("--json")
        .arg(&json)
        .arg("--report")
        .arg(&report)
        .current_dir(repo())
        .output()
        .expect("mtcal runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    // 1: done, an acceptance check not passed (tests/exit_codes.rs); the report is written.
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = report.join("index.html");
    assert!(
        stdout.contains(&format!("wrote {}", page.display())),
        "{stdout}"
    );
    let text = std::fs::read_to_string(&json).expect("the JSON is written");
    let names: Vec<_> = std::fs::read_dir(&report)
        .expect("the report folder exists")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(names, ["index.html"], "only the page, no temporary file");
    (page, serde_json::from_str(&text).expect("JSON"), stdout)
}

/// Chromium with a fresh profile and nothing that reaches the network, stopped after two
/// minutes. Its output is read while it runs (a page's DOM fills a pipe).
fn chromium(profile: &Path, args: &[String]) -> std::process::Output {
    let mut child = Command::new(CHROMIUM)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("chromium starts");
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut buf);
            }
            buf
        })
    };
    let stdout = drain(
        child
            .stdout
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let stderr = drain(
        child
            .stderr
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for chromium") {
            break status;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("chromium did not finish within two minutes");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    std::process::Output {
        status,
        stdout: stdout.join().expect("stdout reader"),
        stderr: stderr.join().expect("stderr reader"),
    }
}

fn url(page: &Path) -> String {
    let abs = page.canonicalize().expect("the page exists");
    // The folder name has a space, `<`, `&` and `>`: percent-encode what a URL cannot carry.
    let mut url = String::from("file://");
    for b in abs.to_string_lossy().bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'/' | b'-' | b'_' | b'.' => {
                url.push(b as char)
            }
            _ => url.push_str(&format!("%{b:02X}")),
        }
    }
    url
}

/// The page's DOM after its scripts ran; a screenshot of it is checked to be a real image.
fn render(page: &Path, tmp: &Path) -> String {
    let out = chromium(
        &tmp.join("profile-dom"),
        &["--dump-dom".to_string(), url(page)],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let dom = String::from_utf8(out.stdout).expect("UTF-8 DOM");
    assert!(dom.contains("<body"), "no DOM:\n{dom}");
    let shot = tmp.join("page.png");
    let out = chromium(
        &tmp.join("profile-shot"),
        &[
            "--window-size=1280,3000".to_string(),
            format!("--screenshot={}", shot.display()),
            url(page),
        ],
    );
    assert!(out.status.success());
    let png = std::fs::read(&shot).expect("the screenshot is written");
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 20_000,
        "a real screenshot"
    );
    dom
}

/// The DOM of `<section id="id">`.
fn section<'a>(dom: &'a str, id: &str) -> &'a str {
    let start = dom
        .find(&format!("<section id=\"{id}\">"))
        .unwrap_or_else(|| panic!("no section {id} in the rendered page"));
    let end = dom[start..].find("</section>").expect("the section closes");
    &dom[start..start + end]
}

fn svgs(html: &str) -> usize {
    html.matches("<svg ").count()
}

/// Checks common to every report: the scripts ran without error, every section is there, the
/// plot count the page's own script made equals the SVGs in the DOM.
fn check_page(dom: &str) -> usize {
    assert!(
        dom.contains("data-report-ready=\"yes\""),
        "the closing script did not run"
    );
    let errors_at = dom.find("id=\"script-errors\"").expect("the error box");
    let errors = &dom[errors_at..];
    let errors = &errors[errors.find('>').expect("tag") + 1..errors.find("</pre>").expect("box")];
    assert!(errors.trim().is_empty(), "script errors: {errors}");
    for id in [
        "summary",
        "ballbar",
        "residuals",
        "components",
        "volumetric",
        "parameters",
        "identifiability",
        "discoveries",
    ] {
        section(dom, id);
    }
    let n = svgs(dom);
    assert!(
        dom.contains(&format!("data-plots=\"{n}\"")),
        "the page counted other plots than the DOM has ({n})"
    );
    n
}

/// Header columns of the session's run files.
fn csv_headers(session: &Path) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(session).expect("session folder") {
        let path = e.expect("entry").path();
        if path.extension().is_some_and(|x| x == "csv") {
            let text = std::fs::read_to_string(&path).expect("run file");
            let header = text.lines().next().unwrap_or("");
            out.push(header.split(',').map(|s| s.trim().to_string()).collect());
        }
    }
    out
}

fn is_context(column: &str) -> bool {
    matches!(column, "S" | "F") || ["T_", "P_", "H_"].iter().any(|p| column.starts_with(p))
}

/// The parameter table: every identified parameter has a row, every one the data cannot
/// separate reads "not identifiable" with no number in its cells.
fn check_parameters(dom: &str, json: &serde_json::Value) {
    let table = section(dom, "parameters");
    let row = |name: &str| {
        let start = table
            .find(&format!("<tr data-param=\"{name}\">"))
            .unwrap_or_else(|| panic!("no row for {name}"));
        &table[start..start + table[start..].find("</tr>").expect("row closes")]
    };
    for p in json["parameters"].as_array().expect("parameters") {
        let name = p["name"].as_str().expect("name");
        assert!(!row(name).contains("not identifiable"), "{name}");
    }
    let unidentifiable: BTreeSet<&str> = json["unidentifiable"]
        .as_array()
        .expect("unidentifiable")
        .iter()
        .flat_map(|u| u["parameters"].as_array().expect("names"))
        .map(|n| n.as_str().expect("name"))
        .collect();
    for name in &unidentifiable {
        let r = row(name);
        assert!(r.contains("not identifiable"), "{r}");
        for cell in r.split("<td").skip(2) {
            let text = &cell[cell.find('>').expect("td") + 1..cell.find("</td>").expect("td")];
            assert!(!text.chars().any(|c| c.is_ascii_digit()), "a number: {r}");
        }
        assert!(
            section(dom, "identifiability").contains(name),
            "{name} not explained"
        );
    }
}

#[test]
fn the_warm_five_axis_report_shows_what_the_search_found() {
    if !have_chromium() {
        return;
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let session = "examples/five-axis-warm/session";
    let (page, json, _) = identify(&[session, "--search"], tmp.path());
    let dom = render(&page, tmp.path());
    let total = check_page(&dom);

    // One polar plot per ball-bar circle: the runs the ISO 230-4 evaluation recognised.
    let runs = json["fit"]["runs"]
        .as_array()
        .expect("runs")
        .iter()
        .chain(json["validation"].as_array().expect("validation"));
    let circles: Vec<&str> = runs
        .filter(|r| r["instrument"] == "ballbar")
        .filter(|r| r["metrics"].as_array().is_some_and(|m| !m.is_empty()))
        .map(|r| r["name"].as_str().expect("name"))
        .collect();
    assert!(!circles.is_empty());
    let ballbar = section(&dom, "ballbar");
    assert_eq!(svgs(ballbar), circles.len());
    for name in &circles {
        assert!(ballbar.contains(&format!("data-name=\"{name}\"")), "{name}");
    }
    // The XY circle pair's diagnostics as the JSON has them, the first ranked row the X
    // backlash the search found, with the discovery behind it.
    let diagnosis = &json["diagnostics"][0];
    assert_eq!(diagnosis["subject"], "XY");
    let first = &diagnosis["items"][0];
    let name = first["name"].as_str().expect("name");
    assert!(
        name.starts_with("backlash X") && first["rank"] == 1,
        "{first}"
    );
    let behind = first["behind"][0]["name"].as_str().expect("behind");
    assert!(
        json["discoveries"]
            .as_array()
            .expect("discoveries")
            .iter()
            .any(|d| d["label"] == behind),
        "{behind}"
    );
    let table = ballbar
        .split("id=\"diagnostics-0\"")
        .nth(1)
        .expect("the diagnostics table under the circles");
    let row = table
        .split("<tr data-determined=\"true\"")
        .nth(1)
        .expect("a ranked row");
    assert!(row.contains(name) && row.contains(behind), "{row}");

    // One residual plot per context variable the run files recorded, plus time; each with the
    // model before and after the search.
    let headers = csv_headers(&repo().join(session));
    let mut variables: BTreeSet<String> = BTreeSet::from(["t".to_string()]);
    variables.extend(headers.iter().flatten().filter(|c| is_context(c)).cloned());
    let residuals = section(&dom, "residuals");
    assert_eq!(svgs(residuals), variables.len());
    for v in &variables {
        assert!(residuals.contains(&format!("data-name=\"{v}\"")), "{v}");
    }
    assert_eq!(
        residuals.matches("before the physics search").count(),
        variables.len()
    );
    assert_eq!(
        residuals.matches("after the physics search").count(),
        variables.len()
    );

    // Component curves as the JSON has them; one map slice per pair of the three linear axes.
    let components = json["component_errors"].as_array().expect("curves").len();
    assert_eq!(svgs(section(&dom, "components")), components);
    let linear: BTreeSet<&String> = headers
        .iter()
        .flatten()
        .filter(|c| ["X", "Y", "Z"].contains(&c.as_str()))
        .collect();
    let pairs = linear.len() * (linear.len() - 1) / 2;
    assert_eq!(svgs(section(&dom, "volumetric")), pairs.min(3));
    assert_eq!(
        total,
        circles.len() + variables.len() + components + pairs.min(3)
    );

    check_parameters(&dom, &json);

    // The discoveries in words: every effect the search added, with its sentence.
    let discoveries = json["discoveries"].as_array().expect("discoveries");
    assert!(
        !discoveries.is_empty(),
        "the README's example finds effects"
    );
    let words = section(&dom, "discoveries");
    for d in discoveries {
        let label = d["label"].as_str().expect("label");
        assert!(words.contains(&format!("<h3>{label}</h3>")), "{label}");
        let sentence = d["explanation"].as_str().expect("sentence");
        let start: String = sentence.chars().take(40).collect();
        assert!(words.contains(&start), "{start}");
    }
    // The drift may be named as the spindle growing along its axis with a drift of Z among
    // what these data cannot tell it from: on a trunnion the two are one column.
    let effects: BTreeSet<&str> = discoveries
        .iter()
        .flat_map(|d| {
            let alternatives = d["alternatives"].as_array().into_iter().flatten();
            std::iter::once(&d["effect"]).chain(alternatives.map(|a| &a["effect"]))
        })
        .map(|e| e.as_str().expect("effect"))
        .collect();
    assert!(
        effects.contains("reversal") && effects.contains("thermal-drift"),
        "{effects:?}"
    );
}

#[test]
fn a_report_without_the_search_shows_component_curves_with_bands() {
    if !have_chromium() {
        return;
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let acceptance = ["--acceptance", "examples/acceptance/three-axis.toml"];
    let (page, json, _) = identify(
        &["examples/three-axis/session", acceptance[0], acceptance[1]],
        tmp.path(),
    );
    let dom = render(&page, tmp.path());
    check_page(&dom);
    // The acceptance section: the overall verdict and one row per check of the JSON, each with
    // its verdict.
    let verdicts = section(&dom, "acceptance");
    let checks = json["acceptance"]["checks"].as_array().expect("checks");
    let overall = json["acceptance"]["verdict"].as_str().expect("verdict");
    assert!(
        verdicts.contains(&format!("data-verdict=\"{overall}\"")),
        "{verdicts}"
    );
    assert_eq!(
        verdicts.matches("<tr").count(),
        checks.len() + 1,
        "{verdicts}"
    );
    // What the numbers mean, under the parameter table.
    let card = section(&dom, "parameters");
    for key in ["values are", "squareness", "rotary direction", "units"] {
        assert!(card.contains(&format!("<th>{key}</th>")), "{key}");
    }
    let curves = json["component_errors"].as_array().expect("curves");
    assert!(!curves.is_empty());
    let components = section(&dom, "components");
    assert_eq!(svgs(components), curves.len());
    // Each plot has its band: one filled polygon per curve.
    assert_eq!(components.matches("<polygon ").count(), curves.len());
    for c in curves {
        let name = c["name"].as_str().expect("name");
        assert!(
            components.contains(&format!("data-name=\"{name}\"")),
            "{name}"
        );
    }
    assert!(section(&dom, "discoveries").contains("did not run"));
    assert!(section(&dom, "ballbar").contains("No ball-bar circle runs"));
    assert!(!section(&dom, "residuals").contains("before the physics search"));
    check_parameters(&dom, &json);
}

/// The bundled R-test sets between rotary load cycles: the page has the location errors cycle
/// by cycle, one plot per series of the JSON (the moving lines first), each with a bar per
/// cycle the cycle separates; a page without series has no such section.
#[test]
fn the_rtest_sets_report_shows_the_location_errors_cycle_by_cycle() {
    if !have_chromium() {
        return;
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let (page, json, _) = identify(&["examples/volumetric/rtest-sets", "--search"], tmp.path());
    let dom = render(&page, tmp.path());
    check_page(&dom);
    let series = json["location_series"].as_array().expect("series");
    let plots = section(&dom, "series");
    assert_eq!(svgs(plots), series.len(), "{plots}");
    let first = plots.find("data-name=\"").expect("a named plot");
    let name = &plots[first + 11..first + 15];
    assert!(["EY0A", "EX0C"].contains(&name), "first plot {name}");
    for l in series {
        let name = l["parameter"].as_str().expect("name");
        assert!(plots.contains(&format!("data-name=\"{name}\"")), "{name}");
    }
    let page_text = std::fs::read_to_string(&page).expect("page");
    assert!(page_text.contains("<section id=\"series\">"));
    let other = tempfile::tempdir().expect("temporary folder");
    let (page, _, _) = identify(&["examples/three-axis/session"], other.path());
    let text = std::fs::read_to_string(&page).expect("page");
    assert!(!text.contains("<section id=\"series\">"));
}

/// `history report`: a machine's page in Chromium: the scripts ran, the fleet row is there, one
/// trend plot per parameter asked for with the tolerance lines, and the page counted them.
#[test]
fn the_history_page_shows_the_trends_and_the_fleet() {
    if !have_chromium() {
        return;
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let db = tmp.path().join("history.sqlite");
    let result = tmp.path().join("result.json");
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
            .args(args)
            .current_dir(repo())
            .output()
            .expect("mtcal runs");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let (db, result) = (db.to_str().unwrap(), result.to_str().unwrap());
    run(&[
        "identify",
        "examples/three-axis/session",
        "--quiet",
        "--json",
        result,
    ]);
    for date in ["2026-01-10", "2026-04-10", "2026-07-01"] {
        run(&[
            "history",
            "add",
            result,
            "--machine",
            "mill <3>",
            "--date",
            date,
            "--db",
            db,
        ]);
    }
    let out_dir = tmp.path().join("history page");
    run(&[
        "history",
        "report",
        "mill <3>",
        "--param",
        "EC0Y",
        "--param",
        "EXX.P1",
        "--tolerances",
        "examples/acceptance/three-axis.toml",
        "--db",
        db,
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let dom = render(&out_dir.join("index.html"), tmp.path());
    assert!(
        dom.contains("data-report-ready=\"yes\""),
        "the closing script did not run"
    );
    assert!(dom.contains("id=\"script-errors\" hidden"), "script errors");
    let fleet = section(&dom, "fleet");
    assert!(fleet.contains("<td>mill &lt;3&gt;</td>"), "{fleet}");
    let trends = section(&dom, "trends");
    assert_eq!(svgs(trends), 2);
    assert!(dom.contains("data-plots=\"2\""));
    // EC0Y has a tolerance (20 µrad): its plot draws the two limit lines in the limit colour.
    let ec0y = &trends[trends.find("data-name=\"EC0Y\"").expect("EC0Y's plot")..];
    let ec0y = &ec0y[..ec0y.find("</figure>").expect("figure closes")];
    assert!(
        ec0y.to_ascii_uppercase().matches("#C02020").count() >= 2,
        "no limit lines"
    );
}

/// `volumetric --report FILE.html` on a simulated drive-heat test: the page in Chromium ran
/// its scripts cleanly, says "not uniform" with one table row per axis, draws one vector plot
/// per phase asked for and the three time plots, and counted them itself.
#[test]
fn the_volumetric_page_shows_the_verdict_the_vectors_and_the_time_plots() {
    if !have_chromium() {
        return;
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let session = tmp.path().join("drive");
    let machine =
        mtcal_indsim::Machine::from_urdf_file(&mtcal_indsim::shipped_machine("mcu630-cafyxz.urdf"))
            .expect("the shipped trunnion");
    let mut spec = mtcal_indsim::VolumetricSpec::short(mtcal_indsim::VolumetricLoad::YDrive, 5);
    spec.stream = None;
    mtcal_indsim::Campaign::volumetric_trunnion(
        &session,
        &mtcal_indsim::Truth::zero(&machine),
        &spec,
        &mtcal_indsim::Realism::realistic(2),
    )
    .expect("the simulator writes the session");
    let page = tmp.path().join("page <&>.html");
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .arg("volumetric")
        .arg(&session)
        .arg("--report")
        .arg(&page)
        .args(["--phase", "0.3,1.0"])
        .output()
        .expect("mtcal runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let dom = render(&page, tmp.path());
    assert!(
        dom.contains("data-report-ready=\"yes\""),
        "the closing script did not run"
    );
    assert!(dom.contains("id=\"script-errors\" hidden"), "script errors");
    let verdict = section(&dom, "verdict");
    assert!(
        verdict.contains("data-verdict=\"not uniform\""),
        "{verdict}"
    );
    assert_eq!(verdict.matches("<tr data-axis=").count(), 3);
    assert_eq!(svgs(section(&dom, "phases")), 2);
    assert_eq!(svgs(section(&dom, "time")), 3);
    section(&dom, "details");
    assert!(
        dom.contains("data-plots=\"5\""),
        "the page counted other plots"
    );
}
