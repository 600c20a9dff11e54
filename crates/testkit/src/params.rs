//! The five-axis example's error set and truth, and how tests write them into TOML.

/// Source 000's eleven errors of a five-axis trunnion, in the order the tests list them: the
/// three squareness errors, the four location errors of A, the four of C.
pub const ELEVEN: [&str; 11] = [
    "EC0Y", "EB0Z", "EA0Z", "EY0A", "EZ0A", "EB0A", "EC0A", "EX0C", "EY0C", "EA0C", "EB0C",
];

/// The truth of `examples/five-axis/truth.params.toml` (µm, µrad), in the order of [`ELEVEN`].
pub const FIVE_AXIS_TRUTH: [(&str, f64); 11] = [
    ("EC0Y", 12.0),
    ("EB0Z", -8.0),
    ("EA0Z", 15.0),
    ("EY0A", 18.0),
    ("EZ0A", -25.0),
    ("EB0A", 20.0),
    ("EC0A", -10.0),
    ("EX0C", 12.0),
    ("EY0C", -6.0),
    ("EA0C", 30.0),
    ("EB0C", -15.0),
];

/// `names` as a TOML array of strings: `["EC0Y", "EB0Z"]`.
pub fn toml_list(names: &[&str]) -> String {
    format!("[{}]", quoted(names))
}

/// `names` quoted and separated by commas, as inside a TOML array: `"EC0Y", "EB0Z"`.
pub fn quoted(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    quoted.join(", ")
}

/// A parameter file (`mtcal.params/1`) holding `values` (µm, µrad) and nothing else.
pub fn values_file(values: &[(&str, f64)]) -> String {
    let mut text = String::from("schema = \"mtcal.params/1\"\n[values]\n");
    for (name, value) in values {
        text += &format!("{name} = {value:?}\n");
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_truth_is_the_examples_file() {
        let text = std::fs::read_to_string(crate::five_axis_truth_file()).unwrap();
        let file: toml::Table = toml::from_str(&text).unwrap();
        let written: toml::Table = toml::from_str(&values_file(&FIVE_AXIS_TRUTH)).unwrap();
        assert_eq!(file, written);
        let names: Vec<&str> = FIVE_AXIS_TRUTH.iter().map(|(n, _)| *n).collect();
        assert_eq!(names, ELEVEN);
    }

    #[test]
    fn lists_are_toml_arrays() {
        assert_eq!(toml_list(&["EC0Y", "EB0Z"]), r#"["EC0Y", "EB0Z"]"#);
        assert_eq!(toml_list(&[]), "[]");
    }
}
