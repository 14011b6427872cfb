//! Fixed-length arrays in parameter files that refuse a wrong number of entries, too many as
//! well as too few: `#[serde(deserialize_with = "sdae_systems::exact::array")]` on a `[T; N]`
//! field (serde's own arrays stop reading after N entries and drop the rest unread).
//!
//! ```
//! #[derive(serde::Deserialize)]
//! struct Trap {
//!     #[serde(deserialize_with = "sdae_systems::exact::array")]
//!     center: [f64; 3],
//! }
//! let ok: Trap = serde_json::from_str(r#"{"center": [0.0, 0.0, 1.0]}"#)?;
//! assert_eq!(ok.center, [0.0, 0.0, 1.0]);
//! let long = serde_json::from_str::<Trap>(r#"{"center": [0.0, 0.0, 1.0, 2.0]}"#);
//! let message = long.err().map(|e| e.to_string()).unwrap_or_default();
//! assert!(message.contains("invalid length 4, expected an array of length 3"), "{message}");
//! # Ok::<(), serde_json::Error>(())
//! ```

use serde::de::{Deserialize, Deserializer, Error};

/// An array of exactly `N` entries.
struct Exactly<T, const N: usize>([T; N]);

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Exactly<T, N> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let entries = Vec::<T>::deserialize(deserializer)?;
        let given = entries.len();
        let expected = format!("an array of length {N}");
        entries
            .try_into()
            .map(Exactly)
            .map_err(|_| D::Error::invalid_length(given, &expected.as_str()))
    }
}

/// A `[T; N]` of exactly `N` entries (the error gives the length found and the one expected).
pub fn array<'de, D, T, const N: usize>(deserializer: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Exactly::<T, N>::deserialize(deserializer).map(|a| a.0)
}

/// An optional `[T; N]` of exactly `N` entries.
pub fn option_array<'de, D, T, const N: usize>(deserializer: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<Exactly<T, N>>::deserialize(deserializer).map(|a| a.map(|a| a.0))
}

/// A `[[T; C]; R]` of exactly `R` rows of exactly `C` entries each.
pub fn matrix<'de, D, T, const R: usize, const C: usize>(
    deserializer: D,
) -> Result<[[T; C]; R], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let rows: [Exactly<T, C>; R] = array(deserializer)?;
    Ok(rows.map(|row| row.0))
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;

    #[derive(Debug, Deserialize, PartialEq)]
    struct Fields {
        #[serde(deserialize_with = "super::array")]
        vector: [f64; 3],
        #[serde(default, deserialize_with = "super::option_array")]
        levels: Option<[u32; 2]>,
        #[serde(default, deserialize_with = "super::matrix")]
        shear: [[f64; 2]; 2],
    }

    fn read(text: &str) -> Result<Fields, String> {
        serde_json::from_str(text).map_err(|e| e.to_string())
    }

    #[test]
    fn exact_lengths_are_read() {
        let fields = read(r#"{"vector": [1, 2, 3], "levels": [3, 8], "shear": [[1, 2], [3, 4]]}"#);
        assert_eq!(
            fields,
            Ok(Fields {
                vector: [1.0, 2.0, 3.0],
                levels: Some([3, 8]),
                shear: [[1.0, 2.0], [3.0, 4.0]],
            })
        );
        assert_eq!(read(r#"{"vector": [1, 2, 3]}"#).map(|f| f.levels), Ok(None));
    }

    #[test]
    fn too_many_and_too_few_entries_are_refused_with_both_lengths() {
        for (text, given, expected) in [
            (r#"{"vector": [1, 2, 3, 4]}"#, 4, 3),
            (r#"{"vector": [1, 2]}"#, 2, 3),
            (r#"{"vector": [1, 2, 3], "levels": [3, 8, 9]}"#, 3, 2),
            (
                r#"{"vector": [1, 2, 3], "shear": [[1, 2], [3, 4], [5, 6]]}"#,
                3,
                2,
            ),
            (
                r#"{"vector": [1, 2, 3], "shear": [[1, 2], [3, 4, 5]]}"#,
                3,
                2,
            ),
            (r#"{"vector": [1, 2, 3], "shear": [[1, 2], [3]]}"#, 1, 2),
        ] {
            let e = read(text).unwrap_err();
            let want = format!("invalid length {given}, expected an array of length {expected}");
            assert!(e.contains(&want), "{text}: {e}");
        }
    }
}
