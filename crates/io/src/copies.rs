//! Recordings that hold another recording's samples: a part of it, every k-th sample of it, the same
//! samples written with fewer digits or in other units, or its track turned by a heading offset. A
//! byte-for-byte copy is caught by its fingerprint where the data set is read; these are not, and a
//! fit counted their samples twice without a word (the uncertainty understated, the recording's
//! misfit weighted double).
//!
//! The test compares the channels a track's rotation leaves alone (u, v, r and δ, in the project's
//! units after conversion) at the samples of one recording against the samples of the other at the
//! same times less an offset. Two runs of one manoeuvre never agree to a millionth of their range
//! (the tank's noise, a sea's disturbances), and noise-free simulations of different manoeuvres part
//! once their rudders do; a recording without yaw carries no test (any straight run matches any
//! other's approach).

use crate::Recording;

/// Samples agree when every channel is within this share of its largest magnitude in either
/// recording: 8 significant digits and unit conversions stay far inside, measurement noise far
/// outside.
const AGREE_SHARE: f64 = 1e-6;

/// Samples of the later recording compared, spread over its whole length, besides its anchor.
const CHECKED_SAMPLES: usize = 48;

/// At most this many candidate offsets are tried (a steady turn matches its anchor at many).
const MAX_OFFSETS: usize = 64;

/// A recording prepared for the test: its channels and its samples sorted by yaw rate.
pub(crate) struct CopyIndex {
    by_r: Vec<usize>,
}

impl CopyIndex {
    pub(crate) fn new(rec: &Recording) -> CopyIndex {
        let mut by_r: Vec<usize> = (0..rec.r.len()).filter(|&i| rec.r[i].is_finite()).collect();
        by_r.sort_by(|&i, &j| rec.r[i].total_cmp(&rec.r[j]));
        CopyIndex { by_r }
    }
}

