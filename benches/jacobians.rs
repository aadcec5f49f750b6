//! One evaluation of each model's Jacobians, and the stochastic-triangulation
//! initialization. `cargo bench -p bearing-slam --bench jacobians`
fn main() {}
