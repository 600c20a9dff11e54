//! `rtest-stream` imports: a continuous stream built here from known visits (noise, arrivals
//! and departures, off-ball gaps of end-stop values, empty cells and a sensor at its stop, a
//! load phase between cycles), the Fanuc-style program that drove it and a context log give
//! back every visit — the mean of its dwell's middle half at the plateau's midpoint, the
//! commanded axes, the log interpolated — as per-ball runs a study loads; broken inputs are
//! refused where they are broken, writing nothing.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mtcal_import::{ImportError, StreamImported, StreamOptions, import_stream};
use mtcal_kinematics::Machine;
use mtcal_session::{RunColumns, RunUse, SetupRef};
use mtcal_testkit::random::SplitMix64;

const MACHINE: &str = "CAFYXZ";
const DT_S: f64 = 0.002;
/// Samples of a plateau: 1002 intervals, so the middle half's ends (250.5, 751.5) fall
/// between samples and it holds samples 251 ..= 751.
const N_PLATEAU: usize = 1003;
const RAMP: usize = 20;
const NOISE_UM: f64 = 0.3;
const CYCLES: usize = 3;
const DWELL_S: f64 = 2.0;

/// The balls (mm, workpiece frame) and the program's visits: ball, A, C (degrees).
const BALLS: [(&str, [f64; 3]); 3] = [
    ("b1", [150.0, 0.0, 60.0]),
    ("b2", [-100.0, 120.0, 80.0]),
    ("b3", [50.0, -150.0, 40.0]),
];
const POINTS: [(usize, f64); 5] = [(0, 0.0), (1, 0.0), (2, 0.0), (0, 90.0), (1, 90.0)];

fn machine() -> Machine {
    mtcal_machine::load_machine(MACHINE, Default::default())
        .unwrap()
        .machine
}

/// The nominal tool point (mm, workpiece frame) at axes `q` (file units, XYZAC).
fn tool_point_mm(m: &Machine, q: &[f64; 5]) -> [f64; 3] {
    let si: Vec<f64> = m
        .axes()
        .iter()
        .zip(q)
        .map(|(a, &v)| a.kind().from_file(v))
        .collect();
    let p = m.tool_in_workpiece(&si).t * 1e3;
    [p.x, p.y, p.z]
}

/// X, Y, Z (rounded to 0.1 µm as the program writes them) that put the tool point on `ball`
/// at A = 0 and `c_deg`: the point is affine in X, Y, Z, solved by Cramer's rule.
fn axes_for(m: &Machine, ball: [f64; 3], c_deg: f64) -> [f64; 5] {
    let at = |x: f64, y: f64, z: f64| tool_point_mm(m, &[x, y, z, 0.0, c_deg]);
    let p0 = at(0.0, 0.0, 0.0);
    let col = |p: [f64; 3]| [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]];
    let (a, b, c) = (
        col(at(1.0, 0.0, 0.0)),
        col(at(0.0, 1.0, 0.0)),
        col(at(0.0, 0.0, 1.0)),
    );
    let rhs = [ball[0] - p0[0], ball[1] - p0[1], ball[2] - p0[2]];
    let det = |u: [f64; 3], v: [f64; 3], w: [f64; 3]| {
        u[0] * (v[1] * w[2] - v[2] * w[1]) - v[0] * (u[1] * w[2] - u[2] * w[1])
            + w[0] * (u[1] * v[2] - u[2] * v[1])
    };
    let d = det(a, b, c);
    let round = |v: f64| (v * 1e4).round() / 1e4;
    [
        round(det(rhs, b, c) / d),
        round(det(a, rhs, c) / d),
        round(det(a, b, rhs) / d),
        0.0,
        c_deg,
    ]
}

/// The true reading of a visit (µm): different for every cycle and dwell.
fn truth_um(cycle: usize, dwell: usize) -> [f64; 3] {
    let (c, j) = (cycle as f64, dwell as f64);
    [
        5.0 + 2.0 * j + 0.7 * c,
        -3.0 + 0.5 * j - 1.1 * c,
        1.5 * c - 0.8 * j,
    ]
}

fn log_values(t: f64) -> [f64; 2] {
    [7500.0 - 0.1 * t, 20.0 + 0.002 * t]
}

/// What a visit must come back as.
#[derive(Debug, Clone)]
struct Expected {
    cycle: usize,
    dwell: usize,
    t_s: f64,
    start_s: f64,
    reading_um: [f64; 3],
}

