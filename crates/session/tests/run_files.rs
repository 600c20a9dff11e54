//! Run CSV files: every rejected input names file, line, column and the problem; accepted
//! variants load; writing and reading back is bit-exact.

use std::path::{Path, PathBuf};

use mtcal_session::{RunColumns, RunTable, SessionError, read_run, write_run};
use proptest::prelude::*;

const AXES: &[char] = &['X', 'Y', 'Z', 'C'];
const RTEST: &[&str] = &["dx", "dy", "dz"];

fn fit() -> RunColumns<'static> {
    RunColumns {
        axes: AXES,
        readings: RTEST,
        readings_optional: false,
        labels: &[],
    }
}

fn validate() -> RunColumns<'static> {
    RunColumns {
        readings_optional: true,
        ..fit()
    }
}

fn write(dir: &Path, bytes: &[u8]) -> PathBuf {
    let p = dir.join("run1.csv");
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Reads `bytes` as a run file and checks the error's line, column and a phrase of it.
fn check_err(bytes: &[u8], cols: RunColumns, line: usize, column: usize, phrase: &str) {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), bytes);
    let e = read_run(&p, &cols).expect_err("the file must be rejected");
    let at = e.location().expect("a located error");
    assert_eq!(
        (at.file.as_path(), at.line, at.column),
        (p.as_path(), line, column),
        "{e}"
    );
    let text = e.to_string();
    assert!(
        text.starts_with(&format!("{}:{line}:{column}: ", p.display())),
        "{text}"
    );
    assert!(text.contains(phrase), "`{phrase}` not in: {text}");
}

const HEADER: &str = "t,X,Y,Z,C,dx,dy,dz\n";

fn rows(body: &str) -> Vec<u8> {
    format!("{HEADER}{body}").into_bytes()
}

#[test]
fn empty_file() {
    check_err(
        b"",
        fit(),
        1,
        1,
        "the file is empty: expected a header row such as `t,X,Y,Z,C,dx,dy,dz`",
    );
    check_err(b"\n  \n", fit(), 1, 1, "the file is empty");
}

#[test]
fn header_only() {
    check_err(HEADER.as_bytes(), fit(), 2, 1, "header but no rows");
    check_err(&rows("\n\n"), fit(), 2, 1, "header but no rows");
}

#[test]
fn missing_t() {
    check_err(
        b"X,Y,Z,C,dx,dy,dz\n1,2,3,4,5,6,7\n",
        fit(),
        1,
        1,
        "missing column `t`",
    );
}

#[test]
fn missing_axis_names_the_machine_axes() {
    check_err(
        b"t,X,Y,dx,dy,dz\n0,1,2,3,4,5\n",
        fit(),
        1,
        1,
        "missing axis column(s) Z, C: the machine's axes are X, Y, Z, C",
    );
}

#[test]
fn missing_reading_names_the_instrument_columns() {
    check_err(
        b"t,X,Y,Z,C,dx,dy\n0,1,2,3,4,5,6\n",
        fit(),
        1,
        1,
        "missing reading column(s) dz: this instrument's readings are dx, dy, dz",
    );
    // A fitted run may not leave out all of them either.
    check_err(
        b"t,X,Y,Z,C\n0,1,2,3,4\n",
        fit(),
        1,
        1,
        "missing reading column(s) dx, dy, dz",
    );
}

#[test]
fn validation_run_has_all_readings_or_none() {
    check_err(
        b"t,X,Y,Z,C,dy\n0,1,2,3,4,5\n",
        validate(),
        1,
        1,
        "has reading column(s) dy but not dx, dz: a validation run has all",
    );
}

#[test]
fn duplicate_column() {
    check_err(
        b"t,X,Y,Z,X,C,dx,dy,dz\n0,1,2,3,4,5,6,7,8\n",
        fit(),
        1,
        5,
        "column \"X\" appears twice, as columns 2 and 5",
    );
}

