//! `stewart key new`'s flags. Where the shared key of `stewart rig` and `stewart emulate` is
//! found, and how it is made, is [`ops::key`]'s (docs/protocol.md, section 3).

use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};

use crate::common::CommandError;

use ops::key::{Chosen, Side};

/// `stewart key`.
#[derive(Clone, Debug, Args)]
pub struct KeyArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: KeyAction,
}

/// `stewart key` subcommands.
#[derive(Clone, Debug, Subcommand)]
pub enum KeyAction {
    /// Write a new random shared key (256 bits, hex, mode 0600) to the user's key file
    /// ($XDG_CONFIG_HOME/stewart/rig.key, else ~/.config/stewart/rig.key), then copy that file
    /// to the other side of the link.
    New(KeyNewArgs),
}

/// `stewart key new`.
#[derive(Clone, Debug, Args)]
pub struct KeyNewArgs {
    /// Replace an existing key file (the other side then needs the new one).
    #[arg(long)]
    pub force: bool,
    /// Write here instead of the user's key file.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

/// The key of a command ([`ops::key::choose`]), its refusal as an input refused.
pub fn choose(
    flag: Option<&Path>,
    configured: Option<PathBuf>,
    user_file: impl FnOnce() -> Result<PathBuf, ops::key::Error>,
    insecure: bool,
    side: Side,
) -> Result<Chosen, CommandError> {
    ops::key::choose(flag, configured, user_file, insecure, side)
        .map_err(|e| crate::common::refuse(e.to_string()))
}

/// `stewart key` from the command line; returns the exit code.
pub fn main(args: &KeyArgs) -> u8 {
    let KeyAction::New(new) = &args.action;
    let options = ops::key::KeyNewOptions {
        force: new.force,
        out: new.out.clone(),
    };
    match ops::key::new_key(&options) {
        Ok(path) => {
            println!("{}", path.display());
            eprintln!(
                "wrote a new shared key (owner-only); copy this file to the same place on the \
                 other side of the link (the rig or the host)"
            );
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            2
        }
    }
}
