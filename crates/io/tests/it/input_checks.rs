//! Issue 25's input checks of the I/O layer: values checked after unit conversion, time gaps, separator
//! and decimal-comma hints, a byte-order mark, oversized files, a recording listed twice, and the
//! safety of writing a data set (names that leave the output folder, collisions, symbolic links, a
//! failure half-way). Each concern has one `check…` helper and a table of cases.

use std::path::{Path, PathBuf};

use shipid_io::dataset::parse_dataset;
use shipid_io::recording::{MAX_FILE_BYTES, parse_recording, read_recording};
use shipid_io::write::{WriteError, check_output_name, write_dataset};
use shipid_io::{Dataset, DatasetFile, Recording};

const HEADER: &str = "t,x0,y0,psi,u,v,r,delta";

/// 30 samples at 0.1 s of a ship going straight at 1 m/s, one row per line after `header`; `edit`
/// changes row i (0-based) before it is written.
fn recording_text(header: &str, edit: impl Fn(usize, &mut Vec<String>)) -> String {
    let mut text = format!("{header}\n");
    for i in 0..30 {
        let t = i as f64 * 0.1;
        let mut row: Vec<String> = [t, t, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
            .iter()
            .map(|v| format!("{v:.1}"))
            .collect();
        edit(i, &mut row);
        text.push_str(&row.join(","));
        text.push('\n');
    }
    text
}

/// The message for recording text, which must be refused.
fn check_refused(text: &str, expected: &str) {
    match parse_recording(Path::new("rec.csv"), text) {
        Ok(_) => panic!("accepted, expected {expected}:\n{text}"),
        Err(e) => assert_eq!(e.to_string(), expected),
    }
}

#[test]
fn values_are_checked_after_unit_conversion() {
    let cases = [
        (
            "t[min],x0,y0,psi,u,v,r,delta",
            29,
            0,
            "1e307",
            "rec.csv:31:1: column `t[min]`: the value is not finite after conversion to s (too large for its unit)",
        ),
        (
            HEADER,
            3,
            3,
            "1e308",
            "rec.csv:5:4: column `psi`: 1e308 rad (after unit conversion) is beyond the bound ±1e5 rad of `psi` in docs/data-format.md: a wrong unit or a corrupt value",
        ),
        (
            HEADER,
            4,
            7,
            "35",
            "rec.csv:6:8: column `delta`: 35 rad (after unit conversion) is beyond the bound ±π rad (180°) of `delta` in docs/data-format.md: a wrong unit or a corrupt value; a rudder angle in degrees needs the header `delta[deg]`",
        ),
        (
            "t,x0,y0,psi,u[kn],v,r,delta",
            2,
            4,
            "5000",
            "rec.csv:4:5: column `u[kn]`: 2572.2222222222226 m/s (after unit conversion) is beyond the bound ±1000 m/s of `u` in docs/data-format.md: a wrong unit or a corrupt value",
        ),
        (
            HEADER,
            7,
            6,
            "-1e150",
            "rec.csv:9:7: column `r`: -1e150 rad/s (after unit conversion) is beyond the bound ±100 rad/s of `r` in docs/data-format.md: a wrong unit or a corrupt value",
        ),
    ];
    for (header, row, col, value, expected) in cases {
        let text = recording_text(header, |i, r| {
            if i == row {
                r[col] = value.into();
            }
        });
        check_refused(&text, expected);
    }
}

#[test]
fn the_first_fault_in_file_order_is_reported() {
    // Two out-of-bound values: the earlier line wins, whatever the column order of the checks.
    let text = recording_text(HEADER, |i, r| match i {
        9 => r[6] = "1e9".into(),
        4 => r[5] = "1e9".into(),
        _ => {}
    });
    check_refused(
        &text,
        "rec.csv:6:6: column `v`: 1000000000 m/s (after unit conversion) is beyond the bound ±1000 m/s of `v` in docs/data-format.md: a wrong unit or a corrupt value",
    );
}

#[test]
fn time_gaps_repeats_and_reversals_are_refused_with_their_lines() {
    let shift = |from: usize, by: f64| {
        recording_text(HEADER, move |i, r| {
            if i >= from {
                r[0] = format!("{:.1}", i as f64 * 0.1 + by);
            }
        })
    };
    check_refused(
        &shift(12, 5.0),
        "rec.csv:14:1: column `t`: gap in time: 6.2 s after 1.1 s (line 13), a step of 5.1 s, more than 10 × the median step 0.1 s",
    );
    check_refused(
        &shift(12, -0.1),
        "rec.csv:14:1: column `t`: time is not strictly increasing (1.1 s after 1.1 s)",
    );
    check_refused(
        &recording_text(HEADER, |i, r| r[0] = format!("{}", i as f64 * 1e-9)),
        "rec.csv:3:1: column `t`: a time step of 1e-9 s after 0 s is shorter than 0.000001 s: no ship recording samples that fast (a wrong unit?), and derivatives over it would overflow",
    );
    // Uneven sampling within ten median steps is allowed.
    assert!(parse_recording(Path::new("rec.csv"), &shift(12, 0.8)).is_ok());
}

#[test]
fn separators_and_decimal_commas_get_a_hint() {
    let semicolons = recording_text(HEADER, |_, _| {}).replace(',', ";");
    check_refused(
        &semicolons,
        "rec.csv:1: the header `t;x0;y0;psi;u;v;r;delta` looks like ';'-separated; shipid reads comma-separated recordings with `.` as the decimal mark (convert the file, or import it with a mapping with `delimiter = \";\"`)",
    );
    check_refused(
        &semicolons.replace('.', ","),
        "rec.csv:1: the header `t;x0;y0;psi;u;v;r;delta` looks like ';'-separated with decimal commas; shipid reads comma-separated recordings with `.` as the decimal mark (convert the file, or import it with a mapping with `delimiter = \";\"`)",
    );
    check_refused(
        &recording_text(HEADER, |_, _| {}).replace(',', "\t"),
        "rec.csv:1: the header `t\tx0\ty0\tpsi\tu\tv\tr\tdelta` looks like tab-separated; shipid reads comma-separated recordings with `.` as the decimal mark (convert the file, or import it with a mapping with `delimiter = \"\\t\"`)",
    );
    check_refused(
        &recording_text(HEADER, |i, r| {
            if i == 2 {
                r[4] = "1,5".into();
            }
        }),
        "rec.csv:4: expected 8 fields as in the header, found 9 (decimal commas? shipid reads `.` as the decimal mark)",
    );
    check_refused(
        &recording_text(HEADER, |i, r| {
            if i == 2 {
                r[4] = "\"1,5\"".into();
            }
        }),
        "rec.csv:4:5: column `u`: not a number: `1,5` (a decimal comma? write `1.5`)",
    );
}

#[test]
fn a_byte_order_mark_before_comments_and_crlf_are_read() {
    let plain = parse_recording(Path::new("rec.csv"), &recording_text(HEADER, |_, _| {})).unwrap();
    let variants = [
        format!(
            "\u{feff}# exported\n# by a spreadsheet\n{}",
            recording_text(HEADER, |_, _| {})
        ),
        format!("\u{feff}{}", recording_text(HEADER, |_, _| {})),
        recording_text(HEADER, |_, _| {}).replace('\n', "\r\n"),
    ];
    for text in variants {
        let got: Recording = parse_recording(Path::new("rec.csv"), &text)
            .unwrap_or_else(|e| panic!("{e}\n{text:?}"));
        assert_eq!(got, plain);
    }
}

/// A fresh directory under the system's temporary folder, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("shipid-io-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn files_beyond_the_size_limit_are_refused_before_reading() {
    let dir = TempDir::new("huge");
    let path = dir.0.join("huge.csv");
    // A sparse file: its length is over the limit without using the disk space.
    let f = std::fs::File::create(&path).unwrap();
    f.set_len(MAX_FILE_BYTES + 1).unwrap();
    let e = read_recording(&path).unwrap_err().to_string();
    assert!(
        e.ends_with(
            "huge.csv: 1.0 GiB is larger than the 1 GiB shipid reads (split the recording)"
        ),
        "{e}"
    );
}

