# Mirrors the README's commands; `just` is optional, plain cargo works everywhere.

# The main job on the embedded default data.
main:
    cargo run --release -p shipid -- metrics data/kvlcc2-mmg/dataset.toml

# The test suite (what CI runs).
test:
    cargo test --release --workspace

lint:
    cargo fmt --all -- --check
    cargo clippy --workspace --all-targets -- -D warnings

bench:
    cargo bench -p shipid-sim --bench mmg

generate:
    cargo run --release -p shipid -- generate

import-hsva:
    cargo run --release -p shipid -- import data/kvlcc2-hsva/import.toml --out data/kvlcc2-hsva/imported
