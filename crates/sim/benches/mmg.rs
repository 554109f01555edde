//! RK4 steps per second of the MMG KVLCC2 model on one core: 10,000 steps (500 s at dt = 0.05 s) of a
//! 35° turning circle, recording every step. Criterion reports the rate as elements (steps) per second;
//! the floor is 300,000 steps/s.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use shipid_io::Side;
use shipid_sim::{Dynamics, MmgModel, SimOptions, State, Turning, simulate};

const STEPS: u64 = 10_000;

fn turning_circle(c: &mut Criterion) {
    let model = MmgModel::kvlcc2();
    let u0 = model.ship().u0;
    let opts = SimOptions::new(STEPS as f64 * 0.05);
    let mut group = c.benchmark_group("mmg_kvlcc2");
    group.throughput(Throughput::Elements(STEPS));
    group.bench_function("rk4_turning_circle_10k_steps", |b| {
        b.iter(|| {
            let mut ctrl = Turning::new(35.0, Side::Starboard, 1.0).unwrap();
            let out = simulate(&model, &mut ctrl, black_box(State::approach(u0)), &opts).unwrap();
            black_box(out.recording.len())
        })
    });
    group.throughput(Throughput::Elements(1));
    let state = State {
        u: 0.8,
        v: -0.1,
        r: 0.02,
        ..State::default()
    };
    group.bench_function("accelerations", |b| {
        b.iter(|| {
            model
                .accelerations(black_box(&state), black_box(0.6))
                .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, turning_circle);
criterion_main!(benches);
