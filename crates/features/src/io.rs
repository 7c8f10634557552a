//! Keypoint files: CSV with a header line (JSON comes from `serde` on [`Keypoint`]).

use crate::{FeatureError, Keypoint};

/// The CSV header written by [`keypoints_to_csv`].
pub const CSV_HEADER: &str = "x,y,scale,orientation_rad,response,laplacian,octave";

/// Keypoints as CSV: one header line ([`CSV_HEADER`]), one line per keypoint; `x`, `y`,
/// `scale` in pixels, orientation in radians (image axes).
pub fn keypoints_to_csv(keypoints: &[Keypoint]) -> String {
    let mut s = String::with_capacity(64 * (keypoints.len() + 1));
    s.push_str(CSV_HEADER);
    s.push('\n');
    for k in keypoints {
        s.push_str(&format!(
            "{},{},{},{},{},{},{}\n",
            k.x, k.y, k.scale, k.orientation, k.response, k.laplacian, k.octave
        ));
    }
    s
}

/// Parses CSV written by [`keypoints_to_csv`]; `source` names the file in errors.
///
/// # Errors
/// [`FeatureError::ParseKeypoints`] naming the source, the 1-based line and what was expected.
pub fn keypoints_from_csv(text: &str, source: &str) -> Result<Vec<Keypoint>, FeatureError> {
    let err = |line: usize, reason: String| FeatureError::ParseKeypoints {
        file: source.to_string(),
        line,
        reason,
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == CSV_HEADER => {}
        Some((_, h)) => return Err(err(1, format!("header is `{h}`, expected `{CSV_HEADER}`"))),
        None => {
            return Err(err(
                1,
                format!("file is empty, expected the header `{CSV_HEADER}`"),
            ));
        }
    }
    let mut out = Vec::new();
    for (i, line) in lines {
        let n = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 7 {
            return Err(err(
                n,
                format!("{} fields, expected 7 ({CSV_HEADER})", f.len()),
            ));
        }
        let num = |k: usize, name: &str| -> Result<f32, FeatureError> {
            f[k].parse::<f32>()
                .map_err(|_| err(n, format!("`{name}` is `{}`, expected a number", f[k])))
        };
        out.push(Keypoint {
            x: num(0, "x")?,
            y: num(1, "y")?,
            scale: num(2, "scale")?,
            orientation: num(3, "orientation_rad")?,
            response: num(4, "response")?,
            laplacian: f[5]
                .parse()
                .map_err(|_| err(n, format!("`laplacian` is `{}`, expected 1 or -1", f[5])))?,
            octave: f[6]
                .parse()
                .map_err(|_| err(n, format!("`octave` is `{}`, expected 0..255", f[6])))?,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trips_and_errors_name_the_line() {
        let k = Keypoint {
            x: 1.5,
            y: -0.25,
            scale: 2.4,
            orientation: 3.0,
            response: 812.5,
            laplacian: -1,
            octave: 2,
        };
        let text = keypoints_to_csv(&[k, k]);
        assert_eq!(keypoints_from_csv(&text, "a.csv").unwrap(), vec![k, k]);
        let bad = format!("{CSV_HEADER}\n1,2,3,4,5,1,0\n1,2,x,4,5,1,0\n");
        let e = keypoints_from_csv(&bad, "b.csv").unwrap_err().to_string();
        assert!(
            e.contains("b.csv") && e.contains("line 3") && e.contains("scale"),
            "{e}"
        );
    }
}
