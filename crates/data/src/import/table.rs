//! Pose tables with a header row, from a CSV text file or from one sheet of an `.xlsx`
//! workbook, with errors that say where a bad cell is.
//!
//! - CSV (also `;`- or tab-separated): blank lines skipped; a row is located by its line.
//! - `.xlsx` (feature `xlsx`, read with `calamine`): one worksheet, chosen by name or the first
//!   whose header row has a wanted column; rows whose cells are all empty are skipped; a row is
//!   located by the sheet's name and its spreadsheet row number (1-based, as Excel shows it),
//!   a cell by its column letter (`D7`). [`DataError::Parse`]'s `line` is that row number.
//!
//! Header names are trimmed and compared in lower case; cells are kept as text (`.xlsx`
//! numbers as the shortest text that reads back to the same `f64`, so no precision is lost).

use super::parse_field;
use crate::DataError;
use crate::fsutil::text_from_bytes;
use std::path::{Path, PathBuf};

/// Where the rows of a [`Table`] come from.
#[derive(Debug, Clone, PartialEq)]
enum Origin {
    /// A text file: `line` numbers.
    Csv,
    /// A worksheet: its name, and the 0-based column of the table's first column.
    #[cfg_attr(not(feature = "xlsx"), allow(dead_code))]
    Sheet { name: String, first_col: u32 },
}

/// A table: header names (lower case, trimmed) and rows `(line or row number, cells)`.
#[derive(Debug, Clone)]
pub(crate) struct Table {
    /// The file it was read from.
    pub path: PathBuf,
    origin: Origin,
    /// Line (CSV) or spreadsheet row (xlsx) of the header.
    header_line: usize,
    /// Header names, lower case, trimmed.
    pub header: Vec<String>,
    /// `(line or row number, cells)`, every row as long as the header.
    pub rows: Vec<(usize, Vec<String>)>,
}

/// Spreadsheet column letters of a 0-based column index (`0` → `A`, `26` → `AA`).
pub(crate) fn column_letters(col: u32) -> String {
    let mut n = u64::from(col) + 1;
    let mut out = Vec::new();
    while n > 0 {
        let r = ((n - 1) % 26) as u8;
        out.push(b'A' + r);
        n = (n - 1) / 26;
    }
    out.reverse();
    String::from_utf8(out).unwrap_or_default()
}

/// True for a path ending in `.xlsx` (any case).
pub(crate) fn is_xlsx(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xlsx"))
}

impl Table {
    /// Reads `path`: an `.xlsx` workbook (sheet `sheet`, or the first whose header row has
    /// the column `prefer_column`) or else a CSV text file.
    ///
    /// # Errors
    /// [`DataError::Io`]; [`DataError::Parse`] for an empty file or sheet or a row whose
    /// cell count differs from the header's; [`DataError::Invalid`] for an unreadable
    /// workbook, a missing sheet, or an `.xlsx` when built without the `xlsx` feature.
    pub fn read(path: &Path, sheet: Option<&str>, prefer_column: &str) -> Result<Self, DataError> {
        let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
        Self::parse(path, bytes, sheet, prefer_column)
    }

    /// [`Table::read`] of a file's bytes; `path` gives the format (by its extension) and
    /// names the file in errors.
    pub fn parse(
        path: &Path,
        bytes: Vec<u8>,
        sheet: Option<&str>,
        prefer_column: &str,
    ) -> Result<Self, DataError> {
        if is_xlsx(path) {
            return parse_xlsx(path, bytes, sheet, prefer_column);
        }
        Self::parse_csv(path, &text_from_bytes(path, bytes)?)
    }