#[test]
fn non_utf8_bytes_are_named_with_their_line() {
    let dir = TempDir::new("latin1");
    let path = dir.0.join("rec.csv");
    let mut bytes = recording_text(HEADER, |_, _| {}).into_bytes();
    let at = bytes.iter().position(|&b| b == b'\n').unwrap() + 3;
    bytes[at] = 0xb0; // the Latin-1 degree sign
    std::fs::write(&path, bytes).unwrap();
    let e = read_recording(&path).unwrap_err().to_string();
    assert!(
        e.ends_with(&format!(
            "rec.csv:2: not UTF-8 text (byte {at}, value 0xb0); save the file as UTF-8, or import it with a mapping that names its encoding"
        )),
        "{e}"
    );
}

const SHIP: &str = "name = \"d\"\n[ship]\nlpp = 7.0\nbeam = 1.27\ndraft = 0.46\ndisplacement = 3.27\nrho = 1000.0\nxg = 0.25\nkzz = 1.75\nu0 = 1.179\nrudder_rate = 15.8\n";

fn check_dataset_refused(text: &str, expected: &str) {
    match parse_dataset(Path::new("ds.toml"), text) {
        Ok(_) => panic!("accepted, expected {expected}:\n{text}"),
        Err(e) => assert_eq!(e.to_string(), expected),
    }
}

#[test]
fn ship_keys_outside_physical_ranges_are_refused() {
    let cases = [
        (
            "u0 = 1.179",
            "u0 = 1e-300",
            "ds.toml: key `ship.u0`: 1e-300 m/s is outside the physical range 0.001 … 1000 m/s (a wrong unit?)",
        ),
        (
            "rho = 1000.0",
            "rho = 1.025",
            "ds.toml: key `ship.rho`: 1.025 kg/m³ is outside the physical range 500 … 2000 kg/m³ (a wrong unit?)",
        ),
        (
            "lpp = 7.0",
            "lpp = 7000000.0",
            "ds.toml: key `ship.lpp`: 7000000 m is outside the physical range 0.01 … 10000 m (a wrong unit?)",
        ),
        (
            "displacement = 3.27",
            "displacement = 1e300",
            "ds.toml: key `ship.displacement`: 1e300 m³ is outside the physical range 1e-9 … 10000000000 m³ (a wrong unit?)",
        ),
    ];
    for (from, to, expected) in cases {
        check_dataset_refused(&SHIP.replace(from, to), expected);
    }
}

