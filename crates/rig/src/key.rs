//! The shared key: both sides tag every frame with HMAC-SHA256 under it (docs/protocol.md,
//! section 3). [`Key::generate`] and [`Key::write_new`] make a key file readable by its owner
//! only.

use std::fmt;
use std::path::Path;

use crate::codec::key_id;
use crate::error::RigError;

pub use crate::codec::MIN_KEY_LEN;

/// Length of a generated key, bytes (256 bits, the HMAC-SHA256 block's recommended key size).
pub const GENERATED_KEY_LEN: usize = 32;

/// A shared secret. Its `Debug` shows only the fingerprint.
#[derive(Clone, PartialEq, Eq)]
pub struct Key {
    bytes: Vec<u8>,
}

impl Key {
    /// A key from raw bytes, at least [`MIN_KEY_LEN`] long.
    pub fn new(bytes: &[u8]) -> Result<Self, RigError> {
        if bytes.len() < MIN_KEY_LEN {
            return Err(RigError::config(
                "the shared key",
                format!(
                    "a key needs at least {MIN_KEY_LEN} bytes, got {}",
                    bytes.len()
                ),
            ));
        }
        Ok(Self {
            bytes: bytes.to_vec(),
        })
    }

    /// A key from hex text (whitespace ignored), e.g. the output of `openssl rand -hex 32`.
    pub fn from_hex(text: &str) -> Result<Self, RigError> {
        let digits: Vec<u8> = text.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
        if digits.len() % 2 != 0 {
            return Err(RigError::config(
                "the shared key",
                "odd number of hex digits",
            ));
        }
        let nibble = |d: u8| -> Result<u8, RigError> {
            (d as char).to_digit(16).map(|v| v as u8).ok_or_else(|| {
                RigError::config(
                    "the shared key",
                    format!("not a hex digit: {:?}", d as char),
                )
            })
        };
        let bytes = digits
            .chunks_exact(2)
            .map(|pair| Ok(nibble(pair[0])? << 4 | nibble(pair[1])?))
            .collect::<Result<Vec<u8>, RigError>>()?;
        Self::new(&bytes)
    }

    /// Reads a key file: the key in hex, at least 32 hex digits; whitespace ignored.
    pub fn from_file(path: &Path) -> Result<Self, RigError> {
        let text = rig_description::bounded::read_to_string_capped(
            path,
            rig_description::bounded::KEY_CAP_BYTES,
            "a key file",
        )
        .map_err(|e| RigError::io(format!("reading key file {}", path.display()), e))?;
        Self::from_hex(&text).map_err(|e| match e {
            RigError::Config { reason, .. } => RigError::config(
                format!("the key file {}", path.display()),
                format!("{reason}; a key file holds the key in hex (`stewart key new` writes one)"),
            ),
            other => other,
        })
    }

    /// A fresh random key of [`GENERATED_KEY_LEN`] bytes from the operating system's
    /// cryptographically secure generator (through `rand`'s thread generator, ChaCha seeded
    /// from the OS).
    pub fn generate() -> Self {
        let bytes: [u8; GENERATED_KEY_LEN] = rand::random();
        Self {
            bytes: bytes.to_vec(),
        }
    }

    /// The key as lower-case hex, the key file's format.
    pub fn to_hex(&self) -> String {
        self.bytes.iter().map(|b| format!("{b:02x}")).collect()
    }

    /// Writes the key to `path` as hex with a newline, readable and writable by its owner only
    /// (mode 0600 on Unix), creating the parent directory. An existing file is refused unless
    /// `overwrite`, so that a paired key is never replaced by accident.
    pub fn write_new(&self, path: &Path, overwrite: bool) -> Result<(), RigError> {
        use std::io::Write;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| RigError::io(format!("creating {}", dir.display()), e))?;
        }
        if !overwrite && path.exists() {
            return Err(RigError::config(
                format!("the key file {}", path.display()),
                "a key file is already there; it may be paired with a rig: keep it, or replace \
                 it with --force and copy the new one to the other side",
            ));
        }
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create(true).truncate(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            options.mode(0o600);
        }
        let context = || format!("writing key file {}", path.display());
        let mut file = options.open(path).map_err(|e| RigError::io(context(), e))?;
        // An existing file keeps its mode on open: make it the owner's alone.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            file.set_permissions(std::fs::Permissions::from_mode(0o600))
                .map_err(|e| RigError::io(context(), e))?;
        }
        writeln!(file, "{}", self.to_hex()).map_err(|e| RigError::io(context(), e))
    }

    /// The secret bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The key's fingerprint as sent in `Hello` (see [`crate::codec::key_id`]).
    pub fn id(&self) -> u32 {
        key_id(&self.bytes)
    }
}

impl fmt::Debug for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Key(id {:08x})", self.id())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_keys_parse_and_short_or_bad_ones_are_refused() {
        let key = Key::from_hex("00112233 44556677\n8899aabb ccddeeff\n").unwrap();
        assert_eq!(key.bytes()[..4], [0x00, 0x11, 0x22, 0x33]);
        assert_eq!(key.bytes().len(), 16);
        assert!(Key::from_hex("0011").is_err());
        assert!(Key::from_hex("zz112233445566778899aabbccddeeff").is_err());
        assert!(Key::from_hex("0112233445566778899aabbccddeeff").is_err());
        assert!(!format!("{key:?}").contains("0011"));
    }

    #[test]
    fn key_files_are_read_with_a_clear_error() {
        let dir = std::env::temp_dir().join(format!("rig-key-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.key");
        std::fs::write(&good, "000102030405060708090a0b0c0d0e0f\n").unwrap();
        assert_eq!(Key::from_file(&good).unwrap().bytes().len(), 16);
        let missing = dir.join("missing.key");
        let err = Key::from_file(&missing).unwrap_err().to_string();
        assert!(err.contains("missing.key"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn generated_keys_are_written_for_the_owner_only_and_never_overwritten_by_accident() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("stewart").join("rig.key");
        let key = Key::generate();
        assert_eq!(key.bytes().len(), GENERATED_KEY_LEN);
        assert_ne!(key, Key::generate());
        key.write_new(&path, false).unwrap();
        assert_eq!(Key::from_file(&path).unwrap(), key);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o600, "{mode:o}");
        }
        let refused = Key::generate().write_new(&path, false).unwrap_err();
        assert!(refused.to_string().contains("--force"), "{refused}");
        assert_eq!(Key::from_file(&path).unwrap(), key, "kept");
        let replacement = Key::generate();
        replacement.write_new(&path, true).unwrap();
        assert_eq!(Key::from_file(&path).unwrap(), replacement);
    }
}
