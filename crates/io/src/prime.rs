//! The prime system I of paper 000 §2.1 (table in `docs/conventions.md`): everything is made dimensionless with the
//! constant approach speed U0, the length L and the density ρ. Froude-similar model and full scale share
//! every primed value. Each `*_prime` has its inverse `*_from_prime`.

use crate::types::Ship;

/// Scales of the prime system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrimeScale {
    /// Length between perpendiculars L [m].
    pub lpp_m: f64,
    /// Approach speed U0 [m/s].
    pub u0_m_s: f64,
    /// Water density ρ [kg/m³].
    pub rho_kg_m3: f64,
}

macro_rules! scale_pair {
    ($(#[$doc:meta])* $to:ident, $from:ident, |$s:ident| $factor:expr) => {
        $(#[$doc])*
        pub fn $to(&self, x: f64) -> f64 {
            let $s = self;
            x / $factor
        }
        /// Inverse of the function above it.
        pub fn $from(&self, x: f64) -> f64 {
            let $s = self;
            x * $factor
        }
    };
}

impl PrimeScale {
    pub fn of(ship: &Ship) -> PrimeScale {
        PrimeScale {
            lpp_m: ship.lpp,
            u0_m_s: ship.u0,
            rho_kg_m3: ship.rho,
        }
    }

    fn half_rho(&self) -> f64 {
        0.5 * self.rho_kg_m3
    }

    /// Δu' = (u − U0)/U0.
    pub fn delta_u_prime(&self, u_m_s: f64) -> f64 {
        (u_m_s - self.u0_m_s) / self.u0_m_s
    }
    /// u [m/s] from Δu'.
    pub fn u_from_delta_u_prime(&self, du: f64) -> f64 {
        self.u0_m_s * (1.0 + du)
    }

    scale_pair!(/// v' = v/U0 (also for any velocity).
        velocity_prime, velocity_from_prime, |s| s.u0_m_s);
    scale_pair!(/// r' = r L/U0.
        yaw_rate_prime, yaw_rate_from_prime, |s| s.u0_m_s / s.lpp_m);
    scale_pair!(/// t' = t U0/L.
        time_prime, time_from_prime, |s| s.lpp_m / s.u0_m_s);
    scale_pair!(/// x' = x/L (lengths, positions, x_G).
        length_prime, length_from_prime, |s| s.lpp_m);
    scale_pair!(/// u̇' = u̇ L/U0² (also v̇).
        acceleration_prime, acceleration_from_prime, |s| s.u0_m_s * s.u0_m_s / s.lpp_m);
    scale_pair!(/// ṙ' = ṙ L²/U0².
        yaw_acceleration_prime, yaw_acceleration_from_prime, |s| (s.u0_m_s / s.lpp_m).powi(2));
    scale_pair!(/// m' = m/(½ρL³) (also X_u̇, Y_v̇).
        mass_prime, mass_from_prime, |s| s.half_rho() * s.lpp_m.powi(3));
    scale_pair!(/// Y'_ṙ = Y_ṙ/(½ρL⁴) (also N_v̇, first mass moments such as m x_G).
        mass_moment_prime, mass_moment_from_prime, |s| s.half_rho() * s.lpp_m.powi(4));
    scale_pair!(/// I'_z = I_z/(½ρL⁵) (also N_ṙ).
        inertia_prime, inertia_from_prime, |s| s.half_rho() * s.lpp_m.powi(5));
    scale_pair!(/// X' = X/(½ρL²U0²) (also Y).
        force_prime, force_from_prime, |s| s.half_rho() * s.lpp_m.powi(2) * s.u0_m_s.powi(2));
    scale_pair!(/// N' = N/(½ρL³U0²).
        moment_prime, moment_from_prime, |s| s.half_rho() * s.lpp_m.powi(3) * s.u0_m_s.powi(2));
}