/// Regression: each key within its range made an impossible ship that was fitted silently (a
/// displacement given as the mass in tonnes: block coefficient 800, Y_v −15.6 instead of −0.026).
#[test]
fn impossible_ship_proportions_are_refused_naming_the_key() {
    let cases = [
        (
            "displacement = 3.27",
            "displacement = 3270.0",
            "ds.toml: key `ship.displacement`: gives a block coefficient ∇/(L B T) of 800 (accepted",
        ),
        (
            "lpp = 7.0",
            "lpp = 7000.0",
            "ds.toml: key `ship.beam`: gives a length-beam ratio L/B of 5512 (accepted",
        ),
        (
            "kzz = 1.75",
            "kzz = 175.0",
            "ds.toml: key `ship.kzz`: gives a yaw radius of gyration k_zz/L of 25.0 (accepted",
        ),
    ];
    for (from, to, expected) in cases {
        match parse_dataset(Path::new("ds.toml"), &SHIP.replace(from, to)) {
            Ok(_) => panic!("{to} accepted"),
            Err(e) => assert!(e.to_string().starts_with(expected), "{e}"),
        }
    }
    let rudder = "[rudder]\narea_m2 = 539.0\nspan_m = 0.345\nx_m = -3.5\n";
    check_dataset_refused(
        &format!("{SHIP}{rudder}"),
        "ds.toml: key `rudder.area_m2`: 539 m² is 167 × L T (rudders have about 1/70 … 1/30 of it): a wrong unit?",
    );
    let added = "[added_mass]\nX_udot = 247.9\nY_vdot = -2513.0\nY_rdot = 0.0\nN_vdot = 0.0\nN_rdot = -6074.5\n";
    check_dataset_refused(
        &format!("{SHIP}{added}"),
        "ds.toml: key `added_mass.X_udot`: 247.9 kg is positive; it is a derivative, minus the added mass (write -247.9)",
    );
}

/// Regression: a hard link and a byte-for-byte copy of one recording under two names were both
/// read, the run counted twice (9602 samples with no note, the uncertainty understated); so was a
/// copy with its clock shifted.
#[test]
fn a_hard_link_or_a_copy_of_a_recording_is_refused() {
    let dir = TempDir::new("twice");
    let text = recording_text(HEADER, |_, _| {});
    std::fs::write(dir.0.join("a.csv"), &text).unwrap();
    std::fs::hard_link(dir.0.join("a.csv"), dir.0.join("b.csv")).unwrap();
    std::fs::write(dir.0.join("c.csv"), &text).unwrap();
    // The same samples with the clock 1000 s later.
    let shifted = recording_text(HEADER, |i, row| {
        row[0] = format!("{:.1}", 1000.0 + i as f64 * 0.1)
    });
    std::fs::write(dir.0.join("d.csv"), shifted).unwrap();
    let entry = |f: &str| format!("[[recording]]\nfile = \"{f}\"\nkind = \"free\"\n");
    for (second, words) in [
        (
            "b.csv",
            "`b.csv` is the same file as recording[0].file `a.csv`",
        ),
        (
            "c.csv",
            "`c.csv` holds the same samples as recording[0].file `a.csv` (a copy)",
        ),
        (
            "d.csv",
            "`d.csv` holds the same samples as recording[0].file `a.csv` (a copy)",
        ),
    ] {
        let ds = dir.0.join(format!("ds-{second}.toml"));
        std::fs::write(&ds, format!("{SHIP}{}{}", entry("a.csv"), entry(second))).unwrap();
        let e = Dataset::load(&ds).unwrap_err().to_string();
        assert!(
            e.contains("key `recording[1].file`") && e.contains(words),
            "{e}"
        );
    }
}

#[test]
fn a_recording_listed_twice_is_refused_naming_both_entries() {
    let entry = |f: &str| format!("[[recording]]\nfile = \"{f}\"\nkind = \"free\"\n");
    let cases = [
        ("a.csv", "a.csv"),
        ("a.csv", "./a.csv"),
        ("sub/a.csv", "sub//a.csv"),
    ];
    for (first, second) in cases {
        check_dataset_refused(
            &format!("{SHIP}{}{}", entry(first), entry(second)),
            &format!(
                "ds.toml: key `recording[1].file`: `{second}` is the same file as recording[0].file `{first}`; list each recording once"
            ),
        );
    }
}

#[test]
fn one_file_under_two_names_is_found_when_loading() {
    let dir = TempDir::new("two-names");
    std::fs::create_dir_all(dir.0.join("sub")).unwrap();
    std::fs::write(dir.0.join("a.csv"), recording_text(HEADER, |_, _| {})).unwrap();
    let ds = dir.0.join("ds.toml");
    std::fs::write(
        &ds,
        format!(
            "{SHIP}[[recording]]\nfile = \"a.csv\"\nkind = \"free\"\n[[recording]]\nfile = \"sub/../a.csv\"\nkind = \"free\"\n"
        ),
    )
    .unwrap();
    let e = Dataset::load(&ds).unwrap_err().to_string();
    assert!(
        e.ends_with("ds.toml: key `recording[1].file`: `sub/../a.csv` is the same file as recording[0].file `a.csv`; list each recording once"),
        "{e}"
    );
}

#[test]
fn output_names_must_stay_inside_the_output_folder() {
    let cases = [
        ("a.csv", Ok(())),
        ("runs/a.csv", Ok(())),
        ("./a.csv", Ok(())),
        (
            "../victim.csv",
            Err("contains `..`; it must stay inside the output folder"),
        ),
        (
            "runs/../../victim.csv",
            Err("contains `..`; it must stay inside the output folder"),
        ),
        (
            "/tmp/victim.csv",
            Err("is absolute; it must be relative to the output folder"),
        ),
        (
            "..\\victim.csv",
            Err("contains `\\`; use `/` between folders"),
        ),
        ("", Err("is empty")),
        ("runs/", Err("names a folder, not a file")),
        ("DATASET.TOML", Err("is the data set file itself")),
    ];
    for (name, expected) in cases {
        assert_eq!(check_output_name(name), expected, "{name:?}");
    }
}

