//! The minimum number of frames per zone leaves the zonings of the simulator's presets as
//! they were: on their training passes no zone holds fewer than the default minimum, so the
//! zones with the default equal those without any minimum, for every zone count the
//! documentation uses.

use endoloc_net::{DEFAULT_MIN_ZONE_FRAMES, UniformBy, ZoneConfig, ZoneTable};
use endoloc_sim::simulate::build_colon;
use endoloc_sim::trajectory::PassGenerator;
use endoloc_sim::{Preset, SimConfig};

fn check_preset(preset: Preset, counts: &[usize]) {
    let cfg = SimConfig::preset(preset);
    let colon = build_colon(&cfg).unwrap();
    let pass = PassGenerator::new(&colon, &cfg.train)
        .unwrap()
        .generate()
        .unwrap();
    for &count in counts {
        for by in [UniformBy::ArcLength, UniformBy::Frames] {
            let plain = ZoneTable::from_poses(
                &pass.poses,
                None,
                &ZoneConfig::Uniform {
                    count,
                    by,
                    min_frames: 1,
                },
            )
            .unwrap();
            let with_min =
                ZoneTable::from_poses(&pass.poses, None, &ZoneConfig::uniform(count, by)).unwrap();
            let fewest = plain.zones.iter().map(|z| z.frame_count).min().unwrap();
            assert!(
                fewest >= DEFAULT_MIN_ZONE_FRAMES,
                "{preset:?}, {count} zones by {by:?}: a zone of {fewest} frames"
            );
            assert_eq!(
                plain.zones, with_min.zones,
                "{preset:?}, {count} zones by {by:?}"
            );
            assert!(with_min.widened.is_empty() && with_min.frames_note().is_none());
        }
    }
}

#[test]
fn the_small_preset_zones_are_unchanged_by_the_minimum() {
    // The demo's 20 zones, and the counts a 300-frame pass is used with.
    check_preset(Preset::Small, &[10, 20, 30, 50]);
}

#[test]
fn the_paper_preset_zones_are_unchanged_by_the_minimum() {
    // 50 zones (README, experiments) and the zone-count sweep 10..=170.
    let counts: Vec<usize> = (10..=170).step_by(10).collect();
    check_preset(Preset::Paper, &counts);
}
