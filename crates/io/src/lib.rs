//! Recordings and data sets in the project's data format (`docs/data-format.md`), import of other layouts, prime-system scaling and
//! acceleration estimation.
//!
//! Everything handed to other crates is in the project's conventions (see [`Recording`]): SI units,
//! midship reference point, rudder positive to starboard. Conversions from a source's own conventions
//! (`origin = "cg"`, `rudder_sign = -1`, unit suffixes, foreign layouts) happen here and nowhere else.
//!
//! - [`recording`]: one recording CSV file → [`Recording`];
//! - [`dataset`]: a data set TOML and its recordings → [`Dataset`];
//! - [`consistency`]: do a recording's channels describe one motion (units, signs, axes)?
//! - [`import`]: a foreign layout described by a mapping TOML → a data set in the project's format;
//! - [`open_water`]: the propeller's open-water CSV → the quadratic K_T(J);
//! - [`relative_wind`]: the wind measured on board (relative) turned into the true wind;
//! - [`write`]: atomic writing of recordings and data sets;
//! - [`prime`]: the prime system I with U0 (`docs/conventions.md`);
//! - [`deriv`]: the smoothing differentiator that estimates accelerations;
//! - [`error`]: [`InputError`], which always names the file and the line/column or key.

pub mod consistency;
mod copies;
pub mod dataset;
pub mod deriv;
pub mod error;
pub mod import;
pub mod open_water;
pub mod prime;
pub mod recording;
pub mod relative_wind;
pub mod table;
pub mod types;
pub mod units;
pub mod write;

pub use dataset::{Dataset, DatasetFile, DatasetRecording, Origin, PropellerTable, ReferencePoint};
pub use error::InputError;
pub use prime::PrimeScale;
pub use types::*;
