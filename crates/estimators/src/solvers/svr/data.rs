//! The SVR's samples with exact duplicates merged, apart from the solver so that the
//! interior point and the continuation can both take it without importing each other.

use crate::dense::linalg::{Tall, col};
use crate::problem::Problem;

/// The samples with exact duplicates `(zᵢ, yᵢ)` merged into one sample of weight equal to
/// their multiplicity (designs stacked from records at rest repeat the same row many
/// times; merged, a margin set never exceeds q samples for that reason alone).
pub(super) struct Data {
    pub(super) z: Tall,
    pub(super) y: Vec<f64>,
    /// Multiplicities.
    pub(super) w: Vec<f64>,
    pub(super) n: usize,
}

impl Data {
    pub(super) fn new(pb: &Problem) -> Self {
        let (n, q) = (pb.n, pb.q());
        // A 64-bit hash of every row's bits, accumulated column by column (Z is column
        // major), then one map from hash to the first row with it; equal hashes are
        // confirmed by comparing the rows. A collision of unequal rows only leaves them
        // unmerged, which is always correct. A map keyed on the row itself allocated once
        // per row and cost more than a Newton step on the largest designs.
        // One multiply per value (FxHash's step) and a full mix per row at the end.
        let step =
            |h: u64, v: f64| (h.rotate_left(5) ^ v.to_bits()).wrapping_mul(0x517c_c1b7_2722_0a95);
        let mut hash: Vec<u64> = pb.y.iter().map(|&v| step(0, v)).collect();
        for j in 0..q {
            for (h, &v) in hash.iter_mut().zip(col(&pb.z, j)) {
                *h = step(*h, v);
            }
        }
        for h in hash.iter_mut() {
            *h = mix(*h);
        }
        let same_row = |a: usize, b: usize| {
            pb.y[a].to_bits() == pb.y[b].to_bits()
                && (0..q).all(|j| col(&pb.z, j)[a].to_bits() == col(&pb.z, j)[b].to_bits())
        };
        let mut first: std::collections::HashMap<u64, usize, PassThrough> =
            std::collections::HashMap::with_capacity_and_hasher(n, PassThrough);
        let mut keep: Vec<usize> = Vec::with_capacity(n);
        let mut w: Vec<f64> = Vec::with_capacity(n);
        for (i, &h) in hash.iter().enumerate() {
            match first.entry(h) {
                std::collections::hash_map::Entry::Occupied(e) if same_row(keep[*e.get()], i) => {
                    w[*e.get()] += 1.0;
                }
                std::collections::hash_map::Entry::Occupied(_) => {
                    keep.push(i);
                    w.push(1.0);
                }
                std::collections::hash_map::Entry::Vacant(e) => {
                    e.insert(keep.len());
                    keep.push(i);
                    w.push(1.0);
                }
            }
        }
        let m = keep.len();
        if m == n {
            return Data {
                z: Tall::from_column_major(
                    (0..q).flat_map(|j| col(&pb.z, j).iter().copied()).collect(),
                    n,
                    q,
                ),
                y: pb.y.clone(),
                w,
                n,
            };
        }
        let y = keep.iter().map(|&i| pb.y[i]).collect();
        Data {
            z: pb.z.select_rows(&keep),
            y,
            w,
            n: m,
        }
    }

    pub(super) fn q(&self) -> usize {
        self.z.ncols()
    }
}

/// One round of a 64-bit finaliser (splitmix64): every input bit affects every output bit,
/// so that rows differing in any bit of any value get unrelated hashes.
fn mix(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// The map's keys are already well-mixed hashes; hashing them again would only cost time.
#[derive(Clone, Copy, Default)]
struct PassThrough;

impl std::hash::BuildHasher for PassThrough {
    type Hasher = PassThroughHasher;
    fn build_hasher(&self) -> PassThroughHasher {
        PassThroughHasher(0)
    }
}

#[derive(Default)]
struct PassThroughHasher(u64);

impl std::hash::Hasher for PassThroughHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = mix(self.0 ^ u64::from(b));
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = v;
    }
}
