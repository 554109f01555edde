//! The wind measured on board (`relative_wind_speed`, `relative_wind_angle`): read into the recording's
//! true wind with the recorded motion, written back as relative channels, imported from a foreign
//! layout, and refused when it cannot be meant (issue 27).

use std::f64::consts::PI;
use std::path::Path;

use proptest::prelude::*;
use shipid_io::import::{Mapping, parse_table};
use shipid_io::recording::parse_recording;
use shipid_io::relative_wind::{ShipMotion, Wind, relative_wind, true_wind};
use shipid_io::write::{WindChannels, recording_csv_with};
use shipid_io::{FlowSeries, Recording};

/// A recording's CSV text: `header`, then 25 rows of 0.1 s, each from `row(t_s)`.
fn csv(header: &str, row: impl Fn(f64) -> String) -> String {
    let mut text = format!("{header}\n");
    for i in 0..25 {
        let t = i as f64 * 0.1;
        text.push_str(&format!("{t},{}\n", row(t)));
    }
    text
}

/// Heading east (ψ = 90°) at 2 m/s, turning slowly; a relative wind of 2 m/s from the starboard beam
/// (+90°). With r neglected in the conversion the true wind is 2√2 m/s from 225° at ψ = 90° exactly.
fn heading_east_beam_wind(extra: &str) -> String {
    csv(
        &format!(
            "t,x0,y0,psi[deg],u,v,r,delta,relative_wind_speed,relative_wind_angle[deg]{extra}"
        ),
        |t| {
            format!(
                "0,{},90,2,0,0,0,2,90{}",
                2.0 * t,
                if extra.is_empty() { "" } else { ",3,1" }
            )
        },
    )
}

/// The text `text` read as `name` is refused with `expected` after the file name.
fn check_refused(name: &str, text: &str, expected: &str) {
    match parse_recording(Path::new(name), text) {
        Ok(_) => panic!("{name} was accepted, expected {expected}"),
        Err(e) => assert_eq!(e.to_string(), format!("{name}{expected}")),
    }
}

/// Every sample of `got` is `speed_m_s` from `from_deg` to `tol` (speed relative, direction absolute).
fn check_wind(got: &FlowSeries, speed_m_s: f64, from_deg: f64, tol: f64) {
    for (s, f) in got.speed_m_s.iter().zip(&got.from_rad) {
        assert!(
            (s - speed_m_s).abs() <= tol * speed_m_s && (f - from_deg.to_radians()).abs() <= tol,
            "{s} m/s from {} deg, expected {speed_m_s} m/s from {from_deg} deg",
            f.to_degrees()
        );
    }
}

#[test]
fn a_relative_wind_is_read_as_the_true_wind() {
    let rec = parse_recording(Path::new("r.csv"), &heading_east_beam_wind("")).unwrap();
    check_wind(rec.wind.as_ref().unwrap(), 2.0 * 2f64.sqrt(), 225.0, 1e-12);
}

/// `diagnose --reveal` conceals `Recording::wind`: a relative wind leaves nothing else behind, so a
/// recording read with its relative wind and the wind taken away is the recording without the columns.
#[test]
fn concealing_the_wind_of_a_relative_wind_recording_leaves_no_wind() {
    let mut with = parse_recording(Path::new("r.csv"), &heading_east_beam_wind("")).unwrap();
    let without_text = csv("t,x0,y0,psi[deg],u,v,r,delta", |t| {
        format!("0,{},90,2,0,0,0", 2.0 * t)
    });
    let without = parse_recording(Path::new("r.csv"), &without_text).unwrap();
    assert!(with.wind.take().is_some());
    assert_eq!(with, without);
}

