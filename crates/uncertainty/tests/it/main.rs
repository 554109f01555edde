//! Tests of the uncertainty building blocks: one helper per concern.

use shipid_uncertainty::{
    Coverage, SplitMix64, UncertaintyError, block_length, order_statistic_band, percentile_band,
    replicate_rows, spread,
};

/// Standard normal deviates from the crate's generator (Box–Muller).
fn normals(seed: u64, n: usize) -> Vec<f64> {
    let mut rng = SplitMix64::new(seed);
    let mut uniform = move || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    (0..n)
        .map(|_| {
            let (u1, u2) = (uniform().max(1e-300), uniform());
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        })
        .collect()
}

/// AR(1) series x_k = φ x_{k−1} + e_k.
fn ar1(phi: f64, seed: u64, n: usize) -> Vec<f64> {
    let e = normals(seed, n);
    let mut x = Vec::with_capacity(n);
    let mut prev = 0.0;
    for v in e {
        prev = phi * prev + v;
        x.push(prev);
    }
    x
}

fn check_block(residual: &[f64], expected_rows: std::ops::RangeInclusive<usize>) {
    let b = block_length(residual);
    assert!(
        expected_rows.contains(&b.rows),
        "{b:?}, expected rows in {expected_rows:?}"
    );
    assert!(
        b.rows >= b.floor_rows.min(b.cap_rows) && b.rows <= b.cap_rows,
        "{b:?}"
    );
}

#[test]
fn block_length_follows_the_residual_autocorrelation() {
    // White noise decorrelates at once: the n^(1/3) floor (2000^(1/3) = 12.6 → 13) decides.
    check_block(&normals(1, 2000), 13..=13);
    // AR(1) φ = 0.95: ρ(k) = 0.95^k falls below 2/√2000 = 0.045 near k = 60; the sample ACF of
    // 2000 values crosses earlier by chance (34 for this seed).
    check_block(&ar1(0.95, 2, 2000), 25..=110);
    // A constant residual carries no correlation structure: the floor.
    check_block(&[0.5; 1000], 10..=10);
    // A drift that never decorrelates: the n/4 cap keeps four blocks.
    let drift: Vec<f64> = (0..400).map(|i| i as f64).collect();
    check_block(&drift, 100..=100);
    // Too short to estimate anything: single rows.
    check_block(&[1.0, -1.0, 2.0], 1..=1);
}

#[test]
fn replicate_keeps_every_recording_length_and_its_rows_inside_it() {
    let recordings = [0..100, 100..130, 130..131, 131..131];
    let mut rng = SplitMix64::new(7);
    let rows = replicate_rows(&recordings, 12, &mut rng).unwrap();
    assert_eq!(rows.len(), 131);
    for (range, got) in [
        (0..100, &rows[0..100]),
        (100..130, &rows[100..130]),
        (130..131, &rows[130..131]),
    ] {
        assert!(got.iter().all(|r| range.contains(r)), "{range:?}: {got:?}");
    }
    // Blocks are consecutive rows.
    assert!(
        rows[0..12].windows(2).all(|w| w[1] == w[0] + 1),
        "{:?}",
        &rows[0..12]
    );
    // The same seed gives the same replicate; another seed another.
    let again = replicate_rows(&recordings, 12, &mut SplitMix64::new(7)).unwrap();
    let other = replicate_rows(&recordings, 12, &mut SplitMix64::new(8)).unwrap();
    assert_eq!(rows, again);
    assert_ne!(rows, other);
    assert_eq!(
        replicate_rows(std::slice::from_ref(&(0..0)), 5, &mut rng),
        Err(UncertaintyError::NoRows)
    );
}

#[test]
fn split_mix_stream_is_fixed_by_its_definition() {
    // First outputs for seed 0 of the published SplitMix64 (as in Vigna's reference code).
    let mut rng = SplitMix64::new(0);
    assert_eq!(rng.next_u64(), 0xE220_A839_7B1D_CDAF);
    assert_eq!(rng.next_u64(), 0x6E78_9E6A_A1B9_65F4);
}

/// Standard error of the mean of an AR(1) series estimated by the moving-block bootstrap with `block`.
fn bootstrap_se_of_mean(x: &[f64], block: usize, replicates: usize) -> f64 {
    let mut rng = SplitMix64::new(99);
    let means: Vec<Vec<f64>> = (0..replicates)
        .map(|_| {
            let rows =
                replicate_rows(std::slice::from_ref(&(0..x.len())), block, &mut rng).unwrap();
            vec![rows.iter().map(|&i| x[i]).sum::<f64>() / rows.len() as f64]
        })
        .collect();
    spread(&means).unwrap().std_error[0]
}

#[test]
fn blocks_capture_the_spread_that_single_rows_understate() {
    // For AR(1) with unit innovations the standard error of the mean of n values is
    // √(1/n) /(1 − φ) asymptotically: 0.0707 for φ = 0.9, n = 2000.
    let x = ar1(0.9, 3, 2000);
    let truth = (1.0 / 2000.0_f64).sqrt() / (1.0 - 0.9);
    let chosen = block_length(&x).rows;
    let blocked = bootstrap_se_of_mean(&x, chosen, 400);
    let rows = bootstrap_se_of_mean(&x, 1, 400);
    assert!(
        (blocked / truth - 1.0).abs() < 0.35,
        "block {chosen}: {blocked} vs {truth}"
    );
    assert!(rows < 0.5 * truth, "single rows: {rows} vs {truth}");
}