#[test]
fn unknown_column_lists_the_allowed_ones() {
    check_err(
        b"t,X,Y,Z,C,dx,dy,dz,temp\n0,1,2,3,4,5,6,7,8\n",
        fit(),
        1,
        9,
        "unknown column \"temp\": a run file has only `t`; the machine's axes X, Y, Z, C; the \
         instrument's readings dx, dy, dz; context columns T_<name> (°C), P_<name> (hPa), \
         H_<name> (% RH), S (rpm), F (mm/min)",
    );
    check_err(
        b"t,x,Y,Z,C,dx,dy,dz\n0,1,2,3,4,5,6,7\n",
        fit(),
        1,
        2,
        "unknown column \"x\" (axis letters are upper-case)",
    );
    check_err(
        b"t,X,Y,Z,C,dx,dy,dz,T_\n0,1,2,3,4,5,6,7,8\n",
        fit(),
        1,
        9,
        "unknown column \"T_\"",
    );
    check_err(
        b"t,X,,Z,C,dx,dy,dz\n0,1,2,3,4,5,6,7\n",
        fit(),
        1,
        3,
        "column 3 has no name",
    );
}

#[test]
fn wrong_field_count() {
    check_err(
        &rows("0,1,2,3,4,5,6,7\n1,1,2,3,4,5,6\n"),
        fit(),
        3,
        8,
        "expected 8 fields, as in the header, found 7",
    );
    check_err(
        &rows("0,1,2,3,4,5,6,7\n1,1,2,3,4,5,6,7,5\n"),
        fit(),
        3,
        9,
        "found 9 (a decimal comma such as 1,5 splits a number in two",
    );
}

#[test]
fn non_numeric_field_names_column_and_unit() {
    check_err(
        &rows("0,1,2,3,4,5,6,7\n1,1,abc,3,4,5,6,7\n"),
        fit(),
        3,
        3,
        "column \"Y\": expected a position in mm, found \"abc\"",
    );
    check_err(
        &rows("0,1,2,3,x,5,6,7\n"),
        fit(),
        2,
        5,
        "column \"C\": expected an angle in degrees",
    );
    check_err(
        &rows("0,1,2,3,4,,6,7\n"),
        fit(),
        2,
        6,
        "column \"dx\": expected a number, found an empty field",
    );
}

#[test]
fn nan_and_infinity_are_not_measurements() {
    check_err(
        &rows("0,1,2,3,4,5,6,7\n1,1,2,3,4,NaN,6,7\n"),
        fit(),
        3,
        6,
        "column \"dx\": expected a number, found \"NaN\": NaN is not a measurement; leave the row out",
    );
    check_err(
        &rows("0,1,2,-inf,4,5,6,7\n"),
        fit(),
        2,
        4,
        "found \"-inf\": an infinite value is not a measurement",
    );
    check_err(
        &rows("0,1,2,3,4,5,6,1e999\n"),
        fit(),
        2,
        8,
        "too large for a 64-bit float",
    );
}

#[test]
fn decimal_comma_in_a_quoted_field() {
    check_err(
        &rows("0,1,2,3,4,5,6,7\n1,1,\"1,5\",3,4,5,6,7\n"),
        fit(),
        3,
        3,
        "column \"Y\": expected a position in mm, found \"1,5\" with a decimal comma: use '.'",
    );
}

#[test]
fn semicolon_separator() {
    check_err(
        b"t;X;Y;Z;C;dx;dy;dz\n0;1,5;2;3;4;5;6;7\n",
        fit(),
        1,
        1,
        "the separator is ';', expected ','",
    );
}

#[test]
fn non_increasing_t_names_both_rows() {
    check_err(
        &rows("0,1,2,3,4,5,6,7\n1.5,1,2,3,4,5,6,7\n1.5,1,2,3,4,5,6,7\n"),
        fit(),
        4,
        1,
        "column \"t\": t must increase strictly, found t = 1.5 here after t = 1.5 at line 3",
    );
    check_err(
        b"X,t,Y,Z,C,dx,dy,dz\n0,2,2,3,4,5,6,7\n0,1,2,3,4,5,6,7\n",
        fit(),
        3,
        2,
        "found t = 1 here after t = 2 at line 2",
    );
}

