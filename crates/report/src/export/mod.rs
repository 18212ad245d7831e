//! File downloads for people who want files: tables as CSV ([`csv_table`])
//! and as MATLAB MAT-files ([`mat`]); camera images as OpenEXR, ENVI and MAT.

pub mod csv_table;
pub mod exr_read;
pub mod image;
pub mod mat;
