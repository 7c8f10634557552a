//! The run configuration of `endoloc run` (`RunJob::from_toml`), and the `localize.toml` a
//! localization run writes next to its results.
#![no_main]

use endoloc_jobs::{LocalizeJob, RunJob};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(job) = RunJob::from_toml(text) {
        let _ = job.train.command_line();
    }
    let _ = toml::from_str::<LocalizeJob>(text);
});
