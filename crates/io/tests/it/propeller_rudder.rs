//! The optional `[propeller]` and `[rudder]` data-set tables: what a valid table gives, and the message for
//! each mistake (unknown keys, non-physical values, neither or both open-water forms, a bad open-water CSV).

use std::path::Path;

use shipid_io::dataset::parse_dataset;
use shipid_io::{Dataset, PropellerData, RudderData};

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
