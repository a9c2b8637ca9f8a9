//! Frames on the wire: header, postcard body, optional HMAC tag, CRC; COBS for byte streams.
//!
//! ```text
//! frame = magic 0x53 | version | flags | body (postcard Message) | [tag, 32 bytes] | crc32 LE
//! ```
//!
//! * `flags` bit 0 ([`FLAG_TAGGED`]) says a tag is present; other bits are reserved, zero.
//! * `tag` = HMAC-SHA256(key, session_id as u64 LE ‖ magic ‖ version ‖ flags ‖ body), where
//!   `session_id` is 0 for `Hello`/`HelloAck` and the `HelloAck`'s session number afterwards.
//! * `crc32` = CRC-32/ISO-HDLC (the zlib/Ethernet CRC: poly 0x04C11DB7 reflected, init and
//!   xorout 0xFFFFFFFF, check value 0xCBF43926) over every byte before it.
//!
//! A datagram transport (UDP) carries one frame per datagram; a byte stream (serial) carries
//! each frame COBS-encoded and followed by a single 0x00 delimiter. No function here allocates
//! or panics on any input: every malformed frame is an error value, to be counted and dropped.

use core::fmt;

use crc::{Crc, CRC_32_ISO_HDLC};
use hmac::{Hmac, Mac};
use sha2::{Digest, Sha256};

use crate::wire::{Message, PROTOCOL_VERSION};

/// First byte of every frame ('S').
pub const MAGIC: u8 = 0x53;
/// Flag bit: an HMAC-SHA256 tag follows the body.
pub const FLAG_TAGGED: u8 = 0x01;
/// Bytes before the body: magic, version, flags.
pub const HEADER_LEN: usize = 3;
/// Bytes of an HMAC-SHA256 tag.
pub const TAG_LEN: usize = 32;
/// Bytes of the trailing CRC.
pub const CRC_LEN: usize = 4;
/// Largest frame either side sends or accepts, bytes (the largest message needs 215).
pub const MAX_FRAME_LEN: usize = 256;
/// Largest body, bytes.
pub const MAX_BODY_LEN: usize = MAX_FRAME_LEN - HEADER_LEN - TAG_LEN - CRC_LEN;
/// Largest COBS-encoded frame including its 0x00 delimiter, bytes.
pub const MAX_COBS_LEN: usize = MAX_FRAME_LEN + MAX_FRAME_LEN / 254 + 2;

/// Shortest shared key either side accepts, bytes (128 bits).
pub const MIN_KEY_LEN: usize = 16;

/// The CRC of every frame: CRC-32/ISO-HDLC.
pub const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

type HmacSha256 = Hmac<Sha256>;

/// A shared key and the session it tags frames for.
#[derive(Clone, Copy, Debug)]
pub struct Auth<'a> {
    /// The shared secret.
    pub key: &'a [u8],
    /// 0 for `Hello`/`HelloAck`; the `HelloAck`'s `session_id` afterwards.
    pub session_id: u64,
}

/// What the fixed header of a frame says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Protocol version of the sender.
    pub version: u8,
    /// Flag bits.
    pub flags: u8,
}

/// Everything that can be wrong with a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CodecError {
    /// Shorter than a header and a CRC.
    TooShort,
    /// Longer than [`MAX_FRAME_LEN`].
    TooLong,
    /// The CRC does not match: bits flipped on the way.
    BadCrc,
    /// The first byte is not [`MAGIC`]: not a frame of this protocol.
    BadMagic(u8),
    /// The sender speaks another protocol version (its version is given).
    VersionMismatch(u8),
    /// Reserved flag bits are set.
    ReservedFlags(u8),
    /// A key is configured but the frame carries no tag.
    MissingTag,
    /// The frame carries a tag but no key is configured here.
    UnexpectedTag,
    /// The tag does not verify: wrong key, wrong session, or a forged frame.
    BadTag,
    /// The body is not a valid message.
    BadBody,
    /// Bytes left over after the message.
    TrailingBytes,
    /// The output buffer is too small.
    BufferTooSmall,
    /// COBS framing is broken (a zero inside, or a length code pointing past the end).
    BadCobs,
}

/// Coarse classes of [`CodecError`], for counting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CodecErrorKind {
    /// Damaged on the way (length, CRC, COBS, body after a good CRC).
    Corrupt,
    /// Not this protocol or not this version.
    Foreign,
    /// Authentication failed (tag missing, unexpected or wrong).
    Auth,
    /// A local buffer problem when encoding.
    Encode,
}

