//! Property tests of the CSV and TOML readers: any input gives a recording or an error, never a panic,
//! and what the writer writes the reader reads back.

use std::path::Path;

use proptest::prelude::*;
use shipid_io::Recording;
use shipid_io::dataset::parse_dataset;
use shipid_io::recording::parse_recording;
use shipid_io::write::recording_csv;

const GOOD_TOML: &str = include_str!("../fixtures/good/cg_sname.toml");
const GOOD_CSV: &str = include_str!("../fixtures/good/units_wrapped_heading.csv");

fn mutate(base: &str, at: usize, cut: usize, insert: &str) -> String {
    let mut s: Vec<char> = base.chars().collect();
    let at = at % (s.len() + 1);
    let end = (at + cut).min(s.len());
    s.splice(at..end, insert.chars());
    s.into_iter().collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn csv_reader_never_panics_on_arbitrary_text(text in ".{0,400}") {
        let _ = parse_recording(Path::new("fuzz.csv"), &text);
    }

    #[test]
    fn csv_reader_never_panics_on_mutated_recordings(at in 0usize..2000, cut in 0usize..40,
            insert in "[0-9a-z,.#\\[\\]\\n -]{0,12}") {
        let text = mutate(GOOD_CSV, at, cut, &insert);
        let _ = parse_recording(Path::new("fuzz.csv"), &text);
    }

    #[test]
    fn toml_reader_never_panics_on_mutated_data_sets(at in 0usize..2000, cut in 0usize..40,
            insert in "[0-9a-z=\\[\\]\"\\n .-]{0,12}") {
        let text = mutate(GOOD_TOML, at, cut, &insert);
        if let Err(e) = parse_dataset(Path::new("fuzz.toml"), &text) {
            prop_assert!(e.to_string().starts_with("fuzz.toml"), "error must name the file: {e}");
        }
    }

    #[test]
    fn written_recordings_read_back(n in 20usize..60, seed in 0u64..1000) {
        let f = |i: usize, k: u64| ((i as f64 + 1.0) * (seed + k) as f64 * 0.37).sin() * 3.0;
        let rec = Recording {
            t: (0..n).map(|i| i as f64 * 0.1 + seed as f64).collect(),
            x0: (0..n).map(|i| f(i, 1) * 100.0).collect(),
            y0: (0..n).map(|i| f(i, 2)).collect(),
            psi: (0..n).map(|i| i as f64 * 0.01).collect(),
            u: (0..n).map(|i| f(i, 3)).collect(),
            v: (0..n).map(|i| f(i, 4) * 1e-3).collect(),
            r: (0..n).map(|i| f(i, 5) * 1e-2).collect(),
            delta: (0..n).map(|i| f(i, 6) * 0.5).collect(),
            n: None,
            thrust: Some((0..n).map(|i| f(i, 7) * 40.0).collect()),
            accelerations: None,
            wind: None,
            current: None,
        };
        let back = parse_recording(Path::new("rt.csv"), &recording_csv(&rec, &["round trip".into()])).unwrap();
        let cols = |r: &Recording| [r.t.clone(), r.x0.clone(), r.y0.clone(), r.psi.clone(), r.u.clone(), r.v.clone(), r.r.clone(), r.delta.clone(), r.thrust.clone().unwrap_or_default()];
        for (a, b) in cols(&rec).iter().zip(cols(&back).iter()) {
            for (x, y) in a.iter().zip(b) {
                prop_assert!((x - y).abs() <= 1e-8 * x.abs().max(1e-30));
            }
        }
    }
}
