#![no_main]
//! `cargo xtask fuzz` runs this; the body and its oracle are in
//! `ommcheck_fuzz_harness::host_build`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    ommcheck_fuzz_harness::host_build::run(data);
});