fn one_recording_dataset(files: &[&str]) -> (DatasetFile, Recording) {
    let rec = parse_recording(Path::new("rec.csv"), &recording_text(HEADER, |_, _| {})).unwrap();
    let mut text = SHIP.to_string();
    for f in files {
        text.push_str(&format!("[[recording]]\nfile = \"{f}\"\nkind = \"free\"\n"));
    }
    (parse_dataset(Path::new("ds.toml"), &text).unwrap(), rec)
}

#[test]
fn write_dataset_refuses_escapes_and_collisions_and_names_paths() {
    let dir = TempDir::new("write");
    let out = dir.0.join("out");
    let victim = dir.0.join("victim.csv");
    std::fs::write(&victim, "keep\n").unwrap();

    let (file, rec) = one_recording_dataset(&["a.csv"]);
    let mut escaping = file.clone();
    escaping.recordings[0].file = "../victim.csv".into();
    let e = write_dataset(&out, &escaping, &[&rec], &[]).unwrap_err();
    assert!(e.is_bad_input());
    assert_eq!(
        e.to_string(),
        "output file name `../victim.csv`: contains `..`; it must stay inside the output folder"
    );

    let (two, _) = one_recording_dataset(&["Run.csv", "x.csv"]);
    let mut two = two;
    two.recordings[1].file = "run.csv".into();
    let e = write_dataset(&out, &two, &[&rec, &rec], &[]).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "output files `Run.csv` and `run.csv` are the same file in {}",
            out.display()
        )
    );

    // A folder inside `out` that is a symbolic link to the outside.
    std::fs::create_dir_all(&out).unwrap();
    std::os::unix::fs::symlink(&dir.0, out.join("link")).unwrap();
    let mut linked = file.clone();
    linked.recordings[0].file = "link/victim.csv".into();
    let e = write_dataset(&out, &linked, &[&rec], &[]).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "{} leads outside the output folder {} (through a symbolic link)",
            out.join("link/victim.csv").display(),
            out.display()
        )
    );

    // An output file that is a symbolic link to the victim: replaced, the victim untouched.
    std::os::unix::fs::symlink(&victim, out.join("a.csv")).unwrap();
    write_dataset(&out, &file, &[&rec], &[]).unwrap();
    assert!(!out.join("a.csv").is_symlink());
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep\n");

    // `out` is a file.
    let e = write_dataset(&victim, &file, &[&rec], &[]).unwrap_err();
    assert!(matches!(e, WriteError::NotADirectory { .. }));
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep\n");
}

#[test]
fn a_write_failing_half_way_leaves_no_dataset_toml() {
    let dir = TempDir::new("half-way");
    let out = dir.0.join("out");
    let (file, rec) = one_recording_dataset(&["a.csv", "sub/b.csv"]);
    // Two runs, not one copied: the loader refuses a copy counted twice.
    let mut other = rec.clone();
    other.delta.iter_mut().for_each(|d| *d += 0.01);
    write_dataset(&out, &file, &[&rec, &other], &[]).unwrap();
    assert!(Dataset::load(&out.join("dataset.toml")).is_ok());
    // Rewrite with the second recording's folder replaced by a file: the old dataset.toml must not
    // survive beside a half-written set.
    std::fs::remove_dir_all(out.join("sub")).unwrap();
    std::fs::write(out.join("sub"), "not a folder\n").unwrap();
    let e = write_dataset(&out, &file, &[&rec, &rec], &[]).unwrap_err();
    assert!(!e.is_bad_input());
    assert!(
        e.to_string()
            .starts_with(&format!("cannot write {}: ", out.join("sub").display())),
        "{e}"
    );
    assert!(!out.join("dataset.toml").exists());
}

#[test]
fn an_import_copies_the_open_water_table_beside_the_data_set() {
    let dir = TempDir::new("import-open-water");
    std::fs::create_dir_all(dir.0.join("raw/tables")).unwrap();
    std::fs::write(
        dir.0.join("raw/a.dat"),
        recording_text(HEADER, |_, _| {}).replace(',', " "),
    )
    .unwrap();
    std::fs::write(
        dir.0.join("raw/tables/ow.csv"),
        "J,Kt,10Kq\n0,0.3,0.4\n0.2,0.25,0.35\n0.4,0.18,0.3\n0.6,0.1,0.2\n",
    )
    .unwrap();
    let columns = header_columns();
    let ship = SHIP.replace("name = \"d\"\n[ship]", "[dataset.ship]");
    let mapping = format!(
        "source_dir = \"raw\"\n[format]\ndelimiter = \"whitespace\"\nskip_lines = 1\n{columns}[dataset]\nname = \"i\"\n{ship}[dataset.propeller]\ndiameter_m = 0.2\nx_m = -3.3\nopen_water = \"tables/ow.csv\"\nrate_rps = 10.0\n[dataset.rudder]\narea_m2 = 0.05\nspan_m = 0.3\nx_m = -3.5\n[[recording]]\nsource = \"a.dat\"\nfile = \"a.csv\"\nkind = \"free\"\n"
    );
    let mapping_path = dir.0.join("mapping.toml");
    std::fs::write(&mapping_path, &mapping).unwrap();
    let imported = shipid_io::import::import(&mapping_path, None).unwrap();
    let out = dir.0.join("out");
    let recs: Vec<&Recording> = imported.recordings.iter().collect();
    shipid_io::write::write_dataset_with(
        &out,
        &imported.dataset,
        &recs,
        &[],
        &imported.files,
        &imported.inputs,
    )
    .unwrap();
    let ds = Dataset::load(&out.join("dataset.toml")).unwrap();
    let p = ds.propeller.unwrap();
    assert_eq!(p.open_water.unwrap().file, "ow.csv");
    assert_eq!(ds.rudder.map(|r| r.area_m2), Some(0.05));

    // The copy must not take a recording's name.
    std::fs::write(
        &mapping_path,
        mapping.replace("file = \"a.csv\"", "file = \"OW.csv\""),
    )
    .unwrap();
    let e = shipid_io::import::import(&mapping_path, None)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.ends_with("mapping.toml: key `dataset.propeller.open_water`: `tables/ow.csv` would be copied to `ow.csv` in the output folder, the file of recording[0]; rename it"),
        "{e}"
    );
}

