//! MCAP logs and dataset loaders (under construction).

pub mod mrclam;
