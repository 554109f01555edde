//! Paper 001 Tab. 6 and Fig. 9–12 on the HSVA KVLCC2 tests (see `shipid::paper001`).
//!
//! Built by `cargo test --release --workspace --no-run`; then
//! `target/release/examples/hsva_gp [DATASET.toml] [OUT_DIR] [D_GEN]`
//! (defaults: data/kvlcc2-hsva/imported/dataset.toml, results/hsva-gp, the fit's default d_gen).

use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let dataset = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "data/kvlcc2-hsva/imported/dataset.toml".into()),
    );
    let out = PathBuf::from(args.next().unwrap_or_else(|| "results/hsva-gp".into()));
    let similarity = match args.next() {
        Some(s) => s.parse::<f64>()?,
        None => shipid::fit_gp::DEFAULT_SIMILARITY,
    };
    let md = shipid::paper001::run(&dataset, &out, similarity)?;
    print!("{md}");
    eprintln!("wrote {0}/tab6.md and {0}/hsva_25_5.svg", out.display());
    Ok(())
}
