//! JSON files that carry a checksum of their content: the shard files that `merge` and
//! `mlmc-merge` read.
//!
//! A sealed file stays JSON that any tool reads (the shard itself is its `content`):
//!
//! ```text
//! {"format": "sdae-study shard 2",
//! "content": { ...the shard, pretty-printed... },
//! "crc32": "0a1b2c3d"}
//! ```
//!
//! The last line is always `"crc32": "` then 8 lowercase hex digits then `"}` and a newline;
//! the checksum is the CRC-32 (IEEE) of every byte before that line. So a changed bit anywhere
//! (the format, the content, the whitespace, the checksum itself) is a
//! [`StudyError::Checksum`] naming the file, and a file without that line (a shard written by
//! an older version, or not a shard) is refused the same way.

use std::io::Write;
use std::path::Path;

use serde::Serialize;
use serde::de::DeserializeOwned;

use sdae_study::StudyError;
use sdae_study::files::write_with;

/// What every sealed file's last line begins with.
const CHECK_LINE: &[u8] = b"\"crc32\": \"";

/// Bytes of the last line: [`CHECK_LINE`], 8 hex digits, `"}` and a newline.
const CHECK_LINE_LEN: usize = CHECK_LINE.len() + 8 + 3;

/// A writer that keeps the CRC-32 of what passes through it.
struct Hashing<W> {
    inner: W,
    hasher: crc32fast::Hasher,
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Writes `content` to `path` as a sealed file of format `format` (atomically).
pub fn write_sealed<T: Serialize + ?Sized>(
    path: &Path, format: &str, content: &T,
) -> Result<(), StudyError> {
    write_with(path, |out| {
        let mut hashing = Hashing {
            inner: &mut *out,
            hasher: crc32fast::Hasher::new(),
        };
        write!(hashing, "{{\"format\": ")?;
        serde_json::to_writer(&mut hashing, format)?;
        hashing.write_all(b",\n\"content\": ")?;
        serde_json::to_writer_pretty(&mut hashing, content)?;
        hashing.write_all(b",\n")?;
        let sum = hashing.hasher.finalize();
        out.write_all(CHECK_LINE)?;
        writeln!(out, "{sum:08x}\"}}")
    })
}

/// The checked content of a sealed file.
#[derive(serde::Deserialize)]
struct Sealed<T> {
    format: String,
    content: T,
    #[allow(dead_code)]
    crc32: String,
}

/// Reads the content of the sealed file `path` of format `format`: its checksum verified (a
/// mismatch, or no checksum line, is a [`StudyError::Checksum`]), then its format (another one
/// is a [`StudyError::Read`]) and its JSON.
pub fn read_sealed<T: DeserializeOwned>(path: &Path, format: &str) -> Result<T, StudyError> {
    let fail = |message: String| StudyError::Read {
        path: path.into(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
    verify(path, &bytes)?;
    let sealed: Sealed<T> = serde_json::from_slice(&bytes).map_err(|e| fail(e.to_string()))?;
    if sealed.format != format {
        return Err(fail(format!(
            "it is a '{}' file, this version reads '{format}'",
            sealed.format
        )));
    }
    Ok(sealed.content)
}

/// Checks the last line of a sealed file and the checksum it holds.
fn verify(path: &Path, bytes: &[u8]) -> Result<(), StudyError> {
    let damaged = |reason: String| StudyError::Checksum {
        path: path.into(),
        reason,
    };
    let split = bytes.len().checked_sub(CHECK_LINE_LEN);
    let (body, line) = split.map_or((&[][..], bytes), |at| bytes.split_at(at));
    let hex = line
        .strip_prefix(CHECK_LINE)
        .and_then(|rest| rest.strip_suffix(b"\"}\n"))
        .filter(|hex| {
            hex.iter()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(b))
        })
        .and_then(|hex| std::str::from_utf8(hex).ok())
        .and_then(|hex| u32::from_str_radix(hex, 16).ok());
    let Some(said) = hex.filter(|_| split.is_some()) else {
        return Err(damaged(
            "it does not end with a line '\"crc32\": \"<8 hex digits>\"}' holding its checksum \
             (a file of an older version, not a shard file, or changed after it was written)"
                .into(),
        ));
    };
    let sum = crc32fast::hash(body);
    if sum != said {
        return Err(damaged(format!(
            "the checksum of its content does not match (CRC-32 {sum:08x}, saved {said:08x}): \
             the file was changed after it was written"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sealed_file_reads_back_and_every_flipped_bit_is_refused() {
        let dir = std::env::temp_dir().join(format!("sdae-sealed-{}", std::process::id()));
        let path = dir.join("s.json");
        let content = serde_json::json!({"a": [1.5, -2.0], "b": "text", "c": null});
        write_sealed(&path, "test 1", &content).unwrap();
        let back: serde_json::Value = read_sealed(&path, "test 1").unwrap();
        assert_eq!(back, content);
        // Still JSON for other tools, with the content under "content".
        let bytes = std::fs::read(&path).unwrap();
        let json: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        assert_eq!(json["content"], content);
        let other = read_sealed::<serde_json::Value>(&path, "test 2").unwrap_err();
        assert!(matches!(other, StudyError::Read { .. }), "{other}");
        for bit in 0..bytes.len() * 8 {
            let mut flipped = bytes.clone();
            flipped[bit / 8] ^= 1 << (bit % 8);
            std::fs::write(&path, &flipped).unwrap();
            let err = read_sealed::<serde_json::Value>(&path, "test 1").unwrap_err();
            assert!(
                matches!(err, StudyError::Checksum { .. }),
                "bit {bit}: {err}"
            );
            assert!(err.to_string().contains("s.json"), "{err}");
        }
        std::fs::write(&path, serde_json::to_vec(&content).unwrap()).unwrap();
        let old = read_sealed::<serde_json::Value>(&path, "test 1").unwrap_err();
        assert!(old.to_string().contains("older version"), "{old}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
