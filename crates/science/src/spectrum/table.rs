//! Spectra as CSV: first column `nm`, then one column per named spectrum.
//!
//! This is the exchange format of the lab (and of the tables in `crates/science/src/reference_data/`
//! and `scenes/spectra/`): MATLAB's `writetable`, spreadsheets and instrument
//! exports all produce it. A CSV
//! carries no unit, so reading gives a [`SpectraTable`] of plain numbers and
//! the caller says what a column means with [`SpectraTable::spectrum`].
//!
//! A column of light (a radiance or SPD: values far above 1, or a header such
//! as `radiance` or `W/(sr·m²·nm)`) read as a reflectance or transmittance
//! is named as such ([`TableErrorKind::LooksLikeLight`]), not just as a value
//! out of [0, 1].
//!
//! Lines that start with `#` are comments, anywhere in the file (before the
//! header too): exported spectra carry their provenance in them (see
//! `calibration`). A `#` elsewhere in a line is not special.
//!
//! Every error names the file, the line and the column, so an operator can
//! open the file and fix it:
//!
//! ```
//! use lightbooth_science::spectrum::table::SpectraTable;
//! let err = SpectraTable::parse("nm,white\n380,0.5\n385,abc\n", "patch.csv").unwrap_err();
//! assert_eq!(err.to_string(), "patch.csv:3: column 2 (white): `abc` is not a number");
//! ```

use std::fmt;
use std::io::Write;
use std::path::Path;

use super::{Grid, SpectralUnit, Spectrum, SpectrumError};

/// A parsed CSV of spectra on one grid, with the line each row came from.
#[derive(Clone, Debug)]
pub struct SpectraTable {
    source: String,
    grid: Grid,
    /// Line number (1-based) of each grid row in the source, for errors.
    lines: Vec<u64>,
    columns: Vec<(String, Vec<f64>)>,
}

/// A problem in a spectra CSV, with where it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}{}: {kind}", location(*.line, .column))]
pub struct TableError {
    pub source_name: String,
    /// 1-based line, when the problem has one.
    pub line: Option<u64>,
    /// 1-based column and its header, when the problem has one.
    pub column: Option<(usize, String)>,
    pub kind: TableErrorKind,
}

fn location(line: Option<u64>, column: &Option<(usize, String)>) -> String {
    let mut s = String::new();
    if let Some(line) = line {
        s.push_str(&format!(":{line}"));
    }
    if let Some((i, name)) = column {
        s.push_str(&format!(": column {i} ({name})"));
    }
    s
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TableErrorKind {
    #[error("cannot read the file: {0}")]
    Io(String),
    #[error("malformed CSV: {0}")]
    Csv(String),
    #[error("the file is empty: expected a header `nm,<name>,…`")]
    Empty,
    #[error("the first column must be `nm` (wavelength in nm), found `{0}`")]
    FirstColumnNotNm(String),
    #[error("no spectrum columns after `nm`")]
    NoColumns,
    #[error("empty column name")]
    EmptyName,
    #[error("duplicate column name `{0}`, also column {1}")]
    DuplicateName(String, usize),
    #[error("`{0}` is not a number")]
    NotANumber(String),
    #[error("`{0}` is not a finite number (NaN and infinity are not allowed)")]
    NotFinite(String),
    #[error("{found} cells where the header has {expected}")]
    RaggedRow { expected: usize, found: usize },
    #[error("wavelength {nm} nm does not increase on the previous row ({prev_nm} nm)")]
    NotIncreasing { nm: f64, prev_nm: f64 },
    #[error("no data rows")]
    NoRows,
    #[error("the grid {grid} does not cover {lo}–{hi} nm")]
    DoesNotCover { grid: String, lo: f64, hi: f64 },
    #[error("no column named `{0}`; the file has: {1}")]
    NoSuchColumn(String, String),
    #[error("{0}")]
    Spectrum(Box<SpectrumError>),
    #[error(
        "read as a {unit} (0–1), but its values reach {max} and {why}: it looks like a radiance or \
         SPD; use it as light (e.g. `lightbooth color --unit radiance`), not as a {unit}"
    )]
    LooksLikeLight {
        unit: SpectralUnit,
        max: f64,
        why: &'static str,
    },
}

