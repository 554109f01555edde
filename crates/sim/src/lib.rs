//! Manoeuvring simulation for shipid: pure computation, no I/O.
//!
//! - [`dynamics`]: the 3-DOF [`State`] of midship and the [`Dynamics`] trait every manoeuvring model
//!   implements (the MMG reference model here; identified Abkowitz and Gaussian-process models elsewhere).
//! - [`mmg`]: the MMG standard method (Yasukawa & Yoshimura 2015) for KVLCC2, with the self-propulsion
//!   propeller rate solved at construction.
//! - [`sim`]: fixed-step RK4 simulation with a rate-limited rudder actuator, sampling into a
//!   [`shipid_io::Recording`] and divergence detection ([`SimStatus`]).
//! - [`control`]: rudder controllers: zig-zag, turning circle, replay of a recorded rudder.
//! - [`metrics`]: IMO metrics (overshoots, t_a, t_check, advance, transfer, tactical and steady diameter)
//!   of any recording, measured or simulated.
//! - [`abkowitz`]: an identified Abkowitz model ([`shipid_model::AbkowitzModel`]) as a [`Dynamics`].
//! - [`gp`]: a sparse Gaussian-process acceleration model (paper 001) as a [`Dynamics`], and its model file.
//! - [`effects`]: physical effects left out of a model (current, wind, rudder lag, asymmetry, shallow
//!   water), applied around any [`Dynamics`] without changing the simulation loop.
//! - [`environment`], [`propeller_rate`]: a recording's wind, current and propeller rate as known
//!   inputs of a replay.
//!
//! Conventions (`docs/conventions.md`): SI units, midship reference point, body axes x forward / y
//! starboard, earth axes x0 north / y0 east, heading and yaw rate positive to starboard, rudder angle
//! positive when it turns the ship to starboard. Units are given in brackets in the docs, e.g. \[m/s\].
//!
//! ```
//! use shipid_io::{Manoeuvre, Side};
//! use shipid_sim::{controller_for, metrics, simulate, Dynamics, MmgModel, SimOptions, SimStatus, State};
//!
//! let model = MmgModel::kvlcc2();
//! let ship = *model.ship();
//! let zz = Manoeuvre::ZigZag { rudder_deg: 10.0, check_deg: 10.0, side: Side::Starboard };
//! let mut controller = controller_for(&zz, 2.0)?;
//! let out = simulate(&model, controller.as_mut(), State::approach(ship.u0), &SimOptions::new(100.0))?;
//! assert_eq!(out.status, SimStatus::Ok);
//! let m = metrics(&out.recording, &zz, &ship);
//! assert!((m.overshoot_1.unwrap() - 4.9).abs() < 0.3);
//! println!("{}", serde_json::to_string(&m)?);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

// Units in brackets ("[s]", "[rad]") throughout the docs are not intra-doc links.
#![allow(rustdoc::broken_intra_doc_links)]

pub mod abkowitz;
pub mod control;
pub mod dynamics;
pub mod effects;
pub mod environment;
mod flow;
pub mod gp;
pub mod metrics;
pub mod mmg;
pub mod propeller_rate;
pub mod sim;

pub use abkowitz::AbkowitzDynamics;
pub use control::{
    ControlError, Replay, RudderCommand, RudderController, Turning, ZigZag, controller_for,
    controller_with_reaction_delay,
};
pub use dynamics::{
    Dynamics, DynamicsError, Input, LinearHullDerivatives, MassMatrix, OwnRange, RudderFilter,
    State,
};
pub use effects::{Effect, EffectError, EffectParseError, WithEffects, simulate_with_effects};
pub use environment::{
    Aerodynamics, EnvironmentError, KnownEnvironment, WithEnvironment, assumed_windage,
};
pub use gp::{
    GP_INPUTS, GP_KIND, GP_OUTPUTS, GpDynamics, GpModelError, GpModelFile, GpOutputFile,
    SparsificationInfo,
};
pub use metrics::{Metrics, metrics};
pub use mmg::{MmgError, MmgModel, MmgParameters, kvlcc2_added_mass, kvlcc2_ship};
pub use propeller_rate::{RecordedRate, WithPropellerRate};
pub use sim::{
    DivergenceBounds, SimError, SimOptions, SimOutput, SimStatus, simulate, simulate_filtered,
};