    /// Parses CSV text (`,`, `;` or tab separated; quotes around cells stripped).
    fn parse_csv(path: &Path, text: &str) -> Result<Self, DataError> {
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((head_i, head)) = lines.next() else {
            return Err(DataError::parse(
                path,
                1,
                "empty file; expected a header row",
            ));
        };
        let split = |l: &str| -> Vec<String> {
            l.split([',', ';', '\t'])
                .map(|c| c.trim().trim_matches('"').trim().to_string())
                .collect()
        };
        let header = split(head.trim_start_matches('\u{feff}'))
            .into_iter()
            .map(|h| h.to_ascii_lowercase())
            .collect::<Vec<_>>();
        let mut rows = Vec::new();
        for (i, l) in lines {
            let cells = split(l);
            if cells.len() != header.len() {
                return Err(DataError::parse(
                    path,
                    i + 1,
                    format!(
                        "{} columns; expected {} like the header ({})",
                        cells.len(),
                        header.len(),
                        header.join(",")
                    ),
                ));
            }
            rows.push((i + 1, cells));
        }
        Ok(Table {
            path: path.to_path_buf(),
            origin: Origin::Csv,
            header_line: head_i + 1,
            header,
            rows,
        })
    }

    /// Where a row is, for messages: `line 7` or `sheet "Poses" row 7`.
    pub fn row_name(&self, line: usize) -> String {
        match &self.origin {
            Origin::Csv => format!("line {line}"),
            Origin::Sheet { name, .. } => format!("sheet {name:?} row {line}"),
        }
    }

    /// For an `.xlsx` table, adds `sheet "Poses" row 7: ` in front of a [`DataError::Parse`]
    /// message about one of its rows (a CSV error already names the line); other errors are
    /// returned unchanged.
    pub fn locate(&self, e: DataError) -> DataError {
        match (&self.origin, e) {
            (
                Origin::Sheet { .. },
                DataError::Parse {
                    path,
                    line,
                    message,
                },
            ) if line > 0 && !message.starts_with("sheet ") => {
                let message = format!("{}: {message}", self.row_name(line));
                DataError::Parse {
                    path,
                    line,
                    message,
                }
            }
            (_, e) => e,
        }
    }

    /// Where a cell is, for messages: `column 3 (trans_x)` or
    /// `sheet "Poses" row 7, cell C7 (trans_x)`.
    fn cell_name(&self, line: usize, col: usize) -> String {
        let name = self.header.get(col).map_or("?", String::as_str);
        match &self.origin {
            Origin::Csv => format!("column {} ({name})", col + 1),
            Origin::Sheet {
                name: sheet,
                first_col,
            } => {
                let letters = column_letters(first_col.saturating_add(col as u32));
                format!("sheet {sheet:?} row {line}, cell {letters}{line} ({name})")
            }
        }
    }

    /// Column indices of `names` (lower case), or an error naming the header row and listing
    /// what is missing.
    pub fn columns<const N: usize>(&self, names: [&str; N]) -> Result<[usize; N], DataError> {
        let mut idx = [0; N];
        for (k, n) in names.iter().enumerate() {
            idx[k] = self.header.iter().position(|h| h == n).ok_or_else(|| {
                let at = match &self.origin {
                    Origin::Csv => String::new(),
                    Origin::Sheet { .. } => {
                        format!("{} (header): ", self.row_name(self.header_line))
                    }
                };
                DataError::parse(
                    &self.path,
                    self.header_line,
                    format!(
                        "{at}header has no column {n:?}; expected columns {} (found {})",
                        names.join(","),
                        self.header
                            .iter()
                            .filter(|h| !h.is_empty())
                            .cloned()
                            .collect::<Vec<_>>()
                            .join(",")
                    ),
                )
            })?;
        }
        Ok(idx)
    }

    /// The text of a cell (`""` when absent).
    pub fn text(cells: &[String], col: usize) -> &str {
        cells.get(col).map_or("", String::as_str)
    }

    /// A cell as a finite number; the error names the file, the row (line, or sheet and row)
    /// and the column.
    pub fn number(&self, line: usize, cells: &[String], col: usize) -> Result<f64, DataError> {
        let text = Self::text(cells, col);
        let where_ = self.cell_name(line, col);
        if text.trim().is_empty() {
            return Err(DataError::parse(
                &self.path,
                line,
                format!("{where_}: empty; expected a finite number"),
            ));
        }
        parse_field(&self.path, line, &where_, text)
    }
}

