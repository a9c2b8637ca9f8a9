//! The shared key of `stewart rig` and `stewart emulate`, and `stewart key new`'s work.
//!
//! A link is authenticated unless both sides say `--insecure`: every frame carries an
//! HMAC-SHA256 tag under a key both sides hold (docs/protocol.md, section 3). The key is found,
//! in this order, in `--key FILE`, the rig description's `rig.key_file`, and the user's key
//! file `$XDG_CONFIG_HOME/stewart/rig.key` (else `~/.config/stewart/rig.key`, the XDG Base
//! Directory default). `stewart key new` writes that file (mode 0600); `stewart emulate`
//! writes it when it is missing and says so; `stewart rig` without it refuses, saying how to
//! pair.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use rig::Key;

/// The key file's name in the user's configuration directory.
pub const KEY_FILE: &str = "stewart/rig.key";

/// Why no key was found or written: the refusal in words (nothing ran).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The key is missing, unreadable, contradicted or cannot be written.
    #[error("{0}")]
    Refused(String),
}

/// Options of `stewart key new`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KeyNewOptions {
    /// Replace an existing key file (the other side then needs the new one).
    pub force: bool,
    /// Write here instead of the user's key file.
    pub out: Option<PathBuf>,
}

/// Writes a new random shared key (256 bits, hex, mode 0600) to `options.out` or the user's
/// key file; returns the file written.
pub fn new_key(options: &KeyNewOptions) -> Result<PathBuf, Error> {
    let path = match &options.out {
        Some(path) => path.clone(),
        None => user_key_path()?,
    };
    Key::generate()
        .write_new(&path, options.force)
        .map_err(|e| refuse(format!("{e}")))?;
    Ok(path)
}

/// The user's key file from the environment's `XDG_CONFIG_HOME` and `HOME` (an empty or
/// relative `XDG_CONFIG_HOME` is ignored, as the XDG Base Directory specification says).
pub fn user_key_path_from(
    xdg_config_home: Option<OsString>,
    home: Option<OsString>,
) -> Option<PathBuf> {
    let usable = |v: Option<OsString>| v.map(PathBuf::from).filter(|p| p.is_absolute());
    if let Some(dir) = usable(xdg_config_home) {
        return Some(dir.join(KEY_FILE));
    }
    usable(home).map(|home| home.join(".config").join(KEY_FILE))
}

/// The user's key file (see [`user_key_path_from`]).
pub fn user_key_path() -> Result<PathBuf, Error> {
    user_key_path_from(
        std::env::var_os("XDG_CONFIG_HOME"),
        std::env::var_os("HOME"),
    )
    .ok_or_else(|| {
        refuse(
            "cannot find the user's configuration directory for the shared key: neither \
             XDG_CONFIG_HOME nor HOME is an absolute path; set one, or give --key FILE"
                .into(),
        )
    })
}

fn refuse(message: String) -> Error {
    Error::Refused(message)
}

/// Which side of the link wants the key: the rig (`emulate`) makes one when there is none,
/// the host (`rig`) must be paired with the rig's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// `stewart rig`.
    Host,
    /// `stewart emulate`.
    Rig,
}

/// The key a command uses, and where it came from.
#[derive(Clone, Debug)]
pub struct Chosen {
    /// The key; `None` only with `--insecure`.
    pub key: Option<Key>,
    /// What to tell the user at start (a key written, or the insecure warning), if anything.
    pub notice: Option<String>,
}

/// The key of a command: `flag` (`--key`), else `configured` (`rig.key_file`), else the user's
/// key file `user_file`; none with `insecure` (which contradicts the other two).
pub fn choose(
    flag: Option<&Path>,
    configured: Option<PathBuf>,
    user_file: impl FnOnce() -> Result<PathBuf, Error>,
    insecure: bool,
    side: Side,
) -> Result<Chosen, Error> {
    let read = |path: &Path| Key::from_file(path).map_err(|e| refuse(format!("shared key: {e}")));
    if insecure {
        if let Some(path) = flag {
            return Err(refuse(format!(
                "--insecure and --key {} contradict each other: drop one",
                path.display()
            )));
        }
        if let Some(path) = configured {
            return Err(refuse(format!(
                "--insecure contradicts rig.key_file = {} in the rig description: drop one",
                path.display()
            )));
        }
        return Ok(Chosen {
            key: None,
            notice: Some(insecure_warning(side)),
        });
    }
    if let Some(path) = flag.map(Path::to_path_buf).or(configured) {
        return Ok(Chosen {
            key: Some(read(&path)?),
            notice: None,
        });
    }
    let path = user_file()?;
    if path.exists() {
        return Ok(Chosen {
            key: Some(read(&path)?),
            notice: None,
        });
    }
    match side {
        Side::Rig => {
            let key = Key::generate();
            key.write_new(&path, false)
                .map_err(|e| refuse(format!("cannot write the shared key: {e}")))?;
            Ok(Chosen {
                key: Some(key),
                notice: Some(format!(
                    "no shared key yet: wrote a new one to {} (owner-only); copy that file to \
                     the same place on the host (or give it to `stewart rig --key FILE`) to \
                     pair it",
                    path.display()
                )),
            })
        }
        Side::Host => Err(refuse(format!(
            "no shared key at {}: pair this host with the rig first. Copy the rig's key file \
             there (`stewart emulate` writes one in the same place on its machine), or run \
             `stewart key new` here and copy the file to the rig; or give --key FILE (or \
             rig.key_file). `--insecure` on both sides runs without a key",
            path.display()
        ))),
    }
}

