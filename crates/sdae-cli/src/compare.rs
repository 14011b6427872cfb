//! What `compare` compares: the numbers of two reports, without what differs between runs of
//! one study (timings, thread counts, checksums).

/// The fields of a report that differ between runs of one study: timings, what is computed
/// from them (an MLMC report's costs in seconds, speed-up, the slope of its seconds per sample
/// and its standard run's predicted seconds), the thread count, and a shard file's checksum
/// (which covers its timings).
pub const RUN_DEPENDENT: [&str; 14] = [
    "seconds_per_path",
    "steps_per_second",
    "threads",
    "seconds",
    "seconds_per_sample",
    "mlmc_seconds",
    "speedup",
    "mlmc_cost",
    "standard_cost",
    "gamma_seconds",
    "predicted_seconds",
    "cap_seconds",
    "wall_seconds",
    "crc32",
];

/// A report (or shard) in JSON without its [`RUN_DEPENDENT`] fields: what is equal for every
/// run of one study, sharded and merged, interrupted and resumed, on any thread count.
pub fn numbers_of(json: &str) -> Result<serde_json::Value, serde_json::Error> {
    fn strip(value: &mut serde_json::Value) {
        match value {
            serde_json::Value::Object(map) => {
                for key in RUN_DEPENDENT {
                    map.remove(key);
                }
                map.values_mut().for_each(strip);
            }
            serde_json::Value::Array(items) => items.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut value = serde_json::from_str(json)?;
    strip(&mut value);
    Ok(value)
}

/// Where two reports' numbers ([`numbers_of`]) first differ, as a JSON pointer with both
/// values (`None` when they are equal): `/schemes/2/levels/3/errors/r: 0.0123 against 0.0124`.
pub fn first_difference(a: &serde_json::Value, b: &serde_json::Value) -> Option<String> {
    use serde_json::Value;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(u), Some(v)) => first_difference(u, v).map(|d| format!("/{k}{d}")),
                (u, v) => Some(format!("/{k}: {} against {}", shown(u), shown(v))),
            })
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (u, v))| first_difference(u, v).map(|d| format!("/{i}{d}"))),
        (Value::Array(x), Value::Array(y)) => {
            Some(format!(": {} entries against {}", x.len(), y.len()))
        }
        _ if a == b => None,
        _ => Some(format!(": {a} against {b}")),
    }
}

/// A value of [`first_difference`], or "nothing" where a key is missing.
fn shown(v: Option<&serde_json::Value>) -> String {
    v.map_or_else(|| "nothing".to_string(), ToString::to_string)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_difference_is_named_by_its_pointer() {
        let a = numbers_of(r#"{"seconds": 1, "x": [1, {"y": 2.5, "z": 1}], "w": 1}"#).unwrap();
        let same = numbers_of(r#"{"seconds": 9, "x": [1, {"y": 2.5, "z": 1}], "w": 1}"#).unwrap();
        assert_eq!(first_difference(&a, &same), None);
        let other = numbers_of(r#"{"x": [1, {"y": 2.25, "z": 1}], "w": 1}"#).unwrap();
        assert_eq!(
            first_difference(&a, &other).as_deref(),
            Some("/x/1/y: 2.5 against 2.25")
        );
        let shorter = numbers_of(r#"{"x": [1], "w": 1}"#).unwrap();
        assert_eq!(
            first_difference(&a, &shorter).as_deref(),
            Some("/x: 2 entries against 1")
        );
        let missing = numbers_of(r#"{"x": [1, {"y": 2.5, "z": 1}]}"#).unwrap();
        assert_eq!(
            first_difference(&a, &missing).as_deref(),
            Some("/w: 1 against nothing")
        );
    }
}
