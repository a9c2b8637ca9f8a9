//! One random stream per error source, all from the world's seed.
//!
//! Each source draws from its own generator, keyed by the seed and the source's id, so that
//! switching a source off (or changing its figure) leaves every other source's draws as they
//! were: a campaign with one source on sees exactly that source's errors of the full world.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rig_description::sources::ErrorSource;

/// The generator of `source` for `seed`: ChaCha keyed with the seed's 8 bytes followed by the
/// source's id (at most 24 bytes), so no two (seed, source) pairs share a key.
pub(crate) fn stream(seed: u64, source: ErrorSource) -> StdRng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    for (k, b) in key[8..].iter_mut().zip(source.id().bytes()) {
        *k = b;
    }
    StdRng::from_seed(key)
}

/// `sigma · z`, z a standard normal draw (drawn even for `sigma = 0`, so a stream's sequence
/// does not depend on its figures).
pub(crate) fn normal(rng: &mut StdRng, sigma: f64) -> f64 {
    let z: f64 = rng.sample(StandardNormal);
    sigma * z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_source_and_seed_has_its_own_stream() {
        let mut firsts: Vec<u64> = Vec::new();
        for seed in [0, 1, 2, u64::MAX] {
            for source in ErrorSource::ALL {
                assert!(source.id().len() <= 24, "{source}");
                let a: u64 = stream(seed, source).random();
                assert_eq!(a, stream(seed, source).random::<u64>());
                firsts.push(a);
            }
        }
        let n = firsts.len();
        firsts.sort_unstable();
        firsts.dedup();
        assert_eq!(firsts.len(), n);
    }
}
