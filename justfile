# Mirrors the README's commands; `just` is optional, plain cargo works everywhere.

# The main job on the embedded default data: the overshoot-truncation study (tables, figures, HTML report).
main:
    cargo run --release -p shipid -- run studies/truncation.toml

# The test suite (what CI runs).
test:
    cargo test --release --workspace

# The stored-metrics regression check of the studies (what CI runs after the tests).
check:
    for study in truncation estimators gp; do cargo run --release -p shipid -- check studies/$study.toml --reference results/reference/$study; done

# Every crate's file import edges; fails on a circle.
circles:
    cargo xtask circles

lint:
    cargo fmt --all -- --check
    cargo clippy --workspace --all-targets --release -- -D warnings

bench:
    cargo bench -p shipid-sim --bench mmg

generate:
    cargo run --release -p shipid -- generate

import-hsva:
    cargo run --release -p shipid -- import data/kvlcc2-hsva/import.toml --out data/kvlcc2-hsva/imported

# The concealed-effect benchmark of `shipid diagnose` against paper 001's sparse GP as base (about 3 min on
# 2 cores) → results/diagnose/.
bench-diagnose:
    cargo xtask bench-diagnose --out results/diagnose

# The same benchmark against refined full74 LSQ (1.5 min) and the exact MMG model (1.2 min).
bench-diagnose-full74:
    cargo xtask bench-diagnose --base full74 --out results/diagnose/full74-base

bench-diagnose-reference:
    cargo xtask bench-diagnose --base mmg:kvlcc2 --out results/diagnose/reference-base

# Diagnose the HSVA tests against full68 LSQ identified from the default data.
diagnose-hsva: import-hsva
    cargo run --release -p shipid -- fit data/kvlcc2-mmg/dataset.toml --set full68 --estimator lsq --out results/kvlcc2-mmg-full68-lsq-all.toml
    cargo run --release -p shipid -- diagnose results/kvlcc2-mmg-full68-lsq-all.toml data/kvlcc2-hsva/imported/dataset.toml --json results/diagnose/hsva/report.json --plots results/diagnose-hsva/figures
