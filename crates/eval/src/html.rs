//! Self-contained HTML reports: one file with its tables and its plots embedded as base64
//! PNG data URIs, so that it opens in any browser, is mailed as one attachment and never loses
//! an image. No scripts, no external styles.

use std::fmt::Write as _;

/// One piece of a report, in reading order.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A section heading.
    Heading(String),
    /// A paragraph of plain text (escaped).
    Paragraph(String),
    /// A table; numbers are right-aligned.
    Table {
        /// Column names.
        header: Vec<String>,
        /// Rows of cells (plain text).
        rows: Vec<Vec<String>>,
    },
    /// A PNG image with its caption, embedded.
    Image {
        /// Caption under the image.
        caption: String,
        /// The PNG file's bytes.
        png: Vec<u8>,
    },
    /// Preformatted text (a command line, a config file).
    Code(String),
}

/// A report: a title and its blocks.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HtmlReport {
    /// Page title and top heading.
    pub title: String,
    /// Content, in order.
    pub blocks: Vec<Block>,
}

impl HtmlReport {
    /// An empty report with a title.
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            blocks: Vec::new(),
        }
    }

    /// Appends a block.
    pub fn push(&mut self, block: Block) -> &mut Self {
        self.blocks.push(block);
        self
    }

    /// The HTML document.
    pub fn render(&self) -> String {
        let mut s = String::with_capacity(4096);
        let title = escape(&self.title);
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <title>{title}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n<h1>{title}</h1>\n"
        );
        for block in &self.blocks {
            match block {
                Block::Heading(h) => {
                    let _ = writeln!(s, "<h2>{}</h2>", escape(h));
                }
                Block::Paragraph(p) => {
                    let _ = writeln!(s, "<p>{}</p>", escape(p));
                }
                Block::Code(c) => {
                    let _ = writeln!(s, "<pre>{}</pre>", escape(c));
                }
                Block::Table { header, rows } => {
                    s.push_str("<table>\n<thead><tr>");
                    for h in header {
                        let _ = write!(s, "<th>{}</th>", escape(h));
                    }
                    s.push_str("</tr></thead>\n<tbody>\n");
                    for row in rows {
                        s.push_str("<tr>");
                        for cell in row {
                            let class = if looks_numeric(cell) {
                                " class=\"n\""
                            } else {
                                ""
                            };
                            let _ = write!(s, "<td{class}>{}</td>", escape(cell));
                        }
                        s.push_str("</tr>\n");
                    }
                    s.push_str("</tbody>\n</table>\n");
                }
                Block::Image { caption, png } => {
                    let caption = escape(caption);
                    let _ = writeln!(
                        s,
                        "<figure><img alt=\"{caption}\" src=\"data:image/png;base64,{}\">\
                         <figcaption>{caption}</figcaption></figure>",
                        base64(png)
                    );
                }
            }
        }
        s.push_str("</body>\n</html>\n");
        s
    }
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\n\
table{border-collapse:collapse;margin:1em 0}\n\
th,td{border:1px solid #ccc;padding:4px 10px}\n\
th{background:#f0f0f0}\n\
td.n{text-align:right;font-variant-numeric:tabular-nums}\n\
img{max-width:100%;border:1px solid #ddd}\n\
figcaption{color:#555;font-size:90%}\n\
pre{background:#f6f6f6;padding:8px;overflow-x:auto}\n";

fn looks_numeric(cell: &str) -> bool {
    let t = cell.trim().trim_end_matches('%');
    !t.is_empty() && t.parse::<f64>().is_ok()
}

/// Escapes text for HTML element content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for (i, shift) in [18u32, 12, 6, 0].into_iter().enumerate() {
            if i <= chunk.len() {
                out.push(ALPHABET[((n >> shift) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_test_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, encoded) in cases {
            assert_eq!(base64(plain.as_bytes()), encoded, "{plain:?}");
        }
        assert_eq!(base64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    #[test]
    fn report_escapes_text_and_embeds_images() {
        let mut r = HtmlReport::new("A <b> & c");
        r.push(Block::Table {
            header: vec!["method".into(), "mean (mm)".into()],
            rows: vec![vec!["<x>".into(), "2.50".into()]],
        })
        .push(Block::Image {
            caption: "plot".into(),
            png: b"foo".to_vec(),
        });
        let html = r.render();
        assert!(html.contains("<title>A &lt;b&gt; &amp; c</title>"));
        assert!(html.contains("<td>&lt;x&gt;</td><td class=\"n\">2.50</td>"));
        assert!(html.contains("src=\"data:image/png;base64,Zm9v\""));
        assert!(!html.contains("<b>"));
        assert!(html.trim_end().ends_with("</html>"));
    }
}
