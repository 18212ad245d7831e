//! File downloads for people who want files: spectra and comparison tables
//! as CSV and as MATLAB MAT-files.

pub mod mat;
