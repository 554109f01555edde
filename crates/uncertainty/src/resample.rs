//! Rows of one moving-block bootstrap replicate.

use std::ops::Range;

use crate::UncertaintyError;

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny seeded generator whose sequence is fixed by its
/// definition, so stored replicates can be reproduced by any later release (a library generator may
/// change its stream between versions).
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform integer in 0..n (n > 0); the modulo bias is below 2⁻³² for the sizes used here.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Row indices of one replicate: for every recording (a range of rows, in time order) as many
/// blocks of `block_rows` consecutive rows, started uniformly at random inside that recording, as
/// cover its length, cut to its length. Each recording keeps its number of rows, so a replicate
/// weighs the manoeuvres as the original fit did.
pub fn replicate_rows(
    recordings: &[Range<usize>],
    block_rows: usize,
    rng: &mut SplitMix64,
) -> Result<Vec<usize>, UncertaintyError> {
    let total: usize = recordings.iter().map(|r| r.len()).sum();
    if total == 0 {
        return Err(UncertaintyError::NoRows);
    }
    let mut rows = Vec::with_capacity(total);
    for range in recordings.iter().filter(|r| !r.is_empty()) {
        let len = range.len();
        let block = block_rows.clamp(1, len);
        let starts = len - block + 1;
        let mut taken = 0;
        while taken < len {
            let start = range.start + rng.below(starts);
            let take = block.min(len - taken);
            rows.extend(start..start + take);
            taken += take;
        }
    }
    Ok(rows)
}
