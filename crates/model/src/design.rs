//! Design matrices and regression targets (equations of motion in `docs/conventions.md`), in the prime
//! system with the constant U0.
//!
//! With the acceleration derivatives known, each equation of motion gives one target per sample:
//!
//! ```text
//! y_X = (m' − X'_u̇) u̇' − X'_v̇ v̇' − X'_ṙ ṙ' − m' (v' r' + x'_G r'²)
//! y_Y = −Y'_u̇ u̇' + (m' − Y'_v̇) v̇' + (m' x'_G − Y'_ṙ) ṙ' + m' u' r'
//! y_N = −N'_u̇ u̇' + (m' x'_G − N'_v̇) v̇' + (I'_z − N'_ṙ) ṙ' + m' x'_G u' r'
//! ```
//! with u' = 1 + Δu', and y = Φβ where Φ holds the set's monomials of (Δu', v', r', δ). All about midship,
//! rudder positive to starboard (the project's conventions, which `shipid_io` guarantees).

use faer::Mat;
use shipid_io::{Accelerations, AddedMass, PrimeScale, Recording, Ship};

use crate::set::{CoefficientSet, Dof, Known};

/// Rigid-body and added-mass terms in the prime system, about midship.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrimeInertia {
    /// m' = m/(½ρL³).
    pub m: f64,
    /// x'_G = x_G/L.
    pub xg: f64,
    /// I'_z about midship = (I_zG + m x_G²)/(½ρL⁵).
    pub iz: f64,
    pub x_udot: f64,
    pub x_vdot: f64,
    pub x_rdot: f64,
    pub y_udot: f64,
    pub y_vdot: f64,
    pub y_rdot: f64,
    pub n_udot: f64,
    pub n_vdot: f64,
    pub n_rdot: f64,
}

impl PrimeInertia {
    /// The inertia a set uses: acceleration derivatives it does not list as known are zero. The data set
    /// gives X_u̇, Y_v̇, Y_ṙ, N_v̇, N_ṙ; X_v̇, X_ṙ, Y_u̇, N_u̇ vanish by port/starboard symmetry.
    pub fn new(ship: &Ship, added: &AddedMass, set: &CoefficientSet) -> PrimeInertia {
        let s = PrimeScale::of(ship);
        let k = |d: Dof, what: Known, v: f64| if set.knows(d, what) { v } else { 0.0 };
        PrimeInertia {
            m: s.mass_prime(ship.mass_kg()),
            xg: s.length_prime(ship.xg),
            iz: s.inertia_prime(ship.iz_midship_kg_m2()),
            x_udot: k(Dof::X, Known::Udot, s.mass_prime(added.X_udot)),
            x_vdot: 0.0,
            x_rdot: 0.0,
            y_udot: 0.0,
            y_vdot: k(Dof::Y, Known::Vdot, s.mass_prime(added.Y_vdot)),
            y_rdot: k(Dof::Y, Known::Rdot, s.mass_moment_prime(added.Y_rdot)),
            n_udot: 0.0,
            n_vdot: k(Dof::N, Known::Vdot, s.mass_moment_prime(added.N_vdot)),
            n_rdot: k(Dof::N, Known::Rdot, s.inertia_prime(added.N_rdot)),
        }
    }

    /// The mass matrix M (prime) with M a' = f(β) + rigid-body terms.
    pub fn mass_matrix(&self) -> [[f64; 3]; 3] {
        [
            [self.m - self.x_udot, -self.x_vdot, -self.x_rdot],
            [
                -self.y_udot,
                self.m - self.y_vdot,
                self.m * self.xg - self.y_rdot,
            ],
            [
                -self.n_udot,
                self.m * self.xg - self.n_vdot,
                self.iz - self.n_rdot,
            ],
        ]
    }

    /// Rigid-body terms that sit on the force side: [m'(v'r' + x'_G r'²), −m' u' r', −m' x'_G u' r'].
    pub fn rigid_body_forces(&self, du: f64, v: f64, r: f64) -> [f64; 3] {
        let u = 1.0 + du;
        [
            self.m * (v * r + self.xg * r * r),
            -self.m * u * r,
            -self.m * self.xg * u * r,
        ]
    }

