//! The propeller and rudder data an MMG model needs besides the ship's main particulars: known, not
//! identified. No I/O.

use serde::{Deserialize, Serialize};
use shipid_io::Dataset;

use crate::error::{PipelineError, bad_input};

/// Propeller and rudder of the ship (model scale when the recordings are model tests), midship origin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MmgGeometry {
    /// D_P [m].
    pub propeller_diameter_m: f64,
    /// Longitudinal propeller position x_P [m], negative aft of midship.
    pub propeller_x_m: f64,
    /// Open-water K_T(J) = k0 + k1 J + k2 J² [-].
    pub k_t: [f64; 3],
    /// A_R [m²].
    pub rudder_area_m2: f64,
    /// H_R [m].
    pub rudder_span_m: f64,
    /// Longitudinal rudder position x_R [m], negative aft of midship.
    pub rudder_x_m: f64,
}

impl MmgGeometry {
    /// KVLCC2 at model scale L = 7.00 m: Yasukawa & Yoshimura (2015) Tables 1 and 5.
    pub fn kvlcc2_model_scale() -> MmgGeometry {
        MmgGeometry {
            propeller_diameter_m: 0.216,
            propeller_x_m: -0.48 * 7.0,
            k_t: [0.2931, -0.2753, -0.1385],
            rudder_area_m2: 0.0539,
            rudder_span_m: 0.345,
            rudder_x_m: -0.5 * 7.0,
        }
    }

    /// The data set's `[propeller]` and `[rudder]` tables.
    pub fn of_dataset(ds: &Dataset) -> Result<MmgGeometry, PipelineError> {
        let missing = |table: &str, what: &str| {
            bad_input(format!(
                "{}: no [{table}] table; the mmg family needs the {what} (docs/mmg.md)",
                ds.path.display()
            ))
        };
        let p = ds
            .propeller
            .as_ref()
            .ok_or_else(|| missing("propeller", "propeller diameter, position and K_T(J)"))?;
        let r = ds
            .rudder
            .as_ref()
            .ok_or_else(|| missing("rudder", "rudder area, span and position"))?;
        let g = MmgGeometry {
            propeller_diameter_m: p.diameter_m,
            propeller_x_m: p.x_m,
            k_t: p.k_t,
            rudder_area_m2: r.area_m2,
            rudder_span_m: r.span_m,
            rudder_x_m: r.x_m,
        };
        g.check(
            ds.ship.lpp,
            &format!("{}: [propeller]/[rudder]", ds.path.display()),
        )?;
        Ok(g)
    }

    /// Positive sizes, positions within the ship, a thrust curve with positive bollard thrust.
    pub fn check(&self, lpp_m: f64, what: &str) -> Result<(), PipelineError> {
        for (key, value) in [
            ("propeller_diameter_m", self.propeller_diameter_m),
            ("rudder_area_m2", self.rudder_area_m2),
            ("rudder_span_m", self.rudder_span_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(bad_input(format!(
                    "{what}: `{key}` must be a positive number, not {value}"
                )));
            }
        }
        for (key, value) in [
            ("propeller_x_m", self.propeller_x_m),
            ("rudder_x_m", self.rudder_x_m),
        ] {
            if !(value.is_finite() && value.abs() <= lpp_m) {
                return Err(bad_input(format!(
                    "{what}: `{key}` must be a position within the ship length {lpp_m} m, not {value}"
                )));
            }
        }
        if !self.k_t.iter().all(|k| k.is_finite()) || self.k_t[0] <= 0.0 {
            return Err(bad_input(format!(
                "{what}: `k_t` must be three finite numbers with K_T(0) > 0, not {:?}",
                self.k_t
            )));
        }
        Ok(())
    }
}
