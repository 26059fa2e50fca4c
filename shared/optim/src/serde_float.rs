//! Serde for floats that may be infinite or NaN: JSON has no such numbers (serde_json would
//! write `null` and fail to read it back), so they are written as the strings "inf", "-inf"
//! and "NaN". Finite values stay plain numbers. Use with `#[serde(with = "...")]`.

use serde::{Deserialize, Deserializer, Serializer};

#[derive(Deserialize)]
#[serde(untagged)]
enum Repr {
    Num(f64),
    Text(String),
    /// How serde_json wrote a non-finite float before this module was used (read as NaN).
    Null(()),
}

fn decode<E: serde::de::Error>(r: Repr) -> Result<f64, E> {
    match r {
        Repr::Num(v) => Ok(v),
        Repr::Null(()) => Ok(f64::NAN),
        Repr::Text(t) => match t.as_str() {
            "inf" => Ok(f64::INFINITY),
            "-inf" => Ok(f64::NEG_INFINITY),
            "NaN" => Ok(f64::NAN),
            other => Err(E::custom(format!("{other:?} is not a number"))),
        },
    }
}

fn text(v: f64) -> &'static str {
    if v.is_nan() {
        "NaN"
    } else if v > 0.0 {
        "inf"
    } else {
        "-inf"
    }
}

pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_finite() { s.serialize_f64(*v) } else { s.serialize_str(text(*v)) }
}

pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    decode(Repr::deserialize(d)?)
}

/// The same for `Vec<f64>`.
pub mod vec {
    use serde::ser::SerializeSeq;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(v.len()))?;
        for x in v {
            if x.is_finite() {
                seq.serialize_element(x)?;
            } else {
                seq.serialize_element(super::text(*x))?;
            }
        }
        seq.end()
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Vec::<super::Repr>::deserialize(d)?.into_iter().map(super::decode).collect()
    }
}

/// The same for `Option<f64>` (`None` is `null`).
pub mod option {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(x) if x.is_finite() => s.serialize_some(x),
            Some(x) => s.serialize_some(super::text(*x)),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        Option::<super::Repr>::deserialize(d)?.map(super::decode).transpose()
    }
}

#[cfg(test)]
mod tests {
    #[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
    struct S {
        #[serde(with = "super")]
        a: f64,
        #[serde(with = "super::vec")]
        b: Vec<f64>,
    }

    #[test]
    fn non_finite_values_round_trip_through_json() {
        let s = S { a: f64::NEG_INFINITY, b: vec![1.5, f64::INFINITY, -0.0] };
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(json, r#"{"a":"-inf","b":[1.5,"inf",-0.0]}"#);
        assert_eq!(serde_json::from_str::<S>(&json).unwrap(), s);
        // What plain serde_json wrote for a non-finite value reads back as NaN.
        let old: S = serde_json::from_str(r#"{"a":null,"b":[null,2.0]}"#).unwrap();
        assert!(old.a.is_nan() && old.b[0].is_nan() && old.b[1] == 2.0);
    }

    #[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
    struct O {
        #[serde(with = "super::option")]
        v: Option<f64>,
    }

    #[test]
    fn optional_values_keep_none_apart_from_infinity() {
        for v in [None, Some(2.5), Some(f64::INFINITY)] {
            let json = serde_json::to_string(&O { v }).unwrap();
            assert_eq!(serde_json::from_str::<O>(&json).unwrap(), O { v }, "{json}");
        }
        assert_eq!(serde_json::to_string(&O { v: Some(f64::INFINITY) }).unwrap(), r#"{"v":"inf"}"#);
    }
}
