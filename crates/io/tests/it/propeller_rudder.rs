//! The optional `[propeller]` and `[rudder]` data-set tables: what a valid table gives, and the message for
//! each mistake (unknown keys, non-physical values, neither or both open-water forms, a bad open-water CSV).

use std::path::Path;

use shipid_io::dataset::parse_dataset;
use shipid_io::{Dataset, DatasetRecording, Manoeuvre, PropellerData, Recording, RudderData};

const SHIP: &str = r#"name = "tables"

[ship]
lpp = 7.0
beam = 1.27
draft = 0.46
displacement = 3.27
rho = 1000.0
xg = 0.25
kzz = 1.75
u0 = 1.179
rudder_rate = 15.8
"#;

const PROPELLER: &str =
    "[propeller]\ndiameter_m = 0.204\nx_m = -3.36\nk_t = [0.2931, -0.2753, -0.1385]\n";
const RUDDER: &str = "[rudder]\narea_m2 = 0.0539\nspan_m = 0.345\nx_m = -3.5\n";

/// The message `parse_dataset` gives for the ship header followed by `tables`.
fn check_message(tables: &str, expected: &str) {
    let text = format!("{SHIP}\n{tables}");
    match parse_dataset(Path::new("ds.toml"), &text) {
        Ok(_) => panic!("accepted:\n{tables}"),
        Err(e) => assert_eq!(e.to_string(), expected, "tables:\n{tables}"),
    }
}

/// The message `Dataset::load` gives for a fixture under `tests/fixtures/propeller/`.
fn check_load_message(fixture: &str, expected: &str) {
    let path = Path::new("tests/fixtures/propeller").join(fixture);
    match Dataset::load(&path) {
        Ok(_) => panic!("{fixture} was accepted"),
        Err(e) => assert_eq!(e.to_string(), expected, "fixture {fixture}"),
    }
}

#[test]
fn a_data_set_without_the_tables_has_neither() {
    let file = parse_dataset(Path::new("ds.toml"), SHIP).unwrap();
    assert_eq!((file.propeller, file.rudder), (None, None));
}

#[test]
fn the_tables_with_k_t_coefficients_are_read_as_written() {
    let file = parse_dataset(
        Path::new("ds.toml"),
        &format!("{SHIP}\n{PROPELLER}\n{RUDDER}"),
    )
    .unwrap();
    let p = file.propeller.unwrap();
    assert_eq!((p.diameter_m, p.x_m), (0.204, -3.36));
    assert_eq!(p.k_t, Some(vec![0.2931, -0.2753, -0.1385]));
    assert_eq!(p.rate_rps, None);
    assert_eq!(
        file.rudder,
        Some(RudderData {
            area_m2: 0.0539,
            span_m: 0.345,
            x_m: -3.5
        })
    );
}

#[test]
fn an_open_water_table_gives_its_points_and_the_quadratic_through_them() {
    // The fixture samples K_T = 0.2931 − 0.2753 J − 0.1385 J² at J = 0 … 1.1 (10 decimals): the
    // least-squares quadratic must give those coefficients back.
    let ds = Dataset::load(Path::new("tests/fixtures/propeller/open_water_table.toml")).unwrap();
    let p: PropellerData = ds.propeller.unwrap();
    for (got, want) in p.k_t.iter().zip([0.2931, -0.2753, -0.1385]) {
        assert!((got - want).abs() < 1e-8, "k_t {:?}", p.k_t);
    }
    let curve = p.open_water.as_ref().unwrap();
    assert_eq!(curve.file, "open_water_j_kt_10kq_eta.csv");
    assert_eq!(curve.j.len(), 12);
    assert_eq!((curve.j_min, curve.j_max), (0.0, 1.1));
    assert!(curve.rms_residual < 1e-9, "{}", curve.rms_residual);
    assert_eq!(p.rate_rps, Some(10.23));
    assert!((p.k_t_at(0.5) - (0.2931 - 0.2753 * 0.5 - 0.1385 * 0.25)).abs() < 1e-8);
    assert_eq!(ds.rudder.map(|r| r.span_m), Some(0.345));
}