/// Where `b` holds the samples of `a`: the span of `a`'s clock [s] that `b` covers, shifted by the
/// offset at which they agree; `None` when `b` is not a copy of (a part of) `a`.
pub(crate) fn copied_span(a: &Recording, a_index: &CopyIndex, b: &Recording) -> Option<(f64, f64)> {
    let n_b = b.t.len();
    if n_b < 2 || a.t.len() < 2 {
        return None;
    }
    let (b0, b1) = (b.t[0], b.t[n_b - 1]);
    if b1 - b0 > (a.t[a.t.len() - 1] - a.t[0]) * (1.0 + 1e-9) {
        return None;
    }
    let scale = |x: &[f64], y: &[f64]| {
        x.iter()
            .chain(y)
            .filter(|v| v.is_finite())
            .fold(0.0_f64, |m, v| m.max(v.abs()))
    };
    let tol = [
        AGREE_SHARE * scale(&a.u, &b.u),
        AGREE_SHARE * scale(&a.v, &b.v),
        AGREE_SHARE * scale(&a.r, &b.r),
        AGREE_SHARE * scale(&a.delta, &b.delta),
    ];
    // The anchor is b's most distinctive sample, its largest yaw rate; without yaw, no test.
    let k = (0..n_b).max_by(|&i, &j| b.r[i].abs().total_cmp(&b.r[j].abs()))?;
    let (r_min, r_max) =
        b.r.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
    if r_max - r_min <= 100.0 * tol[2] || (r_max - r_min).is_nan() {
        return None;
    }
    let agree = |i: usize, j: usize| {
        (a.u[j] - b.u[i]).abs() <= tol[0]
            && (a.v[j] - b.v[i]).abs() <= tol[1]
            && (a.r[j] - b.r[i]).abs() <= tol[2]
            && (a.delta[j] - b.delta[i]).abs() <= tol[3]
    };
    let lo = a_index.by_r.partition_point(|&j| a.r[j] < b.r[k] - tol[2]);
    let hi = a_index.by_r.partition_point(|&j| a.r[j] <= b.r[k] + tol[2]);
    let step = (n_b / CHECKED_SAMPLES).max(1);
    let checked: Vec<usize> = (0..n_b).step_by(step).chain([n_b - 1]).collect();
    // A sample of `a` within a quarter of its own interval of a time: the same sample.
    let a_dt = (a.t[a.t.len() - 1] - a.t[0]) / (a.t.len() - 1) as f64;
    let sample_at = |t: f64| {
        let j = a.t.partition_point(|&s| s < t);
        [j.checked_sub(1), Some(j)]
            .into_iter()
            .flatten()
            .filter(|&j| j < a.t.len())
            .min_by(|&x, &y| (a.t[x] - t).abs().total_cmp(&(a.t[y] - t).abs()))
            .filter(|&j| (a.t[j] - t).abs() <= 0.25 * a_dt)
    };
    a_index.by_r[lo..hi]
        .iter()
        .take(MAX_OFFSETS)
        .filter(|&&j| agree(k, j))
        .find_map(|&j| {
            let offset = a.t[j] - b.t[k];
            checked
                .iter()
                .all(|&i| sample_at(b.t[i] + offset).is_some_and(|j| agree(i, j)))
                .then_some((b0 + offset, b1 + offset))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A zig-zag-like recording: u, v, r and δ varying with `phase` (another manoeuvre for another
    /// phase), sampled every `dt_s` from 0 to `end_s`.
    fn recording(dt_s: f64, end_s: f64, phase: f64) -> Recording {
        let n = (end_s / dt_s).round() as usize + 1;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt_s).collect();
        let f = |g: fn(f64) -> f64, s: f64| t.iter().map(|&t| s * g(0.05 * t + phase)).collect();
        Recording {
            u: t.iter()
                .map(|&t| 1.2 - 0.1 * (0.03 * t + phase).cos())
                .collect(),
            v: f(f64::sin, 0.05),
            r: f(f64::cos, 0.02),
            delta: f(|x| (2.0 * x).sin(), 0.3),
            x0: vec![0.0; n],
            y0: vec![0.0; n],
            psi: vec![0.0; n],
            t,
            ..Recording::default()
        }
    }

    fn check(a: &Recording, b: &Recording, expected: Option<(f64, f64)>) {
        let got = copied_span(a, &CopyIndex::new(a), b);
        match (got, expected) {
            (Some(g), Some(e)) => assert!(
                (g.0 - e.0).abs() < 1e-6 && (g.1 - e.1).abs() < 1e-6,
                "{g:?} vs {e:?}"
            ),
            (g, e) => assert_eq!(g, e),
        }
    }

    fn transformed(a: &Recording, keep: impl Fn(usize) -> bool, t_shift: f64) -> Recording {
        let pick = |x: &[f64]| -> Vec<f64> {
            x.iter()
                .enumerate()
                .filter(|(i, _)| keep(*i))
                .map(|(_, v)| *v)
                .collect()
        };
        let mut b = Recording {
            t: pick(&a.t),
            x0: pick(&a.x0),
            y0: pick(&a.y0),
            psi: pick(&a.psi),
            u: pick(&a.u),
            v: pick(&a.v),
            r: pick(&a.r),
            delta: pick(&a.delta),
            ..Recording::default()
        };
        b.t.iter_mut().for_each(|t| *t += t_shift);
        b
    }

    #[test]
    fn a_part_of_a_recording_on_another_clock_is_a_copy() {
        let a = recording(0.1, 200.0, 0.0);
        let b = transformed(&a, |i| (300..1500).contains(&i), 1000.0);
        check(&a, &b, Some((30.0, 149.9)));
    }

    #[test]
    fn every_second_sample_is_a_copy() {
        let a = recording(0.1, 200.0, 0.0);
        check(
            &a,
            &transformed(&a, |i| i % 2 == 0, 0.0),
            Some((0.0, 200.0)),
        );
    }

    #[test]
    fn the_samples_rounded_to_eight_digits_are_a_copy() {
        let a = recording(0.1, 200.0, 0.0);
        let mut b = transformed(&a, |_| true, 0.0);
        let round = |x: &mut Vec<f64>| {
            x.iter_mut()
                .for_each(|v| *v = format!("{:.7e}", *v).parse().unwrap())
        };
        for c in [&mut b.u, &mut b.v, &mut b.r, &mut b.delta] {
            round(c);
        }
        check(&a, &b, Some((0.0, 200.0)));
    }

    #[test]
    fn another_manoeuvre_or_the_same_with_noise_is_not_a_copy() {
        let a = recording(0.1, 200.0, 0.0);
        check(&a, &recording(0.1, 200.0, 0.7), None);
        let mut noisy = transformed(&a, |_| true, 0.0);
        noisy
            .r
            .iter_mut()
            .enumerate()
            .for_each(|(i, r)| *r += 1e-5 * ((i * 7919) % 13) as f64 / 13.0);
        check(&a, &noisy, None);
    }

    #[test]
    fn a_longer_recording_or_one_without_yaw_carries_no_test() {
        let a = recording(0.1, 100.0, 0.0);
        check(&a, &recording(0.1, 200.0, 0.0), None);
        let mut straight = transformed(&a, |i| i < 200, 0.0);
        straight.r.iter_mut().for_each(|r| *r = 0.0);
        check(&a, &straight, None);
    }
}
