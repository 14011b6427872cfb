//! Numbers that survive JSON whatever their value.
//!
//! JSON has no NaN or infinity; serde_json writes them as `null` and cannot read `null` back
//! into an `f64`, so a shard holding an infinite residual could not be merged. Fields that may
//! hold such values are written through this module (`#[serde(with = "sdae_stats::json_f64")]`):
//! finite numbers as JSON numbers, NaN as the string `"NaN"`, infinities as `"inf"` and
//! `"-inf"`. Reading accepts numbers and these strings (and, from TOML, its own `nan` and
//! `inf`). Other tools read the strings as they are; Python's `float("inf")` takes them too.

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// An `f64` written as a number when finite and as `"NaN"`, `"inf"` or `"-inf"` otherwise.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Real(f64);

impl Serialize for Real {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let x = self.0;
        if x.is_finite() {
            s.serialize_f64(x)
        } else if x.is_nan() {
            s.serialize_str("NaN")
        } else if x > 0.0 {
            s.serialize_str("inf")
        } else {
            s.serialize_str("-inf")
        }
    }
}

struct RealVisitor;

impl Visitor<'_> for RealVisitor {
    type Value = Real;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a number, or \"NaN\", \"inf\" or \"-inf\"")
    }
    fn visit_f64<E: de::Error>(self, x: f64) -> Result<Real, E> {
        Ok(Real(x))
    }
    fn visit_i64<E: de::Error>(self, x: i64) -> Result<Real, E> {
        Ok(Real(x as f64))
    }
    fn visit_u64<E: de::Error>(self, x: u64) -> Result<Real, E> {
        Ok(Real(x as f64))
    }
    fn visit_str<E: de::Error>(self, text: &str) -> Result<Real, E> {
        match text {
            "NaN" => Ok(Real(f64::NAN)),
            "inf" => Ok(Real(f64::INFINITY)),
            "-inf" => Ok(Real(f64::NEG_INFINITY)),
            _ => Err(E::invalid_value(de::Unexpected::Str(text), &self)),
        }
    }
}

impl<'de> Deserialize<'de> for Real {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Real, D::Error> {
        d.deserialize_any(RealVisitor)
    }
}

/// A `Vec<f64>` written entry by entry as [`serialize`] writes an `f64`.
pub mod vec {
    use super::Real;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the entries.
    pub fn serialize<S: Serializer>(x: &[f64], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(x.iter().map(|&v| Real(v)))
    }

    /// Reads the entries.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Ok(Vec::<Real>::deserialize(d)?
            .into_iter()
            .map(|r| r.0)
            .collect())
    }
}

/// Writes an `f64` (see the module's documentation).
pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    Real(*x).serialize(s)
}

/// Reads an `f64` (see the module's documentation).
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Real::deserialize(d).map(|r| r.0)
}

/// The same for `Option<f64>` (`None` is `null`); use with `#[serde(default)]`.
pub mod option {
    use super::*;

    /// Writes an `Option<f64>`.
    pub fn serialize<S: Serializer>(x: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        x.map(Real).serialize(s)
    }

    /// Reads an `Option<f64>`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        Option::<Real>::deserialize(d).map(|x| x.map(|r| r.0))
    }
}

/// The same for `Option<[f64; 3]>`; use with `#[serde(default)]`.
pub mod option_triple {
    use super::*;

    /// Writes an `Option<[f64; 3]>`.
    pub fn serialize<S: Serializer>(x: &Option<[f64; 3]>, s: S) -> Result<S::Ok, S::Error> {
        x.map(|t| t.map(Real)).serialize(s)
    }

    /// Reads an `Option<[f64; 3]>`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
        Option::<[Real; 3]>::deserialize(d).map(|x| x.map(|t| t.map(|r| r.0)))
    }
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};

    #[derive(Debug, Serialize, Deserialize)]
    struct Fields {
        #[serde(with = "super")]
        x: f64,
        #[serde(with = "super::option", default)]
        y: Option<f64>,
        #[serde(with = "super::option_triple", default)]
        z: Option<[f64; 3]>,
    }

    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    #[test]
    fn every_value_round_trips_through_json() {
        let values = [
            0.0,
            -0.0,
            1.5e-300,
            -2.0,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for &x in &values {
            let fields = Fields {
                x,
                y: Some(x),
                z: Some([x, 1.0, -x]),
            };
            let json = serde_json::to_string(&fields).unwrap();
            assert!(!json.contains("null"), "{json}");
            let back: Fields = serde_json::from_str(&json).unwrap();
            assert!(same(back.x, x) && same(back.y.unwrap(), x), "{json}");
            let z = back.z.unwrap();
            assert!(same(z[0], x) && same(z[1], 1.0) && same(z[2], -x), "{json}");
        }
        let back: Fields = serde_json::from_str(r#"{"x": 3, "y": null}"#).unwrap();
        assert_eq!((back.x, back.y, back.z), (3.0, None, None));
        assert_eq!(
            serde_json::to_string(&Fields {
                x: f64::NEG_INFINITY,
                y: None,
                z: None
            })
            .unwrap(),
            r#"{"x":"-inf","y":null,"z":null}"#
        );
    }

    #[test]
    fn other_strings_are_refused_with_what_is_expected() {
        let err = serde_json::from_str::<Fields>(r#"{"x": "infinity"}"#).unwrap_err();
        assert!(
            err.to_string().contains("\"NaN\", \"inf\" or \"-inf\""),
            "{err}"
        );
    }
}
