//! `endoloc experiment benchmark`.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::Progress;
use endoloc_jobs::experiment::*;

/// Run the whole chain — simulate, index (or train), map, localize with each method,
/// evaluate — on several colons: procedural ones (one per --seeds value; none of them was
/// used to choose a setting) and CT colons (--gca). Writes benchmark.md, benchmark.json,
/// benchmark.png and report.html: each method's figures per colon and their mean ± 95 %
/// confidence interval across colons. Every colon is an independent job in colons/<name>/;
/// finished colons are kept, so running again continues. --print-jobs prints one command per
/// colon, for GNU parallel or a Slurm array; --merge then writes the tables.
///
/// Examples:
///
///   endoloc experiment benchmark --seeds 1-8 --gca ../shared/data/gca-edin-00090 --inflation 1.5
///
///   endoloc experiment benchmark --seeds 1-8 --print-jobs | grep -v '^#' | parallel -j 4
///   endoloc experiment benchmark --seeds 1-8 --merge
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value_os_t = BenchmarkJob::default().out)]
    out: PathBuf,
    /// Simulator preset of every colon (see `endoloc simulate --preset`).
    #[arg(long, default_value_t = BenchmarkJob::default().preset)]
    preset: String,
    /// Procedural colons: simulator seeds, e.g. 1-8, 1,3,5 or none.
    #[arg(long, default_value = "1-8", value_parser = parse_seeds_arg)]
    seeds: SeedList,
    /// Development colons: seeds on which settings were chosen (the `paper` preset's is 0).
    /// Run and reported as their own rows, left out of the mean ± interval.
    #[arg(long, default_value = "none", value_parser = parse_seeds_arg)]
    dev_seeds: SeedList,
    /// A CT colon: GCA model folder (repeat for several).
    #[arg(long, value_name = "DIR")]
    gca: Vec<PathBuf>,
    /// Lumen inflation of the CT colons (see `endoloc simulate --inflation`).
    #[arg(long)]
    inflation: Option<f64>,
    /// Frames of each training pass (default: the preset's).
    #[arg(long)]
    train_frames: Option<usize>,
    /// Frames of each test pass (default: the preset's).
    #[arg(long)]
    test_frames: Option<usize>,
    /// Zones (a count, or `expert`).
    #[arg(long, default_value_t = BenchmarkJob::default().zones)]
    zones: String,
    /// Start weights of the zone network: `builtin-joint` (the shipped network, indexed
    /// without training), a weights file, or `none` to train from scratch on each colon as in
    /// the paper.
    #[arg(long, default_value_t = BenchmarkJob::default().pretrained)]
    pretrained: String,
    /// Training epochs (default: 0 with --pretrained, else the schedule's own).
    #[arg(long)]
    epochs: Option<usize>,
    /// Seed of every training.
    #[arg(long, default_value_t = BenchmarkJob::default().seed)]
    seed: u64,
    /// Methods (default: endoloc-paper, endoloc, endoloc-confirm, endoloc-live,
    /// endoloc-live-confirm, classify; see `experiment compare`).
    #[arg(long, value_delimiter = ',')]
    methods: Vec<CompareMethod>,
    /// Run only this colon (`seed-N`, `dev-seed-N` or `ct-<folder>`); the tables are not
    /// written.
    #[arg(long)]
    colon: Option<String>,
    /// Print one command per colon and the merge command, and stop.
    #[arg(long)]
    print_jobs: bool,
    /// Run nothing: write the tables from the finished colons.
    #[arg(long, conflicts_with = "colon")]
    merge: bool,
    /// Use an output folder that holds something else.
    #[arg(long)]
    force: bool,
}

/// Seeds as parsed from the command line.
#[derive(Debug, Clone)]
struct SeedList(Vec<u64>);

fn parse_seeds_arg(s: &str) -> Result<SeedList, String> {
    parse_seeds(s).map(SeedList)
}

impl From<Args> for BenchmarkJob {
    fn from(a: Args) -> Self {
        BenchmarkJob {
            out: a.out,
            preset: a.preset,
            seeds: a.seeds.0,
            dev_seeds: a.dev_seeds.0,
            gca: a.gca,
            inflation: a.inflation,
            train_frames: a.train_frames,
            test_frames: a.test_frames,
            zones: a.zones,
            pretrained: if a.pretrained == "none" {
                String::new()
            } else {
                a.pretrained
            },
            epochs: a.epochs,
            seed: a.seed,
            methods: a.methods,
            colon: a.colon,
            print_jobs: a.print_jobs,
            merge: a.merge,
            force: a.force,
        }
    }
}

/// Runs `endoloc experiment benchmark`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&BenchmarkJob::from(args).run(ui)?)?;
    Ok(())
}
