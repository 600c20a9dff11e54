//! Typed set-up and path tables.
//!
//! A plugin declares one struct per table it reads (`#[derive(Deserialize)]` with
//! `#[serde(deny_unknown_fields)]`, fields named as the keys, `Option` where a key may be left
//! out) and reads the table with [`read`]: through the one located reader
//! (`mtcal_located::toml::from_table`) with the wording every set-up error has. An unknown key
//! lists the keys the table knows; a wrong type says what was expected and shows the value as
//! written. The plugin then checks what a type cannot: required keys ([`required`]), ranges,
//! combinations, the machine.
//!
//! A value with a shape of its own ([`Number`], [`Vec3`], a plugin's words and directions) is
//! read as the TOML value it is (`#[serde(try_from = "toml::Value")]`) and checked by its
//! `TryFrom`, whose message (often [`expected`]) becomes the error at that value's key.

use crate::SetupError;
use mtcal_located::toml::{Found, Messages, from_table};
use serde::de::{self, DeserializeOwned, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Serialize, Serializer};
use std::fmt;

/// Reads a set-up or path table into its typed struct. A key the struct does not know is
/// reported before anything else (serde would report whichever problem comes first in key
/// order): a misspelt key is the likeliest mistake, and its message lists the keys.
pub fn read<T: DeserializeOwned>(table: &toml::Table) -> Result<T, SetupError> {
    if let Some(known) = keys_of::<T>()
        && let Some(key) = table.keys().find(|k| !known.contains(&k.as_str()))
    {
        return Err(SetupError::new(key, unknown_key(known)));
    }
    read_part(table)
}

/// Reads the keys `T` has and leaves the others alone: for the key that says how the rest of
/// a table is read (a path's `kind`), before [`read`] reads the rest.
pub fn read_part<T: DeserializeOwned>(table: &toml::Table) -> Result<T, SetupError> {
    from_table(table, &SetupMessages).map_err(|p| SetupError::new(p.key, p.message))
}

fn unknown_key(known: &[&str]) -> String {
    format!("unknown key; this instrument knows {}", known.join(", "))
}

/// The wording of set-up errors serde finds.
#[derive(Clone, Copy, Debug, Default)]
pub struct SetupMessages;

impl Messages for SetupMessages {
    fn unknown_key(&self, _table: &str, _key: &str, expected: &[&str]) -> Option<String> {
        Some(unknown_key(expected))
    }

    fn wrong_type(&self, _path: &str, found: &Found, expected: &str) -> Option<String> {
        // serde calls a bool "a boolean"; set-up messages have always said what to write.
        let expected = if expected == "a boolean" {
            "true or false"
        } else {
            expected
        };
        let found = found.value.as_deref().unwrap_or(found.noun);
        Some(format!("expected {expected}, found {found}"))
    }
}

/// "expected `what`, found `value`" (the value as TOML writes it).
pub fn expected(what: &str, found: &toml::Value) -> String {
    format!("expected {what}, found {found}")
}

/// A key the table must have: "missing: `what`" otherwise.
pub fn required<T>(value: Option<T>, key: &str, what: &str) -> Result<T, SetupError> {
    value.ok_or_else(|| SetupError::new(key, format!("missing: {what}")))
}

/// A finite number; an integer is taken as the number it is.
pub fn number(value: &toml::Value) -> Option<f64> {
    match value {
        toml::Value::Float(x) if x.is_finite() => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// Three finite numbers `[x, y, z]`.
pub fn vec3(value: &toml::Value) -> Option<[f64; 3]> {
    match value.as_array()?.as_slice() {
        [x, y, z] => Some([number(x)?, number(y)?, number(z)?]),
        _ => None,
    }
}

/// A finite number (integers accepted).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(try_from = "toml::Value")]
pub struct Number(pub f64);

impl TryFrom<toml::Value> for Number {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        number(&value)
            .map(Number)
            .ok_or_else(|| expected("a finite number", &value))
    }
}

impl From<Number> for f64 {
    fn from(n: Number) -> f64 {
        n.0
    }
}

impl Serialize for Number {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_f64(self.0)
    }
}

