//! The checksummed, append-only layout of checkpoint files.
//!
//! A file is a line naming its format (the magic line), then segments, each
//!
//! ```text
//! [length: u32 LE] [CRC-32 of the 4 length bytes: u32 LE] [payload: length bytes] [CRC-32 of the payload: u32 LE]
//! ```
//!
//! The first segment is the header (JSON), every later one a batch of records. A save appends
//! one segment (or a few, for a large batch) with the records finished since the previous save
//! and syncs the file, so saving after every block of paths costs time linear in the run. A
//! checksum covers every byte but the magic line, which is compared whole: a changed bit
//! anywhere is a [`StudyError::Checksum`]. A last segment that is cut short (a process killed
//! in the middle of an append) is dropped on load: [`Segments::torn`] says how many bytes, and
//! the paths they held are run again.

use std::fs::{File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use sdae_study::StudyError;
use sdae_study::files::write_with;

/// Bytes of a segment besides its payload: the length, its checksum, the payload's checksum.
pub(crate) const FRAME: usize = 12;

/// The payload a batch of records is split at (records are never split): segments stay far
/// below the 4 GiB a length can say, and a save holds at most this much in memory at once.
pub(crate) const SEGMENT_BYTES: usize = 16 << 20;

/// The CRC-32 (IEEE) of `bytes`.
fn crc(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

/// Appends the segment of `payload` to `out`.
pub(crate) fn frame(out: &mut Vec<u8>, payload: &[u8]) -> Result<(), String> {
    let length = u32::try_from(payload.len())
        .map_err(|_| format!("a segment of {} bytes exceeds 4 GiB", payload.len()))?;
    let length = length.to_le_bytes();
    out.extend_from_slice(&length);
    out.extend_from_slice(&crc(&length).to_le_bytes());
    out.extend_from_slice(payload);
    out.extend_from_slice(&crc(payload).to_le_bytes());
    Ok(())
}

/// The segments of records: `write` puts records into a payload, which is cut into segments of
/// about [`SEGMENT_BYTES`] between records. Returns the framed bytes.
pub(crate) fn batches<R>(
    records: &[R], mut write: impl FnMut(&mut Vec<u8>, &R) -> std::io::Result<()>,
) -> Result<Vec<u8>, String> {
    let mut framed = Vec::new();
    let mut payload = Vec::new();
    for r in records {
        write(&mut payload, r).map_err(|e| e.to_string())?;
        if payload.len() >= SEGMENT_BYTES {
            frame(&mut framed, &payload)?;
            payload.clear();
        }
    }
    if !payload.is_empty() {
        frame(&mut framed, &payload)?;
    }
    Ok(framed)
}

/// A checkpoint file written by this process: rewritten whole once, then appended to.
#[derive(Debug)]
pub(crate) struct Appender {
    path: PathBuf,
    /// Bytes of the file known to be whole (what a failed append left beyond is cut off).
    len: u64,
}

impl Appender {
    /// Writes `magic`, the header segment of `header` and `body` (framed segments) to `path`
    /// atomically and synced; returns the appender of the file and the bytes written.
    pub(crate) fn create(
        path: &Path, magic: &[u8], header: &[u8], body: &[u8],
    ) -> Result<(Appender, u64), StudyError> {
        let mut head = Vec::with_capacity(magic.len() + header.len() + FRAME);
        head.extend_from_slice(magic);
        frame(&mut head, header).map_err(|e| StudyError::write(path, e))?;
        write_with(path, |out| {
            out.write_all(&head)?;
            out.write_all(body)?;
            out.flush()?;
            out.get_ref().sync_data()
        })?;
        let len = (head.len() + body.len()) as u64;
        let appender = Appender {
            path: path.to_path_buf(),
            len,
        };
        Ok((appender, len))
    }

    /// Appends `body` (framed segments) and syncs the file; returns the bytes written. After a
    /// failed append the file is cut back to its whole part before the next one.
    pub(crate) fn append(&mut self, body: &[u8]) -> Result<u64, StudyError> {
        if body.is_empty() {
            return Ok(0);
        }
        let fail = |e: std::io::Error| StudyError::write(&self.path, e);
        let mut file = OpenOptions::new()
            .write(true)
            .open(&self.path)
            .map_err(fail)?;
        let size = file.metadata().map_err(fail)?.len();
        if size != self.len {
            file.set_len(self.len).map_err(fail)?;
        }
        file.seek(SeekFrom::Start(self.len)).map_err(fail)?;
        write_synced(&mut file, body).map_err(fail)?;
        self.len += body.len() as u64;
        Ok(body.len() as u64)
    }
}

fn write_synced(file: &mut File, body: &[u8]) -> std::io::Result<()> {
    file.write_all(body)?;
    file.sync_data()
}

/// A checkpoint file read back: its header's and its segments' payloads, checksums verified.
#[derive(Debug)]
pub(crate) struct Segments<'a> {
    /// The header's payload.
    pub header: &'a [u8],
    /// The payloads of the record segments, in file order.
    pub records: Vec<&'a [u8]>,
    /// Bytes of a last segment cut short (dropped), 0 if the file ends with a whole segment.
    pub torn: usize,
}

/// The [`StudyError::Checksum`] of `path`.
pub(crate) fn damaged(path: &Path, reason: String) -> StudyError {
    StudyError::Checksum {
        path: path.to_path_buf(),
        reason,
    }
}

/// Reads the segments of a checkpoint file `path` holding `bytes`, whose first line must be
/// `magic` (`older`: the first lines of formats this version no longer reads, named in the
/// refusal). Everything after the magic line must pass its checksum; only a last segment cut
/// short is dropped.
pub(crate) fn read<'a>(
    path: &Path, bytes: &'a [u8], magic: &[u8], older: &[&[u8]],
) -> Result<Segments<'a>, StudyError> {
    let mut rest = after_magic(path, bytes, magic, older)?;
    let mut at = magic.len();
    let mut payloads = Vec::new();
    let mut torn = 0;
    while !rest.is_empty() {
        let Some((payload, taken)) = segment(path, rest, at, payloads.len())? else {
            torn = rest.len();
            break;
        };
        payloads.push(payload);
        rest = &rest[taken..];
        at += taken;
    }
    if payloads.is_empty() {
        return Err(damaged(
            path,
            "its header segment is cut short: nothing to verify against its checksum".into(),
        ));
    }
    let header = payloads.remove(0);
    Ok(Segments {
        header,
        records: payloads,
        torn,
    })
}

