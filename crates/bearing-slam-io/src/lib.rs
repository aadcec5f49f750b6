//! MCAP logs and dataset loaders (under construction).