impl CodecError {
    /// The class of this error.
    pub const fn kind(&self) -> CodecErrorKind {
        match self {
            CodecError::TooShort
            | CodecError::TooLong
            | CodecError::BadCrc
            | CodecError::BadBody
            | CodecError::TrailingBytes
            | CodecError::BadCobs
            | CodecError::ReservedFlags(_) => CodecErrorKind::Corrupt,
            CodecError::BadMagic(_) | CodecError::VersionMismatch(_) => CodecErrorKind::Foreign,
            CodecError::MissingTag | CodecError::UnexpectedTag | CodecError::BadTag => {
                CodecErrorKind::Auth
            }
            CodecError::BufferTooSmall => CodecErrorKind::Encode,
        }
    }
}

impl fmt::Display for CodecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CodecError::TooShort => write!(f, "frame shorter than header and CRC"),
            CodecError::TooLong => write!(f, "frame longer than {MAX_FRAME_LEN} bytes"),
            CodecError::BadCrc => write!(f, "CRC mismatch"),
            CodecError::BadMagic(b) => write!(f, "not a rig protocol frame (first byte {b:#04x})"),
            CodecError::VersionMismatch(v) => write!(
                f,
                "protocol version mismatch: peer speaks v{v}, this side v{PROTOCOL_VERSION}"
            ),
            CodecError::ReservedFlags(b) => write!(f, "reserved flag bits set ({b:#04x})"),
            CodecError::MissingTag => write!(f, "frame has no HMAC tag but a key is configured"),
            CodecError::UnexpectedTag => {
                write!(f, "frame has an HMAC tag but no key is configured")
            }
            CodecError::BadTag => write!(f, "HMAC tag does not verify (wrong key or session)"),
            CodecError::BadBody => write!(f, "body is not a valid message"),
            CodecError::TrailingBytes => write!(f, "bytes left over after the message"),
            CodecError::BufferTooSmall => write!(f, "output buffer too small"),
            CodecError::BadCobs => write!(f, "broken COBS framing"),
        }
    }
}

/// Fingerprint of a key: the first four bytes of SHA-256(key), little-endian. Sent in `Hello`
/// so that a key mismatch is reported as such; it reveals nothing useful about the key.
pub fn key_id(key: &[u8]) -> u32 {
    let digest = Sha256::digest(key);
    u32::from_le_bytes([digest[0], digest[1], digest[2], digest[3]])
}

fn mac_for(auth: &Auth<'_>, header_and_body: &[u8]) -> HmacSha256 {
    // HMAC takes keys of any length (long ones are hashed), so this cannot fail.
    let mut mac = match <HmacSha256 as Mac>::new_from_slice(auth.key) {
        Ok(mac) => mac,
        Err(_) => unreachable_hmac(),
    };
    mac.update(&auth.session_id.to_le_bytes());
    mac.update(header_and_body);
    mac
}

#[cold]
fn unreachable_hmac() -> ! {
    // `Hmac::new_from_slice` only rejects keys for fixed-key-size MACs; SHA-256 HMAC has none.
    unreachable!("HMAC-SHA256 accepts keys of any length")
}

/// Encodes `message` into `out` as one frame; returns its length.
///
/// With `auth`, the frame is tagged. Fails only when `out` is too small.
pub fn encode(
    message: &Message,
    auth: Option<&Auth<'_>>,
    out: &mut [u8],
) -> Result<usize, CodecError> {
    let flags = if auth.is_some() { FLAG_TAGGED } else { 0 };
    let header = [MAGIC, PROTOCOL_VERSION, flags];
    let head = out
        .get_mut(..HEADER_LEN)
        .ok_or(CodecError::BufferTooSmall)?;
    head.copy_from_slice(&header);
    let body_space = out
        .get_mut(HEADER_LEN..)
        .ok_or(CodecError::BufferTooSmall)?;
    let body_len = postcard::to_slice(message, body_space)
        .map_err(|_| CodecError::BufferTooSmall)?
        .len();
    let mut len = HEADER_LEN + body_len;
    if let Some(auth) = auth {
        let tag = mac_for(auth, out.get(..len).ok_or(CodecError::BufferTooSmall)?)
            .finalize()
            .into_bytes();
        out.get_mut(len..len + TAG_LEN)
            .ok_or(CodecError::BufferTooSmall)?
            .copy_from_slice(&tag);
        len += TAG_LEN;
    }
    let crc = CRC32.checksum(out.get(..len).ok_or(CodecError::BufferTooSmall)?);
    out.get_mut(len..len + CRC_LEN)
        .ok_or(CodecError::BufferTooSmall)?
        .copy_from_slice(&crc.to_le_bytes());
    Ok(len + CRC_LEN)
}

