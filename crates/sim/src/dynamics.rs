//! The state of a ship in 3 DOF and the trait every manoeuvring model implements.

use shipid_io::{AddedMass, Ship};
use thiserror::Error;

/// Motion state of the **midship** point in the project's conventions (`docs/conventions.md`):
/// body axes x forward / y starboard, earth axes x0 north / y0 east, heading and yaw rate positive to
/// starboard, SI units.
///
/// Velocities are over ground. Without a current (one of the effects of the `effects` module) they are
/// also the velocities through the water that a hydrodynamic model sees.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct State {
    /// Surge velocity [m/s].
    pub u: f64,
    /// Sway velocity of midship [m/s], positive to starboard.
    pub v: f64,
    /// Yaw rate [rad/s], positive to starboard.
    pub r: f64,
    /// North position of midship [m].
    pub x0: f64,
    /// East position of midship [m].
    pub y0: f64,
    /// Heading [rad], unwrapped, positive to starboard (0 = north).
    pub psi: f64,
}

impl State {
    /// The recorded state at sample `i` (panics if `i` is out of range: callers index their own samples).
    pub fn of_recording(rec: &shipid_io::Recording, i: usize) -> State {
        State {
            u: rec.u[i],
            v: rec.v[i],
            r: rec.r[i],
            x0: rec.x0[i],
            y0: rec.y0[i],
            psi: rec.psi[i],
        }
    }

    /// Straight steady approach at `u_m_s` along north from the origin.
    pub fn approach(u_m_s: f64) -> State {
        State {
            u: u_m_s,
            ..State::default()
        }
    }

    /// Speed of midship [m/s].
    pub fn speed(&self) -> f64 {
        self.u.hypot(self.v)
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.to_array().iter().all(|x| x.is_finite())
    }

    /// Time derivative of the earth-fixed pose: [ẋ0, ẏ0, ψ̇] with ẋ0 = u cosψ − v sinψ,
    /// ẏ0 = u sinψ + v cosψ, ψ̇ = r.
    pub fn kinematics(&self) -> [f64; 3] {
        let (s, c) = self.psi.sin_cos();
        [self.u * c - self.v * s, self.u * s + self.v * c, self.r]
    }

    /// `[u, v, r, x0, y0, psi]`.
    pub fn to_array(&self) -> [f64; 6] {
        [self.u, self.v, self.r, self.x0, self.y0, self.psi]
    }

    /// Inverse of [`State::to_array`].
    pub fn from_array(a: [f64; 6]) -> State {
        State {
            u: a[0],
            v: a[1],
            r: a[2],
            x0: a[3],
            y0: a[4],
            psi: a[5],
        }
    }
}

/// Why a model could not give accelerations for a state.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DynamicsError {
    /// The model is non-dimensionalised with the instantaneous speed and undefined at rest.
    #[error("speed {speed_m_s} m/s is below the model's validity limit of {limit_m_s} m/s")]
    SpeedTooLow { speed_m_s: f64, limit_m_s: f64 },
    /// The propeller turns astern: the MMG propeller model (an open-water curve for ahead) has no
    /// thrust for it, and evaluating the ahead curve at n < 0 gives forward thrust.
    #[error(
        "the propeller turns astern (n = {n_hz} 1/s): the MMG propeller model is for ahead (its open-water curve has no astern quadrant), so it has no forces for astern"
    )]
    PropellerAstern { n_hz: f64 },
    /// The state is outside the model's domain for another reason.
    #[error("model cannot be evaluated: {0}")]
    OutOfDomain(String),
}

/// Linear hull damping derivatives in the MMG non-dimensionalisation (Yasukawa & Yoshimura 2015):
/// Y' = Y / (½ρ L d U²), N' = N / (½ρ L² d U²), v' = v/U, r' = r L/U with the instantaneous speed U.
///
/// Used by effects that scale a model's sway and yaw damping (shallow water).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearHullDerivatives {
    /// Y'_v [-].
    pub y_v: f64,
    /// Y'_r [-].
    pub y_r: f64,
    /// N'_v [-].
    pub n_v: f64,
    /// N'_r [-].
    pub n_r: f64,
}

/// The known inputs that drive a model at one instant besides its state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Input {
    /// Simulation time [s]: what a recorded wind or current is read at.
    pub t_s: f64,
    /// The rudder angle acting on the hull [rad], positive turns the ship to starboard.
    pub delta_rad: f64,
    /// A propeller rate [1/s] other than the model's own (a recorded one); `None`: the model's own.
    /// Models that do not take the rate ([`Dynamics::takes_propeller_rate`]) ignore it.
    pub propeller_rate_hz: Option<f64>,
}