fn check_band(
    values: Vec<Option<f64>>,
    level: f64,
    expected: Result<(f64, f64, usize, usize), UncertaintyError>,
) {
    let got = percentile_band(values, level).map(|b| (b.lo, b.hi, b.finite, b.undefined));
    match (got, expected) {
        (Ok((lo, hi, f, u)), Ok((elo, ehi, ef, eu))) => {
            assert!(
                (lo - elo).abs() < 1e-12 && (hi - ehi).abs() < 1e-12,
                "{lo} {hi} vs {elo} {ehi}"
            );
            assert_eq!((f, u), (ef, eu));
        }
        (got, expected) => assert_eq!(got, expected),
    }
}

#[test]
fn percentile_bands() {
    let one_to_101: Vec<Option<f64>> = (1..=101).map(|v| Some(v as f64)).collect();
    check_band(one_to_101.clone(), 0.9, Ok((6.0, 96.0, 101, 0)));
    check_band(one_to_101.clone(), 0.5, Ok((26.0, 76.0, 101, 0)));
    let mut with_undefined = one_to_101.clone();
    with_undefined.extend([None, Some(f64::NAN), Some(f64::INFINITY)]);
    check_band(with_undefined, 0.9, Ok((6.0, 96.0, 101, 3)));
    check_band(one_to_101.clone(), 1.0, Err(UncertaintyError::Level(1.0)));
    check_band(one_to_101, 0.0, Err(UncertaintyError::Level(0.0)));
    let few: Vec<Option<f64>> = (0..19).map(|v| Some(v as f64)).chain([None]).collect();
    check_band(
        few,
        0.9,
        Err(UncertaintyError::TooFewReplicates {
            finite: 19,
            total: 20,
            needed: 20,
        }),
    );
}

fn check_order_band(
    values: Vec<Option<f64>>,
    level: f64,
    expected: Result<(f64, f64), UncertaintyError>,
) {
    let got = order_statistic_band(values, level).map(|b| (b.lo, b.hi));
    assert_eq!(got, expected);
}

#[test]
fn order_statistic_bands() {
    let members = |n: usize| -> Vec<Option<f64>> { (1..=n).map(|v| Some(v as f64)).collect() };
    // 21 members at 90 %: k = ⌊22 · 0.05⌋ = 1, the range (holds a new member with probability 20/22).
    check_order_band(members(21), 0.9, Ok((1.0, 21.0)));
    // 38 members still give the range (⌊39 · 0.05⌋ = 1); 39 the second smallest and largest.
    check_order_band(members(38), 0.9, Ok((1.0, 38.0)));
    check_order_band(members(39), 0.9, Ok((2.0, 38.0)));
    // 199 at 90 %: k = 10, as the percentiles would give about.
    check_order_band(members(199), 0.9, Ok((10.0, 190.0)));
    // A low level on few members never crosses over: k ≤ ⌈n/2⌉.
    check_order_band(members(20), 0.01, Ok((10.0, 11.0)));
    let mut with_undefined = members(25);
    with_undefined.extend([None, Some(f64::NAN)]);
    check_order_band(with_undefined, 0.9, Ok((1.0, 25.0)));
    check_order_band(members(25), 1.0, Err(UncertaintyError::Level(1.0)));
    check_order_band(
        members(19),
        0.9,
        Err(UncertaintyError::TooFewReplicates {
            finite: 19,
            total: 19,
            needed: 20,
        }),
    );
}

#[test]
fn spread_of_replicates() {
    let reps: Vec<Vec<f64>> = (0..10)
        .map(|i| vec![i as f64, 2.0 * i as f64 + 1.0, 3.0])
        .collect();
    let s = spread(&reps).unwrap();
    assert!((s.mean[0] - 4.5).abs() < 1e-12);
    assert!((s.std_error[1] - 2.0 * s.std_error[0]).abs() < 1e-12);
    assert!((s.correlation[0][1] - 1.0).abs() < 1e-12);
    assert_eq!((s.std_error[2], s.correlation[0][2]), (0.0, 0.0));
    assert_eq!(
        spread(&[vec![1.0], vec![1.0, 2.0]]),
        Err(UncertaintyError::Ragged(1, 2))
    );
    assert!(spread(&[vec![1.0]]).is_err());
}

#[test]
fn coverage_and_its_interval() {
    let mut c = Coverage::new(0.9);
    assert_eq!(c.measured(), None);
    for i in 0..40 {
        c.add(i % 10 != 0);
    }
    assert_eq!((c.inside, c.total), (36, 40));
    let (lo, hi) = c.wilson_95().unwrap();
    assert!(
        (lo - 0.769).abs() < 0.005 && (hi - 0.960).abs() < 0.005,
        "{lo} {hi}"
    );
}

/// One concern: the type-7 quantile, where the values may end in +∞.
fn check_quantile(sorted: &[f64], q: f64, expected: f64) {
    let got = shipid_uncertainty::band::quantile(sorted, q);
    assert!(
        got == expected || (got - expected).abs() < 1e-12,
        "quantile {q} of {sorted:?}: {got}, expected {expected}"
    );
}

#[test]
fn quantiles_interpolate_and_reach_infinity_without_nan() {
    let inf = f64::INFINITY;
    check_quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.5, 3.0);
    check_quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.9, 4.6);
    // An infinite value beyond the quantile changes nothing; reached, it gives +∞ (not ∞ − ∞).
    check_quantile(&[1.0, 2.0, 3.0, 4.0, inf], 0.5, 3.0);
    check_quantile(&[1.0, 2.0, 3.0, 4.0, inf], 0.9, inf);
    check_quantile(&[1.0, 2.0, inf, inf, inf], 0.9, inf);
    check_quantile(&[1.0, inf, inf], 0.5, inf);
}