    /// ∂/∂(Δu', v', r') of [`PrimeInertia::rigid_body_forces`]: row = force, column = variable.
    pub fn rigid_body_force_gradients(&self, du: f64, v: f64, r: f64) -> [[f64; 3]; 3] {
        let u = 1.0 + du;
        let m = self.m;
        [
            [0.0, m * r, m * (v + 2.0 * self.xg * r)],
            [-m * r, 0.0, -m * u],
            [-m * self.xg * r, 0.0, -m * self.xg * u],
        ]
    }
}

/// Primed samples of one or more recordings, stacked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Samples {
    pub du: Vec<f64>,
    pub v: Vec<f64>,
    pub r: Vec<f64>,
    /// Rudder angle [rad] (an angle is already dimensionless).
    pub delta: Vec<f64>,
    pub u_dot: Vec<f64>,
    pub v_dot: Vec<f64>,
    pub r_dot: Vec<f64>,
    /// Index of the recording each sample came from (for blocked cross-validation by recording).
    pub group: Vec<usize>,
    /// Time of each sample in its recording [s].
    pub t: Vec<f64>,
}

impl Samples {
    pub fn len(&self) -> usize {
        self.du.len()
    }

    pub fn is_empty(&self) -> bool {
        self.du.is_empty()
    }

    /// Append a recording (already windowed) with its accelerations (SI, midship).
    pub fn push(&mut self, rec: &Recording, acc: &Accelerations, scale: &PrimeScale, group: usize) {
        for i in 0..rec.len() {
            let [du, v, r, delta] = primed_state(rec, scale, i);
            self.du.push(du);
            self.v.push(v);
            self.r.push(r);
            self.delta.push(delta);
            self.u_dot.push(scale.acceleration_prime(acc.u_dot[i]));
            self.v_dot.push(scale.acceleration_prime(acc.v_dot[i]));
            self.r_dot.push(scale.yaw_acceleration_prime(acc.r_dot[i]));
            self.group.push(group);
            self.t.push(rec.t[i]);
        }
    }
}

/// The primed state (Δu′, v′, r′, δ [rad]) of sample `i`: the regressors of the design matrices and
/// the coordinates of the identification range.
pub fn primed_state(rec: &Recording, scale: &PrimeScale, i: usize) -> [f64; 4] {
    [
        scale.delta_u_prime(rec.u[i]),
        scale.velocity_prime(rec.v[i]),
        scale.yaw_rate_prime(rec.r[i]),
        rec.delta[i],
    ]
}

/// The regression problem of one degree of freedom.
#[derive(Debug, Clone)]
pub struct Design {
    pub dof: Dof,
    /// Coefficient names, one per column.
    pub names: Vec<String>,
    /// Φ, n × p.
    pub phi: Mat<f64>,
    /// Targets y, length n.
    pub y: Vec<f64>,
    /// Bounds per coefficient from the set.
    pub bounds: Vec<(f64, f64)>,
}

/// Φ and y of one DOF.
pub fn design(set: &CoefficientSet, dof: Dof, s: &Samples, inertia: &PrimeInertia) -> Design {
    let terms = &set.terms[dof.index()];
    let n = s.len();
    let phi = Mat::from_fn(n, terms.len(), |i, j| {
        terms[j].eval(s.du[i], s.v[i], s.r[i], s.delta[i])
    });
    let m = inertia.mass_matrix()[dof.index()];
    let y = (0..n)
        .map(|i| {
            let inertial = m[0] * s.u_dot[i] + m[1] * s.v_dot[i] + m[2] * s.r_dot[i];
            inertial - inertia.rigid_body_forces(s.du[i], s.v[i], s.r[i])[dof.index()]
        })
        .collect();
    Design {
        dof,
        names: set.names(dof),
        phi,
        y,
        bounds: set.bounds[dof.index()].clone(),
    }
}

/// Per-term force contributions φ_k β_k over the samples (paper 000 Fig. 12/19): one column per term.
pub fn contributions(d: &Design, beta: &[f64]) -> Mat<f64> {
    Mat::from_fn(d.phi.nrows(), d.phi.ncols(), |i, j| d.phi[(i, j)] * beta[j])
}