#[test]
fn added_masses_must_be_finite_and_of_a_ship_s_order() {
    let table = "[added_mass]\nX_udot = -247.9\nY_vdot = -2513.0\nY_rdot = 0.0\nN_vdot = 0.0\nN_rdot = -6074.5\n";
    let cases = [
        (
            "X_udot = -247.9",
            "X_udot = nan",
            "ds.toml: key `added_mass.X_udot`: NaN kg is not a finite added mass within 100 × the ship's (±327000 kg for this ship)",
        ),
        (
            "N_rdot = -6074.5",
            "N_rdot = -6.07e13",
            "ds.toml: key `added_mass.N_rdot`: -60700000000000 kg m² is not a finite added mass within 100 × the ship's (±16023000 kg m² for this ship)",
        ),
    ];
    assert!(parse_dataset(Path::new("ds.toml"), &format!("{SHIP}{table}")).is_ok());
    for (from, to, expected) in cases {
        check_dataset_refused(&format!("{SHIP}{}", table.replace(from, to)), expected);
    }
}

#[test]
fn a_reference_point_is_on_the_hull_and_only_with_origin_point() {
    let with = |origin: &str, point: &str| {
        SHIP.replacen(
            "name = \"d\"\n",
            &format!("name = \"d\"\norigin = \"{origin}\"\n{point}"),
            1,
        )
    };
    let point = |x: &str, y: &str| format!("[reference_point]\nx_m = {x}\ny_m = {y}\n");
    let cases = [
        (
            with("point", ""),
            "ds.toml: key `reference_point`: origin = \"point\" needs a [reference_point] table with x_m (forward of midship) and y_m (to starboard) [m]",
        ),
        (
            with("midship", &point("-3.0", "0.2")),
            "ds.toml: key `reference_point`: only with origin = \"point\" (this data set says origin = \"midship\")",
        ),
        (
            with("point", &point("-30.0", "0.2")),
            "ds.toml: key `reference_point.x_m`: must be a finite distance from midship within ship.lpp = 7 m (a point on the hull), not -30",
        ),
        (
            with("point", &point("-3.0", "nan")),
            "ds.toml: key `reference_point.y_m`: must be a finite distance from midship within ship.beam = 1.27 m (a point on the hull), not NaN",
        ),
    ];
    for (text, expected) in cases {
        check_dataset_refused(&text, expected);
    }
    assert!(parse_dataset(Path::new("ds.toml"), &with("point", &point("-3.0", "0.2"))).is_ok());
}

/// Regression: a misspelt optional column (`windspeed`, `wind_dir`) or a capitalised one was ignored
/// like any unknown column, and the recorded wind silently read as calm. Near misses of a known name
/// are refused with the name to write; the source's own extra columns are still ignored.
#[test]
fn a_misspelt_column_is_refused_with_the_name_to_write() {
    let header = |extra: &str| format!("{HEADER},{extra}");
    let with_extra = |extra: &str| recording_text(&header(extra), |_, row| row.push("1.0".into()));
    for (extra, words) in [
        ("windspeed", "did you mean `wind_speed`?"),
        ("wind_spd", "did you mean `wind_speed`?"),
        (
            "wind_dir[deg]",
            "did you mean `wind_from` (the direction it comes FROM",
        ),
        ("current_direction", "did you mean `current_from`"),
        ("wind_rel_speed", "did you mean `relative_wind_speed`?"),
        ("Thrust", "names are lower-case, write `thrust`"),
    ] {
        let e = parse_recording(Path::new("rec.csv"), &with_extra(extra)).unwrap_err();
        assert!(
            e.to_string()
                .starts_with(&format!("rec.csv:1:9: column `{extra}`: "))
                && e.to_string().contains(words),
            "{extra}: {e}"
        );
    }
    for extra in ["roll[deg]", "torque", "wind_gust", "heave", "delta_cmd"] {
        assert!(
            parse_recording(Path::new("rec.csv"), &with_extra(extra)).is_ok(),
            "{extra} refused"
        );
    }
}

