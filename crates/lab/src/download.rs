//! A file the lab made for a caller to save: its bytes, its media type and
//! the name to save it under. Every export (a measurement's spectra, a
//! scene's comparisons, an experiment's analysis, a camera image) is made
//! in the lab and handed out as a [`Download`], so the API and the command
//! line write identical files; the HTTP layer only sets the headers.

use std::sync::Arc;

/// The kinds of file the lab writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileFormat {
    /// RFC 4180 CSV (UTF-8), written through the `csv` crate.
    Csv,
    /// A MATLAB level-5 MAT-file (`load('…mat')`).
    Mat,
    /// Multi-channel OpenEXR.
    Exr,
}

impl FileFormat {
    /// The media type the file is served as.
    pub fn media_type(self) -> &'static str {
        match self {
            FileFormat::Csv => "text/csv; charset=utf-8",
            FileFormat::Mat => "application/x-matlab-data",
            FileFormat::Exr => "image/x-exr",
        }
    }

    /// The file name's extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            FileFormat::Csv => "csv",
            FileFormat::Mat => "mat",
            FileFormat::Exr => "exr",
        }
    }
}

/// A file to save: `file_name` (with its extension) and its bytes, shared
/// with the lab's cache where the file is made once per kept result.
#[derive(Clone, Debug)]
pub struct Download {
    pub format: FileFormat,
    pub file_name: String,
    pub bytes: Arc<Vec<u8>>,
}

impl Download {
    /// The file `{stem}.{extension}` of `format`.
    pub fn new(format: FileFormat, stem: &str, bytes: impl Into<Arc<Vec<u8>>>) -> Download {
        Download {
            format,
            file_name: format!("{stem}.{}", format.extension()),
            bytes: bytes.into(),
        }
    }
}