/// Checks length, CRC, magic and version, and returns the header. Lets a receiver tell a
/// version mismatch from noise before it tries to read the body.
pub fn check_frame(frame: &[u8]) -> Result<Header, CodecError> {
    if frame.len() > MAX_FRAME_LEN {
        return Err(CodecError::TooLong);
    }
    if frame.len() < HEADER_LEN + CRC_LEN + 1 {
        return Err(CodecError::TooShort);
    }
    let (covered, crc_bytes) = frame.split_at(frame.len() - CRC_LEN);
    let crc = u32::from_le_bytes([crc_bytes[0], crc_bytes[1], crc_bytes[2], crc_bytes[3]]);
    if CRC32.checksum(covered) != crc {
        return Err(CodecError::BadCrc);
    }
    if covered[0] != MAGIC {
        return Err(CodecError::BadMagic(covered[0]));
    }
    if covered[1] != PROTOCOL_VERSION {
        return Err(CodecError::VersionMismatch(covered[1]));
    }
    let flags = covered[2];
    if flags & !FLAG_TAGGED != 0 {
        return Err(CodecError::ReservedFlags(flags));
    }
    Ok(Header {
        version: covered[1],
        flags,
    })
}

/// Decodes one frame. With `auth`, the frame must carry a tag that verifies under that key
/// and session; without, it must carry none.
pub fn decode(frame: &[u8], auth: Option<&Auth<'_>>) -> Result<Message, CodecError> {
    let header = check_frame(frame)?;
    let covered = &frame[..frame.len() - CRC_LEN];
    let tagged = header.flags & FLAG_TAGGED != 0;
    let body = match (auth, tagged) {
        (Some(_), false) => return Err(CodecError::MissingTag),
        (None, true) => return Err(CodecError::UnexpectedTag),
        (None, false) => &covered[HEADER_LEN..],
        (Some(auth), true) => {
            if covered.len() < HEADER_LEN + TAG_LEN + 1 {
                return Err(CodecError::TooShort);
            }
            let (signed, tag) = covered.split_at(covered.len() - TAG_LEN);
            mac_for(auth, signed)
                .verify_slice(tag)
                .map_err(|_| CodecError::BadTag)?;
            &signed[HEADER_LEN..]
        }
    };
    let (message, rest) =
        postcard::take_from_bytes::<Message>(body).map_err(|_| CodecError::BadBody)?;
    if !rest.is_empty() {
        return Err(CodecError::TrailingBytes);
    }
    Ok(message)
}

/// Decodes a frame's message *without* checking its tag (the CRC, magic and version are still
/// checked); returns the message and whether it was tagged.
///
/// Never act on such a message: it exists so that a rig can read a `Hello` it cannot
/// authenticate and answer with a key fault, and a host can read the rig's untagged refusal.
pub fn decode_unverified(frame: &[u8]) -> Result<(Message, bool), CodecError> {
    let header = check_frame(frame)?;
    let covered = &frame[..frame.len() - CRC_LEN];
    let tagged = header.flags & FLAG_TAGGED != 0;
    let end = if tagged {
        covered
            .len()
            .checked_sub(TAG_LEN)
            .filter(|&end| end > HEADER_LEN)
            .ok_or(CodecError::TooShort)?
    } else {
        covered.len()
    };
    let (message, rest) = postcard::take_from_bytes::<Message>(&covered[HEADER_LEN..end])
        .map_err(|_| CodecError::BadBody)?;
    if !rest.is_empty() {
        return Err(CodecError::TrailingBytes);
    }
    Ok((message, tagged))
}

/// COBS-encodes `frame` into `out` and appends the 0x00 delimiter; returns the bytes written.
pub fn cobs_encode(frame: &[u8], out: &mut [u8]) -> Result<usize, CodecError> {
    let n = cobs::try_encode(frame, out).map_err(|_| CodecError::BufferTooSmall)?;
    *out.get_mut(n).ok_or(CodecError::BufferTooSmall)? = 0;
    Ok(n + 1)
}

/// Decodes one COBS-encoded frame (without or with its trailing delimiter) into `out`;
/// returns the frame length.
pub fn cobs_decode(encoded: &[u8], out: &mut [u8]) -> Result<usize, CodecError> {
    let encoded = match encoded.split_last() {
        Some((0, rest)) => rest,
        _ => encoded,
    };
    if encoded.is_empty() || encoded.contains(&0) {
        return Err(CodecError::BadCobs);
    }
    if encoded.len() > MAX_COBS_LEN {
        return Err(CodecError::TooLong);
    }
    // `cobs::decode` expects a destination at least as long as the source.
    let mut scratch = [0u8; MAX_COBS_LEN];
    let n = cobs::decode(encoded, &mut scratch).map_err(|_| CodecError::BadCobs)?;
    let decoded = scratch.get(..n).ok_or(CodecError::BadCobs)?;
    out.get_mut(..n)
        .ok_or(CodecError::BufferTooSmall)?
        .copy_from_slice(decoded);
    Ok(n)
}

#[cfg(test)]
mod tests;
