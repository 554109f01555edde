//! The bad-input corpus: every file under `tests/fixtures/bad_input/` is named after the mistake it
//! holds, and the exact message a user sees is asserted. A message must name the file and the line and
//! column (CSV) or the key (TOML), in one readable sentence.

use std::path::Path;

use shipid_io::Dataset;
use shipid_io::recording::read_recording;

fn message_for(name: &str) -> String {
    let path = Path::new("tests/fixtures/bad_input").join(name);
    let result = if name.ends_with(".csv") {
        read_recording(&path).map(|_| ())
    } else {
        Dataset::load(&path).map(|_| ())
    };
    match result {
        Ok(()) => panic!("{name} was accepted"),
        Err(e) => e.to_string(),
    }
}

fn check(name: &str, expected: &str) {
    let got = message_for(name);
    let expected = format!("tests/fixtures/bad_input/{name}{expected}");
    assert_eq!(got, expected, "message for {name}");
}

#[test]
fn csv_missing_required_column_names_it_at_the_header() {
    check("missing_column.csv", ":1: missing required column `r`");
}

#[test]
fn csv_nan_cell() {
    check("nan_cell.csv", ":4:3: column `y0`: NaN value");
}

#[test]
fn csv_empty_cell() {
    check("empty_cell.csv", ":6:6: column `v`: empty cell");
}

#[test]
fn csv_infinite_value_after_comments_points_at_the_real_line() {
    check(
        "infinite_value.csv",
        ":5:4: column `psi`: infinite value `inf`",
    );
}

#[test]
fn csv_non_increasing_time() {
    check(
        "non_increasing_time.csv",
        ":12:1: column `t`: time is not strictly increasing (0.9 s after 0.9 s)",
    );
}

#[test]
fn csv_unknown_unit() {
    check(
        "unknown_unit.csv",
        ":1:4: column `psi[grad]`: unknown unit `grad` for `psi` (known: rad, deg)",
    );
}

#[test]
fn csv_malformed_unit() {
    check(
        "malformed_unit.csv",
        ":1:4: column `psi[deg`: malformed unit in header `psi[deg` (expected `name[unit]`)",
    );
}

#[test]
fn csv_not_a_number() {
    check("not_a_number.csv", ":9:7: column `r`: not a number: `abc`");
}

#[test]
fn csv_too_short() {
    check(
        "too_short.csv",
        ": too short: 5 samples, at least 20 are needed",
    );
}

#[test]
fn csv_wrong_field_count() {
    check(
        "wrong_field_count.csv",
        ":5: expected 8 fields as in the header, found 7",
    );
}

#[test]
fn csv_duplicate_column() {
    check(
        "duplicate_column.csv",
        ":1:9: column `psi[deg]`: duplicate column `psi` (also column 4)",
    );
}

#[test]
fn csv_only_comments_has_no_header() {
    check("only_comments.csv", ": no header row");
}

#[test]
fn toml_unknown_key_is_named_with_its_position() {
    check(
        "unknown_key.toml",
        ":2:1: key `colour`: unknown field `colour`, expected one of `name`, `origin`, `reference_point`, `rudder_sign`, `ship`, `added_mass`, `propeller`, `rudder`, `windage`, `recording`",
    );
}

#[test]
fn toml_missing_ship_key() {
    check(
        "missing_ship_key.toml",
        ":4:1: key `ship.lpp`: missing field `lpp`",
    );
}

#[test]
fn toml_rudder_sign_must_be_one_or_minus_one() {
    check(
        "bad_rudder_sign.toml",
        ": key `rudder_sign`: must be 1 or -1, not 2",
    );
}

#[test]
fn toml_missing_recording_file() {
    check(
        "missing_recording_file.toml",
        ": key `recording[0].file`: recording file `tests/fixtures/bad_input/does_not_exist.csv` not found",
    );
}

#[test]
fn toml_zigzag_without_check_angle() {
    check(
        "zigzag_without_check.toml",
        ": key `recording[0].check`: required for kind = \"zigzag\"",
    );
}

#[test]
fn toml_unknown_side() {
    check(
        "bad_side.toml",
        ":19:8: key `recording[0].side`: unknown variant `left`, expected `port` or `starboard`",
    );
}

#[test]
fn toml_negative_length() {
    check(
        "negative_length.toml",
        ": key `ship.lpp`: must be a positive number, not -7",
    );
}

#[test]
fn toml_syntax_error() {
    check("not_toml.toml", ":2:6: unclosed table, expected `]`");
}

#[test]
fn missing_data_set_file() {
    check("no_such_dataset.toml", ": file not found");
}

#[test]
fn csv_wind_speed_without_its_direction_is_refused() {
    check(
        "wind_speed_without_direction.csv",
        ":1: column `wind_speed` needs the column `wind_from` too (a recorded wind is its speed and the direction it comes from, docs/data-format.md)",
    );
}

#[test]
fn csv_negative_wind_speed_names_the_cell() {
    check(
        "negative_wind_speed.csv",
        ":9:9: column `wind_speed`: negative wind speed -1 m/s: give the speed (≥ 0) and the direction it comes from",
    );
}

#[test]
fn toml_windage_without_lateral_area() {
    check(
        "windage_without_lateral_area.toml",
        ":14:1: key `windage.lateral_area_m2`: missing field `lateral_area_m2`",
    );
}

#[test]
fn toml_windage_air_density_of_water() {
    check(
        "windage_air_density_of_water.toml",
        ": key `windage.air_density_kg_m3`: must lie between 0.5 and 2.0 kg/m³ (sea level: 1.225), not 1000",
    );
}