/// A recording whose wind is written as relative channels reads back to the same true wind (9 digits)
/// and the same motion as when written as true channels.
#[test]
fn written_relative_channels_read_back_to_the_true_wind() {
    let text = csv("t,x0,y0,psi,u,v,r,delta,wind_speed,wind_from", |t| {
        format!("0,0,{},1.3,-0.2,0.05,0.1,{},{}", 0.3 + t, 3.0 + t, 4.0 - t)
    });
    let rec = parse_recording(Path::new("w.csv"), &text).unwrap();
    let written = recording_csv_with(&rec, &[], WindChannels::Relative);
    assert!(
        written.starts_with("t,x0,y0,psi,u,v,r,delta,relative_wind_speed,relative_wind_angle\n")
    );
    let back = parse_recording(Path::new("w.csv"), &written).unwrap();
    let (a, b) = (rec.wind.as_ref().unwrap(), back.wind.as_ref().unwrap());
    for i in 0..rec.len() {
        assert!(
            (a.speed_m_s[i] - b.speed_m_s[i]).abs() <= 1e-8 * a.speed_m_s[i],
            "{i}"
        );
        assert!((a.from_rad[i] - b.from_rad[i]).abs() <= 1e-8, "{i}");
    }
    // Everything else reads back as from the true channels (both rounded to 9 digits alike).
    let as_true = parse_recording(
        Path::new("w.csv"),
        &recording_csv_with(&rec, &[], WindChannels::True),
    )
    .unwrap();
    assert_eq!(
        Recording {
            wind: None,
            ..as_true
        },
        Recording { wind: None, ..back }
    );
}

/// An imported layout maps the relative wind in knots and degrees, with earth-fixed velocities.
#[test]
fn an_import_mapping_reads_a_relative_wind_in_knots_and_degrees() {
    let quantities = [
        ("t", None),
        ("x0", None),
        ("y0", None),
        ("psi", Some("deg")),
        ("x0_dot", None),
        ("y0_dot", None),
        ("r", None),
        ("delta", None),
        ("relative_wind_speed", Some("kn")),
        ("relative_wind_angle", Some("deg")),
    ];
    let columns: String = quantities
        .iter()
        .enumerate()
        .map(|(i, (q, unit))| {
            let unit = unit.map_or(String::new(), |u| format!("unit = \"{u}\"\n"));
            format!("[[column]]\nindex = {}\nquantity = \"{q}\"\n{unit}", i + 1)
        })
        .collect();
    let mapping: Mapping = toml::from_str(&format!(
        "[format]\ndelimiter = \" \"\n{columns}[dataset]\nname = \"i\"\n[dataset.ship]\nlpp = 7.0\nbeam = 1.27\ndraft = 0.46\ndisplacement = 3.27\nrho = 1000.0\nxg = 0.25\nkzz = 1.75\nu0 = 1.179\nrudder_rate = 15.8\n[[recording]]\nsource = \"a.dat\"\nfile = \"a.csv\"\nkind = \"free\"\n"
    ))
    .unwrap();
    // Heading east at 2 m/s over ground (east velocity 2), 2√2 m/s (in knots) from 45° off the port
    // bow: the air past the ship moves aft 2 and to starboard 2 m/s, plus the ship's 2 m/s forward,
    // so the true air moves south at 2 m/s: a true wind of 2 m/s from the north.
    let kn = 2.0 * 2f64.sqrt() * 3600.0 / 1852.0;
    let text: String = (0..25)
        .map(|i| format!("{} 0 0 90 0 2 0 0 {kn} -45\n", i as f64 * 0.1))
        .collect();
    let rec = parse_table(Path::new("a.dat"), &text, &mapping).unwrap();
    let wind = rec.wind.as_ref().unwrap();
    for (s, f) in wind.speed_m_s.iter().zip(&wind.from_rad) {
        let from = (f + PI).rem_euclid(2.0 * PI) - PI;
        assert!(
            (s - 2.0).abs() < 1e-9 && from.abs() < 1e-9,
            "{s} m/s from {f} rad"
        );
    }
}

