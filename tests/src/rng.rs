//! The one seeded random generator of the end-to-end tools: proptest's ChaCha `TestRng`
//! (`rand::RngCore` and `Rng`), so a fault campaign or a soak run replays from its seed.

pub use proptest::prelude::{Rng, RngCore};
use proptest::test_runner::{RngAlgorithm, TestRng};

/// A generator for `seed`: the same seed, the same sequence.
pub fn seeded(seed: u64) -> TestRng {
    let mut bytes = [0u8; 32];
    for (i, chunk) in bytes.chunks_mut(8).enumerate() {
        chunk.copy_from_slice(&seed.wrapping_add(i as u64).to_le_bytes());
    }
    TestRng::from_seed(RngAlgorithm::ChaCha, &bytes)
}

/// The seed in environment variable `var`, else one from the clock (printed by the caller so
/// that the run can be replayed).
pub fn seed_from_env(var: &str) -> u64 {
    std::env::var(var).ok().and_then(|s| s.trim().parse().ok()).unwrap_or_else(|| {
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(1, |d| d.as_nanos() as u64)
    })
}
