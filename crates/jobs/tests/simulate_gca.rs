//! `SimulateJob` on Gut Cell Atlas model folders as they are published: landmark files without
//! RSJ and CCJ, mid-lines that run on through the appendix orifice into a narrow appendix,
//! the nested `Paths/` and `Surfaces/` layout. The colon is a synthetic tube written in the GCA
//! formats, so these tests need no data.

use std::fmt::Write as _;
use std::path::Path;

use endoloc_data::{Dataset, Section};
use endoloc_jobs::{Progress, SimulateJob};

/// Mid-line samples (one per mm of parameter) and landmark indices of the fixture colon.
const N_POINTS: usize = 701;
const DSJ: usize = 250;
const SF: usize = 360;
const HF: usize = 520;
const ICVC: usize = 620;
const AO: usize = 660;
const AT: usize = 700;

/// A gently curving mid-line, mm.
fn midline(i: usize) -> [f64; 3] {
    let t = i as f64;
    [t, 40.0 * (t / 150.0).sin(), 20.0 * (t / 97.0).sin()]
}

/// Lumen radius at path index `i`, mm: a 14 mm colon, a narrowing of `narrow` mm radius over
/// path indices 390..410 when given, and a 2.5 mm appendix beyond the appendix orifice.
fn radius(i: f64, narrow: Option<f64>) -> f64 {
    let ao = AO as f64;
    if i >= ao + 5.0 {
        return 2.5;
    }
    if i > ao {
        return 14.0 + (2.5 - 14.0) * (i - ao) / 5.0;
    }
    match narrow {
        Some(r) if (390.0..410.0).contains(&i) => r,
        _ => 14.0,
    }
}

