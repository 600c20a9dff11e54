use super::*;
use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Top {
    name: Option<Spanned<String>>,
    #[serde(default)]
    run: Vec<Run>,
    #[allow(dead_code)] // read only to be checked
    inner: Option<Inner>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Run {
    speed: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Inner {
    depth: Option<u32>,
}

/// A format with its own wording.
struct House;

impl Messages for House {
    fn syntax(&self, message: &str) -> String {
        format!("this is not valid TOML: {message}")
    }
    fn unknown_key(&self, table: &str, key: &str, expected: &[&str]) -> Option<String> {
        Some(format!(
            "unknown key `{key}` in [{table}]; known: {}",
            expected.join(", ")
        ))
    }
    fn wrong_type(&self, path: &str, found: &Found, expected: &str) -> Option<String> {
        let what = found.value.as_deref().unwrap_or(found.noun);
        Some(format!("`{path}` must be {expected}, found {what}"))
    }
}

fn at(text: &str, p: &Problem) -> (usize, usize) {
    let l = crate::Location::of_offset(std::path::Path::new("f"), text, p.span.start);
    (l.line, l.column)
}

#[test]
fn serde_messages_are_kept_by_default_and_located_at_the_key_or_value() {
    let text = "name = \"a\"\n[inner]\ndeph = 3\n";
    let p = from_str::<Top>(text, &SerdeMessages).unwrap_err();
    assert_eq!(p.message, "unknown field `deph`, expected `depth`");
    assert_eq!(at(text, &p), (3, 1));
    let text = "name = \"a\"\n[[run]]\nspeed = \"fast\"\n";
    let p = from_str::<Top>(text, &SerdeMessages).unwrap_err();
    assert_eq!(p.message, "invalid type: string \"fast\", expected f64");
    assert_eq!(at(text, &p), (3, 9));
    let ok: Top = from_str("name = \"x\"\n[[run]]\nspeed = 2\n", &SerdeMessages).unwrap();
    assert_eq!(ok.name.unwrap().span(), 7..10);
    assert_eq!(ok.run[0].speed, 2.0);
}

#[test]
fn a_format_words_unknown_keys_wrong_types_and_syntax_errors_its_own_way() {
    let text = "name = \"a\"\n[inner]\ndeph = 3\n";
    let p = from_str::<Top>(text, &House).unwrap_err();
    assert_eq!(p.message, "unknown key `deph` in [inner]; known: depth");
    let text = "nmae = 1\n";
    let p = from_str::<Top>(text, &House).unwrap_err();
    assert_eq!(
        p.message,
        "unknown key `nmae` in []; known: name, run, inner"
    );
    assert_eq!(at(text, &p), (1, 1));
    let text = "[[run]]\nspeed = 1\n[[run]]\nspeed = true\n";
    let p = from_str::<Top>(text, &House).unwrap_err();
    assert_eq!(p.message, "`run[1].speed` must be f64, found a boolean");
    assert_eq!(at(text, &p), (4, 9));
    let p = from_str::<Top>("name = \"a\n", &House).unwrap_err();
    assert!(
        p.message.starts_with("this is not valid TOML: "),
        "{}",
        p.message
    );
}

#[test]
fn a_part_of_the_tree_reads_with_spans_into_the_whole_file() {
    let text = "x = 1\n[inner]\ndepth = \"deep\"\n";
    let doc = document(text).unwrap();
    let item = doc.get("inner").unwrap().clone();
    let p = from_item::<Inner>(item, "inner", &House).unwrap_err();
    assert_eq!(p.message, "`inner.depth` must be u32, found a string");
    assert_eq!(at(text, &p), (3, 9));
    let item = document("[inner]\ndepth = 4\n")
        .unwrap()
        .get("inner")
        .unwrap()
        .clone();
    assert_eq!(
        from_item::<Inner>(item, "inner", &House).unwrap().depth,
        Some(4)
    );
}

#[test]
fn serde_wording_is_what_the_rewording_parses() {
    // If serde ever words these differently, the formats' own messages would silently fall
    // back to serde's: this test fails first.
    use serde::de::Error as _;
    let e = toml::de::Error::unknown_field("k", &["a", "b"]);
    assert_eq!(
        complaint(e.message()),
        Complaint::UnknownKey {
            key: "k",
            expected: vec!["a", "b"]
        }
    );
    let e = toml::de::Error::unknown_field("k", &["a"]);
    assert_eq!(
        complaint(e.message()),
        Complaint::UnknownKey {
            key: "k",
            expected: vec!["a"]
        }
    );
    let e = toml::de::Error::unknown_field("k", &[]);
    assert_eq!(
        complaint(e.message()),
        Complaint::UnknownKey {
            key: "k",
            expected: vec![]
        }
    );
    let e = toml::de::Error::invalid_type(serde::de::Unexpected::Signed(3), &"a string");
    assert_eq!(
        complaint(e.message()),
        Complaint::WrongType {
            found: "integer `3`",
            expected: "a string"
        }
    );
    let e =
        toml::de::Error::invalid_type(serde::de::Unexpected::Str("yes, expected"), &"a boolean");
    assert_eq!(
        complaint(e.message()),
        Complaint::WrongType {
            found: "string \"yes, expected\"",
            expected: "a boolean"
        }
    );
    assert_eq!(found_noun("integer `3`"), "an integer");
    assert_eq!(found_noun("floating point `1.5`"), "a float");
    assert_eq!(found_noun("string \"x\""), "a string");
    assert_eq!(found_noun("sequence"), "an array");
}

#[test]
fn the_tree_accessors_say_what_was_expected() {
    let text = "schema = \"f/2\"\nn = \"x\"\nk = 40\nv = -1\n";
    let doc = document(text).unwrap();
    let p = check_schema(&doc, "f/1").unwrap_err();
    assert_eq!(
        p.message,
        "schema \"f/2\" is not supported: this version of mtcal reads \"f/1\""
    );
    let p = check_keys(&doc, &["schema", "n"], "at the top level").unwrap_err();
    assert_eq!(
        p.message,
        "unknown key `k` at the top level; expected one of: schema, n"
    );
    let p = number(doc.get("n").unwrap(), "`n`").unwrap_err();
    assert_eq!(p.message, "`n` must be a number, found a string");
    let p = count(doc.get("k").unwrap(), "`k`", 0..=20).unwrap_err();
    assert_eq!(p.message, "`k` must be an integer from 0 to 20, got 40");
    let p = positive(doc.get("v").unwrap(), "`v`").unwrap_err();
    assert_eq!(p.message, "`v` must be positive, got -1");
}

#[test]
fn list_indices_are_read_from_key_paths() {
    assert_eq!(index_in("run[3]", "run"), Some(3));
    assert_eq!(index_in("run[x]", "run"), None);
    assert_eq!(index_in("runs[3]", "run"), None);
    assert_eq!(index_in("run", "run"), None);
}

#[test]
fn every_length_of_serde_key_list_is_read() {
    use serde::de::Error as _;
    let e = toml::de::Error::unknown_field("k", &["a", "b", "c"]);
    assert_eq!(
        complaint(e.message()),
        Complaint::UnknownKey {
            key: "k",
            expected: vec!["a", "b", "c"]
        }
    );
}

#[test]
fn a_table_without_spans_names_the_key_and_shows_the_value() {
    let t: toml::Table = toml::from_str("[[run]]\nspeed = 1\n[[run]]\nspeed = [1, 2]\n").unwrap();
    let p = from_table::<Top>(&t, &House).unwrap_err();
    assert_eq!(p.key, "run[1].speed");
    assert_eq!(p.message, "`run[1].speed` must be f64, found [1, 2]");
    let t: toml::Table = toml::from_str("nome = 1").unwrap();
    let p = from_table::<Top>(&t, &House).unwrap_err();
    assert_eq!(
        (p.key.as_str(), p.message.as_str()),
        ("nome", "unknown key `nome` in []; known: name, run, inner")
    );
    let t: toml::Table = toml::from_str("[inner]\ndepth = 2").unwrap();
    assert_eq!(from_table::<Top>(&t, &SerdeMessages).unwrap().run.len(), 0);
}