/// The bytes of checkpoint file `path` after its first line, which must be `magic`: a file of
/// an `older` format, or of none, is refused naming its first line.
fn after_magic<'a>(
    path: &Path, bytes: &'a [u8], magic: &[u8], older: &[&[u8]],
) -> Result<&'a [u8], StudyError> {
    let shown = |m: &[u8]| String::from_utf8_lossy(m.trim_ascii_end()).into_owned();
    let Some(rest) = bytes.strip_prefix(magic) else {
        let reason = match older.iter().find(|o| bytes.starts_with(o)) {
            Some(old) => format!(
                "it is a checkpoint of an older version ('{}', without checksums): finish it \
                 with that version, or discard it with --fresh",
                shown(old)
            ),
            None => format!(
                "its first line is not '{}': not a checkpoint of this version, or damaged \
                 before its checksums",
                shown(magic)
            ),
        };
        return Err(damaged(path, reason));
    };
    Ok(rest)
}

/// The segment at the start of `rest` (segment `number`, 0 the header, at byte `at` of file
/// `path`) with its checksums verified: its payload and the bytes it takes, or `None` where
/// `rest` ends before the segment does (cut short).
fn segment<'a>(
    path: &Path, rest: &'a [u8], at: usize, number: usize,
) -> Result<Option<(&'a [u8], usize)>, StudyError> {
    let which = if number == 0 {
        "the header segment".to_string()
    } else {
        format!("segment {number}")
    };
    if rest.len() < 8 {
        return Ok(None);
    }
    let length: [u8; 4] = rest[..4].try_into().unwrap_or_default();
    let said = u32::from_le_bytes(rest[4..8].try_into().unwrap_or_default());
    if crc(&length) != said {
        return Err(damaged(
            path,
            format!(
                "the checksum of the length of {which} (at byte {at}) does not match: the \
                 file was changed after it was written"
            ),
        ));
    }
    let length = u32::from_le_bytes(length) as usize;
    if rest.len() < 8 + length + 4 {
        return Ok(None);
    }
    let payload = &rest[8..8 + length];
    let end = 8 + length;
    let said = u32::from_le_bytes(rest[end..end + 4].try_into().unwrap_or_default());
    if crc(payload) != said {
        return Err(damaged(
            path,
            format!(
                "the checksum of {which} (bytes {at}..{}) does not match its content \
                 (CRC-32 {:08x}, saved {said:08x}): the file was changed after it was \
                 written",
                at + end + 4,
                crc(payload)
            ),
        ));
    }
    Ok(Some((payload, end + 4)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(records: &[&[u8]]) -> Vec<u8> {
        let mut bytes = b"magic\n".to_vec();
        frame(&mut bytes, b"{\"h\":1}").unwrap();
        for r in records {
            frame(&mut bytes, r).unwrap();
        }
        bytes
    }

    #[test]
    fn every_flipped_bit_is_refused_and_a_torn_tail_dropped() {
        let path = Path::new("x.bin");
        let bytes = file(&[b"first", b"second record"]);
        let read = read(path, &bytes, b"magic\n", &[]).unwrap();
        assert_eq!(read.header, b"{\"h\":1}");
        assert_eq!(read.records, vec![&b"first"[..], b"second record"]);
        assert_eq!(read.torn, 0);
        for bit in 0..bytes.len() * 8 {
            let mut flipped = bytes.clone();
            flipped[bit / 8] ^= 1 << (bit % 8);
            let err = super::read(path, &flipped, b"magic\n", &[]).unwrap_err();
            assert!(
                matches!(err, StudyError::Checksum { .. }),
                "bit {bit}: {err}"
            );
        }
        let last = FRAME + b"second record".len();
        for cut in 1..last {
            let short = &bytes[..bytes.len() - cut];
            let read = super::read(path, short, b"magic\n", &[]).unwrap();
            assert_eq!(read.records, vec![&b"first"[..]], "cut {cut}");
            assert_eq!(read.torn, last - cut);
        }
        let old = super::read(path, b"old 1\n{}", b"magic\n", &[b"old 1\n"]).unwrap_err();
        assert!(old.to_string().contains("older version"), "{old}");
    }

    #[test]
    fn appends_write_only_the_new_segments() {
        let dir = std::env::temp_dir().join(format!("sdae-segments-{}", std::process::id()));
        let path = dir.join("c.bin");
        let (mut appender, first) = Appender::create(&path, b"m\n", b"{}", b"").unwrap();
        assert_eq!(first, 2 + FRAME as u64 + 2);
        let mut segment = Vec::new();
        frame(&mut segment, &[7; 100]).unwrap();
        for k in 1..=50u64 {
            assert_eq!(appender.append(&segment).unwrap(), 112);
            let size = std::fs::metadata(&path).unwrap().len();
            assert_eq!(size, first + 112 * k);
        }
        // What a failed append left is cut off before the next one.
        std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .unwrap()
            .write_all(b"torn")
            .unwrap();
        appender.append(&segment).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let read = read(&path, &bytes, b"m\n", &[]).unwrap();
        assert_eq!((read.records.len(), read.torn), (51, 0));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
