//! Mid-line paths, GCA landmarks and the sections cut from them.

use endoloc_data::{
    DataError, Landmark, Section, cumulative_length, read_gca_landmarks, read_path, section_cut,
    section_ranges, sections_from_landmarks,
};
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn gca_json_and_csv_paths() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let j = write(
        d,
        "p.jsn",
        r#"{"n": 3, "points": [[0, 0, 0], [1.5, 0, 0], [1.5, 2, 0]], "tangents": [], "normals": []}"#,
    );
    let pts = read_path(&j).unwrap();
    assert_eq!(pts.len(), 3);
    assert_eq!(*cumulative_length(&pts).last().unwrap(), 3.5);

    let c = write(d, "p.csv", "x,y,z\n# comment\n0,0,0\n1.5, 0, 0\n1.5;2;0\n");
    assert_eq!(read_path(&c).unwrap(), pts);
}

#[test]
fn gca_path_with_nan_names_the_point() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // As Python's json.dump writes it.
    let j = write(
        d,
        "p.jsn",
        "{\"n\": 3,\n \"points\": [[0, 0, 0],\n [1, NaN, 0],\n [2, 0, 0]]}",
    );
    let err = read_path(&j).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, DataError::Parse { .. }), "{err:?}");
    assert!(
        msg.contains("p.jsn") && msg.contains("point 1 ") && msg.contains("non-finite"),
        "{msg}"
    );

    let j = write(
        d,
        "q.json",
        "{\"n\": 4, \"points\": [[0, 0, 0], [1, 0, 0]]}",
    );
    let msg = read_path(&j).unwrap_err().to_string();
    assert!(msg.contains("\"n\" is 4 but there are 2 points"), "{msg}");
    let j = write(d, "r.json", "{\"n\": 2, \"points\": [[0, 0, 0], [1, 0]]}");
    let msg = read_path(&j).unwrap_err().to_string();
    assert!(msg.contains("point 1 has 2 coordinates"), "{msg}");

    let c = write(d, "p.csv", "x,y,z\n0,0,0\n1,nan,0\n");
    match read_path(&c).unwrap_err() {
        DataError::Parse { line, message, .. } => {
            assert_eq!(line, 3);
            assert!(message.contains("not finite"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    let c = write(d, "q.csv", "0,0,0\n1,0\n");
    let msg = read_path(&c).unwrap_err().to_string();
    assert!(
        msg.contains("q.csv:2:") && msg.contains("expected 3"),
        "{msg}"
    );
}

fn lm(abbr: &str, i: usize) -> Landmark {
    Landmark {
        name: abbr.to_string(),
        abbreviation: abbr.to_string(),
        path_index: i,
    }
}

fn gca_like() -> Vec<Landmark> {
    vec![
        lm("anus", 0),
        lm("RSJ", 84),
        lm("DSJ", 323),
        lm("SF", 771),
        lm("HF", 1154),
        lm("CCJ", 1278),
        lm("ICVc", 1314),
        lm("AO", 1352),
    ]
}

/// The expected cut of the GCA 00090 path (1375 points).
fn expected_ranges() -> Vec<(Section, usize, usize)> {
    vec![
        (Section::AnalCanal, 0, 28), // 84 / 3 < 30 points
        (Section::Rectum, 28, 69),
        (Section::Rectosigmoid, 69, 99),
        (Section::Sigmoid, 99, 323),
        (Section::Descending, 323, 731),
        (Section::SplenicFlexure, 731, 811),
        (Section::Transverse, 811, 1114),
        (Section::HepaticFlexure, 1114, 1194),
        (Section::Ascending, 1194, 1278),
        (Section::Caecum, 1278, 1375),
    ]
}

fn check_labels(labels: &[Section]) {
    assert_eq!(labels.len(), 1375);
    for (s, a, b) in expected_ranges() {
        assert!(labels[a..b].iter().all(|&l| l == s), "{s} over {a}..{b}");
    }
    assert!(
        labels.windows(2).all(|w| w[0] <= w[1]),
        "labels must be in insertion order"
    );
}

#[test]
fn sections_follow_the_landmarks() {
    let labels = sections_from_landmarks(1375, &gca_like()).unwrap();
    check_labels(&labels);
    let ranges = section_ranges(1375, &gca_like()).unwrap();
    let got: Vec<_> = ranges.iter().map(|r| (r.section, r.start, r.end)).collect();
    assert_eq!(got, expected_ranges());
}

#[test]
fn sections_stay_ordered_and_non_empty_on_tiny_paths() {
    let lms = vec![
        lm("anus", 0),
        lm("RSJ", 1),
        lm("DSJ", 2),
        lm("SF", 4),
        lm("HF", 5),
        lm("CCJ", 9),
    ];
    let labels = sections_from_landmarks(12, &lms).unwrap();
    assert_eq!(labels.len(), 12);
    for s in Section::ALL {
        assert!(labels.contains(&s), "{s} missing: {labels:?}");
    }
    assert!(labels.windows(2).all(|w| w[0] <= w[1]), "{labels:?}");
}

#[test]
fn disordered_or_out_of_range_landmarks_are_named() {
    let mut lms = gca_like();
    lms[2].path_index = 900; // DSJ after SF
    let msg = sections_from_landmarks(1375, &lms).unwrap_err().to_string();
    assert!(
        msg.contains("SF") && msg.contains("DSJ") && msg.contains("order"),
        "{msg}"
    );

    let msg = sections_from_landmarks(1200, &gca_like())
        .unwrap_err()
        .to_string();
    assert!(msg.contains("CCJ") && msg.contains("< 1200"), "{msg}");

    // ICVc before the hepatic flexure cannot start the caecum.
    let mut lms = gca_like();
    lms.retain(|l| l.abbreviation != "CCJ");
    lms.iter_mut()
        .find(|l| l.abbreviation == "ICVc")
        .unwrap()
        .path_index = 1000;
    let msg = sections_from_landmarks(1375, &lms).unwrap_err().to_string();
    assert!(msg.contains("CCJ") && msg.contains("HF"), "{msg}");
}

/// The landmarks of GCA models such as EdinGCA_3D_00060 (path of 1625 points): no RSJ, no
/// CCJ, and the path runs on through the appendix orifice to the appendix tip.
fn without_rsj_and_ccj() -> Vec<Landmark> {
    vec![
        lm("anus", 0),
        lm("DSJ", 910),
        lm("SF", 1247),
        lm("HF", 1381),
        lm("ICVc", 1549),
        lm("AO", 1606),
        lm("AT", 1624),
    ]
}

#[test]
fn missing_rsj_and_ccj_are_placed_from_the_landmarks_present_and_reported() {
    let cut = section_cut(1625, &without_rsj_and_ccj()).unwrap();
    // RSJ: 170 of the typical 585 mm from the anus to the DSJ; CCJ: at the ileocaecal valve.
    let placed: Vec<(&str, usize)> = cut
        .estimated
        .iter()
        .map(|e| (e.abbreviation, e.path_index))
        .collect();
    assert_eq!(placed, vec![("RSJ", 264), ("CCJ", 1549)]);
    let lines: Vec<String> = cut.estimated.iter().map(|e| e.to_string()).collect();
    assert_eq!(
        lines[0],
        "landmark RSJ (recto-sigmoid junction) is missing: placed at path index 264, by typical \
         section lengths between anus (path index 0) and DSJ (path index 910)"
    );
    assert!(
        lines[1].contains("the caecum starts at ICVc (path index 1549)"),
        "{}",
        lines[1]
    );
    let got: Vec<_> = cut
        .ranges
        .iter()
        .map(|r| (r.section, r.start, r.end))
        .collect();
    assert_eq!(
        got,
        vec![
            (Section::AnalCanal, 0, 30),
            (Section::Rectum, 30, 249),
            (Section::Rectosigmoid, 249, 279),
            (Section::Sigmoid, 279, 910),
            (Section::Descending, 910, 1207),
            (Section::SplenicFlexure, 1207, 1287),
            (Section::Transverse, 1287, 1341),
            (Section::HepaticFlexure, 1341, 1421),
            (Section::Ascending, 1421, 1549),
            (Section::Caecum, 1549, 1625),
        ]
    );
    // A complete landmark file estimates nothing.
    assert!(section_cut(1375, &gca_like()).unwrap().estimated.is_empty());
}

#[test]
fn a_missing_middle_landmark_is_placed_between_its_neighbours() {
    let mut lms = gca_like();
    lms.retain(|l| l.abbreviation != "SF");
    let cut = section_cut(1375, &lms).unwrap();
    assert_eq!(cut.estimated.len(), 1);
    let sf = &cut.estimated[0];
    // DSJ 323 and HF 1154 bound it; typically 290 of their 820 mm.
    assert_eq!((sf.abbreviation, sf.path_index), ("SF", 617));
    assert!(
        sf.to_string()
            .contains("between DSJ (path index 323) and HF (path index 1154)")
    );
    let labels = sections_from_landmarks(1375, &lms).unwrap();
    assert_eq!(labels[617], Section::SplenicFlexure);
    assert!(labels.windows(2).all(|w| w[0] <= w[1]));

    // Only the anus: every section from typical lengths, up to the appendix orifice.
    let cut = section_cut(1000, &[lm("anus", 0), lm("AO", 990)]).unwrap();
    assert_eq!(cut.estimated.len(), 5);
    assert!(
        cut.estimated[4]
            .to_string()
            .contains("and AO (path index 990)")
    );
    let order: Vec<Section> = cut.ranges.iter().map(|r| r.section).collect();
    assert_eq!(order, Section::ALL.to_vec());
}

fn gca_dir() -> Option<PathBuf> {
    // The CT colon's folder comes from the environment; `.ci/run` sets it when the data exists.
    match std::env::var_os("ENDOLOC_GCA_DIR").map(PathBuf::from) {
        Some(d) if d.is_dir() => Some(d),
        other => {
            eprintln!(
                "SKIPPED: set ENDOLOC_GCA_DIR to a Gut Cell Atlas colon folder (now {:?})",
                other
            );
            None
        }
    }
}

#[test]
fn real_gca_path_and_landmarks() {
    let Some(d) = gca_dir() else { return };
    let path = read_path(&d.join("large_intestine_path.jsn")).unwrap();
    assert_eq!(path.len(), 1375);
    let len = *cumulative_length(&path).last().unwrap();
    assert!((len - 1391.5).abs() < 1.0, "path length {len} mm");

    let lms = read_gca_landmarks(&d.join("EdinGCA_3D_00090_1_1.json")).unwrap();
    let at = |a: &str| {
        lms.iter()
            .find(|l| l.abbreviation == a)
            .map(|l| l.path_index)
            .unwrap_or_else(|| panic!("{a} missing"))
    };
    assert_eq!(
        ["anus", "RSJ", "DSJ", "SF", "HF", "CCJ", "ICVc", "AO", "AT"].map(at),
        [0, 84, 323, 771, 1154, 1278, 1314, 1352, 1374]
    );
    // Small-intestine landmarks (another path) are left out.
    assert!(
        lms.iter()
            .all(|l| l.abbreviation != "JIJ" && l.abbreviation != "OGJ")
    );
    assert_eq!(
        lms.iter().find(|l| l.abbreviation == "RSJ").unwrap().name,
        "recto-sigmoid junction"
    );
    check_labels(&sections_from_landmarks(path.len(), &lms).unwrap());
}
