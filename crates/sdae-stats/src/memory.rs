//! The memory a study may take: settings whose records or paths in flight would need more than
//! the machine has available are refused before anything is allocated.

/// The limit assumed where the system does not say how much memory is available (no
/// `/proc/meminfo`): 16 GiB.
pub const FALLBACK_LIMIT: u64 = 16 << 30;

/// The memory available to a study, in bytes, and where the number comes from:
/// `MemAvailable` of `/proc/meminfo` on Linux, else [`FALLBACK_LIMIT`].
pub fn available() -> (u64, &'static str) {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| mem_available(&text))
        .map_or(
            (
                FALLBACK_LIMIT,
                "the fixed limit where the system does not say",
            ),
            |bytes| (bytes, "MemAvailable in /proc/meminfo"),
        )
}

/// The `MemAvailable` line of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// `None` when `needed` bytes fit in the available memory, else the rule a refused setting
/// breaks: how much it needs for `what`, and the limit.
pub fn exceeded(needed: u64, what: &str) -> Option<String> {
    let (limit, source) = available();
    (needed > limit).then(|| {
        format!(
            "{what} need at least {}, more than the {} available ({source})",
            bytes(needed),
            bytes(limit)
        )
    })
}

/// A byte count in the largest binary unit that keeps it >= 1 (`1.5 GiB`).
pub fn bytes(n: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut value = n as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < units.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{n} B")
    } else {
        format!("{value:.1} {}", units[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_is_read_in_bytes() {
        let text = "MemTotal:       16303392 kB\nMemFree:  1 kB\nMemAvailable:   12000000 kB\n";
        assert_eq!(mem_available(text), Some(12_000_000 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
        assert!(available().0 > 0);
    }

    #[test]
    fn byte_counts_read_in_binary_units() {
        assert_eq!(bytes(512), "512 B");
        assert_eq!(bytes(1536), "1.5 KiB");
        assert_eq!(bytes(16 << 30), "16.0 GiB");
        assert_eq!(bytes(u64::MAX), "16.0 EiB");
    }

    #[test]
    fn more_than_available_is_refused_naming_both_amounts() {
        assert_eq!(exceeded(1, "the records"), None);
        let rule = exceeded(u64::MAX, "the records").unwrap();
        assert!(
            rule.starts_with("the records need at least 16.0 EiB, more than the "),
            "{rule}"
        );
    }
}