/// Regression: a write whose rename failed (the target an existing folder) left its `*.tmp` file
/// beside it.
#[test]
fn a_failed_atomic_write_leaves_no_temporary_file() {
    let dir = TempDir::new("atomic");
    let target = dir.0.join("model.toml");
    std::fs::create_dir_all(&target).unwrap();
    assert!(shipid_io::write::write_atomic(&target, b"x = 1\n").is_err());
    let left: Vec<_> = std::fs::read_dir(&dir.0)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, ["model.toml"], "{left:?}");
}

/// The `[[column]]` entries of an import mapping for `HEADER`'s columns, in order.
fn header_columns() -> String {
    HEADER
        .split(',')
        .enumerate()
        .map(|(i, q)| format!("[[column]]\nindex = {}\nquantity = \"{q}\"\n", i + 1))
        .collect()
}

/// A minimal whitespace mapping of `HEADER`'s columns (plus `extra` column entries) over `raw/a.dat`.
fn whitespace_mapping(dir: &Path, extra: &str) -> PathBuf {
    let columns = header_columns();
    let ship = SHIP.replace("name = \"d\"\n[ship]", "[dataset.ship]");
    let mapping = format!(
        "source_dir = \"raw\"\n[format]\ndelimiter = \"whitespace\"\nskip_lines = 1\n{columns}{extra}[dataset]\nname = \"i\"\n{ship}[[recording]]\nsource = \"a.dat\"\nfile = \"a.csv\"\nkind = \"free\"\n"
    );
    let path = dir.join("mapping.toml");
    std::fs::write(&path, mapping).unwrap();
    path
}

/// Regression: a blank field in a whitespace-separated source shifted every later field into the
/// wrong quantity (the propeller rate read from the roll column), and one source column could be
/// mapped to two quantities (the rudder copied into `n`); both imported with exit 0.
#[test]
fn an_import_refuses_a_short_row_and_a_column_mapped_twice() {
    let dir = TempDir::new("import-shift");
    std::fs::create_dir_all(dir.0.join("raw")).unwrap();
    let text = recording_text(&format!("{HEADER},roll"), |i, row| {
        row.push("0.5".into());
        if i == 7 {
            row[7] = String::new(); // a blank rudder cell
        }
    })
    .replace(',', " ");
    std::fs::write(dir.0.join("raw/a.dat"), text).unwrap();
    let mapping = whitespace_mapping(&dir.0, "");
    let e = match shipid_io::import::import(&mapping, None) {
        Ok(_) => panic!("a short row was imported"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains(":9: 8 fields where line 2 has 9: a missing value"),
        "{e}"
    );
    let twice = whitespace_mapping(&dir.0, "[[column]]\nindex = 8\nquantity = \"n\"\n");
    let e = shipid_io::import::read_mapping(&twice)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("key `column[8].index`: source column 8 is already mapped to delta (column[7])"),
        "{e}"
    );
}

/// Regression: times of 2.9e7 s (seconds since a year began) sampled at 0.1 s were written with nine
/// significant digits, as repeated times, and the imported data set could not be read back.
#[test]
fn large_times_and_positions_are_written_exactly() {
    let mut rec =
        parse_recording(Path::new("rec.csv"), &recording_text(HEADER, |_, _| {})).unwrap();
    rec.t.iter_mut().for_each(|t| *t += 2.9e7 + 0.05);
    rec.x0.iter_mut().for_each(|x| *x += 5.8e6);
    let text = shipid_io::write::recording_csv(&rec, &[]);
    let back = parse_recording(Path::new("rec.csv"), &text).unwrap();
    assert_eq!(back.t, rec.t);
    assert_eq!(back.x0, rec.x0);
}

/// Regression: a recording cut from another, every second sample of it, its samples rounded to
/// 8 digits or its track turned by a heading offset was read as a recording of its own, and the
/// fit counted the run twice without a word.
#[test]
fn a_cut_thinned_rewritten_or_turned_copy_of_a_recording_is_refused() {
    let dir = TempDir::new("near-copies");
    // 200 samples of a zig-zag-like yaw (the copy test needs a recording that yaws), heading and
    // track integrated from the velocities so that the channels agree.
    let rows: Vec<[f64; 8]> = {
        let (mut psi, mut x0, mut y0) = (0.0_f64, 0.0_f64, 0.0_f64);
        (0..200)
            .map(|i| {
                let t = i as f64 * 0.1;
                let r = 0.02 * (0.3 * t).sin();
                let (u, v) = (1.0, -0.5 * r);
                if i > 0 {
                    psi += r * 0.1;
                    let (s, c) = psi.sin_cos();
                    x0 += (u * c - v * s) * 0.1;
                    y0 += (u * s + v * c) * 0.1;
                }
                [t, x0, y0, psi, u, v, r, 0.1 * (0.3 * t).sin()]
            })
            .collect()
    };
    let row = |i: usize| rows[i];
    let write =
        |name: &str, rows: &mut dyn Iterator<Item = [f64; 8]>, fmt: &dyn Fn(f64) -> String| {
            let mut text = format!("{HEADER}\n");
            for r in rows {
                text.push_str(&r.map(fmt).join(","));
                text.push('\n');
            }
            std::fs::write(dir.0.join(name), text).unwrap();
        };
    let full = |x: f64| format!("{x:e}");
    write("a.csv", &mut (0..200).map(row), &full);
    write("cut.csv", &mut (50..150).map(row), &full);
    write("thinned.csv", &mut (0..200).step_by(2).map(row), &full);
    write("rounded.csv", &mut (0..200).map(row), &|x| {
        format!("{x:.7e}")
    });
    write(
        "turned.csv",
        &mut (0..200).map(|i| {
            let mut r = row(i);
            r[3] += 0.5; // heading turned by 0.5 rad, track kept: only u, v, r, δ compare
            r
        }),
        &full,
    );
    let entry = |f: &str| format!("[[recording]]\nfile = \"{f}\"\nkind = \"free\"\n");
    for (second, span) in [
        ("cut.csv", "from t = 5.00 s to 14.90 s"),
        ("thinned.csv", "from t = 0.00 s to 19.80 s"),
        ("rounded.csv", "from t = 0.00 s to 19.90 s"),
        ("turned.csv", "from t = 0.00 s to 19.90 s"),
    ] {
        let ds = dir.0.join(format!("ds-{second}.toml"));
        std::fs::write(&ds, format!("{SHIP}{}{}", entry("a.csv"), entry(second))).unwrap();
        let e = Dataset::load(&ds).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "key `recording[1].file`: `{second}` holds the samples of recording[0].file `a.csv` {span}"
            )),
            "{e}"
        );
    }
}

