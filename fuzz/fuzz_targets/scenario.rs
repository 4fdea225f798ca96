//! The scenario parser (`RunConfig::from_toml`): no panic on any text; an accepted
//! scenario validates again, and every error names the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use trackfuse::RunConfig;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match RunConfig::from_toml(text, "scenario.toml") {
        Ok(cfg) => cfg
            .scenario
            .validate("scenario.toml")
            .expect("an accepted scenario validates again"),
        Err(e) => assert!(e.to_string().contains("scenario.toml"), "{e}"),
    }
});