impl Input {
    /// The rudder alone, at time 0 and the model's own propeller rate.
    pub fn rudder(delta_rad: f64) -> Input {
        Input {
            t_s: 0.0,
            delta_rad,
            propeller_rate_hz: None,
        }
    }
}

/// A 3-DOF manoeuvring model: body-axis accelerations of midship for a state and the known inputs
/// (time, rudder angle acting on the hull, propeller rate).
///
/// The MMG reference model implements it; so can an identified Abkowitz model or a Gaussian-process
/// model of the accelerations. Models are expected to be linear in the accelerations with the rigid-body
/// plus added-mass matrix of [`Dynamics::ship`] and [`Dynamics::added_mass`] (see [`MassMatrix`]); effects
/// that add external forces rely on this.
///
/// A model that wraps another (an environment, physical effects, a recorded propeller rate) names it
/// in [`Dynamics::wrapped`]: every optional method it does not override then answers as the wrapped
/// model does, so a wrapper states only what it changes.
pub trait Dynamics {
    /// `[u̇, v̇, ṙ]` [m/s², m/s², rad/s²] of midship for `state` and `input`: the one method a
    /// model implements; a simulation calls it at every RK4 stage. An `Err` ends a simulation as
    /// diverged.
    fn accelerations_for(&self, state: &State, input: &Input) -> Result<[f64; 3], DynamicsError>;

    /// [`Dynamics::accelerations_for`] with the rudder alone (time 0, the model's own propeller rate).
    fn accelerations(&self, state: &State, delta_rad: f64) -> Result<[f64; 3], DynamicsError> {
        self.accelerations_for(state, &Input::rudder(delta_rad))
    }

    /// [`Dynamics::accelerations_for`] at simulation time `t_s` [s] and the model's own propeller rate.
    fn accelerations_at(
        &self,
        t_s: f64,
        state: &State,
        delta_rad: f64,
    ) -> Result<[f64; 3], DynamicsError> {
        self.accelerations_for(
            state,
            &Input {
                t_s,
                delta_rad,
                propeller_rate_hz: None,
            },
        )
    }

    /// [`Dynamics::accelerations_for`] at `t_s` [s] with the propeller turning at `n_hz` [1/s].
    fn accelerations_at_rate(
        &self,
        t_s: f64,
        state: &State,
        delta_rad: f64,
        n_hz: f64,
    ) -> Result<[f64; 3], DynamicsError> {
        self.accelerations_for(
            state,
            &Input {
                t_s,
                delta_rad,
                propeller_rate_hz: Some(n_hz),
            },
        )
    }

    /// The model this one wraps, for the optional methods below that it does not override; `None`
    /// for a model of its own.
    fn wrapped(&self) -> Option<&dyn Dynamics> {
        None
    }

    /// Whether the model's forces take the propeller rate as an input (the MMG model's thrust and
    /// rudder slipstream): a recorded rate then drives it through [`Input::propeller_rate_hz`]
    /// ([`crate::WithPropellerRate`]). Models without that input were identified at one rate and
    /// keep it.
    fn takes_propeller_rate(&self) -> bool {
        self.wrapped().is_some_and(|m| m.takes_propeller_rate())
    }

    /// The ship the model describes.
    fn ship(&self) -> &Ship;

    /// Added-mass derivatives about midship (SI, negative numbers).
    fn added_mass(&self) -> &AddedMass;

    /// Propeller rate [1/s] when the model has one (it is then written to the recording's `n`).
    fn propeller_rate_hz(&self) -> Option<f64> {
        self.wrapped().and_then(|m| m.propeller_rate_hz())
    }

    /// The model's own linear hull damping derivatives, when it has them in this form.
    fn linear_hull_derivatives(&self) -> Option<LinearHullDerivatives> {
        self.wrapped().and_then(|m| m.linear_hull_derivatives())
    }

    /// The filter between the recorded and the acting rudder that is part of this model (a steering-gear
    /// lag or a neutral offset found by `shipid diagnose`); a fresh one per simulation. `None`: the
    /// recorded rudder acts as it is.
    fn model_rudder_filter(&self) -> Option<Box<dyn RudderFilter>> {
        self.wrapped().and_then(|m| m.model_rudder_filter())
    }

    /// The over-ground state of a ship moving through the water with `through_water` (they differ when
    /// the model includes a current).
    fn over_ground(&self, through_water: &State) -> State {
        self.wrapped()
            .map_or(*through_water, |m| m.over_ground(through_water))
    }