/// Reads one worksheet of an `.xlsx` workbook as a [`Table`].
#[cfg(feature = "xlsx")]
fn parse_xlsx(
    path: &Path,
    bytes: Vec<u8>,
    sheet: Option<&str>,
    prefer_column: &str,
) -> Result<Table, DataError> {
    use calamine::{Reader, Xlsx};
    let unreadable = |what: String| {
        DataError::invalid(
            path,
            format!("cannot read the .xlsx workbook ({what}); expected an Excel 2007+ workbook"),
        )
    };
    // calamine parses untrusted bytes; a panic inside it must become an error, not a crash.
    let opened = std::panic::catch_unwind(|| -> Result<Vec<(String, SheetCells)>, String> {
        let mut book = Xlsx::new(std::io::Cursor::new(bytes)).map_err(|e| e.to_string())?;
        let names = book.sheet_names();
        let mut sheets = Vec::with_capacity(names.len());
        for n in names {
            let cells = sheet_cells(&mut book, &n).map_err(|e| format!("sheet {n:?}: {e}"))?;
            sheets.push((n, cells));
        }
        Ok(sheets)
    })
    .map_err(|_| unreadable("the reader failed on this file".into()))?
    .map_err(unreadable)?;
    if opened.is_empty() {
        return Err(DataError::invalid(path, "the workbook has no worksheet"));
    }
    let sheet_names = || {
        opened
            .iter()
            .map(|(n, _)| format!("{n:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let tables = || opened.iter().map(|(n, c)| table_from_cells(path, n, c));
    let table = match sheet {
        Some(want) => {
            let Some((n, c)) = opened.iter().find(|(n, _)| n == want) else {
                return Err(DataError::invalid(
                    path,
                    format!("no sheet {want:?}; the workbook has {}", sheet_names()),
                ));
            };
            table_from_cells(path, n, c)?
        }
        None => {
            // The first sheet whose header has the wanted column; else the first sheet, so
            // that its error (empty, missing columns) is the one reported.
            let mut found = None;
            for t in tables() {
                if let Ok(t) = t
                    && t.header.iter().any(|h| h == prefer_column)
                {
                    found = Some(t);
                    break;
                }
            }
            match found {
                Some(t) => t,
                None => {
                    let (n, c) = &opened[0];
                    table_from_cells(path, n, c)?
                }
            }
        }
    };
    Ok(table)
}

/// Most cells with a value read from one worksheet: a pose table has a few per frame. A
/// workbook's size says little about its sheets (their XML is compressed), so a sheet with
/// more is refused rather than read into memory.
#[cfg(feature = "xlsx")]
const MAX_SHEET_CELLS: usize = 1 << 22;

/// Most cells (rows with a value × columns of the used range) of a [`Table`] from a sheet:
/// a few cells far apart must not make a table of billions of empty ones.
#[cfg(feature = "xlsx")]
const MAX_TABLE_CELLS: usize = 1 << 22;

/// The cells of a worksheet that hold a value: `((row, column), text)`, 0-based, in the
/// sheet's order.
#[cfg(feature = "xlsx")]
type SheetCells = Vec<((u32, u32), String)>;

/// Reads the cells of sheet `name` that hold a value, as text (strings trimmed; numbers as
/// the shortest text that reads back to the same `f64`).
#[cfg(feature = "xlsx")]
fn sheet_cells<RS: std::io::Read + std::io::Seek>(
    book: &mut calamine::Xlsx<RS>,
    name: &str,
) -> Result<SheetCells, String> {
    use calamine::{Data, DataRef};
    let mut reader = match book.worksheet_cells_reader(name) {
        Ok(r) => r,
        // A chart sheet or another non-worksheet: no cells, as calamine's own ranges.
        Err(calamine::XlsxError::NotAWorksheet(_)) => return Ok(Vec::new()),
        Err(e) => return Err(e.to_string()),
    };
    let mut cells = Vec::new();
    while let Some(cell) = reader.next_cell().map_err(|e| e.to_string())? {
        if matches!(cell.get_value(), DataRef::Empty) {
            continue;
        }
        if cells.len() == MAX_SHEET_CELLS {
            return Err(format!(
                "more than {MAX_SHEET_CELLS} cells with a value; expected a pose table"
            ));
        }
        let text = match Data::from(cell.get_value().clone()) {
            Data::Empty => String::new(),
            Data::String(s) => s.trim().to_string(),
            other => other.to_string(),
        };
        cells.push((cell.get_position(), text));
    }
    Ok(cells)
}

/// A worksheet's used range (the cells with a value) as a [`Table`]: the first non-empty row
/// is the header.
#[cfg(feature = "xlsx")]
fn table_from_cells(path: &Path, sheet: &str, cells: &SheetCells) -> Result<Table, DataError> {
    use std::collections::BTreeMap;
    let empty = || {
        DataError::parse(
            path,
            0,
            format!("sheet {sheet:?} is empty; expected a header row and one row per pose"),
        )
    };
    let Some(col0) = cells.iter().map(|((_, c), _)| *c).min() else {
        return Err(empty());
    };
    let col_end = cells.iter().map(|((_, c), _)| *c).max().unwrap_or(col0);
    let width = (col_end - col0) as usize + 1;
    // Rows with a non-empty cell, in row order.
    let mut by_row: BTreeMap<u32, Vec<(u32, &str)>> = BTreeMap::new();
    for ((r, c), text) in cells {
        if !text.is_empty() {
            by_row.entry(*r).or_default().push((*c, text));
        }
    }
    if by_row.len().saturating_mul(width) > MAX_TABLE_CELLS {
        return Err(DataError::invalid(
            path,
            format!(
                "sheet {sheet:?}: {} rows with a value × {width} columns ({} to {}); expected a pose table of at most {MAX_TABLE_CELLS} cells",
                by_row.len(),
                column_letters(col0),
                column_letters(col_end),
            ),
        ));
    }
    let mut rows = by_row.into_iter().map(|(r, row_cells)| {
        let mut cells = vec![String::new(); width];
        for (c, text) in row_cells {
            cells[(c - col0) as usize] = text.to_string();
        }
        (r as usize + 1, cells)
    });
    let Some((header_line, header)) = rows.next() else {
        return Err(empty());
    };
    let header = header
        .into_iter()
        .map(|h| h.trim_start_matches('\u{feff}').trim().to_ascii_lowercase())
        .collect();
    Ok(Table {
        path: path.to_path_buf(),
        origin: Origin::Sheet {
            name: sheet.to_string(),
            first_col: col0,
        },
        header_line,
        header,
        rows: rows.collect(),
    })
}

/// Without the `xlsx` feature: an error telling how to proceed.
#[cfg(not(feature = "xlsx"))]
fn parse_xlsx(
    path: &Path,
    _bytes: Vec<u8>,
    _sheet: Option<&str>,
    _prefer: &str,
) -> Result<Table, DataError> {
    Err(DataError::invalid(
        path,
        "this build cannot read .xlsx workbooks (endoloc-data without the `xlsx` feature); export the sheet to CSV (e.g. `libreoffice --headless --convert-to csv FILE.xlsx`) and give the .csv",
    ))
}

#[cfg(test)]
mod tests {
    use super::column_letters;

    #[test]
    fn column_letters_follow_spreadsheet_naming() {
        assert_eq!(column_letters(0), "A");
        assert_eq!(column_letters(25), "Z");
        assert_eq!(column_letters(26), "AA");
        assert_eq!(column_letters(27), "AB");
        assert_eq!(column_letters(701), "ZZ");
        assert_eq!(column_letters(702), "AAA");
    }
}
