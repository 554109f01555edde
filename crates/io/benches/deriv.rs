//! Acceleration estimation on a high-rate recording: the smoothing differentiator over one hour of a
//! full-scale trial logged at 100 Hz (360,000 samples; KVLCC2 at full scale, L/U0 = 41 s, gives a
//! window of 0.3 L/U0 = 12.3 s, 1,231 samples), evenly sampled (the Savitzky–Golay kernel) and with a
//! jittered clock (a least-squares cubic per sample). Criterion reports samples per second.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use shipid_io::deriv::Differentiator;

const SAMPLES: usize = 360_000;
const RATE_HZ: f64 = 100.0;
const WINDOW_S: f64 = 12.3;

fn signal(t: &[f64]) -> Vec<f64> {
    t.iter()
        .map(|&t| 7.0 + 0.3 * (0.02 * t).sin() + 0.01 * (1.3 * t).cos())
        .collect()
}

fn differentiator(c: &mut Criterion) {
    let even: Vec<f64> = (0..SAMPLES).map(|i| i as f64 / RATE_HZ).collect();
    let mut jittered = vec![0.0];
    for i in 1..SAMPLES {
        let jitter = 0.2 * ((i as f64 * 12.9898).sin() * 43758.5453).fract();
        jittered.push(jittered[i - 1] + (1.0 + jitter) / RATE_HZ);
    }
    let mut group = c.benchmark_group("differentiator_1h_at_100hz");
    group.throughput(Throughput::Elements(SAMPLES as u64));
    group.sample_size(10);
    for (name, t) in [("even", &even), ("jittered", &jittered)] {
        let y = signal(t);
        let d = Differentiator::for_window(t, WINDOW_S);
        group.bench_function(name, |b| {
            b.iter(|| black_box(d.derivative(t, black_box(&y))))
        });
    }
    group.finish();
}

criterion_group!(benches, differentiator);
criterion_main!(benches);