/// Regression: a `turning` entry with a `check`, a `free` one with a rudder, were read with the key
/// ignored; a rudder of 179° passed loading and failed later as a "diverged" simulation.
#[test]
fn keys_a_manoeuvre_has_no_use_for_and_angles_beyond_the_controller_are_refused() {
    let dir = TempDir::new("entry-keys");
    std::fs::write(dir.0.join("a.csv"), recording_text(HEADER, |_, _| {})).unwrap();
    for (entry, expected) in [
        (
            "kind = \"turning\"\nrudder = 35.0\nside = \"port\"\ncheck = 5.0\n",
            "key `recording[0].check`: does not apply to kind = \"turning\"",
        ),
        (
            "kind = \"free\"\nrudder = 10.0\n",
            "key `recording[0].rudder`: does not apply to kind = \"free\"",
        ),
        (
            "kind = \"zigzag\"\nrudder = 179.0\ncheck = 5.0\nside = \"port\"\n",
            "key `recording[0].rudder`: 179° is above the 90° a rudder angle can be",
        ),
        (
            "kind = \"zigzag\"\nrudder = 20.0\ncheck = 200.0\nside = \"port\"\n",
            "key `recording[0].check`: 200° is above the 180° a check angle can be",
        ),
    ] {
        let ds = dir.0.join("ds.toml");
        std::fs::write(
            &ds,
            format!("{SHIP}[[recording]]\nfile = \"a.csv\"\n{entry}"),
        )
        .unwrap();
        let e = Dataset::load(&ds).unwrap_err().to_string();
        assert!(e.contains(expected), "{e}");
    }
}

/// Regression: a recording with `u_dot` and `v_dot` but no `r_dot` was read as one without
/// accelerations (all three estimated, the model file saying so) with nothing said; a lone wind or
/// current column is refused, and so are some of the accelerations.
#[test]
fn some_but_not_all_recorded_accelerations_are_refused_naming_the_missing_ones() {
    for (extra, expected) in [
        (
            "u_dot,v_dot",
            "rec.csv:1: columns `u_dot` and `v_dot` need the column `r_dot` too",
        ),
        (
            "r_dot[deg/s^2]",
            "rec.csv:1: column `r_dot` needs the columns `u_dot` and `v_dot` too",
        ),
    ] {
        let n = extra.split(',').count();
        let text = recording_text(&format!("{HEADER},{extra}"), |_, row| {
            row.extend(std::iter::repeat_n("0.0".to_string(), n))
        });
        let e = parse_recording(Path::new("rec.csv"), &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(expected) && e.contains("recorded accelerations are all three"),
            "{extra}: {e}"
        );
    }
    let all = recording_text(&format!("{HEADER},u_dot,v_dot,r_dot"), |_, row| {
        row.extend(std::iter::repeat_n("0.0".to_string(), 3))
    });
    assert!(
        parse_recording(Path::new("rec.csv"), &all)
            .unwrap()
            .accelerations
            .is_some()
    );
}