/// The three input files and what they must give.
struct Synthetic {
    program: String,
    /// The program's line and column of each dwell's `G4`.
    g4_at: Vec<(usize, usize)>,
    /// The program's line of the `G0 X… Y…` before each dwell.
    xy_line: Vec<usize>,
    axes: Vec<[f64; 5]>,
    stream: Vec<String>,
    /// The stream's line of the first sample of each visit's plateau.
    plateau_line: Vec<usize>,
    log: String,
    expected: Vec<Expected>,
}

impl Synthetic {
    fn new() -> Synthetic {
        let m = machine();
        assert_eq!(m.letters(), "XYZAC");
        let axes: Vec<[f64; 5]> = POINTS
            .iter()
            .map(|&(b, c)| axes_for(&m, BALLS[b].1, c))
            .collect();
        let (program, g4_at, xy_line) = program(&axes);
        let mut s = Synthetic {
            program,
            g4_at,
            xy_line,
            axes,
            stream: vec!["t,dx,dy,dz".to_string()],
            plateau_line: Vec::new(),
            log: String::new(),
            expected: Vec::new(),
        };
        s.build_stream();
        s.log = log((s.stream.len() - 1) as f64 * DT_S);
        s
    }

    /// Pushes the next sample (`t` counts on from 0 in steps of `DT_S`); returns its time.
    fn push(&mut self, cells: String) -> f64 {
        let t = (self.stream.len() - 1) as f64 * DT_S;
        self.stream.push(format!("{t},{cells}"));
        t
    }

    /// Off the ball: end stops, empty cells, or one sensor at its stop.
    fn gap(&mut self, samples: usize, kind: usize) {
        for i in 0..samples {
            let cells = match kind % 3 {
                0 => "2000,2000,-2047.5".to_string(),
                1 => ",,".to_string(),
                _ => format!("2000,{},-3.25", 15.0 + i as f64 * 0.01),
            };
            self.push(cells);
        }
    }

    fn ramp(&mut self, from: [f64; 3], to: [f64; 3]) {
        for i in 0..RAMP {
            let w = i as f64 / (RAMP - 1) as f64;
            let v: Vec<String> = (0..3)
                .map(|c| (from[c] + w * (to[c] - from[c])).to_string())
                .collect();
            self.push(v.join(","));
        }
    }

    /// One visit: arrival, the plateau with noise, departure; records what it must give.
    fn visit(&mut self, cycle: usize, dwell: usize, rng: &mut SplitMix64) {
        let v = truth_um(cycle, dwell);
        self.ramp([1800.0; 3], v.map(|x| x + 40.0));
        self.plateau_line.push(self.stream.len() + 1);
        let mut samples = Vec::with_capacity(N_PLATEAU);
        let mut times = Vec::with_capacity(N_PLATEAU);
        for _ in 0..N_PLATEAU {
            let r = v.map(|x| x + NOISE_UM * rng.signed());
            // What the file gives back: the shortest decimal reads back to the same number.
            times.push(self.push(format!("{},{},{}", r[0], r[1], r[2])));
            samples.push(r);
        }
        let (start_s, end_s) = (times[0], times[N_PLATEAU - 1]);
        let middle = &samples[251..=751];
        let mean = [0, 1, 2].map(|c| middle.iter().map(|r| r[c]).sum::<f64>() / 501.0);
        self.expected.push(Expected {
            cycle,
            dwell,
            t_s: 0.5 * (start_s + end_s),
            start_s,
            reading_um: mean,
        });
        self.ramp(v.map(|x| x - 40.0), [-1800.0; 3]);
    }

    fn build_stream(&mut self) {
        let mut rng = SplitMix64(7);
        self.gap(1000, 0);
        for cycle in 0..CYCLES {
            for dwell in 0..POINTS.len() {
                self.visit(cycle, dwell, &mut rng);
                self.gap(300 + 7 * dwell, dwell);
            }
            // The load phase between cycles.
            self.gap(5000, cycle + 1);
        }
    }

    /// Writes the files into a new session folder; returns the folder (in `tmp`).
    fn write(&self, tmp: &Path) -> PathBuf {
        let dir = tmp.join("session");
        std::fs::create_dir_all(&dir).unwrap();
        let mut toml = format!("machine = \"{MACHINE}\"\n");
        for (name, b) in BALLS {
            writeln!(
                toml,
                "\n[setup.{name}]\nball = [{}, {}, {}]",
                b[0], b[1], b[2]
            )
            .unwrap();
        }
        std::fs::write(dir.join("session.toml"), toml).unwrap();
        std::fs::write(tmp.join("program.nc"), &self.program).unwrap();
        std::fs::write(tmp.join("stream.csv"), self.stream.join("\n") + "\n").unwrap();
        std::fs::write(tmp.join("log.csv"), &self.log).unwrap();
        dir
    }
}

