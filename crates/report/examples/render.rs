//! `cargo run -p shipid-report --example render -- study|diagnosis DIR`: write DIR/report.html.
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (kind, dir) = match args.as_slice() {
        [_, k, d] => (k.as_str(), Path::new(d)),
        _ => {
            eprintln!("usage: render study|diagnosis DIR");
            std::process::exit(2);
        }
    };
    let meta = shipid_report::RunMeta {
        tool_version: Some(env!("CARGO_PKG_VERSION").into()),
        ..Default::default()
    };
    let html = match kind {
        "study" => shipid_report::study_page(dir, &meta),
        _ => shipid_report::diagnosis_page(&shipid_report::DiagnosisFiles::in_dir(dir), &meta),
    };
    match html.and_then(|h| shipid_report::write_report(dir, &h)) {
        Ok(p) => println!("{}", p.display()),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