#[test]
fn not_utf8() {
    check_err(b"t,X,Y,Z,C,dx,dy,dz\n0,1\xff,2\n", fit(), 2, 4, "not UTF-8");
}

#[test]
fn bom_crlf_and_trailing_blank_lines_are_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let text = "\u{feff}t,X,Y,Z,C,dx,dy,dz\r\n0,1,2,3,4,5,6,7\r\n1, 1 ,2,3,4,5,6,7\r\n\r\n\n  \n";
    let p = write(dir.path(), text.as_bytes());
    let table = read_run(&p, &fit()).unwrap();
    assert_eq!(table.len(), 2);
    assert_eq!(
        table.columns[0], "t",
        "the BOM is stripped from the first name"
    );
    assert_eq!(table.q_row(1), &[1.0, 2.0, 3.0, 4.0]);
    // Line numbers stay right with CRLF and a BOM.
    let bad = "\u{feff}t,X,Y,Z,C,dx,dy,dz\r\n0,1,2,3,4,5,6,7\r\n1,1,2,3,4,5,6,x\r\n";
    check_err(bad.as_bytes(), fit(), 3, 8, "column \"dz\"");
}

#[test]
fn columns_in_any_order_are_returned_in_the_callers_order() {
    let dir = tempfile::tempdir().unwrap();
    let text = "dz,C,T_spindle,Y,t,S,X,dx,Z,dy,F\n3,40,21.5,20,0,8000,10,1,30,2,500\n";
    let p = write(dir.path(), text.as_bytes());
    let t = read_run(&p, &fit()).unwrap();
    assert_eq!(t.q_row(0), &[10.0, 20.0, 30.0, 40.0]);
    assert_eq!(t.reading_row(0), Some(&[1.0, 2.0, 3.0][..]));
    let names: Vec<_> = t.context.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["T_spindle", "S", "F"], "context in file order");
    assert_eq!(t.context_column("S"), Some(&[8000.0][..]));
    assert_eq!(t.columns.join(","), "dz,C,T_spindle,Y,t,S,X,dx,Z,dy,F");
}

#[test]
fn validation_run_without_readings_has_no_values() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), b"t,X,Y,Z,C\n0,1,2,3,4\n1,1,2,3,5\n");
    let t = read_run(&p, &validate()).unwrap();
    assert_eq!(t.values, None);
    assert_eq!(t.reading_row(0), None);
    assert_eq!(t.readings, ["dx", "dy", "dz"]);
    // Written back, it has no reading columns and loads the same.
    let out = dir.path().join("out.csv");
    write_run(&out, &t).unwrap();
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "t,X,Y,Z,C\n0,1,2,3,4\n1,1,2,3,5\n"
    );
}

#[test]
fn read_failure_names_the_file() {
    let e = read_run(Path::new("/nonexistent/run.csv"), &fit()).unwrap_err();
    assert!(matches!(e, SessionError::Read { .. }));
    assert!(
        e.to_string()
            .starts_with("/nonexistent/run.csv: cannot read"),
        "{e}"
    );
    assert!(e.location().is_none());
}

fn small_table(path: &Path) -> RunTable {
    RunTable {
        path: path.to_path_buf(),
        columns: vec![],
        t: vec![0.0, 1.0],
        axes: vec!['X', 'C'],
        positions: vec![1.0, 2.0, 3.0, 4.0],
        readings: vec!["d".into()],
        values: Some(vec![0.5, 0.25]),
        context: vec![("T_bed".into(), vec![20.0, 20.5])],
        labels: vec![],
    }
}