    /// Velocity [north, east] [m/s] at simulation time `t_s` of the uniform current this model carries
    /// the ship in (a `current` effect, a recorded or given current), summed over the wrappers that
    /// add one; `None` when the model has none. A simulation records it, so that its metrics are
    /// taken relative to the water (`docs/conventions.md`, "Wind and current").
    fn current_velocity_earth(&self, t_s: f64) -> Option<[f64; 2]> {
        self.wrapped().and_then(|m| m.current_velocity_earth(t_s))
    }

    /// The identification range this model carries with it (a sparse GP's coverage by its sparse
    /// points); `None` for models whose range needs their training data (a polynomial's leverage,
    /// computed from the data its model file names) or that have none (the reference model).
    fn own_range(&self) -> Option<&dyn OwnRange> {
        self.wrapped().and_then(|m| m.own_range())
    }
}

/// An identification range a model carries with it, tested one state at a time.
pub trait OwnRange: Send + Sync {
    /// Whether the state (u [m/s], v [m/s], r [rad/s], δ [rad]) lies where the model was identified.
    fn covers(&self, u: f64, v: f64, r: f64, delta_rad: f64) -> bool;
    /// What "outside" means, for explanations to the user.
    fn criterion(&self) -> &'static str;
}

/// Turns the rudder as recorded into the rudder that acts on the hull (an actuator lag, a neutral
/// offset…). The simulation loop applies one between the controller and the model: the model's own
/// ([`Dynamics::model_rudder_filter`]), the rudder effects' (lag, delay, neutral offset) or the identity
/// ([`NoFilter`]) for plain simulations.
pub trait RudderFilter {
    /// Effective rudder angles [rad] at the RK4 stage times `t_s`, `t_s + dt_s/2`, `t_s + dt_s` given the
    /// recorded angles there. Called once per step in time order (`dt_s` may be 0 for a single
    /// evaluation at the start); advances the filter's state to `t_s + dt_s`.
    fn step(&mut self, t_s: f64, dt_s: f64, recorded_rad: [f64; 3]) -> [f64; 3];
}

/// The identity [`RudderFilter`].
#[derive(Debug, Clone, Copy, Default)]
pub struct NoFilter;

impl RudderFilter for NoFilter {
    fn step(&mut self, _t_s: f64, _dt_s: f64, recorded_rad: [f64; 3]) -> [f64; 3] {
        recorded_rad
    }
}

/// A pointer to a model is the model: every method passes through, so that boxes and references keep
/// the time, the propeller rate and the range of what they point to. (A pointer to an unsized model
/// cannot name it as [`Dynamics::wrapped`], so each optional method is forwarded here.)
macro_rules! forward_dynamics {
    ($($pointer:ty),*) => {$(
        impl<T: Dynamics + ?Sized> Dynamics for $pointer {
            fn accelerations_for(
                &self,
                state: &State,
                input: &Input,
            ) -> Result<[f64; 3], DynamicsError> {
                (**self).accelerations_for(state, input)
            }
            fn takes_propeller_rate(&self) -> bool {
                (**self).takes_propeller_rate()
            }
            fn own_range(&self) -> Option<&dyn OwnRange> {
                (**self).own_range()
            }
            fn ship(&self) -> &Ship {
                (**self).ship()
            }
            fn added_mass(&self) -> &AddedMass {
                (**self).added_mass()
            }
            fn propeller_rate_hz(&self) -> Option<f64> {
                (**self).propeller_rate_hz()
            }
            fn linear_hull_derivatives(&self) -> Option<LinearHullDerivatives> {
                (**self).linear_hull_derivatives()
            }
            fn model_rudder_filter(&self) -> Option<Box<dyn RudderFilter>> {
                (**self).model_rudder_filter()
            }
            fn over_ground(&self, through_water: &State) -> State {
                (**self).over_ground(through_water)
            }
            fn current_velocity_earth(&self, t_s: f64) -> Option<[f64; 2]> {
                (**self).current_velocity_earth(t_s)
            }
        }
    )*};
}

forward_dynamics!(&T, Box<T>);

/// Rigid-body plus added-mass matrix about midship (the left-hand side of the equations of motion in
/// `docs/conventions.md`, with X_v̇ = X_ṙ = Y_u̇ = N_u̇ = 0):
///
/// ```text
/// | m − X_u̇        0              0        |
/// |   0        m − Y_v̇      m x_G − Y_ṙ    |
/// |   0      m x_G − N_v̇    I_z − N_ṙ      |
/// ```
/// with I_z = I_zG + m x_G² about midship.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassMatrix {
    /// Surge entry [kg].
    pub m11: f64,
    /// Sway–sway [kg].
    pub m22: f64,
    /// Sway–yaw [kg m].
    pub m23: f64,
    /// Yaw–sway [kg m].
    pub m32: f64,
    /// Yaw–yaw [kg m²].
    pub m33: f64,
}

