//! A MATLAB MAT-file (Level 5) writer for numeric matrices and strings: the
//! downloads scientists load with `load('file.mat')`.
//!
//! Format: MathWorks, "MAT-File Format" (matfile_format.pdf), Level 5: a
//! 128-byte header, then one `miMATRIX` element per variable holding array
//! flags, dimensions, name and data sub-elements, each padded to 8 bytes.
//! Only what lightbooth writes is supported: real double matrices
//! (column-major), real single N-dimensional arrays (camera images, H × W × N)
//! and char row vectors; no compression. No maintained Rust crate writes
//! Level 5 MAT-files (the `matfile` crate, used in the tests, only reads), so
//! this small writer follows the MathWorks PDF directly.
//!
//! ```
//! use lightbooth_report::export::mat::MatFile;
//! let mut mat = MatFile::new();
//! mat.matrix("radiance", 3, 1, &[0.1, 0.2, 0.3]).unwrap();
//! mat.text("unit", "W/(sr m^2 nm)").unwrap();
//! let bytes = mat.into_bytes();
//! assert_eq!(&bytes[126..128], b"IM"); // little-endian marker
//! ```

const MI_INT8: u32 = 1;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_SINGLE: u32 = 7;
const MI_UINT32: u32 = 6;
const MI_DOUBLE: u32 = 9;
const MI_MATRIX: u32 = 14;
const MX_CHAR_CLASS: u32 = 4;
const MX_DOUBLE_CLASS: u32 = 6;
const MX_SINGLE_CLASS: u32 = 7;

/// A MAT-file being built in memory.
pub struct MatFile {
    bytes: Vec<u8>,
}

impl Default for MatFile {
    fn default() -> Self {
        Self::new()
    }
}

impl MatFile {
    pub fn new() -> MatFile {
        let mut header = format!(
            "MATLAB 5.0 MAT-file, Platform: lightbooth, Created by: lightbooth {}",
            env!("CARGO_PKG_VERSION")
        )
        .into_bytes();
        header.resize(116, b' ');
        let mut bytes = header;
        bytes.extend_from_slice(&[0u8; 8]); // subsystem data offset: none
        bytes.extend_from_slice(&0x0100u16.to_le_bytes()); // version
        bytes.extend_from_slice(b"IM"); // endian indicator, written little-endian
        MatFile { bytes }
    }

    /// A `rows × cols` double matrix from column-major `data`.
    pub fn matrix(&mut self, name: &str, rows: usize, cols: usize, data: &[f64]) -> Result<(), String> {
        if rows * cols != data.len() {
            return Err(format!(
                "{name}: {rows}×{cols} needs {} values, got {}",
                rows * cols,
                data.len()
            ));
        }
        let mut body = Vec::new();
        push_element(&mut body, MI_UINT32, &flags(MX_DOUBLE_CLASS));
        push_element(&mut body, MI_INT32, &dims(rows, cols)?);
        push_element(&mut body, MI_INT8, valid_name(name)?.as_bytes());
        let raw: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        push_element(&mut body, MI_DOUBLE, &raw);
        push_element(&mut self.bytes, MI_MATRIX, &body);
        Ok(())
    }

    /// A single-precision array of any rank from column-major `data`
    /// (element (i, j, k) of an H × W × N array at i + H·j + H·W·k).
    pub fn single_array(&mut self, name: &str, shape: &[usize], data: &[f32]) -> Result<(), String> {
        let count: usize = shape.iter().product();
        if shape.len() < 2 || count != data.len() {
            return Err(format!(
                "{name}: shape {shape:?} (at least 2 dimensions) needs {count} values, got {}",
                data.len()
            ));
        }
        if data.len() * 4 > u32::MAX as usize - 1024 {
            return Err(format!(
                "{name}: {} values are too many for a Level 5 MAT-file element",
                data.len()
            ));
        }
        let mut dim_bytes = Vec::new();
        for d in shape {
            let d = i32::try_from(*d).map_err(|_| format!("{name}: dimension {d} too large for a MAT-file"))?;
            dim_bytes.extend_from_slice(&d.to_le_bytes());
        }
        let mut body = Vec::new();
        push_element(&mut body, MI_UINT32, &flags(MX_SINGLE_CLASS));
        push_element(&mut body, MI_INT32, &dim_bytes);
        push_element(&mut body, MI_INT8, valid_name(name)?.as_bytes());
        let raw: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        push_element(&mut body, MI_SINGLE, &raw);
        push_element(&mut self.bytes, MI_MATRIX, &body);
        Ok(())
    }

    /// A column vector.
    pub fn column(&mut self, name: &str, data: &[f64]) -> Result<(), String> {
        self.matrix(name, data.len(), 1, data)
    }

    /// A scalar.
    pub fn scalar(&mut self, name: &str, v: f64) -> Result<(), String> {
        self.matrix(name, 1, 1, &[v])
    }

    /// A char row vector (UTF-16 code units, as MATLAB stores char).
    pub fn text(&mut self, name: &str, s: &str) -> Result<(), String> {
        let units: Vec<u16> = s.encode_utf16().collect();
        self.char_matrix(name, 1, units.len(), &units)
    }