#[test]
fn write_refuses_what_read_would_reject() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("w.csv");
    let refused = |t: RunTable, phrase: &str| {
        let e = write_run(&p, &t).unwrap_err();
        assert!(matches!(e, SessionError::NotWritten { .. }), "{e}");
        assert!(e.to_string().contains(phrase), "`{phrase}` not in: {e}");
        assert!(!p.exists());
    };
    let mut t = small_table(&p);
    t.values = Some(vec![f64::NAN, 0.0]);
    refused(t, "`values` holds NaN at index 0");
    let mut t = small_table(&p);
    t.t = vec![1.0, 1.0];
    refused(t, "t must increase strictly");
    let mut t = small_table(&p);
    t.positions.pop();
    refused(t, "`positions` has 3 numbers, expected 4");
    let mut t = small_table(&p);
    t.context[0].0 = "temp".into();
    refused(t, "context column \"temp\" would not load");
    let mut t = small_table(&p);
    t.columns = vec!["t".into(), "X".into()];
    refused(t, "`columns` lists t, X");
    let mut t = small_table(&p);
    t.t.clear();
    t.positions.clear();
    t.values = Some(vec![]);
    t.context[0].1.clear();
    refused(t, "no rows");
}

#[test]
fn write_keeps_the_column_order_and_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("w.csv");
    let mut t = small_table(&p);
    write_run(&p, &t).unwrap();
    assert_eq!(
        std::fs::read_to_string(&p).unwrap(),
        "t,X,C,d,T_bed\n0,1,2,0.5,20\n1,3,4,0.25,20.5\n"
    );
    t.columns = ["d", "C", "t", "T_bed", "X"].map(String::from).to_vec();
    write_run(&p, &t).unwrap();
    let cols = RunColumns {
        axes: &['X', 'C'],
        readings: &["d"],
        readings_optional: false,
        labels: &[],
    };
    assert_eq!(read_run(&p, &cols).unwrap(), t);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["w.csv"]);
}

#[test]
fn numbers_are_written_shortest_with_exponents_only_at_the_extremes() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("n.csv");
    let mut t = small_table(&p);
    t.positions = vec![1e300, -1e-300, 0.1, -0.0];
    t.values = Some(vec![123456.789, 5e-324]);
    t.context[0].1 = vec![1e16, 1e-5];
    write_run(&p, &t).unwrap();
    assert_eq!(
        std::fs::read_to_string(&p).unwrap(),
        "t,X,C,d,T_bed\n0,1e300,-1e-300,123456.789,1e16\n1,0.1,-0,5e-324,0.00001\n"
    );
}

// ---------------------------------------------------------------------------------------------
// Round trip

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<f64>().prop_filter("finite", |x| x.is_finite()),
        (-1e6..1e6f64),
        (-1000i32..1000).prop_map(f64::from),
        Just(0.0),
        Just(-0.0),
        Just(f64::MIN_POSITIVE),
        Just(5e-324),
        Just(f64::MAX),
    ]
}

