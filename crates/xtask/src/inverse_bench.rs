//! `cargo xtask inverse-bench`: wall time of building paper 003's simulation database (4 manoeuvres
//! per ship) for the first target of a targets file.

use std::path::Path;

use anyhow::Result;
use shipid::inverse_cmd::{build, load};
use shipid_inverse::indexes::SimSettings;

/// Times the database build `repeats` times and prints a markdown table row per run.
pub fn bench(
    targets: &Path,
    ships: &Path,
    samples: usize,
    repeats: usize,
    seed: u64,
) -> Result<()> {
    shipid_estimators::faer::set_global_parallelism(shipid_estimators::faer::Par::Seq);
    let (modes, targets) = load(Some(ships), targets).map_err(|e| anyhow::anyhow!("{e}"))?;
    let target = &targets[0];
    let n_modes = modes.modes_for(0.95);
    let settings = SimSettings::default();
    let threads = rayon::current_num_threads();
    println!(
        "| target | ships | manoeuvres | threads | usable | dropped | wall time [s] | ms per ship | CPU time [s] | load average before |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    for _ in 0..repeats.max(1) {
        // Other processes share the cores; the 1-minute load average says how much.
        let load = std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|t| t.split_whitespace().next().map(str::to_string))
            .unwrap_or_else(|| "n/a".into());
        let cpu0 = process_cpu_s();
        let (db, secs) = build(target, &modes, n_modes, samples, seed, &settings)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let cpu = match (cpu0, process_cpu_s()) {
            (Some(a), Some(b)) => format!("{:.1}", b - a),
            _ => "n/a".into(),
        };
        println!(
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {cpu} | {load} |",
            target.name,
            samples,
            4 * samples,
            threads,
            db.samples.len(),
            db.dropped.len(),
            secs,
            1e3 * secs / samples as f64
        );
    }
    Ok(())
}

/// User + system CPU time of this process [s] from /proc/self/stat (Linux; clock ticks of 1/100 s, the
/// kernel's USER_HZ), or `None` elsewhere. Less sensitive than wall time to other jobs on the cores.
fn process_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = after.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}
