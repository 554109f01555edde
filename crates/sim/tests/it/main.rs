//! Integration tests of shipid-sim through its public API, in one test binary: one module per topic,
//! helpers shared between them in [`common`].

mod common;
mod divergence;
mod effects;
mod environment;
mod hsva_metrics;
mod metrics_synthetic;
mod mmg_check_values;
mod mmg_rate;

// Public paths other crates use (`shipid diagnose` imports `shipid_sim::sim::RudderFilter`): the rudder
// filter lives in `dynamics`, next to `Dynamics`, and `sim` and the crate root re-export it.
#[allow(unused_imports)]
use shipid_sim::{
    RudderFilter as _,
    dynamics::{NoFilter as _, RudderFilter as _},
    sim::{NoFilter as _, RudderFilter as _},
};
