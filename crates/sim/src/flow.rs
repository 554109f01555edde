//! Currents and flows as velocities: shared by the effects, the known environment and the
//! simulation loop (which records the current its model carries), so that none of them imports
//! another for it.

/// The sum of two optional currents [north, east] (`None` when neither is there).
pub(crate) fn add_currents(a: Option<[f64; 2]>, b: Option<[f64; 2]>) -> Option<[f64; 2]> {
    match (a, b) {
        (Some([an, ae]), Some([bn, be])) => Some([an + bn, ae + be]),
        (a, b) => a.or(b),
    }
}

/// A flow given by its velocity [north, east] [m/s] at times `t_s` as recorded: speed and the
/// direction it comes from, clockwise from north in [0, 2π) (the inverse of
/// `FlowSeries::velocity_earth`).
pub(crate) fn flow_series(
    t_s: &[f64],
    velocity_at: impl Fn(f64) -> [f64; 2],
) -> shipid_io::FlowSeries {
    let (speed_m_s, from_rad) = t_s
        .iter()
        .map(|&t| {
            let [n, e] = velocity_at(t);
            (n.hypot(e), (-e).atan2(-n).rem_euclid(std::f64::consts::TAU))
        })
        .unzip();
    shipid_io::FlowSeries {
        speed_m_s,
        from_rad,
    }
}