    /// A char matrix of equal-length rows, padded with spaces (MATLAB's
    /// `char({'a','bcd'})`): how a column of names is stored without cells.
    pub fn text_rows(&mut self, name: &str, rows: &[String]) -> Result<(), String> {
        let encoded: Vec<Vec<u16>> = rows.iter().map(|r| r.encode_utf16().collect()).collect();
        let width = encoded.iter().map(Vec::len).max().unwrap_or(0);
        let mut data = vec![u16::from(b' '); rows.len() * width];
        for (r, row) in encoded.iter().enumerate() {
            for (c, unit) in row.iter().enumerate() {
                data[c * rows.len() + r] = *unit; // column-major
            }
        }
        self.char_matrix(name, rows.len(), width, &data)
    }

    fn char_matrix(&mut self, name: &str, rows: usize, cols: usize, units: &[u16]) -> Result<(), String> {
        let mut body = Vec::new();
        push_element(&mut body, MI_UINT32, &flags(MX_CHAR_CLASS));
        push_element(&mut body, MI_INT32, &dims(rows, cols)?);
        push_element(&mut body, MI_INT8, valid_name(name)?.as_bytes());
        let raw: Vec<u8> = units.iter().flat_map(|u| u.to_le_bytes()).collect();
        push_element(&mut body, MI_UINT16, &raw);
        push_element(&mut self.bytes, MI_MATRIX, &body);
        Ok(())
    }

    pub fn into_bytes(self) -> Vec<u8> {
        self.bytes
    }
}

fn flags(class: u32) -> Vec<u8> {
    let mut v = class.to_le_bytes().to_vec();
    v.extend_from_slice(&0u32.to_le_bytes());
    v
}

fn dims(rows: usize, cols: usize) -> Result<Vec<u8>, String> {
    let r = i32::try_from(rows).map_err(|_| "too many rows for a MAT-file".to_string())?;
    let c = i32::try_from(cols).map_err(|_| "too many columns for a MAT-file".to_string())?;
    Ok([r.to_le_bytes(), c.to_le_bytes()].concat())
}

/// MATLAB variable names: a letter, then letters, digits or underscores, at most 63.
fn valid_name(name: &str) -> Result<&str, String> {
    let mut chars = name.chars();
    let ok = chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && name.len() <= 63;
    if ok {
        Ok(name)
    } else {
        Err(format!("`{name}` is not a valid MATLAB variable name"))
    }
}

/// A tagged data element, padded to a multiple of 8 bytes.
fn push_element(out: &mut Vec<u8>, data_type: u32, data: &[u8]) {
    out.extend_from_slice(&data_type.to_le_bytes());
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(data);
    let pad = (8 - data.len() % 8) % 8;
    out.extend(std::iter::repeat_n(0u8, pad));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Read back with the independent `matfile` crate.
    #[test]
    fn matrices_read_back_with_an_independent_reader() {
        let mut m = MatFile::new();
        m.matrix("samples", 2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        m.scalar("Y", 34.25).unwrap();
        m.text("coding", "nstep9").unwrap();
        let bytes = m.into_bytes();
        let parsed = matfile::MatFile::parse(bytes.as_slice()).expect("a valid MAT-file");
        let samples = parsed.find_by_name("samples").unwrap();
        assert_eq!(samples.size(), &vec![2, 3]);
        match samples.data() {
            matfile::NumericData::Double { real, .. } => assert_eq!(real, &vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
            other => panic!("{other:?}"),
        }
        let y = parsed.find_by_name("Y").unwrap();
        assert!(matches!(y.data(), matfile::NumericData::Double { real, .. } if real == &vec![34.25]));
    }

    /// A 3-D single array: dimensions and column-major order as MATLAB's.
    #[test]
    fn single_3d_arrays_read_back_with_an_independent_reader() {
        let mut m = MatFile::new();
        let data: Vec<f32> = (0..24).map(|i| i as f32 * 0.5).collect();
        m.single_array("radiance", &[2, 3, 4], &data).unwrap();
        assert!(m.single_array("bad", &[2, 3], &data).is_err());
        let bytes = m.into_bytes();
        let parsed = matfile::MatFile::parse(bytes.as_slice()).expect("a valid MAT-file");
        let a = parsed.find_by_name("radiance").unwrap();
        assert_eq!(a.size(), &vec![2, 3, 4]);
        match a.data() {
            matfile::NumericData::Single { real, .. } => assert_eq!(real, &data),
            other => panic!("{other:?}"),
        }
        // The tag of the data sub-element: miSINGLE (7), 96 bytes.
        let tag = [7u32.to_le_bytes(), 96u32.to_le_bytes()].concat();
        assert!(bytes.windows(8).any(|w| w == tag.as_slice()));
    }

    #[test]
    fn bad_names_and_shapes_are_refused() {
        let mut m = MatFile::new();
        assert!(m.matrix("1abc", 1, 1, &[0.0]).is_err());
        assert!(m.matrix("a", 2, 2, &[0.0]).is_err());
    }
}