impl MassMatrix {
    /// The matrix of `ship` with `added_mass` about midship.
    pub fn new(ship: &Ship, added_mass: &AddedMass) -> MassMatrix {
        let m = ship.mass_kg();
        MassMatrix {
            m11: m - added_mass.X_udot,
            m22: m - added_mass.Y_vdot,
            m23: m * ship.xg - added_mass.Y_rdot,
            m32: m * ship.xg - added_mass.N_vdot,
            m33: ship.iz_midship_kg_m2() - added_mass.N_rdot,
        }
    }

    /// Accelerations `M⁻¹ [X, Y, N]`; `None` when the matrix is singular.
    pub fn solve(&self, force: [f64; 3]) -> Option<[f64; 3]> {
        let det = self.m22 * self.m33 - self.m23 * self.m32;
        if self.m11 == 0.0 || det == 0.0 || !det.is_finite() {
            return None;
        }
        Some([
            force[0] / self.m11,
            (self.m33 * force[1] - self.m23 * force[2]) / det,
            (self.m22 * force[2] - self.m32 * force[1]) / det,
        ])
    }

    /// `M a`.
    pub fn times(&self, acc: [f64; 3]) -> [f64; 3] {
        [
            self.m11 * acc[0],
            self.m22 * acc[1] + self.m23 * acc[2],
            self.m32 * acc[1] + self.m33 * acc[2],
        ]
    }
}

/// A model whose accelerations depend on a parameter vector θ that an output-error fit adjusts
/// (`shipid_pipeline::refine`): the Abkowitz polynomial (θ = its coefficients) and any physics-based
/// family that implements it.
///
/// The refinement integrates the sensitivities of a replay, S = ∂x/∂θ, alongside the state with
/// the same RK4 stages (which gives the exact Jacobian of the discretised replay), so it needs at each
/// stage ∂a/∂(u, v, r) and ∂a/∂θ. A model that knows them (the Abkowitz polynomial is linear in θ)
/// overrides [`Parametric::sensitivities`] and says so in [`Parametric::analytic_sensitivities`];
/// any other gets [`FiniteDifferences`], whose perturbed models are built once per replay, not at every
/// stage.
pub trait Parametric: Dynamics + Clone + Send + Sync {
    /// The parameter vector θ.
    fn parameters(&self) -> Vec<f64>;

    /// The same model with parameters `theta` (as long as [`Parametric::parameters`]); `None` when
    /// they make no valid model.
    fn with_parameters(&self, theta: &[f64]) -> Option<Self>;

    /// Lower and upper bound of each parameter (−∞/+∞ when free, the default).
    fn parameter_bounds(&self) -> Vec<(f64, f64)> {
        vec![(f64::NEG_INFINITY, f64::INFINITY); self.parameters().len()]
    }

    /// The step of each parameter that changes the accelerations by their own size on `states`
    /// (state, rudder [rad]) — the refinement works in these units so that every parameter matters
    /// on the same scale; `None` for a parameter the states do not move (it stays where it is).
    /// Default: 1 / RMS over the states of ‖∂a/∂θ_j ⊘ rms(a)‖.
    fn parameter_units(&self, states: &[(State, f64)]) -> Vec<Option<f64>> {
        let k = self.parameters().len();
        let fd = (!self.analytic_sensitivities()).then(|| FiniteDifferences::new(self, 0..k));
        let mut d_theta = vec![[0.0; 3]; k];
        let mut d_state = [[0.0; 3]; 3];
        let mut acc_sq = [0.0; 3];
        let mut col_sq = vec![[0.0; 3]; k];
        let mut n = 0.0;
        for (s, delta) in states {
            let a = match &fd {
                Some(fd) => fd.sensitivities(s, *delta, &mut d_state, &mut d_theta),
                None => self.sensitivities(s, *delta, &mut d_state, &mut d_theta),
            };
            let Ok(a) = a else {
                continue;
            };
            if !a
                .iter()
                .chain(d_theta.iter().flatten())
                .all(|x| x.is_finite())
            {
                continue;
            }
            n += 1.0;
            (0..3).for_each(|i| acc_sq[i] += a[i] * a[i]);
            for (sq, d) in col_sq.iter_mut().zip(&d_theta) {
                (0..3).for_each(|i| sq[i] += d[i] * d[i]);
            }
        }
        col_sq
            .iter()
            .map(|sq| {
                let relative: f64 = (0..3)
                    .filter(|&i| acc_sq[i] > 0.0)
                    .map(|i| sq[i] / acc_sq[i])
                    .sum();
                (n > 0.0 && relative > 1e-24 && relative.is_finite()).then(|| 1.0 / relative.sqrt())
            })
            .collect()
    }