/// Words of a header that names light, not a reflectance.
const LIGHT_HEADER_WORDS: [&str; 8] = [
    "radiance",
    "irradiance",
    "w/",
    "watt",
    "cd/m",
    "spd",
    "power",
    "luminance",
];

/// Why a column of a factor unit (reflectance, transmittance) looks like
/// light: values far above 1 (more than twice a perfect white), or above 1
/// under a header that names light. `None` for plausible factors.
fn looks_like_light(header: &str, values: &[f64]) -> Option<(f64, &'static str)> {
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if max <= 1.0 {
        return None;
    }
    let header = header.to_ascii_lowercase();
    if LIGHT_HEADER_WORDS.iter().any(|w| header.contains(w)) {
        Some((max, "the header names light"))
    } else if max > 2.0 {
        Some((max, "no reflectance exceeds 2"))
    } else {
        None
    }
}

impl SpectraTable {
    /// Reads a CSV file.
    pub fn read(path: &Path) -> Result<SpectraTable, TableError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| TableError {
            source_name: name.clone(),
            line: None,
            column: None,
            kind: TableErrorKind::Io(e.to_string()),
        })?;
        SpectraTable::parse(&text, &name)
    }

    /// Parses CSV text; `source_name` is used in error messages.
    pub fn parse(text: &str, source_name: &str) -> Result<SpectraTable, TableError> {
        let err = |line: Option<u64>, column: Option<(usize, String)>, kind| TableError {
            source_name: source_name.to_string(),
            line,
            column,
            kind,
        };
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let mut records = reader.records();
        let header = match records.next() {
            None => return Err(err(None, None, TableErrorKind::Empty)),
            Some(Err(e)) => return Err(err(csv_line(&e), None, TableErrorKind::Csv(e.to_string()))),
            Some(Ok(h)) => h,
        };
        let header_line = header.position().map(|p| p.line()).unwrap_or(1);
        let first = header.get(0).unwrap_or("").trim_start_matches('\u{feff}');
        if !first.eq_ignore_ascii_case("nm") {
            return Err(err(
                Some(header_line),
                Some((1, first.to_string())),
                TableErrorKind::FirstColumnNotNm(first.to_string()),
            ));
        }
        let names: Vec<String> = header.iter().skip(1).map(str::to_string).collect();
        if names.is_empty() {
            return Err(err(Some(header_line), None, TableErrorKind::NoColumns));
        }
        for (i, name) in names.iter().enumerate() {
            if name.is_empty() {
                return Err(err(
                    Some(header_line),
                    Some((i + 2, String::new())),
                    TableErrorKind::EmptyName,
                ));
            }
            if let Some(j) = names[..i].iter().position(|n| n == name) {
                return Err(err(
                    Some(header_line),
                    Some((i + 2, name.clone())),
                    TableErrorKind::DuplicateName(name.clone(), j + 2),
                ));
            }
        }

        let mut nm = Vec::new();
        let mut lines = Vec::new();
        let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
        for record in records {
            let record = record.map_err(|e| err(csv_line(&e), None, TableErrorKind::Csv(e.to_string())))?;
            let line = record.position().map(|p| p.line()).unwrap_or(0);
            if record.iter().all(str::is_empty) {
                continue; // blank line
            }
            if record.len() != names.len() + 1 {
                return Err(err(
                    Some(line),
                    None,
                    TableErrorKind::RaggedRow {
                        expected: names.len() + 1,
                        found: record.len(),
                    },
                ));
            }
            for (i, cell) in record.iter().enumerate() {
                let col_name = if i == 0 { "nm".to_string() } else { names[i - 1].clone() };
                let value =
                    parse_number(cell).map_err(|kind| err(Some(line), Some((i + 1, col_name.clone())), kind))?;
                if i == 0 {
                    if let Some(&prev_nm) = nm.last() {
                        if value <= prev_nm {
                            return Err(err(
                                Some(line),
                                Some((1, col_name)),
                                TableErrorKind::NotIncreasing { nm: value, prev_nm },
                            ));
                        }
                    }
                    nm.push(value);
                } else {
                    columns[i - 1].push(value);
                }
            }
            lines.push(line);
        }
        if nm.is_empty() {
            return Err(err(None, None, TableErrorKind::NoRows));
        }
        let grid = Grid::from_wavelengths(nm).map_err(|e| err(None, None, TableErrorKind::Spectrum(Box::new(e))))?;
        Ok(SpectraTable {
            source: source_name.to_string(),
            grid,
            lines,
            columns: names.into_iter().zip(columns).collect(),
        })
    }

    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    pub fn source_name(&self) -> &str {
        &self.source
    }

    /// Column names in file order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.columns.iter().map(|(n, _)| n.as_str())
    }

    pub fn len(&self) -> usize {
        self.columns.len()
    }

    pub fn is_empty(&self) -> bool {
        self.columns.is_empty()
    }

    /// Errors unless the grid reaches from `lo_nm` to `hi_nm`.
    pub fn require_range(&self, lo_nm: f64, hi_nm: f64) -> Result<(), TableError> {
        if self.grid.covers(lo_nm, hi_nm) {
            return Ok(());
        }
        Err(TableError {
            source_name: self.source.clone(),
            line: None,
            column: Some((1, "nm".into())),
            kind: TableErrorKind::DoesNotCover {
                grid: self.grid.to_string(),
                lo: lo_nm,
                hi: hi_nm,
            },
        })
    }

    /// The column `name` as a spectrum of `unit`. A value the unit does not
    /// allow (negative reflectance) is reported with its line.
    pub fn spectrum(&self, name: &str, unit: SpectralUnit) -> Result<Spectrum, TableError> {
        let idx = self
            .columns
            .iter()
            .position(|(n, _)| n == name)
            .ok_or_else(|| TableError {
                source_name: self.source.clone(),
                line: None,
                column: None,
                kind: TableErrorKind::NoSuchColumn(name.to_string(), self.names().collect::<Vec<_>>().join(", ")),
            })?;
        self.spectrum_at(idx, unit)
    }

    /// Every column as a spectrum of `unit`, with its name.
    pub fn spectra(&self, unit: SpectralUnit) -> Result<Vec<(String, Spectrum)>, TableError> {
        (0..self.columns.len())
            .map(|i| Ok((self.columns[i].0.clone(), self.spectrum_at(i, unit)?)))
            .collect()
    }

    fn spectrum_at(&self, idx: usize, unit: SpectralUnit) -> Result<Spectrum, TableError> {
        let (name, values) = &self.columns[idx];
        if matches!(unit, SpectralUnit::Reflectance | SpectralUnit::Transmittance) {
            if let Some((max, why)) = looks_like_light(name, values) {
                return Err(TableError {
                    source_name: self.source.clone(),
                    line: None,
                    column: Some((idx + 2, name.clone())),
                    kind: TableErrorKind::LooksLikeLight { unit, max, why },
                });
            }
        }
        Spectrum::new(self.grid.clone(), unit, values.clone()).map_err(|e| {
            // Point at the offending row where the error names a wavelength.
            let line = match &e {
                SpectrumError::FactorOutOfRange { nm, .. } | SpectrumError::NonFiniteValue { nm } => {
                    self.grid.index_of(*nm).map(|i| self.lines[i])
                }
                _ => None,
            };
            TableError {
                source_name: self.source.clone(),
                line,
                column: Some((idx + 2, name.clone())),
                kind: TableErrorKind::Spectrum(Box::new(e)),
            }
        })
    }
}