#[test]
fn an_unknown_key_is_named() {
    check_message(
        &format!("{PROPELLER}pitch_m = 0.15\n"),
        "ds.toml:18:1: key `propeller.pitch_m`: unknown field `pitch_m`, expected one of `diameter_m`, `x_m`, `k_t`, `open_water`, `rate_rps`",
    );
    check_message(
        &format!("{RUDDER}chord_m = 0.15\n"),
        "ds.toml:18:1: key `rudder.chord_m`: unknown field `chord_m`, expected one of `area_m2`, `span_m`, `x_m`",
    );
}

#[test]
fn a_missing_key_is_named() {
    check_message(
        "[rudder]\narea_m2 = 0.0539\nx_m = -3.5\n",
        "ds.toml:14:1: key `rudder.span_m`: missing field `span_m`",
    );
}

#[test]
fn non_physical_values_are_refused_with_their_key() {
    let cases = [
        (
            PROPELLER.replace("0.204", "0.0"),
            "ds.toml: key `propeller.diameter_m`: must be a positive number, not 0",
        ),
        (
            PROPELLER.replace("0.204", "-0.2"),
            "ds.toml: key `propeller.diameter_m`: must be a positive number, not -0.2",
        ),
        (
            PROPELLER.replace("0.204", "nan"),
            "ds.toml: key `propeller.diameter_m`: must be a positive number, not NaN",
        ),
        (
            PROPELLER.replace("0.204", "9.0"),
            "ds.toml: key `propeller.diameter_m`: 9 m is not shorter than the ship (ship.lpp = 7 m): a wrong unit?",
        ),
        (
            PROPELLER.replace("-3.36", "-70.0"),
            "ds.toml: key `propeller.x_m`: must be a finite distance from midship within the ship length ship.lpp = 7 m, not -70",
        ),
        (
            format!("{PROPELLER}rate_rps = -10.0\n"),
            "ds.toml: key `propeller.rate_rps`: must be a positive number, not -10",
        ),
        (
            RUDDER.replace("0.0539", "inf"),
            "ds.toml: key `rudder.area_m2`: must be a positive number, not inf",
        ),
        (
            RUDDER.replace("0.345", "0"),
            "ds.toml: key `rudder.span_m`: must be a positive number, not 0",
        ),
        (
            RUDDER.replace("-3.5", "1e300"),
            "ds.toml: key `rudder.x_m`: must be a finite distance from midship within the ship length ship.lpp = 7 m, not 1e300",
        ),
    ];
    for (tables, expected) in cases {
        check_message(&tables, expected);
    }
}

#[test]
fn the_open_water_curve_is_given_at_most_once_and_well_formed() {
    let cases = [
        (
            format!("{PROPELLER}open_water = \"ow.csv\"\n"),
            "ds.toml: key `propeller`: give either `k_t` or `open_water`, not both",
        ),
        (
            PROPELLER.replace("[0.2931, -0.2753, -0.1385]", "[0.2931, -0.2753]"),
            "ds.toml: key `propeller.k_t`: must hold three coefficients [k0, k1, k2] of K_T(J) = k0 + k1 J + k2 J², not 2",
        ),
        (
            PROPELLER.replace("-0.2753", "nan"),
            "ds.toml: key `propeller.k_t`: coefficients must be finite, not NaN",
        ),
        (
            PROPELLER.replace("0.2931", "-0.1"),
            "ds.toml: key `propeller.k_t`: K_T at J = 0 (the first coefficient) must be positive, not -0.1",
        ),
        (
            "[propeller]\ndiameter_m = 0.204\nx_m = -3.36\nopen_water = \" \"\n".to_string(),
            "ds.toml: key `propeller.open_water`: must name a CSV file",
        ),
    ];
    for (tables, expected) in cases {
        check_message(&tables, expected);
    }
}