/// A Fanuc-style program: comments, N numbers, modal G1 with F once, retracts; the line and
/// column of each dwell's G4 and the line of each approach's X Y.
fn program(axes: &[[f64; 5]]) -> (String, Vec<(usize, usize)>, Vec<usize>) {
    let mut lines = vec![
        "%".to_string(),
        "O0042 (MT-CHECK VOLUMETRIC THERMAL CYCLE)".to_string(),
        "N10 G21 G90 G17 G40 G49 G80".to_string(),
        "N20 G0 Z300. A0 C0 ; safe height".to_string(),
    ];
    let (mut g4_at, mut xy_line) = (Vec::new(), Vec::new());
    let mut n = 30;
    let mut block = |lines: &mut Vec<String>, text: String| {
        lines.push(format!("N{n} {text}"));
        n += 10;
        lines.len()
    };
    for (j, q) in axes.iter().enumerate() {
        block(&mut lines, format!("G0 C{:.4}", q[4]));
        xy_line.push(block(&mut lines, format!("X{:.4} Y{:.4}", q[0], q[1])));
        // G1 is modal from here to the retract; F only once.
        let f = if j == 0 { " F2000" } else { "" };
        block(&mut lines, format!("G1 Z{:.4}{f}", q[2]));
        let line = block(&mut lines, format!("G4 P{DWELL_S} (BALL VISIT {})", j + 1));
        let column = lines[line - 1].find("G4").unwrap() + 1;
        g4_at.push((line, column));
        block(&mut lines, format!("G0 Z{:.4}", q[2] + 50.0));
    }
    block(&mut lines, "M30".to_string());
    lines.push("%".to_string());
    (lines.join("\n") + "\n", g4_at, xy_line)
}

/// The log: every 0.5 s from before the stream to after it.
fn log(end_s: f64) -> String {
    let mut text = String::from("t,S,T_spindle,T_x_nut\n");
    let mut k = -2i64;
    loop {
        let t = k as f64 * 0.5;
        let [s, temp] = log_values(t);
        writeln!(text, "{t},{s},{temp},{}", temp + 1.0).unwrap();
        if t > end_s + 1.0 {
            return text;
        }
        k += 1;
    }
}

