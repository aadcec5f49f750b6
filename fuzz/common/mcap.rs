//! Shared by the `mcap_*` targets.

/// Reads `bytes` as an MCAP file and checks what a successful read promises.
pub fn read(bytes: &[u8]) {
    if let Ok(run) = bearing_slam_io::read_log_bytes(bytes, "fuzz.mcap") {
        if run.warnings.is_empty() {
            run.log
                .validate()
                .expect("a run read without warnings holds a valid log");
        }
    }
}
