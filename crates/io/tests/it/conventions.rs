//! Reading good files: unit suffixes, comments, heading unwrapping, `origin = "cg"` and `rudder_sign`.

use std::path::Path;

use shipid_io::dataset::{added_mass_cg_to_midship, cg_to_midship};
use shipid_io::recording::read_recording;
use shipid_io::{AddedMass, Dataset, Manoeuvre, Side};

const DEG: f64 = std::f64::consts::PI / 180.0;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn unit_suffixes_convert_to_si_and_heading_is_unwrapped() {
    let rec = read_recording(Path::new("tests/fixtures/good/units_wrapped_heading.csv")).unwrap();
    assert_eq!(rec.len(), 30);
    assert!(close(rec.t[1], 0.1, 1e-12), "ms → s");
    assert!(close(rec.r[0], 1.0 * DEG, 1e-12), "deg/s → rad/s");
    assert!(close(rec.delta[0], 10.0 * DEG, 1e-12), "deg → rad");
    // 175°, 176°, … crosses ±180° in the file; unwrapped it keeps climbing one degree per sample.
    for w in rec.psi.windows(2) {
        assert!(
            close(w[1] - w[0], DEG, 1e-9),
            "heading step {}",
            w[1] - w[0]
        );
    }
    assert!(close(rec.psi[29], 204.0 * DEG, 1e-9));
}

#[test]
fn cg_origin_and_sname_rudder_are_converted_to_midship_and_starboard_positive() {
    let path = Path::new("tests/fixtures/good/cg_sname.toml");
    let ds = Dataset::load(path).unwrap();
    let raw = read_recording(Path::new("tests/fixtures/good/cg_turn.csv")).unwrap();
    let rec = &ds.recordings[0].recording;
    let xg = ds.ship.xg;
    assert_eq!(
        ds.recordings[0].manoeuvre,
        Manoeuvre::Turning {
            rudder_deg: 35.0,
            side: Side::Starboard
        }
    );
    for i in 0..rec.len() {
        assert!(
            close(rec.delta[i], -raw.delta[i], 1e-15),
            "rudder sign flipped"
        );
        assert!(close(rec.u[i], raw.u[i], 1e-15));
        assert!(
            close(rec.v[i], raw.v[i] - xg * raw.r[i], 1e-12),
            "v at midship"
        );
        let (s, c) = raw.psi[i].sin_cos();
        assert!(close(rec.x0[i], raw.x0[i] - xg * c, 1e-12));
        assert!(close(rec.y0[i], raw.y0[i] - xg * s, 1e-12));
    }
    let a = ds.added_mass.unwrap();
    assert!(close(a.Y_rdot, xg * -2513.0, 1e-9));
    assert!(close(a.N_vdot, xg * -2513.0, 1e-9));
    assert!(close(a.N_rdot, -6074.5 + xg * xg * -2513.0, 1e-9));
}

#[test]
fn cg_to_midship_keeps_the_rigid_body_kinematics_consistent() {
    // A ship turning on a circle about the origin: velocity of any hull point is r × its position.
    // Converting the centre of gravity's track to midship must give midship's own velocity.
    let r = 0.05;
    let radius = 20.0;
    let xg = 0.25;
    let n = 50;
    let mut rec = shipid_io::Recording::default();
    for i in 0..n {
        let t = i as f64 * 0.5;
        let psi = r * t;
        // G moves on the circle, heading tangent: x0 = R sin ψ, y0 = R (1 − cos ψ) (turn to starboard).
        rec.t.push(t);
        rec.x0.push(radius * psi.sin());
        rec.y0.push(radius * (1.0 - psi.cos()));
        rec.psi.push(psi);
        rec.u.push(r * radius);
        rec.v.push(0.0);
        rec.r.push(r);
        rec.delta.push(0.0);
    }
    let mut mid = rec.clone();
    cg_to_midship(&mut mid, xg);
    for i in 1..n - 1 {
        // Earth velocity of midship from its track, rotated into body axes, equals (u, v_mid).
        let dt = mid.t[i + 1] - mid.t[i - 1];
        let xd = (mid.x0[i + 1] - mid.x0[i - 1]) / dt;
        let yd = (mid.y0[i + 1] - mid.y0[i - 1]) / dt;
        let (s, c) = mid.psi[i].sin_cos();
        let v_body = -xd * s + yd * c;
        let u_body = xd * c + yd * s;
        assert!(close(v_body, mid.v[i], 1e-3), "{v_body} vs {}", mid.v[i]);
        assert!(close(u_body, mid.u[i], 1e-3));
    }
    assert!(close(mid.v[0], -xg * r, 1e-15));
}