/// Regression: `u_dot(m/s2)`, `du`, `true_wind_speed`, `true_wind_from`, `cur_speed` and
/// `cur_from` were ignored as the source's own columns, the recorded accelerations, wind or current
/// silently dropped, while `udot` and `wind_speed(m/s)` were refused. A known channel with its unit
/// written otherwise than `name[unit]`, and the names other tools give these channels, are refused
/// with the header to write; columns that name no channel shipid reads are still ignored.
#[test]
fn a_channel_under_another_name_or_unit_syntax_is_refused_with_the_header_to_write() {
    let with_extra = |extra: &str| {
        recording_text(&format!("{HEADER},{extra}"), |_, row| {
            row.push("1.0".into())
        })
    };
    for (extra, words) in [
        ("u_dot(m/s2)", "write `u_dot[m/s2]`"),
        ("U_dot (m/s^2)", "write `u_dot[m/s^2]`"),
        ("r_dot{deg/s2}", "write `r_dot[deg/s2]`"),
        ("n<rpm>", "write `n[rpm]`"),
        ("udot(m/s2)", "write `u_dot[m/s2]`"),
        ("wind_speed(m/s)", "write `wind_speed[m/s]`"),
        (
            "wind_from(grad)",
            "`wind_from[UNIT]`, and `grad` is no unit of `wind_from` (known: rad, deg)",
        ),
        ("thrust_kN", "write `thrust[kN]`"),
        ("n_rpm", "write `n[rpm]`"),
        ("u_dot_m_s2", "write `u_dot[m/s2]`"),
        ("current_from_deg", "write `current_from[deg]`"),
        ("du", "did you mean `u_dot` (the surge acceleration du/dt)?"),
        ("dv/dt", "did you mean `v_dot`"),
        ("yaw_acc", "did you mean `r_dot`"),
        ("true_wind_speed", "did you mean `wind_speed`?"),
        (
            "true_wind_from",
            "did you mean `wind_from` (the direction it comes FROM",
        ),
        ("true_wind_direction", "did you mean `wind_from`"),
        ("tws", "did you mean `wind_speed`?"),
        ("twd", "did you mean `wind_from`"),
        (
            "twa",
            "a true wind angle off the bow needs the heading added",
        ),
        ("apparent_wind_angle", "did you mean `relative_wind_angle`"),
        ("aws", "did you mean `relative_wind_speed`"),
        ("wind_dir", "did you mean `wind_from`"),
        ("current_dir", "did you mean `current_from`"),
        ("cur_speed", "did you mean `current_speed`?"),
        // A propeller rate under another name was dropped and the data set's constant rate used.
        ("rpm", "did you mean `n`?"),
        ("shaft_rpm", "did you mean `n`?"),
        ("propeller_rate", "did you mean `n`?"),
        ("cur_from", "did you mean `current_from`"),
        ("curr_dir", "did you mean `current_from`"),
    ] {
        let e = parse_recording(Path::new("rec.csv"), &with_extra(extra)).unwrap_err();
        assert!(
            e.to_string()
                .starts_with(&format!("rec.csv:1:9: column `{extra}`: "))
                && e.to_string().contains(words),
            "{extra}: {e}"
        );
    }
    for extra in [
        "roll(deg)",
        "heave_m",
        "delta_cmd",
        "wind_gust",
        "current_ma",
        "motor_current",
        "cursor",
        "dx",
        "r_s",
        "x(m)",
        // An engine's rate is not the propeller's (a gearbox between): the source's own column.
        "engine_rpm",
    ] {
        assert!(
            parse_recording(Path::new("rec.csv"), &with_extra(extra)).is_ok(),
            "{extra} refused"
        );
    }
}

/// Regression: an unknown top-level table `[foo]` was reported as key `foo.foo` (the table's
/// header line read as a key inside it).
#[test]
fn an_unknown_table_is_named_by_its_own_path() {
    for (table, key) in [
        ("[foo]\nbar = 1\n", "foo"),
        ("[ship.foo]\nbar = 1\n", "ship.foo"),
        ("[[foo]]\nbar = 1\n", "foo"),
    ] {
        let text = format!("{SHIP}{table}");
        let e = parse_dataset(Path::new("ds.toml"), &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("key `{key}`: unknown field `foo`")),
            "{table}: {e}"
        );
    }
}

/// Regression: a recording `file` that is a FIFO or a device (`/dev/zero`) was reported "not found";
/// it is there, and no regular file.
#[cfg(unix)]
#[test]
fn a_recording_that_is_a_fifo_or_a_device_is_named_as_no_regular_file() {
    let dir = TempDir::new("special");
    std::os::unix::fs::symlink("/dev/zero", dir.0.join("zero.csv")).unwrap();
    let fifo = std::process::Command::new("mkfifo")
        .arg(dir.0.join("pipe.csv"))
        .status()
        .is_ok_and(|s| s.success());
    let entry = |f: &str| format!("[[recording]]\nfile = \"{f}\"\nkind = \"free\"\n");
    let files: &[&str] = if fifo {
        &["zero.csv", "pipe.csv"]
    } else {
        &["zero.csv"]
    };
    for f in files {
        let ds = dir.0.join("ds.toml");
        std::fs::write(&ds, format!("{SHIP}{}", entry(f))).unwrap();
        let e = Dataset::load(&ds).unwrap_err().to_string();
        assert!(
            e.contains("key `recording[0].file`")
                && e.ends_with(&format!(
                    "{f}` is not a regular file (a FIFO, device or socket)"
                )),
            "{f}: {e}"
        );
        let e = read_recording(&dir.0.join(f)).unwrap_err().to_string();
        assert!(
            e.ends_with("is not a regular file (a FIFO, device or socket)"),
            "{e}"
        );
    }
}

/// Regression: `fit --recordings sub/a.csv` was refused as "not in the data set" when the entry was
/// written `./sub//a.csv`, the same file as the loader opens it.
#[test]
fn a_recording_is_found_under_another_spelling_of_its_path() {
    let dir = TempDir::new("spelling");
    std::fs::create_dir_all(dir.0.join("sub")).unwrap();
    std::fs::write(dir.0.join("sub/a.csv"), recording_text(HEADER, |_, _| {})).unwrap();
    let ds = dir.0.join("ds.toml");
    std::fs::write(
        &ds,
        format!("{SHIP}[[recording]]\nfile = \"./sub//a.csv\"\nkind = \"free\"\n"),
    )
    .unwrap();
    let loaded = Dataset::load(&ds).unwrap();
    for spelling in ["./sub//a.csv", "sub/a.csv", "sub/./a.csv"] {
        let found = loaded.recording(spelling).map(|r| r.file.as_str());
        assert_eq!(found, Some("./sub//a.csv"), "{spelling}");
    }
    assert!(loaded.recording("a.csv").is_none());
}
