//! `endoloc experiment`: the paper's comparisons and studies, each in one output folder with
//! its tables (markdown, JSON), plots and a self-contained HTML report.
//!
//! - `compare` — every method on the same data (the paper's Table I);
//! - `zones` — the Monte-Carlo zone-count sweep (the paper's Fig. 4), resumable;
//! - `expert` — anatomical zones against uniform ones;
//! - `perturb` — the error when the zone is forced wrong by ±e (the paper's Fig. 7).
//!
//! Experiments reuse what they already computed: a folder's models, maps and runs are kept,
//! and a second invocation continues where the first stopped. SURF features of the test
//! frames are extracted once per process and shared by every run that needs them.

mod common;
mod compare;
mod expert;
mod perturb;
mod zones;

use anyhow::Result;

pub(crate) use common::predict_zones;

/// Run the paper's comparisons and studies (Table I, Fig. 4, Fig. 7, anatomical zones).
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    Compare(compare::Args),
    Zones(zones::Args),
    Expert(expert::Args),
    Perturb(perturb::Args),
}

/// Runs `endoloc experiment`.
pub fn run(args: Args) -> Result<()> {
    match args.what {
        What::Compare(a) => compare::run(a),
        What::Zones(a) => zones::run(a),
        What::Expert(a) => expert::run(a),
        What::Perturb(a) => perturb::run(a),
    }
}
