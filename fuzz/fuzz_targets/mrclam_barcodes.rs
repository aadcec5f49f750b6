//! The MRCLAM loader with a fuzzed `Barcodes.dat` (the other files valid).
#![no_main]

#[path = "../common/mrclam.rs"]
mod mrclam;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    mrclam::load_with("Barcodes.dat", data);
});
