//! File downloads for people who want files: spectra and comparison tables
//! as CSV and as MATLAB MAT-files; camera images as OpenEXR, ENVI and MAT.

pub mod exr_read;
pub mod image;
pub mod mat;
