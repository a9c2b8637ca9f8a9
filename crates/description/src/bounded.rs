//! Reading a file a user names with a cap on its size, fitted to what such a file can
//! legitimately hold. A path can name anything: `/dev/zero`, a FIFO, a directory, a log
//! mistaken for a description. The read goes through [`Read::take`] with one byte more than
//! the cap, so an endless or oversized source is refused after at most `cap + 1` bytes instead
//! of growing the process until the kernel kills it.
//!
//! The refusal is a [`std::io::Error`] whose message states the size (or, for a source without
//! one, that it runs past the cap) and the cap; every caller already names the file beside an
//! I/O error, so the message does not repeat the path.

use std::io::{self, Read};
use std::path::Path;

/// One mebibyte, the unit of the caps below.
pub const MIB: u64 = 1 << 20;

/// A rig description or scenario (`--config`, `--rig`): a few hundred lines of TOML; a
/// mebibyte is a thousand times the embedded default, far beyond any hand-written description.
pub const DESCRIPTION_CAP_BYTES: u64 = MIB;

/// An excitation file (`--excitation`, `stewart plan --out`): one `[excitation]` table of a
/// few dozen harmonics.
pub const EXCITATION_CAP_BYTES: u64 = MIB;

/// A calibration file (`[calibration] imu`, `load_cells`): a few tables of numbers with their
/// covariance.
pub const CALIBRATION_CAP_BYTES: u64 = MIB;

/// A saved tare (`--tare`): ten parameters, their covariance and a few sensitivity matrices as
/// JSON, tens of kilobytes at most.
pub const TARE_CAP_BYTES: u64 = MIB;

/// A shared-key file (`--key`, `rig.key_file`): a key in hex, 64 digits for a generated key;
/// 4 KiB leaves room for any key length the rig takes and for comments' whitespace.
pub const KEY_CAP_BYTES: u64 = 4 * 1024;

/// A JSON report (`export`, `report`, `plan --prior`): a measurement with its budget,
/// convergence and residuals, a few megabytes for the longest runs; a campaign's report holds
/// many of them.
pub const REPORT_CAP_BYTES: u64 = 64 * MIB;

/// `bytes` in words: exact bytes, with mebibytes or kibibytes when it is a round number of
/// them.
fn size_in_words(bytes: u64) -> String {
    if bytes >= MIB && bytes % MIB == 0 {
        format!("{} MiB", bytes / MIB)
    } else if bytes >= 1024 && bytes % 1024 == 0 {
        format!("{} KiB", bytes / 1024)
    } else {
        format!("{bytes} bytes")
    }
}

/// The text of the file at `path`, `what` it is named in the message ("a rig description"),
/// read through [`Read::take`] so that at most `cap_bytes + 1` bytes are ever held.
///
/// Refused, as an [`io::Error`] of kind `InvalidData` (or `InvalidInput` for a directory):
/// a directory; a file larger than `cap_bytes`, with its size and the cap; a source that
/// runs past the cap without a size (a device, a FIFO); text that is not UTF-8. An error
/// opening or reading the file is passed on as it is.
pub fn read_to_string_capped(path: &Path, cap_bytes: u64, what: &str) -> io::Result<String> {
    if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("it is a directory, not {what}; name the file inside it"),
        ));
    }
    let file = std::fs::File::open(path)?;
    let stated = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    if let Some(len) = stated.filter(|&len| len > cap_bytes) {
        return Err(too_large(Some(len), cap_bytes, what));
    }
    let mut bytes = Vec::new();
    file.take(cap_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > cap_bytes {
        // A regular file that grew while it was read, or a source without a size.
        return Err(too_large(
            stated.filter(|&len| len > cap_bytes),
            cap_bytes,
            what,
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "not UTF-8 text (byte {} is not), so not {what}",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// The refusal of a source of `len` bytes (unknown for a device or a FIFO) over `cap_bytes`.
fn too_large(len: Option<u64>, cap_bytes: u64, what: &str) -> io::Error {
    let cap = format!(
        "the {} ({cap_bytes} bytes) that {what} can hold",
        size_in_words(cap_bytes)
    );
    let problem = match len {
        Some(len) => format!("it is {len} bytes, over {cap}"),
        None => format!("it runs on past {cap} without a stated size (a device or a pipe?)"),
    };
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("{problem}; check that the path names the right file"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_within_the_cap_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.toml");
        std::fs::write(&path, "x".repeat(16)).unwrap();
        assert_eq!(
            read_to_string_capped(&path, 16, "a test file").unwrap(),
            "x".repeat(16)
        );
    }

    #[test]
    fn a_file_one_byte_over_the_cap_is_refused_with_its_size_and_the_cap() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        std::fs::write(&path, vec![b'#'; (KEY_CAP_BYTES + 1) as usize]).unwrap();
        let e = read_to_string_capped(&path, KEY_CAP_BYTES, "a key file").unwrap_err();
        let message = e.to_string();
        assert!(message.contains("4097 bytes"), "{message}");
        assert!(message.contains("4 KiB (4096 bytes)"), "{message}");
        assert!(message.contains("a key file"), "{message}");
    }

    #[test]
    #[cfg(unix)]
    fn dev_zero_is_refused_after_the_cap() {
        let e =
            read_to_string_capped(Path::new("/dev/zero"), MIB, "a calibration file").unwrap_err();
        assert!(e.to_string().contains("without a stated size"), "{e}");
        assert!(e.to_string().contains("1 MiB"), "{e}");
    }

    #[test]
    fn a_directory_is_refused_as_a_directory() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_to_string_capped(dir.path(), MIB, "a rig description").unwrap_err();
        assert!(e.to_string().contains("is a directory"), "{e}");
    }

    #[test]
    fn binary_bytes_are_refused_as_not_text() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bin");
        std::fs::write(&path, [b'a', 0xff, 0xfe]).unwrap();
        let e = read_to_string_capped(&path, MIB, "a tare file").unwrap_err();
        assert!(e.to_string().contains("not UTF-8"), "{e}");
    }
}
