//! A minimal `.xlsx` writer for test workbooks: sheets of numbers, inline strings, booleans and
//! empty cells, stored uncompressed in the zip container (Office Open XML, ECMA-376 part 1:
//! the content types, the package and workbook relationships, the workbook, one XML part per
//! sheet). Enough for the EndoSLAM pose sheets the importer reads; no styles, formulas or
//! shared strings.

use std::collections::BTreeMap;
use std::io::{Cursor, Write};
use std::path::Path;

use zip::write::SimpleFileOptions;

/// One cell's content.
#[derive(Debug, Clone)]
enum Cell {
    Number(f64),
    Text(String),
    Bool(bool),
    Empty,
}

/// A sheet: its name and its cells by (row, column), both 0-based.
#[derive(Debug, Clone, Default)]
pub struct Worksheet {
    name: String,
    cells: BTreeMap<(u32, u16), Cell>,
}

impl Worksheet {
    pub fn set_name(&mut self, name: &str) -> &mut Self {
        self.name = name.to_string();
        self
    }

    pub fn write_number(&mut self, row: u32, col: u16, v: f64) -> &mut Self {
        self.cells.insert((row, col), Cell::Number(v));
        self
    }

    pub fn write_string(&mut self, row: u32, col: u16, s: &str) -> &mut Self {
        self.cells.insert((row, col), Cell::Text(s.to_string()));
        self
    }

    pub fn write_boolean(&mut self, row: u32, col: u16, b: bool) -> &mut Self {
        self.cells.insert((row, col), Cell::Bool(b));
        self
    }

    /// A cell that is present but holds nothing.
    pub fn write_blank(&mut self, row: u32, col: u16) -> &mut Self {
        self.cells.insert((row, col), Cell::Empty);
        self
    }

    fn xml(&self) -> String {
        let mut rows: BTreeMap<u32, Vec<(u16, &Cell)>> = BTreeMap::new();
        for (&(r, c), cell) in &self.cells {
            rows.entry(r).or_default().push((c, cell));
        }
        let dimension = match (self.cells.keys().next(), self.cells.keys().next_back()) {
            (Some(_), Some(_)) => {
                let (r0, r1) = (
                    rows.keys().next().unwrap(),
                    rows.keys().next_back().unwrap(),
                );
                let c0 = self.cells.keys().map(|k| k.1).min().unwrap();
                let c1 = self.cells.keys().map(|k| k.1).max().unwrap();
                format!("{}:{}", cell_ref(*r0, c0), cell_ref(*r1, c1))
            }
            _ => "A1".to_string(),
        };
        let mut s = format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"yes\"?>\n<worksheet \
             xmlns=\"http://schemas.openxmlformats.org/spreadsheetml/2006/main\"><dimension \
             ref=\"{dimension}\"/><sheetData>"
        );
        for (r, cells) in rows {
            s += &format!("<row r=\"{}\">", r + 1);
            for (c, cell) in cells {
                let at = cell_ref(r, c);
                s += &match cell {
                    Cell::Number(v) => format!("<c r=\"{at}\"><v>{v:?}</v></c>"),
                    Cell::Text(t) => {
                        format!(
                            "<c r=\"{at}\" t=\"inlineStr\"><is><t>{}</t></is></c>",
                            escape(t)
                        )
                    }
                    Cell::Bool(b) => format!("<c r=\"{at}\" t=\"b\"><v>{}</v></c>", u8::from(*b)),
                    Cell::Empty => format!("<c r=\"{at}\"/>"),
                };
            }
            s += "</row>";
        }
        s + "</sheetData></worksheet>"
    }
}

/// A workbook of sheets, in order.
#[derive(Debug, Clone, Default)]
pub struct Workbook {
    sheets: Vec<Worksheet>,
}

impl Workbook {
    pub fn new() -> Self {
        Self::default()
    }

    /// A new sheet named `Sheet<N>` until renamed.
    pub fn add_worksheet(&mut self) -> &mut Worksheet {
        let name = format!("Sheet{}", self.sheets.len() + 1);
        self.sheets.push(Worksheet {
            name,
            ..Worksheet::default()
        });
        self.sheets.last_mut().unwrap()
    }

    pub fn save(&self, path: &Path) {
        std::fs::write(path, self.save_to_buffer()).unwrap();
    }

    pub fn save_to_buffer(&self) -> Vec<u8> {
        const HEAD: &str = "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"yes\"?>\n";
        const REL: &str = "http://schemas.openxmlformats.org/officeDocument/2006/relationships";
        const SML: &str = "application/vnd.openxmlformats-officedocument.spreadsheetml";
        let n = self.sheets.len().max(1);
        let mut types = format!(
            "{HEAD}<Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">\
             <Default Extension=\"rels\" ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>\
             <Default Extension=\"xml\" ContentType=\"application/xml\"/>\
             <Override PartName=\"/xl/workbook.xml\" ContentType=\"{SML}.sheet.main+xml\"/>"
        );
        let (mut sheets, mut rels) = (String::new(), String::new());
        for i in 1..=n {
            let name = self.sheets.get(i - 1).map_or("Sheet1", |s| s.name.as_str());
            types += &format!(
                "<Override PartName=\"/xl/worksheets/sheet{i}.xml\" ContentType=\"{SML}.worksheet+xml\"/>"
            );
            sheets += &format!(
                "<sheet name=\"{}\" sheetId=\"{i}\" r:id=\"rId{i}\"/>",
                escape(name)
            );
            rels += &format!(
                "<Relationship Id=\"rId{i}\" Type=\"{REL}/worksheet\" Target=\"worksheets/sheet{i}.xml\"/>"
            );
        }
        types += "</Types>";
        let parts = [
            ("[Content_Types].xml".to_string(), types),
            (
                "_rels/.rels".to_string(),
                format!(
                    "{HEAD}<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\
                     <Relationship Id=\"rId1\" Type=\"{REL}/officeDocument\" Target=\"xl/workbook.xml\"/>\
                     </Relationships>"
                ),
            ),
            (
                "xl/workbook.xml".to_string(),
                format!(
                    "{HEAD}<workbook xmlns=\"http://schemas.openxmlformats.org/spreadsheetml/2006/main\" \
                     xmlns:r=\"{REL}\"><sheets>{sheets}</sheets></workbook>"
                ),
            ),
            (
                "xl/_rels/workbook.xml.rels".to_string(),
                format!(
                    "{HEAD}<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">{rels}</Relationships>"
                ),
            ),
        ];
        let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
        let stored =
            SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
        for (name, body) in parts {
            zip.start_file(name, stored).unwrap();
            zip.write_all(body.as_bytes()).unwrap();
        }
        for i in 1..=n {
            let xml = self
                .sheets
                .get(i - 1)
                .map_or_else(|| Worksheet::default().xml(), Worksheet::xml);
            zip.start_file(format!("xl/worksheets/sheet{i}.xml"), stored)
                .unwrap();
            zip.write_all(xml.as_bytes()).unwrap();
        }
        zip.finish().unwrap().into_inner()
    }
}

/// `A1`-style reference of a 0-based cell.
fn cell_ref(row: u32, col: u16) -> String {
    let mut letters = Vec::new();
    let mut c = u32::from(col) + 1;
    while c > 0 {
        letters.push(b'A' + ((c - 1) % 26) as u8);
        c = (c - 1) / 26;
    }
    letters.reverse();
    format!("{}{}", String::from_utf8(letters).unwrap(), row + 1)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