/// Imports the files [`Synthetic::write`] wrote into `tmp`.
fn import(tmp: &Path, dir: &Path, validate: &[usize]) -> Result<StreamImported, ImportError> {
    let (stream, program, log) = (
        tmp.join("stream.csv"),
        tmp.join("program.nc"),
        tmp.join("log.csv"),
    );
    import_stream(&StreamOptions {
        stream: &stream,
        program: &program,
        log: Some(&log),
        session: dir,
        validate_cycles: validate,
        name: None,
    })
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn a_synthetic_stream_gives_back_its_visits_as_per_ball_runs() {
    let s = Synthetic::new();
    let tmp = tempfile::tempdir().unwrap();
    let dir = s.write(tmp.path());
    let imported = import(tmp.path(), &dir, &[2]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(imported.cycles, CYCLES);
    assert_eq!(imported.cut.plateaus.len(), CYCLES * POINTS.len());
    assert_eq!(imported.cut.passages_without_plateau, 0);
    let names: Vec<(&str, RunUse)> = imported
        .runs
        .iter()
        .map(|r| (r.name.as_str(), r.use_))
        .collect();
    use RunUse::{Fit, Validate};
    assert_eq!(
        names,
        [
            ("b1", Fit),
            ("b2", Fit),
            ("b3", Fit),
            ("b1-c2", Validate),
            ("b2-c2", Validate),
            ("b3-c2", Validate)
        ]
    );
    let session = mtcal_session::load_session(&dir).unwrap();
    for run in &session.runs {
        check_run(&s, &dir, run);
    }
    // Every visit is in exactly one run.
    let rows: usize = imported.runs.iter().map(|r| r.rows).sum();
    assert_eq!(rows, s.expected.len());
    let study = mtcal_identify::Study::load(&dir).unwrap_or_else(|e| panic!("{e}"));
    drop(study);
    let card = imported.card();
    for says in [
        "5 dwells (lines 8 … 28) of 2 … 2 s on 3 balls",
        "15 plateaus = 3 cycles of 5 dwells",
        "visits per ball: b1 6, b2 6, b3 3",
        "columns S, T_spindle, T_x_nut",
        "wrote 6 runs (3 fit, 3 validate)",
        "b1-c2.csv: rtest run b1-c2, setup b1, validate, 2 visits",
        "b3-c2.csv: rtest run b3-c2, setup b3, validate, 1 visit\n",
        "cycles 2 withheld",
        "off a ball: an empty cell or a reading at or beyond ±2000 µm",
    ] {
        assert!(card.contains(says), "the card lacks `{says}`:\n{card}");
    }
}

/// The run's rows are its ball's visits of its cycles, in time order, exactly.
fn check_run(s: &Synthetic, dir: &Path, run: &mtcal_session::RunSpec) {
    let SetupRef::Shared(ball) = &run.setup else {
        panic!("run {} has no shared set-up", run.name)
    };
    assert_eq!(run.instrument, "rtest");
    let cycle = run
        .name
        .split_once("-c")
        .map(|(_, k)| k.parse::<usize>().unwrap() - 1);
    let want: Vec<&Expected> = s
        .expected
        .iter()
        .filter(|e| BALLS[POINTS[e.dwell].0].0 == ball)
        .filter(|e| match cycle {
            Some(c) => e.cycle == c,
            None => e.cycle != 1,
        })
        .collect();
    let table = mtcal_session::read_run(
        &dir.join(&run.file_as_written),
        &RunColumns {
            axes: &['X', 'Y', 'Z', 'A', 'C'],
            readings: &["dx", "dy", "dz"],
            readings_optional: false,
            labels: &[],
        },
    )
    .unwrap();
    assert_eq!(table.len(), want.len(), "run {}", run.name);
    for (i, e) in want.iter().enumerate() {
        assert!(close(table.t[i], e.t_s), "run {} row {i}: t", run.name);
        assert_eq!(
            table.q_row(i),
            &s.axes[e.dwell][..],
            "run {} row {i}",
            run.name
        );
        let r = table.reading_row(i).unwrap();
        for (c, (got, want)) in r.iter().zip(e.reading_um).enumerate() {
            assert!(
                close(*got, want),
                "run {} row {i}: reading {c} {got} against {want}",
                run.name
            );
        }
        let [speed, temp] = log_values(e.t_s);
        assert!(close(table.context_column("S").unwrap()[i], speed));
        assert!(close(table.context_column("T_spindle").unwrap()[i], temp));
        assert!(close(
            table.context_column("T_x_nut").unwrap()[i],
            temp + 1.0
        ));
    }
}

/// Every file of `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect()
}

/// Imports `s` with `validate`; the error's message, after checking nothing was written.
fn refused(s: &Synthetic, validate: &[usize]) -> (String, tempfile::TempDir) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = s.write(tmp.path());
    let before = snapshot(&dir);
    let e = import(tmp.path(), &dir, validate).expect_err("must be refused");
    assert_eq!(snapshot(&dir), before, "nothing written for: {e}");
    (e.to_string(), tmp)
}

#[test]
fn a_cell_that_is_not_a_number_is_named_by_line_and_column() {
    let mut s = Synthetic::new();
    let line = s.plateau_line[6] + 10;
    let cells: Vec<String> = s.stream[line - 1].split(',').map(String::from).collect();
    let column = cells[0].len() + cells[1].len() + 3;
    s.stream[line - 1] = format!("{},{},4.2.1,{}", cells[0], cells[1], cells[3]);
    let (message, tmp) = refused(&s, &[]);
    let file = tmp.path().join("stream.csv");
    assert_eq!(
        message,
        format!(
            "{}:{line}:{column}: column \"dy\": expected a number, found `4.2.1`",
            file.display()
        )
    );
}

#[test]
fn an_incremental_program_is_refused_at_its_g91() {
    let mut s = Synthetic::new();
    s.program = s.program.replace("N10 G21 G90", "N10 G21 G91");
    let (message, tmp) = refused(&s, &[]);
    assert!(
        message.starts_with(&format!(
            "{}:3:9: expected G90 (absolute positions), found G91",
            tmp.path().join("program.nc").display()
        )),
        "{message}"
    );
}