#[test]
fn a_relative_wind_speed_without_its_angle_is_refused() {
    let text = csv("t,x0,y0,psi,u,v,r,delta,relative_wind_speed", |_| {
        "0,0,0,1,0,0,0,2".into()
    });
    check_refused(
        "lone.csv",
        &text,
        ":1: column `relative_wind_speed` needs the column `relative_wind_angle` too (a recorded relative wind is its speed and the angle off the bow it comes from, docs/data-format.md)",
    );
}

#[test]
fn a_true_and_a_relative_wind_together_are_refused() {
    check_refused(
        "both.csv",
        &heading_east_beam_wind(",wind_speed,wind_from"),
        ":1:9: column `relative_wind_speed`: the recording has both a true wind (`wind_speed`, `wind_from`: columns 11 and 12) and a relative wind (`relative_wind_speed`, `relative_wind_angle[deg]`: columns 9 and 10); give one of them (docs/data-format.md): the relative wind is turned into the true wind on reading, and two winds for one ship would disagree",
    );
}

#[test]
fn a_negative_relative_wind_speed_names_the_cell() {
    let text = csv(
        "t,x0,y0,psi,u,v,r,delta,relative_wind_speed,relative_wind_angle",
        |t| format!("0,0,0,1,0,0,0,{},0", if t > 0.25 { -1 } else { 1 }),
    );
    check_refused(
        "negative.csv",
        &text,
        ":5:9: column `relative_wind_speed`: negative relative wind speed -1 m/s: give the speed (≥ 0) and the angle off the bow it comes from",
    );
}

/// The motion the conversion needs is required anyway; the message says the relative wind needs it.
#[test]
fn a_relative_wind_without_the_sway_velocity_says_it_needs_it() {
    let text = csv(
        "t,x0,y0,psi,u,r,delta,relative_wind_speed,relative_wind_angle",
        |_| "0,0,0,1,0,0,2,0".into(),
    );
    check_refused(
        "no_v.csv",
        &text,
        ":1: missing required column `v` (the relative wind columns need it too: the true wind is the relative wind turned by the heading plus the ship's velocity over ground)",
    );
}

fn motion() -> impl Strategy<Value = ShipMotion> {
    (-10.0..10.0f64, -5.0..5.0f64, -2.0..2.0f64).prop_map(|(psi_rad, u_m_s, v_m_s)| ShipMotion {
        psi_rad,
        u_m_s,
        v_m_s,
    })
}

proptest! {
    /// A relative-wind recording cut and spliced anywhere reads or is refused naming the file, never
    /// panics.
    #[test]
    fn mutated_relative_wind_recordings_never_panic(at in 0usize..1200, cut in 0usize..40,
            insert in "[0-9a-z_,.\\[\\]\\n -]{0,12}") {
        let mut text: Vec<char> = heading_east_beam_wind("").chars().collect();
        let at = at % (text.len() + 1);
        let end = (at + cut).min(text.len());
        text.splice(at..end, insert.chars());
        let text: String = text.into_iter().collect();
        if let Err(e) = parse_recording(Path::new("fuzz.csv"), &text) {
            prop_assert!(e.to_string().starts_with("fuzz.csv"), "{e}");
        }
    }

    /// relative → true → relative is the identity (speed to 1e-12 m/s, angle to 1e-12 rad where the
    /// relative wind is not near calm, where its angle means nothing).
    #[test]
    fn relative_to_true_and_back(speed in 0.01..30.0f64, angle in -PI..PI, m in motion()) {
        let relative = Wind { speed_m_s: speed, from_rad: angle };
        let back = relative_wind(true_wind(relative, m).unwrap(), m).unwrap();
        let d = (back.from_rad - angle + PI).rem_euclid(2.0 * PI) - PI;
        prop_assert!((back.speed_m_s - speed).abs() < 1e-12 && d.abs() < 1e-12 / speed.min(1.0),
            "{relative:?} on {m:?} back as {back:?}");
    }
}
