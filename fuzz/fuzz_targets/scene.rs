//! libFuzzer target: arbitrary bytes as a scene file must give a scene or an input error,
//! never a panic (`cargo +nightly fuzz run scene`).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| grainstat_fuzz::check_scene(data));