#[test]
fn a_dwell_on_no_ball_is_refused_at_its_line() {
    let mut s = Synthetic::new();
    let line = s.xy_line[1];
    let mut lines: Vec<String> = s.program.lines().map(String::from).collect();
    lines[line - 1] = format!("N999 X{:.4} Y{:.4}", s.axes[1][0] + 5.0, s.axes[1][1]);
    s.program = lines.join("\n") + "\n";
    let (message, tmp) = refused(&s, &[]);
    let (g4_line, g4_column) = s.g4_at[1];
    let prefix = format!(
        "{}:{g4_line}:{g4_column}: expected the nominal tool point on a set-up's ball (within 1 \
         mm), found it at (",
        tmp.path().join("program.nc").display()
    );
    assert!(message.starts_with(&prefix), "{message}");
    assert!(
        message.ends_with("5.000 mm from the nearest, `b2`"),
        "{message}"
    );
}

#[test]
fn a_missing_plateau_is_refused_where_the_cycles_go_out_of_step() {
    let mut s = Synthetic::new();
    // Visit 3 of cycle 2 (index 7): its plateau becomes empty cells, the head off the ball.
    let first = s.plateau_line[7];
    for line in first - 1 - RAMP..first - 1 + N_PLATEAU + RAMP {
        let t = s.stream[line].split(',').next().unwrap().to_string();
        s.stream[line] = format!("{t},,,");
    }
    let (message, tmp) = refused(&s, &[]);
    // The next plateau (visit 4 of cycle 2) is taken for visit 3: its gap is out of step.
    assert_eq!(
        message,
        format!(
            "{}: t = {} s: expected a whole number of cycles of 5 dwells, found 14 plateaus (2 \
             cycles and 4 over); the gap before this plateau differs from cycle 1's: a visit \
             missing or extra near here?",
            tmp.path().join("stream.csv").display(),
            s.expected[8].start_s
        )
    );
}

#[test]
fn a_dwell_in_milliseconds_is_refused_at_the_first_plateau() {
    let mut s = Synthetic::new();
    s.program = s.program.replace("G4 P2 ", "G4 P2000 ");
    let (message, tmp) = refused(&s, &[]);
    assert!(
        message.starts_with(&format!(
            "{}: t = {} s: plateau 1 (cycle 1, dwell 1 of 5) lasts 2.004 s, much shorter than \
             its dwell of 2000 s",
            tmp.path().join("stream.csv").display(),
            s.expected[0].start_s
        )),
        "{message}"
    );
    assert!(message.ends_with("or a G4 P in ms?)"), "{message}");
}

#[test]
fn unknown_columns_are_refused_at_their_header_cell() {
    let mut s = Synthetic::new();
    s.stream[0] = "t,dx,dy,dq".to_string();
    let (message, tmp) = refused(&s, &[]);
    assert_eq!(
        message,
        format!(
            "{}:1:9: expected the columns t, dx, dy, dz (in any order), found \"dq\"",
            tmp.path().join("stream.csv").display()
        )
    );
    let mut s = Synthetic::new();
    s.log = s
        .log
        .replacen("t,S,T_spindle,T_x_nut", "t,S,load,T_x_nut", 1);
    let (message, tmp) = refused(&s, &[]);
    assert!(
        message.starts_with(&format!(
            "{}:1:5: expected t and context columns",
            tmp.path().join("log.csv").display()
        )),
        "{message}"
    );
    assert!(message.ends_with("found \"load\""), "{message}");
}

#[test]
fn a_log_that_ends_early_or_a_cycle_beyond_the_stream_is_refused() {
    let mut s = Synthetic::new();
    let keep: Vec<&str> = s.log.lines().take(100).collect();
    s.log = keep.join("\n") + "\n";
    let (message, tmp) = refused(&s, &[]);
    assert!(
        message.starts_with(&format!(
            "{}: t = {} s: expected the log to cover every visit, found it from t = -1 to 48 s",
            tmp.path().join("log.csv").display(),
            s.expected.iter().find(|e| e.t_s > 48.0).unwrap().t_s
        )),
        "{message}"
    );
    let s = Synthetic::new();
    let (message, _) = refused(&s, &[4]);
    assert_eq!(
        message,
        "--validate-cycles 4: the stream has 3 cycles, numbered 1 … 3"
    );
    let (message, _) = refused(&s, &[1, 2, 3]);
    assert_eq!(
        message,
        "--validate-cycles leaves none of the 3 cycles to fit"
    );
}