fn csv_line(e: &csv::Error) -> Option<u64> {
    e.position().map(|p| p.line())
}

fn parse_number(cell: &str) -> Result<f64, TableErrorKind> {
    let v: f64 = cell.parse().map_err(|_| TableErrorKind::NotANumber(cell.to_string()))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(TableErrorKind::NotFinite(cell.to_string()))
    }
}

/// Writes spectra that share a grid as CSV (`nm` first). Values are written
/// in Rust's shortest round-trip form, so reading them back is exact.
pub fn write_csv<W: Write>(out: W, grid: &Grid, columns: &[(&str, &[f64])]) -> std::io::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    let mut header = vec!["nm".to_string()];
    header.extend(columns.iter().map(|(n, _)| n.to_string()));
    w.write_record(&header)?;
    for (i, nm) in grid.wavelengths().iter().enumerate() {
        let mut row = vec![nm.to_string()];
        for (_, values) in columns {
            row.push(values[i].to_string());
        }
        w.write_record(&row)?;
    }
    w.flush()
}

impl fmt::Display for SpectraTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {} spectra on {}", self.source, self.columns.len(), self.grid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(text: &str) -> String {
        SpectraTable::parse(text, "t.csv").unwrap_err().to_string()
    }

    #[test]
    fn reads_and_writes_round_trip() {
        let t = SpectraTable::parse("nm,a,b\n380,0.1,1e-3\n385,0.2,-0.5\n", "t.csv").unwrap();
        assert_eq!(t.names().collect::<Vec<_>>(), ["a", "b"]);
        assert_eq!(t.grid().step_nm(), Some(5.0));
        let a = t.spectrum("a", SpectralUnit::Reflectance).unwrap();
        let b = t.spectrum("b", SpectralUnit::SpectralRadiance).unwrap();
        let mut out = Vec::new();
        write_csv(&mut out, t.grid(), &[("a", a.values()), ("b", b.values())]).unwrap();
        let back = SpectraTable::parse(std::str::from_utf8(&out).unwrap(), "back").unwrap();
        assert_eq!(back.spectrum("b", SpectralUnit::SpectralRadiance).unwrap(), b);
    }

    #[test]
    fn every_malformed_case_names_file_line_and_column() {
        assert_eq!(msg("nm,a\n380,x\n"), "t.csv:2: column 2 (a): `x` is not a number");
        assert_eq!(
            msg("nm,a\n380,0.1\n380,0.2\n"),
            "t.csv:3: column 1 (nm): wavelength 380 nm does not increase on the previous row (380 nm)"
        );
        assert_eq!(
            msg("nm,a,a\n380,1,2\n"),
            "t.csv:1: column 3 (a): duplicate column name `a`, also column 2"
        );
        assert_eq!(
            msg("nm,a\n380,NaN\n"),
            "t.csv:2: column 2 (a): `NaN` is not a finite number (NaN and infinity are not allowed)"
        );
        assert_eq!(
            msg("nm,a\n380,inf\n"),
            "t.csv:2: column 2 (a): `inf` is not a finite number (NaN and infinity are not allowed)"
        );
        assert_eq!(msg("nm,a\n380,1,2\n"), "t.csv:2: 3 cells where the header has 2");
        assert_eq!(
            msg("lambda,a\n380,1\n"),
            "t.csv:1: column 1 (lambda): the first column must be `nm` (wavelength in nm), found `lambda`"
        );
        assert_eq!(msg(""), "t.csv: the file is empty: expected a header `nm,<name>,…`");
        assert_eq!(msg("nm,a\n"), "t.csv: no data rows");
        assert_eq!(msg("nm,a\n380,\n"), "t.csv:2: column 2 (a): `` is not a number");
    }

    #[test]
    fn comment_lines_are_skipped_and_errors_keep_their_file_line() {
        let text =
            "# provenance: measurement 3 / 4\n# standard: spectralon.csv\nnm,a\n# mid-file note\n380,0.5\n385,x\n";
        assert_eq!(
            SpectraTable::parse(text, "t.csv").unwrap_err().to_string(),
            "t.csv:6: column 2 (a): `x` is not a number"
        );
        let t = SpectraTable::parse("# made by lightbooth\nnm,a\n380,0.5\n# end\n", "t.csv").unwrap();
        assert_eq!(t.names().collect::<Vec<_>>(), ["a"]);
        assert_eq!(t.spectrum("a", SpectralUnit::Reflectance).unwrap().values(), [0.5]);
    }

    #[test]
    fn a_grid_short_of_380_780_is_an_error_when_required() {
        let t = SpectraTable::parse("nm,a\n400,1\n700,1\n", "t.csv").unwrap();
        assert_eq!(
            t.require_range(380.0, 780.0).unwrap_err().to_string(),
            "t.csv: column 1 (nm): the grid 400–700 nm at 300 nm (2 samples) does not cover 380–780 nm"
        );
    }

    #[test]
    fn negative_reflectance_is_reported_at_its_line() {
        let t = SpectraTable::parse("nm,paint\n380,0.1\n385,-0.02\n", "t.csv").unwrap();
        assert_eq!(
            t.spectrum("paint", SpectralUnit::Reflectance).unwrap_err().to_string(),
            "t.csv:3: column 2 (paint): reflectance at 385 nm is -0.02, outside [0, 1]"
        );
        // The same numbers as radiance are instrument noise, not an error.
        assert!(t.spectrum("paint", SpectralUnit::SpectralRadiance).is_ok());
    }
}
