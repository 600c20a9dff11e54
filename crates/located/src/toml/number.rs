//! A number as a format's messages quote it.

use serde::de::{self, Deserialize, Deserializer, Visitor};
use std::fmt;

/// A TOML integer or float, read as `f64` and remembering which it was, so that a message
/// quotes it as the file writes it (`3` and `3.0` are different texts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Number {
    pub value: f64,
    /// Written as an integer (`3`, not `3.0`).
    pub integer: bool,
}

impl fmt::Display for Number {
    /// As `toml` writes the value.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let value = if self.integer {
            toml::Value::Integer(self.value as i64)
        } else {
            toml::Value::Float(self.value)
        };
        write!(f, "{value}")
    }
}

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(NumberVisitor)
    }
}

struct NumberVisitor;

impl Visitor<'_> for NumberVisitor {
    type Value = Number;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number")
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Number, E> {
        Ok(Number {
            value: v as f64,
            integer: true,
        })
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Number, E> {
        Ok(Number {
            value: v as f64,
            integer: true,
        })
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Number, E> {
        Ok(Number {
            value: v,
            integer: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize)]
    struct Holder {
        x: Number,
    }

    fn read(text: &str) -> Number {
        let table: toml::Table = toml::from_str(text).unwrap();
        table.try_into::<Holder>().unwrap().x
    }

    #[test]
    fn a_number_is_quoted_as_toml_writes_it() {
        for text in ["3", "-3", "3.0", "-0.0", "2.5e-7", "inf", "nan"] {
            let value: toml::Table = toml::from_str(&format!("x = {text}")).unwrap();
            let n = read(&format!("x = {text}"));
            assert_eq!(n.to_string(), value["x"].to_string(), "{text}");
        }
        assert_eq!(read("x = 3").value, 3.0);
        assert!(read("x = 3").integer && !read("x = 3.0").integer);
    }
}