/// The loud warning of `--insecure`.
pub fn insecure_warning(side: Side) -> String {
    let who = match side {
        Side::Host => "this host's commands carry no tag: anyone on the network can forge them",
        Side::Rig => {
            "this rig accepts untagged commands: anyone who can reach its port can open a \
             session, and anyone who can forge the host's address can command the platform"
        }
    };
    format!(
        "WARNING: --insecure: no shared key; {who}. Use it only on an isolated network; \
         `stewart key new` and a copied key file authenticate the link"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_user_key_file_follows_xdg_then_home() {
        let p = |xdg: Option<&str>, home: Option<&str>| {
            user_key_path_from(xdg.map(OsString::from), home.map(OsString::from))
        };
        assert_eq!(
            p(Some("/x/cfg"), Some("/home/u")),
            Some(PathBuf::from("/x/cfg/stewart/rig.key"))
        );
        assert_eq!(
            p(None, Some("/home/u")),
            Some(PathBuf::from("/home/u/.config/stewart/rig.key"))
        );
        // Relative or empty XDG_CONFIG_HOME is ignored (XDG Base Directory specification).
        assert_eq!(
            p(Some("cfg"), Some("/home/u")),
            Some(PathBuf::from("/home/u/.config/stewart/rig.key"))
        );
        assert_eq!(
            p(Some(""), Some("/home/u")),
            Some(PathBuf::from("/home/u/.config/stewart/rig.key"))
        );
        assert_eq!(p(None, None), None);
    }

    #[test]
    fn the_rig_side_makes_a_key_and_the_host_side_says_how_to_pair() {
        let dir = tempfile::tempdir().unwrap();
        let user = dir.path().join("stewart").join("rig.key");
        let file = || Ok(user.clone());
        let host = choose(None, None, file, false, Side::Host).unwrap_err();
        let message = host.to_string();
        assert!(message.contains("stewart key new"), "{message}");
        assert!(message.contains(&user.display().to_string()), "{message}");
        assert!(matches!(host, Error::Refused(_)));
        let rig = choose(None, None, file, false, Side::Rig).unwrap();
        assert!(rig.notice.unwrap().contains("wrote a new one"));
        let host = choose(None, None, file, false, Side::Host).unwrap();
        assert_eq!(host.key, rig.key, "paired through the file");
        assert!(host.notice.is_none());
        // The emulator does not replace a key it finds.
        let again = choose(None, None, file, false, Side::Rig).unwrap();
        assert_eq!(again.key, rig.key);
    }

    #[test]
    fn insecure_is_keyless_warned_and_exclusive() {
        let dir = tempfile::tempdir().unwrap();
        let never = || -> Result<PathBuf, Error> { panic!("not looked up") };
        let chosen = choose(None, None, never, true, Side::Host).unwrap();
        assert!(chosen.key.is_none());
        assert!(chosen.notice.unwrap().starts_with("WARNING: --insecure"));
        let path = dir.path().join("k");
        assert!(choose(Some(&path), None, never, true, Side::Host)
            .unwrap_err()
            .to_string()
            .contains("contradict"));
        assert!(choose(None, Some(path), never, true, Side::Rig)
            .unwrap_err()
            .to_string()
            .contains("rig.key_file"));
    }

    #[test]
    fn key_new_refuses_to_overwrite_without_force() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("a").join("rig.key");
        let options = |force| KeyNewOptions {
            force,
            out: Some(out.clone()),
        };
        assert_eq!(new_key(&options(false)).unwrap(), out);
        let first = Key::from_file(&out).unwrap();
        let refused = new_key(&options(false)).unwrap_err();
        assert!(refused.to_string().contains("--force"), "{refused}");
        assert_eq!(Key::from_file(&out).unwrap(), first);
        new_key(&options(true)).unwrap();
        assert_ne!(Key::from_file(&out).unwrap(), first);
    }
}
