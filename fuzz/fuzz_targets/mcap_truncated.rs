//! The MCAP reader on truncated files: the first two bytes choose where the
//! rest (a file) is cut, as a writer killed mid-run leaves it.
#![no_main]

#[path = "../common/mcap.rs"]
mod mcap;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((head, file)) = data.split_first_chunk::<2>() else {
        return;
    };
    let cut = usize::from(u16::from_le_bytes(*head)) * file.len() / usize::from(u16::MAX);
    mcap::read(&file[..cut]);
});