#[test]
fn a_bad_open_water_file_is_named_with_its_line() {
    let dir = "tests/fixtures/propeller";
    check_load_message(
        "open_water_missing.toml",
        &format!(
            "{dir}/open_water_missing.toml: key `propeller.open_water`: open-water file `{dir}/no_such_open_water.csv` not found"
        ),
    );
    check_load_message(
        "open_water_without_kt.toml",
        &format!(
            "{dir}/open_water_without_kt.csv:1: no `K_T` column in the header (found: J, 10Kq, Eta); an open-water table needs `J` and `K_T` (or `KT`) columns"
        ),
    );
    check_load_message(
        "open_water_j_not_increasing.toml",
        &format!(
            "{dir}/open_water_j_not_increasing.csv:4:1: column `J`: J must increase from row to row (0.1 after 0.2)"
        ),
    );
    check_load_message(
        "open_water_two_points.toml",
        &format!(
            "{dir}/open_water_two_points.csv: 2 open-water points; at least 3 are needed for the quadratic K_T(J)"
        ),
    );
}

#[test]
fn the_data_sets_of_the_repository_still_load() {
    Dataset::load(Path::new("../../data/kvlcc2-mmg/dataset.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
}

/// A `[propeller]` without a curve takes the documented default, and says where it comes from
/// (regression: it was refused, although the mmg family's issue asks for a default with its source).
#[test]
fn a_propeller_without_a_curve_takes_the_default_and_names_it() {
    let ds = Dataset::load(Path::new(
        "tests/fixtures/propeller/open_water_default.toml",
    ))
    .unwrap();
    let p: PropellerData = ds.propeller.unwrap();
    assert_eq!(p.k_t, shipid_io::DEFAULT_K_T);
    assert_eq!(
        p.k_t_default.as_deref(),
        Some(shipid_io::DEFAULT_K_T_SOURCE)
    );
    assert!(p.open_water.is_none());
    let given = Dataset::load(Path::new("tests/fixtures/propeller/open_water_table.toml")).unwrap();
    assert_eq!(given.propeller.unwrap().k_t_default, None);
}

/// A recording with wind and current columns (knots and degrees) reads into SI, and writes back
/// (metres per second and radians) to the same values.
#[test]
fn recorded_wind_and_current_read_in_si_and_round_trip() {
    use shipid_io::recording::parse_recording;
    use shipid_io::write::recording_csv;
    let mut text = String::from(
        "t,x0,y0,psi,u,v,r,delta,wind_speed[kn],wind_from[deg],current_speed,current_from[deg]\n",
    );
    for i in 0..25 {
        text.push_str(&format!("{},0,0,0,1,0,0,0,10,270,0.1,45\n", i as f64 * 0.1));
    }
    let rec = parse_recording(std::path::Path::new("w.csv"), &text).unwrap();
    let wind = rec.wind.as_ref().unwrap();
    assert!((wind.speed_m_s[3] - 10.0 * 1852.0 / 3600.0).abs() < 1e-12);
    assert!((wind.from_rad[3] - 270f64.to_radians()).abs() < 1e-12);
    // From the west: the air moves east.
    let [n, e] = wind.velocity_earth(0);
    assert!(n.abs() < 1e-12 && (e - wind.speed_m_s[0]).abs() < 1e-12);
    let current = rec.current.as_ref().unwrap();
    assert_eq!(current.speed_m_s[0], 0.1);
    let back = parse_recording(std::path::Path::new("w.csv"), &recording_csv(&rec, &[])).unwrap();
    for (a, b) in [(&rec.wind, &back.wind), (&rec.current, &back.current)] {
        let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
        for i in 0..rec.len() {
            assert!((a.speed_m_s[i] - b.speed_m_s[i]).abs() <= 1e-9 * a.speed_m_s[i]);
            assert!((a.from_rad[i] - b.from_rad[i]).abs() <= 1e-9 * a.from_rad[i].abs());
        }
    }
    assert_eq!(rec.slice(2..5).wind.unwrap().speed_m_s.len(), 3);
}

/// The message `parse_open_water` gives for an open-water table's text.
fn check_open_water(text: &str, expected: &str) {
    match shipid_io::open_water::parse_open_water(Path::new("ow.csv"), "ow.csv", text) {
        Ok((k, _)) => panic!("accepted (k_t {k:?}):\n{text}"),
        Err(e) => assert_eq!(e.to_string(), expected, "table:\n{text}"),
    }
}

/// The table `J,Kt` of the default curve at J = 0 … 0.8, its columns passed through `f`.
fn table(f: impl Fn(f64, f64) -> (f64, f64)) -> String {
    let mut text = String::from("J,Kt\n");
    for i in 0..=16 {
        let j = 0.05 * i as f64;
        let (j, k) = f(j, 0.2931 - 0.2753 * j - 0.1385 * j * j);
        text.push_str(&format!("{j:.3},{k:.5}\n"));
    }
    text
}

/// Regression: J in percent, K_T rising with J, K_T × 100 and two K_T columns were all read with
/// exit 0 (the first K_T column silently), and the mmg fit put up to 11 parameters on bounds.
#[test]
fn an_absurd_open_water_table_is_refused_with_the_likely_slip() {
    check_open_water(
        &table(|j, k| (100.0 * j, k)),
        "ow.csv: the table's J runs from 0 to 80; a propeller's advance ratio stays below 3 (J in percent?)",
    );
    check_open_water(
        &table(|j, _| (j, 0.1 + 0.2 * j)),
        "ow.csv: K_T rises from 0.1 at J = 0 to 0.26 at J = 0.8: a propeller's thrust coefficient falls as the advance ratio grows (K_T and J swapped, or another column?)",
    );
    check_open_water(
        &table(|j, k| (j, 100.0 * k)),
        "ow.csv: the quadratic through the open-water points: K_T at J = 0 is 29.31, outside the 0.05 … 1 of a propeller's open-water curve (K_T × 100 (in percent)?)",
    );
    check_open_water(
        "J,Kt,KT\n0,0.29,0.58\n0.4,0.16,0.32\n0.8,-0.02,-0.03\n",
        "ow.csv:1: two `K_T` columns, `Kt` (column 2) and `KT` (column 3): which one holds K_T is ambiguous; keep one, or rename the other (e.g. `KT_alt`)",
    );
}

#[test]
fn the_open_water_tables_of_real_propellers_are_read() {
    // The default curve, and the HSVA table (K_T 0.323 at J = 0 to 0.006 at J = 0.9).
    let hsva = "J,Kt,10Kq,Eta\n0,0.323,0.37,0\n0.3,0.245,0.30,0.38\n0.6,0.137,0.21,0.63\n0.9,0.006,0.06,0.15\n";
    for text in [table(|j, k| (j, k)), hsva.to_string()] {
        shipid_io::open_water::parse_open_water(Path::new("ow.csv"), "ow.csv", &text)
            .unwrap_or_else(|e| panic!("{e}"));
    }
}

/// Regression: `k_t = [29.31, -27.53, -13.85]` (×100) and a rising curve were accepted; the model ran
/// straight at 2.7 U0.
#[test]
fn absurd_k_t_coefficients_are_refused_naming_the_key() {
    let cases = [
        (
            "[29.31, -27.53, -13.85]",
            "ds.toml: key `propeller.k_t`: K_T at J = 0 is 29.31, outside the 0.05 … 1 of a propeller's open-water curve (K_T × 100 (in percent)?)",
        ),
        (
            "[0.001, -0.001, 0.0]",
            "ds.toml: key `propeller.k_t`: K_T at J = 0 is 0.001, outside the 0.05 … 1 of a propeller's open-water curve (K_T ÷ 10 or ÷ 100, or another coefficient (K_Q?) in its place?)",
        ),
        (
            "[0.1, 0.2, 0.0]",
            "ds.toml: key `propeller.k_t`: K_T rises with J (dK_T/dJ = 0.200 at J = 0, over J = 0 … 3): a propeller's thrust coefficient falls as the advance ratio grows (K_T and J swapped, or another column?)",
        ),
    ];
    for (k_t, expected) in cases {
        check_message(
            &PROPELLER.replace("[0.2931, -0.2753, -0.1385]", k_t),
            expected,
        );
    }
}

/// Regression: a rudder or propeller forward of midship (a sign slip: the turn came out twice as
/// large), a rudder ahead of the propeller, and a rudder span below the propeller diameter
/// (η = D/H_R 4.3: a 0.89 L turn) were accepted.
#[test]
fn a_misplaced_or_undersized_rudder_or_propeller_is_refused_naming_the_key() {
    let cases = [
        (
            format!("{PROPELLER}\n{}", RUDDER.replace("-3.5", "3.5")),
            "ds.toml: key `rudder.x_m`: 3.5 m is at or forward of midship, where the MMG model has no rudder: positions are forward of midship, aft is negative (a sign slip? write -3.5)",
        ),
        (
            format!("{}\n{RUDDER}", PROPELLER.replace("-3.36", "3.36")),
            "ds.toml: key `propeller.x_m`: 3.36 m is at or forward of midship, where the MMG model has no propeller: positions are forward of midship, aft is negative (a sign slip? write -3.36)",
        ),
        (
            format!("{PROPELLER}\n{}", RUDDER.replace("-3.5", "-3.0")),
            "ds.toml: key `rudder.x_m`: -3 m puts the rudder forward of the propeller (propeller.x_m = -3.36 m): the MMG rudder sits behind the propeller, in its slipstream (aft is more negative; the two positions swapped?)",
        ),
        (
            format!("{PROPELLER}\n{}", RUDDER.replace("0.345", "0.1")),
            "ds.toml: key `rudder.span_m`: 0.1 m is smaller than the propeller's diameter propeller.diameter_m = 0.204 m: the share of the rudder in the slipstream, η = D/H_R = 2.04, would exceed 1 (a rudder's span is about 1.2 … 2 × the diameter); rudder.span_m or propeller.diameter_m in another unit?",
        ),
        (
            format!("{}\n{RUDDER}", PROPELLER.replace("0.204", "2.04")),
            "ds.toml: key `propeller.diameter_m`: 2.04 m is 4.43 × the draft ship.draft = 0.46 m (a propeller's diameter is about 0.5 … 0.8 × the draft; at most 2 × is accepted): a wrong unit?",
        ),
    ];
    for (tables, expected) in cases {
        check_message(&tables, expected);
    }
    // The model files' check (`hardware_fault`) has the span and diameter but not the positions.
    let ship = parse_dataset(Path::new("ds.toml"), SHIP).unwrap().ship;
    let fault = shipid_io::dataset::hardware_fault(&ship, Some(0.216), Some((0.0539, 0.05)));
    assert_eq!(fault.map(|f| f.0), Some("rudder.span_m"));
}

/// Regression: a `[propeller] rate_rps` beside recordings that all have `n` was ignored without a
/// word (5 1/s beside a recorded 11.85 1/s).
#[test]
fn a_rate_rps_no_recording_uses_is_noted_with_the_recorded_rate() {
    let check_notes = |rate_rps: Option<f64>, n: Option<f64>, expected: &[&str]| {
        let recording = Recording {
            t: vec![0.0, 0.1, 0.2],
            n: n.map(|n| vec![n; 3]),
            ..Default::default()
        };
        let ds = Dataset {
            path: "ds.toml".into(),
            name: "notes".into(),
            ship: parse_dataset(Path::new("ds.toml"), SHIP).unwrap().ship,
            added_mass: None,
            propeller: Some(PropellerData {
                diameter_m: 0.216,
                x_m: -3.36,
                k_t: shipid_io::DEFAULT_K_T,
                open_water: None,
                k_t_default: None,
                rate_rps,
            }),
            rudder: None,
            windage: None,
            recordings: vec![DatasetRecording {
                file: "a.csv".into(),
                manoeuvre: Manoeuvre::Free,
                recording,
            }],
        };
        assert_eq!(shipid_io::dataset::load_notes(&ds), expected);
    };
    check_notes(
        Some(5.0),
        Some(11.85),
        &[
            "ds.toml: key `propeller.rate_rps` = 5 1/s is not used: every recording has an `n` column (median 11.85 1/s), a different rate: check which one is the ship's",
        ],
    );
    check_notes(
        Some(11.85),
        Some(11.85),
        &[
            "ds.toml: key `propeller.rate_rps` = 11.85 1/s is not used: every recording has an `n` column (median 11.85 1/s)",
        ],
    );
    check_notes(Some(5.0), None, &[]);
    check_notes(None, Some(11.85), &[]);
}
