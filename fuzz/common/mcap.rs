//! Shared by the `mcap_*` targets.

use std::sync::Once;

/// Reads `bytes` as an MCAP file and checks what a successful read promises.
pub fn read(bytes: &[u8]) {
    tolerate_the_caught_mcap_panic();
    if let Ok(run) = bearing_slam_io::read_log_bytes(bytes, "fuzz.mcap") {
        if run.warnings.is_empty() {
            run.log
                .validate()
                .expect("a run read without warnings holds a valid log");
        }
    }
}

/// `mcap` 0.26's linear reader subtracts with overflow on a chunk whose inner
/// record is longer than the chunk (`sans_io/linear_reader.rs:745`, found by
/// these targets). `bearing_slam_io`'s reader catches that one panic and
/// reports a damaged file (`next_event_guarded`). libFuzzer's panic hook
/// aborts at the panic itself, before any `catch_unwind`, so this hook lets a
/// panic raised inside that file unwind to the reader's guard and aborts on
/// every other panic, as libfuzzer-sys's own hook does. A panic from there
/// that the reader failed to catch still aborts: libfuzzer-sys aborts on any
/// panic that reaches the target's boundary.
fn tolerate_the_caught_mcap_panic() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let default_hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let known = info
                .location()
                .is_some_and(|l| l.file().ends_with("mcap-0.26.0/src/sans_io/linear_reader.rs"));
            if !known {
                default_hook(info);
                std::process::abort();
            }
        }));
    });
}
