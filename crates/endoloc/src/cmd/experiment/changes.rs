//! `endoloc experiment changes`.

use anyhow::Result;
use endoloc_experiments::ChangesJob;
use endoloc_jobs::Progress;

/// How far endoloc's figures carry into a colon that changed between the passes: each factor
/// of the simulator's change model (segments shifted, insufflation, local deformation,
/// exposure, colour, light, highlights, texture, residue, bubbles, blur, a wider scope) alone
/// at each severity, and every factor at once, on several colons; or chosen factors together
/// (`shape+specular`: single factors and the groups shape, look, scope joined by +). Each test
/// pass is localized live and per frame against the unchanged map and evaluated against the
/// anatomical truth.
/// Writes changes.md (mean ± 95 % interval over the colons per condition, and for each factor
/// the severity where endoloc stops holding, with the reason), changes.json and changes.png.
/// Every colon is an independent job in colons/<name>/ and every condition's figures are kept
/// as soon as they are done, so running again continues; --print-jobs prints one command per
/// colon, --merge then writes the tables.
///
/// Examples:
///
///   endoloc experiment changes --seeds 1-5 --gca ../shared/data/gca-edin-00090
///
///   endoloc experiment changes --seeds 1-3 --factors blur,fov --severities moderate
///
///   endoloc experiment changes --factors shape,look+scope,all --severities moderate
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: ChangesJob,
}

/// Runs `endoloc experiment changes`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