/// Three finite numbers `[x, y, z]` (a point or a vector, mm).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize, Serialize)]
#[serde(try_from = "toml::Value")]
pub struct Vec3(pub [f64; 3]);

/// The farthest a set-up's point or vector reaches from the machine's origin (mm): a
/// kilometre, beyond any machine and any instrument standing beside one. Finite is not
/// enough: a ball at 1e308 mm passes every other check and fails inside the fit.
pub const MAX_SETUP_MM: f64 = 1e6;

impl TryFrom<toml::Value> for Vec3 {
    type Error = String;
    fn try_from(value: toml::Value) -> Result<Self, String> {
        let v = vec3(&value).ok_or_else(|| expected("three numbers [x, y, z]", &value))?;
        if let Some(far) = v.iter().find(|c| c.abs() > MAX_SETUP_MM) {
            return Err(format!(
                "{far:e} mm lies beyond any machine's reach: a set-up's points and vectors are \
                 within {MAX_SETUP_MM:e} mm (a kilometre) of the machine's origin"
            ));
        }
        Ok(Vec3(v))
    }
}

impl From<Vec3> for [f64; 3] {
    fn from(v: Vec3) -> [f64; 3] {
        v.0
    }
}

/// A table whose keys are data (axis letters, sensor names), its values as written: for a
/// field `#[serde(default, deserialize_with = "…")]` whose function calls this with what a
/// value that is not a table is called ("a table like { A = 0.0 }"). The plugin reads each
/// entry once it knows the key means something (an axis of the machine, a valid name), so
/// its errors name the key first, as they always have.
pub fn table<'de, D: Deserializer<'de>>(
    deserializer: D,
    what: &'static str,
) -> Result<toml::Table, D::Error> {
    deserializer.deserialize_map(TableOf(what))
}

/// The visitor of [`table`]: what a value that is not a table is called.
struct TableOf(&'static str);

impl TableOf {
    fn wrong<E: de::Error>(&self, found: toml::Value) -> E {
        E::custom(expected(self.0, &found))
    }
}

impl<'de> Visitor<'de> for TableOf {
    type Value = toml::Table;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<toml::Table, A::Error> {
        toml::Table::deserialize(de::value::MapAccessDeserializer::new(map))
    }

    // Any other value: what was expected, and the value as written.
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<toml::Table, E> {
        Err(self.wrong(v.into()))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<toml::Table, E> {
        Err(self.wrong(v.into()))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<toml::Table, E> {
        Err(self.wrong(v.into()))
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<toml::Table, E> {
        Err(self.wrong(v.into()))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<toml::Table, A::Error> {
        let array = toml::Value::deserialize(de::value::SeqAccessDeserializer::new(seq))?;
        Err(self.wrong(array))
    }
}

/// The keys a typed table knows, in the order its struct declares them: the field names
/// serde's derive hands to `deserialize_struct`, caught by a deserializer that reads nothing
/// else. `None` for a type that is not a struct. (A plugin's tests pin its documented key
/// list with it.)
pub fn keys_of<T: DeserializeOwned>() -> Option<&'static [&'static str]> {
    match T::deserialize(FieldNames) {
        Err(Caught(fields)) => fields,
        Ok(_) => None,
    }
}

/// The deserializer of [`keys_of`].
struct FieldNames;

/// What [`FieldNames`] caught: a struct's field names, or nothing.
#[derive(Debug)]
struct Caught(Option<&'static [&'static str]>);

impl fmt::Display for Caught {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("field names")
    }
}

impl std::error::Error for Caught {}

impl de::Error for Caught {
    fn custom<M: fmt::Display>(_: M) -> Self {
        Caught(None)
    }
}

impl<'de> Deserializer<'de> for FieldNames {
    type Error = Caught;

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Caught> {
        Err(Caught(Some(fields)))
    }

    fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, Caught> {
        Err(Caught(None))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

#[cfg(test)]
mod tests;
