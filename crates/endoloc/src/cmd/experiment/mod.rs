//! `endoloc experiment`: the paper's comparisons and studies, each in one output folder with
//! its tables (markdown, JSON), plots and a self-contained HTML report. Experiments reuse what
//! they already computed: running the same command again continues where it stopped.

mod benchmark;
mod changes;
mod compare;
mod expert;
mod perturb;
mod zones;

use anyhow::Result;
use endoloc_jobs::Progress;

/// Run the paper's comparisons and studies (Table I, Fig. 4, Fig. 7, anatomical zones), the
/// benchmark across colons and the study of a colon that changes between the passes.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    Benchmark(benchmark::Args),
    Changes(changes::Args),
    Compare(compare::Args),
    Zones(zones::Args),
    Expert(expert::Args),
    Perturb(perturb::Args),
}

/// Runs `endoloc experiment`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    match args.what {
        What::Benchmark(a) => benchmark::run(a, ui),
        What::Changes(a) => changes::run(a, ui),
        What::Compare(a) => compare::run(a, ui),
        What::Zones(a) => zones::run(a, ui),
        What::Expert(a) => expert::run(a, ui),
        What::Perturb(a) => perturb::run(a, ui),
    }
}