    /// Whether [`Parametric::sensitivities`] is analytic (overridden); otherwise the refinement
    /// differentiates through [`FiniteDifferences`] built once per replay.
    fn analytic_sensitivities(&self) -> bool {
        false
    }

    /// [`Dynamics::accelerations`] with `d_state[i][k]` = ∂a_i/∂x_k for x = (u [m/s], v [m/s],
    /// r [rad/s]) and `d_theta[j]` = ∂a/∂θ_j (`d_theta` as long as θ). Default: [`FiniteDifferences`]
    /// over every parameter, built for this one call.
    fn sensitivities(
        &self,
        state: &State,
        delta_rad: f64,
        d_state: &mut [[f64; 3]; 3],
        d_theta: &mut [[f64; 3]],
    ) -> Result<[f64; 3], DynamicsError> {
        FiniteDifferences::new(self, 0..self.parameters().len())
            .sensitivities(state, delta_rad, d_state, d_theta)
    }
}

/// Finite-difference derivatives of a [`Parametric`] model at its θ: central over the three
/// velocities, one-sided over the chosen parameters with models perturbed once at construction (a
/// replay evaluates them at every stage, so building a model per parameter per stage would cost more
/// than the replay). A parameter that cannot be moved forwards (at a bound where the model refuses
/// it) is moved backwards; one that moves neither way gets a zero derivative.
pub struct FiniteDifferences<'a, P> {
    model: &'a P,
    /// (parameter index, perturbed model, its step).
    probes: Vec<(usize, P, f64)>,
}

impl<'a, P: Parametric> FiniteDifferences<'a, P> {
    /// Probes for the parameters `indices` of `model`, steps of √ε relative (1e-3 absolute floor),
    /// which balance truncation and rounding at about 1e-8 relative.
    pub fn new(model: &'a P, indices: impl IntoIterator<Item = usize>) -> FiniteDifferences<'a, P> {
        let theta = model.parameters();
        let probes = indices
            .into_iter()
            .filter(|&j| j < theta.len())
            .filter_map(|j| {
                let h = 1.5e-8 * theta[j].abs().max(1e-3);
                [h, -h].into_iter().find_map(|step| {
                    let mut q = theta.clone();
                    q[j] += step;
                    model.with_parameters(&q).map(|m| (j, m, step))
                })
            })
            .collect();
        FiniteDifferences { model, probes }
    }

    /// As [`Parametric::sensitivities`]; entries of `d_theta` of parameters without a probe are zero.
    pub fn sensitivities(
        &self,
        state: &State,
        delta_rad: f64,
        d_state: &mut [[f64; 3]; 3],
        d_theta: &mut [[f64; 3]],
    ) -> Result<[f64; 3], DynamicsError> {
        let a = self.model.accelerations(state, delta_rad)?;
        let ship = self.model.ship();
        // Central differences, steps of a millionth of the state's natural scale (U0, U0/L).
        let scales = [ship.u0, ship.u0, ship.u0 / ship.lpp];
        for (k, scale) in scales.into_iter().enumerate() {
            let h = 1e-6 * scale;
            let shifted = |sign: f64| {
                let mut x = *state;
                match k {
                    0 => x.u += sign * h,
                    1 => x.v += sign * h,
                    _ => x.r += sign * h,
                }
                self.model.accelerations(&x, delta_rad)
            };
            let (plus, minus) = (shifted(1.0)?, shifted(-1.0)?);
            (0..3).for_each(|i| d_state[i][k] = (plus[i] - minus[i]) / (2.0 * h));
        }
        d_theta.iter_mut().for_each(|d| *d = [0.0; 3]);
        for (j, probe, h) in &self.probes {
            let Some(out) = d_theta.get_mut(*j) else {
                continue;
            };
            // A probe that fails where the model does not is a parameter the state cannot resolve.
            if let Ok(moved) = probe.accelerations(state, delta_rad) {
                *out = std::array::from_fn(|i| (moved[i] - a[i]) / h);
            }
        }
        Ok(a)
    }
}
