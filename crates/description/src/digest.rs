//! SHA-256 digests of the texts a report names (the rig description as the log records it, each
//! calibration as applied), so that a certificate identifies exactly what was measured with.

/// SHA-256 of `text`'s UTF-8 bytes, lower-case hex (FIPS 180-4).
pub fn sha256_hex(text: &str) -> String {
    use sha2::Digest as _;
    sha2::Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[cfg(test)]
mod tests {
    /// FIPS 180-4's example: SHA-256("abc").
    #[test]
    fn the_standards_example_digest() {
        assert_eq!(
            super::sha256_hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
