use super::*;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Keys {
    ball: Option<Vec3>,
    sigma_um: Option<Number>,
    free: Option<bool>,
    mode: Option<String>,
    #[serde(default, deserialize_with = "hold")]
    hold: Option<toml::Table>,
}

fn hold<'de, D: Deserializer<'de>>(d: D) -> Result<Option<toml::Table>, D::Error> {
    table(d, "a table like { A = 0.0 }").map(Some)
}

fn error(text: &str) -> (String, String) {
    let t: toml::Table = toml::from_str(text).expect("valid TOML");
    let e = read::<Keys>(&t).expect_err("rejected");
    (e.key, e.message)
}

fn pair(key: &str, message: &str) -> (String, String) {
    (key.to_string(), message.to_string())
}

#[test]
fn a_typed_table_reads_numbers_vectors_flags_words_and_maps() {
    let t: toml::Table = toml::from_str(
        "ball = [1.0, 2, 3.5]\nsigma_um = 2\nfree = false\nmode = \"m\"\nhold = { A = 30 }",
    )
    .unwrap();
    let k: Keys = read(&t).unwrap();
    assert_eq!(k.ball, Some(Vec3([1.0, 2.0, 3.5])));
    assert_eq!(k.sigma_um.map(f64::from), Some(2.0));
    assert_eq!((k.free, k.mode.as_deref()), (Some(false), Some("m")));
    assert_eq!(k.hold.unwrap()["A"], toml::Value::Integer(30));
    let empty: Keys = read(&toml::Table::new()).unwrap();
    assert!(empty.ball.is_none() && empty.hold.is_none());
}

#[test]
fn an_unknown_key_is_named_with_the_keys_the_table_knows() {
    assert_eq!(
        error("ball = [0, 0, 0]\nbal = 1"),
        pair(
            "bal",
            "unknown key; this instrument knows ball, sigma_um, free, mode, hold"
        )
    );
}

#[test]
fn a_wrong_type_says_what_was_expected_and_shows_the_value() {
    assert_eq!(
        error("sigma_um = \"x\""),
        pair("sigma_um", "expected a finite number, found \"x\"")
    );
    assert_eq!(
        error("sigma_um = inf"),
        pair("sigma_um", "expected a finite number, found inf")
    );
    assert_eq!(
        error("ball = [1, 2]"),
        pair("ball", "expected three numbers [x, y, z], found [1, 2]")
    );
    assert_eq!(
        error("ball = [1, \"y\", 3]"),
        pair(
            "ball",
            "expected three numbers [x, y, z], found [1, \"y\", 3]"
        )
    );
    assert_eq!(
        error("free = 1"),
        pair("free", "expected true or false, found 1")
    );
    assert_eq!(
        error("mode = 3"),
        pair("mode", "expected a string, found 3")
    );
}

#[test]
fn a_data_keyed_table_has_its_own_wording() {
    assert_eq!(
        error("hold = [1, 2]"),
        pair("hold", "expected a table like { A = 0.0 }, found [1, 2]")
    );
    assert_eq!(
        error("hold = \"A\""),
        pair("hold", "expected a table like { A = 0.0 }, found \"A\"")
    );
    // The entries are kept as written, for the plugin to read once it knows the key.
    let t: toml::Table = toml::from_str("hold = { A = true, B = [1] }").unwrap();
    let hold = read::<Keys>(&t).unwrap().hold.unwrap();
    assert_eq!(hold["A"], toml::Value::Boolean(true));
    assert_eq!(hold["B"], toml::Value::Array(vec![1.into()]));
}

#[test]
fn a_missing_key_says_what_it_is() {
    let e = required::<f64>(None, "length", "the bar length in mm").unwrap_err();
    assert_eq!(
        e.to_string(),
        "setup key `length`: missing: the bar length in mm"
    );
    assert_eq!(required(Some(2), "length", "-"), Ok(2));
}

#[test]
fn an_unknown_key_comes_before_any_other_problem() {
    // `ball` and `mode` are wrong too and sort first: serde alone would report `ball`.
    assert_eq!(
        error("ball = 1\nmode = 3\nzz = 1"),
        pair(
            "zz",
            "unknown key; this instrument knows ball, sigma_um, free, mode, hold"
        )
    );
    assert_eq!(keys_of::<Number>(), None);
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Outer {
    #[allow(dead_code)] // read only to be checked
    inner: Option<Inner>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Inner {
    #[allow(dead_code)] // read only to be checked
    depth: Option<Number>,
}

#[test]
fn a_nested_table_words_its_unknown_keys_the_same_way() {
    let t: toml::Table = toml::from_str("inner = { deep = 1 }").unwrap();
    let e = read::<Outer>(&t).unwrap_err();
    assert_eq!(
        (e.key.as_str(), e.message.as_str()),
        ("inner.deep", "unknown key; this instrument knows depth")
    );
}
