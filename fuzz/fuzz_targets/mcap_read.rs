//! The MCAP reader on whole files: any bytes give a run or an error, never a
//! panic, and a run without warnings holds a valid log.
#![no_main]

#[path = "../common/mcap.rs"]
mod mcap;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    mcap::read(data);
});