#[test]
fn added_mass_shift_is_identity_at_zero_and_composes() {
    let a = AddedMass {
        X_udot: -250.0,
        Y_vdot: -2500.0,
        Y_rdot: 10.0,
        N_vdot: 12.0,
        N_rdot: -6000.0,
    };
    assert_eq!(added_mass_cg_to_midship(a, 0.0), a);
    let two_steps = added_mass_cg_to_midship(added_mass_cg_to_midship(a, 0.1), 0.15);
    let one_step = added_mass_cg_to_midship(a, 0.25);
    assert!(close(two_steps.N_rdot, one_step.N_rdot, 1e-9));
    assert!(close(two_steps.Y_rdot, one_step.Y_rdot, 1e-9));
}

/// A sea trial's GNSS antenna (`origin = "point"`, `[reference_point]`): midship's own motion,
/// recorded at a hull point (x, y) from midship and converted back, comes out as it was.
#[test]
fn a_hull_point_converts_to_midship_on_a_turning_ship() {
    use shipid_io::dataset::point_to_midship;
    let check = |x_m: f64, y_m: f64| {
        // Midship on a circle to starboard with drift: u, v constant in body axes, r constant.
        let (u, v, r) = (7.5, -0.9, 0.012);
        let n = 200;
        let mut midship = shipid_io::Recording::default();
        let (mut x0, mut y0) = (100.0, -40.0);
        for i in 0..n {
            let t = i as f64 * 0.25;
            let psi = 0.3 + r * t;
            if i > 0 {
                // Exact integration of the earth velocity over a step at constant body velocity.
                let dt = 0.25;
                let p0 = psi - r * dt;
                let (s1, c1) = psi.sin_cos();
                let (s0, c0) = p0.sin_cos();
                x0 += (u * (s1 - s0) + v * (c1 - c0)) / r;
                y0 += (-u * (c1 - c0) + v * (s1 - s0)) / r;
            }
            midship.t.push(t);
            midship.x0.push(x0);
            midship.y0.push(y0);
            midship.psi.push(psi);
            midship.u.push(u);
            midship.v.push(v);
            midship.r.push(r);
            midship.delta.push(0.0);
        }
        // The point's record: midship's position plus (x, y) turned by ψ; its velocity (u − r y, v + r x).
        let mut at_point = midship.clone();
        for i in 0..n {
            let (s, c) = midship.psi[i].sin_cos();
            at_point.x0[i] += x_m * c - y_m * s;
            at_point.y0[i] += x_m * s + y_m * c;
            at_point.u[i] -= r * y_m;
            at_point.v[i] += r * x_m;
        }
        // The point's velocities are its track's own (rigid-body motion), checked before converting.
        let k = n / 2;
        let dt = at_point.t[k + 1] - at_point.t[k - 1];
        let xd = (at_point.x0[k + 1] - at_point.x0[k - 1]) / dt;
        let yd = (at_point.y0[k + 1] - at_point.y0[k - 1]) / dt;
        let (s, c) = at_point.psi[k].sin_cos();
        assert!(
            close(xd * c + yd * s, at_point.u[k], 1e-3)
                && close(-xd * s + yd * c, at_point.v[k], 1e-3),
            "point ({x_m}, {y_m}): track and velocities disagree"
        );
        point_to_midship(&mut at_point, x_m, y_m);
        for i in 0..n {
            for (a, b, what) in [
                (at_point.x0[i], midship.x0[i], "x0"),
                (at_point.y0[i], midship.y0[i], "y0"),
                (at_point.u[i], midship.u[i], "u"),
                (at_point.v[i], midship.v[i], "v"),
            ] {
                assert!(
                    close(a, b, 1e-9),
                    "point ({x_m}, {y_m}), sample {i}: {what} {a} vs {b}"
                );
            }
        }
        // The velocities agree with the track's own: the point's conversion is rigid-body motion.
        let i = n / 2;
        let dt = midship.t[i + 1] - midship.t[i - 1];
        let xd = (midship.x0[i + 1] - midship.x0[i - 1]) / dt;
        let yd = (midship.y0[i + 1] - midship.y0[i - 1]) / dt;
        let (s, c) = midship.psi[i].sin_cos();
        assert!(close(xd * c + yd * s, u, 1e-3) && close(-xd * s + yd * c, v, 1e-3));
    };
    check(-130.0, 5.0);
    check(40.0, -7.5);
    check(0.0, 0.0);
}