/// Writes a GCA model folder in the published layout: the model JSON with the landmarks of
/// `landmarks` (abbreviation, path index) and older configuration next to it,
/// `Paths/large_intestine_path.jsn` and `Surfaces/large-intestine.vtk`.
fn write_gca_folder(dir: &Path, landmarks: &[(&str, usize)], narrow: Option<f64>) {
    std::fs::create_dir_all(dir.join("Paths")).unwrap();
    std::fs::create_dir_all(dir.join("Surfaces")).unwrap();
    // Mid-line.
    let points: Vec<String> = (0..N_POINTS)
        .map(|i| {
            let p = midline(i);
            format!("[{:.4}, {:.4}, {:.4}]", p[0], p[1], p[2])
        })
        .collect();
    std::fs::write(
        dir.join("Paths/large_intestine_path.jsn"),
        format!(
            "{{\n  \"n\": {N_POINTS},\n  \"points\": [\n    {}\n  ]\n}}\n",
            points.join(",\n    ")
        ),
    )
    .unwrap();
    // Surface: rings every 2 mm of parameter, 32 vertices each, capped at both ends.
    let segments = 32;
    let rings: Vec<f64> = (0..=(N_POINTS - 1) / 2).map(|k| 2.0 * k as f64).collect();
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    for &t in &rings {
        let p = midline_f(t);
        let q = midline_f(t + 0.5);
        let tan = normalize(sub(q, p));
        let n = normalize(cross(tan, [0.0, 0.0, 1.0]));
        let b = cross(tan, n);
        let r = radius(t, narrow);
        for j in 0..segments {
            let th = j as f64 * std::f64::consts::TAU / segments as f64;
            let (c, s) = (th.cos(), th.sin());
            vertices.push([
                p[0] + r * (c * n[0] + s * b[0]),
                p[1] + r * (c * n[1] + s * b[1]),
                p[2] + r * (c * n[2] + s * b[2]),
            ]);
        }
    }
    let first_centre = vertices.len();
    vertices.push(midline_f(0.0));
    vertices.push(midline_f(*rings.last().unwrap()));
    let mut tris: Vec<[usize; 3]> = Vec::new();
    for k in 0..rings.len() - 1 {
        for j in 0..segments {
            let a = k * segments + j;
            let b = k * segments + (j + 1) % segments;
            let c = a + segments;
            let d = b + segments;
            tris.push([a, c, d]);
            tris.push([a, d, b]);
        }
    }
    let last = (rings.len() - 1) * segments;
    for j in 0..segments {
        tris.push([first_centre, (j + 1) % segments, j]);
        tris.push([first_centre + 1, last + j, last + (j + 1) % segments]);
    }
    let mut vtk =
        String::from("# vtk DataFile Version 3.0\nfixture colon\nASCII\nDATASET POLYDATA\n");
    writeln!(vtk, "POINTS {} float", vertices.len()).unwrap();
    for v in &vertices {
        writeln!(vtk, "{:.4} {:.4} {:.4}", v[0], v[1], v[2]).unwrap();
    }
    writeln!(vtk, "POLYGONS {} {}", tris.len(), 4 * tris.len()).unwrap();
    for t in &tris {
        writeln!(vtk, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    std::fs::write(dir.join("Surfaces/large-intestine.vtk"), vtk).unwrap();
    // Model JSON, and an older one without landmarks on this path.
    let lms: Vec<String> = landmarks
        .iter()
        .map(|(abbr, i)| {
            format!(
                "{{\"anatomy\": [{{\"abbreviated_name\": \"{abbr}\", \"text\": \"{abbr}\"}}], \
                 \"paths\": [\"GUT_ATLAS_PAT:90\"], \"position\": [{i}], \"type\": \"landmark\"}}"
            )
        })
        .collect();
    let model = format!(
        "{{\"landmarks\": [{}], \"paths\": [{{\"filepath\": \"Paths/\", \"id\": \"GUT_ATLAS_PAT:90\", \
         \"spline_filename\": \"large_intestine_path.jsn\"}}], \"version\": 1, \"sub_version\": 8}}",
        lms.join(", ")
    );
    std::fs::write(dir.join("EdinGCA_3D_99999_1_8.json"), model).unwrap();
    std::fs::write(
        dir.join("EdinGCA_3D_99999_1_X.json"),
        "{\"landmarks\": [{\"anatomy\": [{\"abbreviated_name\": \"anus\"}], \"paths\": [\"P\"], \
         \"position\": [0]}], \"version\": 1, \"sub_version\": 6}",
    )
    .unwrap();
}

fn midline_f(t: f64) -> [f64; 3] {
    [t, 40.0 * (t / 150.0).sin(), 20.0 * (t / 97.0).sin()]
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// The landmarks of GCA models such as EdinGCA_3D_00060: no RSJ, no CCJ, an appendix path.
fn landmarks_without_rsj_ccj() -> Vec<(&'static str, usize)> {
    vec![
        ("anus", 0),
        ("DSJ", DSJ),
        ("SF", SF),
        ("HF", HF),
        ("ICVc", ICVC),
        ("AO", AO),
        ("AT", AT),
    ]
}

/// Notes sent to the progress sink.
#[derive(Default)]
struct Notes(std::sync::Mutex<Vec<String>>);

impl Progress for Notes {
    fn start(&self, _label: &str, _total: u64) {}
    fn inc(&self, _n: u64) {}
    fn finish(&self) {}
    fn note(&self, line: &str) {
        self.0.lock().unwrap().push(line.to_string());
    }
}

fn tiny_job(gca: &Path, out: &Path) -> SimulateJob {
    SimulateJob {
        gca: Some(gca.to_path_buf()),
        train_frames: Some(60),
        test_frames: Some(40),
        width: Some(64),
        height: Some(48),
        depth: Some(false),
        out: out.to_path_buf(),
        ..SimulateJob::default()
    }
}

#[test]
fn a_gca_folder_without_rsj_and_ccj_and_with_an_appendix_simulates() {
    let tmp = tempfile::tempdir().unwrap();
    let gca = tmp.path().join("EdinGCA_3D_99999");
    write_gca_folder(&gca, &landmarks_without_rsj_ccj(), None);
    let out = tmp.path().join("data");
    let notes = Notes::default();
    let report = tiny_job(&gca, &out).run(&notes).unwrap();

    // The missing landmarks are reported, in the progress notes and in the report.
    let text = report.to_string();
    let notes = notes.0.into_inner().unwrap().join("\n");
    for needle in [
        "landmark RSJ (recto-sigmoid junction) is missing: placed at path index 73",
        "landmark CCJ (caeco-colonic junction) is missing: placed at path index 620, the caecum starts at ICVc",
        "before landmark AO",
    ] {
        assert!(text.contains(needle), "report lacks {needle:?}:\n{text}");
        assert!(notes.contains(needle), "notes lack {needle:?}:\n{notes}");
    }
    assert!(
        report.summary.min_clearance_mm >= 3.0 - 1e-9,
        "{}",
        report.summary.min_clearance_mm
    );

    // Every frame is labelled; the pass runs from the anal canal into the caecum, in order,
    // through every section, and never reaches the appendix orifice.
    let ds = Dataset::open(&out).unwrap();
    for name in ["train", "test"] {
        let seq = ds.sequence(name).unwrap();
        let sections = seq.sections.clone().expect("sections.csv");
        assert_eq!(sections.len(), seq.len());
        assert_eq!(sections[0], Section::AnalCanal);
        assert_eq!(*sections.last().unwrap(), Section::Caecum);
        assert!(
            sections.windows(2).all(|w| w[0] <= w[1]),
            "{name}: out of order"
        );
        if name == "train" {
            for s in Section::ALL {
                assert!(sections.contains(&s), "{name}: no frame in {s}");
            }
        }
        let poses = &seq.poses;
        let ao = midline(AO);
        for (k, p) in poses.iter().enumerate() {
            let t = p.pose.translation.vector;
            assert!(
                t.x < ao[0] - 5.0,
                "{name} frame {k} at x = {:.1} mm, the appendix orifice is at x = {:.1} mm",
                t.x,
                ao[0]
            );
        }
    }
}

#[test]
fn a_real_narrowing_still_stops_the_simulation() {
    let tmp = tempfile::tempdir().unwrap();
    let gca = tmp.path().join("narrow");
    write_gca_folder(&gca, &landmarks_without_rsj_ccj(), Some(2.0));
    let err = tiny_job(&gca, &tmp.path().join("data"))
        .run(&endoloc_jobs::Silent)
        .unwrap_err();
    let msg = err.full_message();
    assert!(msg.contains("the lumen is too narrow at"), "{msg}");
    // The narrowing is at path indices 390..410 (about 400 mm along the mid-line).
    let at: f64 = msg
        .split("too narrow at ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or(f64::NAN);
    assert!(
        (370.0..450.0).contains(&at),
        "narrowing reported at {at} mm: {msg}"
    );
}

#[test]
fn a_gca_folder_without_a_surface_names_what_it_looked_for() {
    let tmp = tempfile::tempdir().unwrap();
    let gca = tmp.path().join("m");
    write_gca_folder(&gca, &landmarks_without_rsj_ccj(), None);
    std::fs::remove_file(gca.join("Surfaces/large-intestine.vtk")).unwrap();
    let err = tiny_job(&gca, &tmp.path().join("data"))
        .run(&endoloc_jobs::Silent)
        .unwrap_err();
    let msg = err.full_message();
    assert!(
        msg.contains("no large-intestine surface") && msg.contains("Surfaces/large-intestine.vtk"),
        "{msg}"
    );
}