prop_compose! {
    fn table()(
        axes in proptest::sample::subsequence(vec!['X', 'Y', 'Z', 'U', 'V', 'W', 'A', 'B', 'C'], 1..=9),
        n in 1usize..6,
        has_values in any::<bool>(),
        n_context in 0usize..4,
    )(
        positions in proptest::collection::vec(finite(), n * axes.len()),
        values in proptest::collection::vec(finite(), n * 2),
        context in proptest::collection::vec(proptest::collection::vec(finite(), n), n_context),
        steps in proptest::collection::vec(1e-9..1e3f64, n),
        t0 in -1e3..1e3f64,
        axes in Just(axes),
        has_values in Just(has_values),
    ) -> RunTable {
        let t = steps.iter().scan(t0, |acc, s| { *acc += s; Some(*acc) }).collect();
        let names = ["S", "T_spindle", "F", "T_bed"];
        RunTable {
            path: PathBuf::new(),
            columns: vec![],
            t,
            axes,
            positions,
            readings: vec!["dx".into(), "d_2".into()],
            values: has_values.then_some(values),
            context: context.into_iter().enumerate().map(|(i, c)| (names[i].to_string(), c)).collect(),
            labels: vec![],
        }
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn write_then_read_is_bit_exact(mut table in table()) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.csv");
        table.path = p.clone();
        write_run(&p, &table).unwrap();
        let cols = RunColumns { axes: &table.axes, readings: &["dx", "d_2"], readings_optional: true ,
 labels: &[],};
        let back = read_run(&p, &cols).unwrap();
        prop_assert_eq!(bits(&back.t), bits(&table.t));
        prop_assert_eq!(bits(&back.positions), bits(&table.positions));
        prop_assert_eq!(back.values.as_deref().map(bits), table.values.as_deref().map(bits));
        prop_assert_eq!(back.context.len(), table.context.len());
        for ((n1, c1), (n2, c2)) in back.context.iter().zip(&table.context) {
            prop_assert_eq!(n1, n2);
            prop_assert_eq!(bits(c1), bits(c2));
        }
        prop_assert_eq!(&back.columns, &table.canonical_columns());
        prop_assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file left");
    }
}

/// An artefact-like instrument: a text label column beside the readings.
fn labelled() -> RunColumns<'static> {
    RunColumns {
        axes: &['X', 'Y', 'Z'],
        readings: &["x", "y", "z"],
        readings_optional: false,
        labels: &["feature"],
    }
}

#[test]
fn label_columns_are_read_as_text_and_written_back() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        b"t,X,Y,Z,feature,x,y,z,T_air,P_air,H_air\n\
          0,10,20,0,h01,10.001,20,0,20.1,1013.2,45\n\
          1,30,20,0,p2/h07,30,19.999,0,20.2,1013.1,46\n",
    );
    let table = read_run(&p, &labelled()).unwrap();
    assert_eq!(
        table.labels,
        vec![(
            "feature".to_string(),
            vec!["h01".to_string(), "p2/h07".to_string()]
        )]
    );
    assert_eq!(table.label_row(1), vec!["p2/h07"]);
    assert_eq!(table.context_column("P_air"), Some(&[1013.2, 1013.1][..]));
    assert_eq!(table.context_column("H_air"), Some(&[45.0, 46.0][..]));
    let q = dir.path().join("back.csv");
    write_run(&q, &table).unwrap();
    let again = read_run(&q, &labelled()).unwrap();
    assert_eq!(again.labels, table.labels);
    assert_eq!(
        bits(again.values.as_ref().unwrap()),
        bits(table.values.as_ref().unwrap())
    );
}

#[test]
fn a_missing_or_empty_label_is_located() {
    check_err(
        b"t,X,Y,Z,x,y,z\n0,1,2,3,1,2,3\n",
        labelled(),
        1,
        1,
        "missing label column(s) feature",
    );
    check_err(
        b"t,X,Y,Z,feature,x,y,z\n0,1,2,3,h1,1,2,3\n1,1,2,3,,1,2,3\n",
        labelled(),
        3,
        5,
        "expected a label, found an empty field",
    );
    // Without label columns the name is unknown, and the message lists the context columns.
    check_err(
        b"t,X,Y,Z,C,dx,dy,dz,feature\n0,1,2,3,4,1,2,3,h1\n",
        fit(),
        1,
        9,
        "P_<name> (hPa)",
    );
}

#[test]
fn a_label_that_would_not_read_back_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("w.csv");
    let mut table = small_table(&p);
    table.labels = vec![("feature".into(), vec!["a,b".into(), "c".into()])];
    let e = write_run(&p, &table).unwrap_err().to_string();
    assert!(e.contains("label \"a,b\""), "{e}");
    table.labels = vec![("feature".into(), vec!["a".into()])];
    let e = write_run(&p, &table).unwrap_err().to_string();
    assert!(e.contains("`feature` has 1 numbers"), "{e}");
    assert!(!p.exists());
}
