//! Fuzz target: `checks::resp_reader` on every input (see `fuzz/src/checks.rs`).
#![no_main]

// Each target uses one of the checks.
#[allow(dead_code)]
#[path = "../src/checks.rs"]
mod checks;

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| checks::resp_reader(bytes));
