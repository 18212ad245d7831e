//! A measurement's spectra as files and as a chart: the CSV (`nm`, the
//! mean, its SD, one column per sample with a spectrum), the MAT-file and
//! the spectrum chart. The API's downloads and `lightbooth measure --csv`
//! write the CSV with the one function here, so they are the same file.
//!
//! A colorimeter's or a luminance meter's measurement has no spectrum: each
//! refuses it with a message naming the instrument and what it measures,
//! never a grid of values it did not measure.

use lightbooth_report::charts;
use lightbooth_report::export::mat::MatFile;
use lightbooth_science::spectrum::{table::write_csv, Grid};
use lightbooth_store::MeasurementDetail;

use crate::error::LabError;
use crate::measure::recorder::stored_spectrum;

/// One sample's spectrum for the CSV: its index in the series and its
/// values on the measurement's grid.
pub struct SampleSpectrum<'a> {
    pub index: usize,
    pub radiance: &'a [f64],
}

/// The spectra CSV: `nm`, then `radiance` and `radiance_sd` (the mean and
/// its SD, when there is one), then `sample_{index}` for each sample that
/// has a spectrum. Values in Rust's shortest round-trip form.
pub fn spectrum_csv(
    wavelengths_nm: &[f64],
    mean_and_sd: Option<(&[f64], &[f64])>,
    samples: &[SampleSpectrum],
) -> Result<Vec<u8>, String> {
    let grid = Grid::from_wavelengths(wavelengths_nm.to_vec()).map_err(|e| e.to_string())?;
    let names: Vec<String> = samples.iter().map(|s| format!("sample_{}", s.index)).collect();
    let mut columns: Vec<(&str, &[f64])> = Vec::new();
    if let Some((mean, sd)) = mean_and_sd {
        columns.push(("radiance", mean));
        columns.push(("radiance_sd", sd));
    }
    columns.extend(names.iter().zip(samples).map(|(n, s)| (n.as_str(), s.radiance)));
    if let Some((name, values)) = columns.iter().find(|(_, v)| v.len() != grid.len()) {
        return Err(format!(
            "column `{name}` has {} values for a grid of {}",
            values.len(),
            grid.len()
        ));
    }
    let mut out = Vec::new();
    write_csv(&mut out, &grid, &columns).map_err(|e| e.to_string())?;
    Ok(out)
}

/// A stored measurement's spectra CSV (see [`spectrum_csv`]).
pub fn stored_spectrum_csv(m: &MeasurementDetail) -> Result<Vec<u8>, LabError> {
    refuse_without_spectra(m, "a spectrum CSV")?;
    let wl = sample_grid(m)?;
    let samples: Vec<SampleSpectrum> = m
        .samples
        .iter()
        .filter_map(|s| {
            s.radiance.as_deref().map(|radiance| SampleSpectrum {
                index: s.index,
                radiance,
            })
        })
        .collect();
    let mean = m.radiance.as_deref().zip(m.radiance_sd.as_deref());
    spectrum_csv(&wl, mean, &samples).map_err(LabError::Internal)
}

/// A stored measurement as a MAT-file: `wavelength_nm`, `radiance`,
/// `radiance_sd`, `samples` (one column per sample; NaN where a sample had
/// no valid spectrum), `sample_code`, `sample_usable`, `Y`, `x`, `y` (with
/// `observer`), the instrument's own CIE 1931 `instrument_Y`,
/// `instrument_x`, `instrument_y`, and `state`.
pub fn stored_spectrum_mat(m: &MeasurementDetail) -> Result<Vec<u8>, LabError> {
    refuse_without_spectra(m, "a MAT file of its spectra")?;
    let wl = sample_grid(m)?;
    let mut mat = MatFile::new();
    mat.column("wavelength_nm", &wl).map_err(LabError::Internal)?;
    if let (Some(mean), Some(sd)) = (&m.radiance, &m.radiance_sd) {
        mat.column("radiance", mean).map_err(LabError::Internal)?;
        mat.column("radiance_sd", sd).map_err(LabError::Internal)?;
    }
    let mut samples = Vec::with_capacity(wl.len() * m.samples.len());
    for s in &m.samples {
        match &s.radiance {
            Some(r) if r.len() == wl.len() => samples.extend_from_slice(r),
            Some(r) => {
                return Err(LabError::Internal(format!(
                    "measurement {} sample {}: {} values for a grid of {}",
                    m.summary.id,
                    s.index,
                    r.len(),
                    wl.len()
                )))
            }
            None => samples.extend(std::iter::repeat_n(f64::NAN, wl.len())),
        }
    }
    mat.matrix("samples", wl.len(), m.samples.len(), &samples)
        .map_err(LabError::Internal)?;
    let codes: Vec<f64> = m.samples.iter().map(|s| s.code as f64).collect();
    let usable: Vec<f64> = m.samples.iter().map(|s| if s.usable { 1.0 } else { 0.0 }).collect();
    mat.matrix("sample_code", 1, codes.len(), &codes)
        .map_err(LabError::Internal)?;
    mat.matrix("sample_usable", 1, usable.len(), &usable)
        .map_err(LabError::Internal)?;
    // Y, x, y with the measurement's observer (named in `observer`); the
    // instrument's own CIE 1931 values under their own names.
    for (name, v) in [
        ("Y", m.summary.luminance_cd_m2),
        ("x", m.summary.x),
        ("y", m.summary.y),
        ("instrument_Y", m.summary.instrument_luminance_cd_m2),
        ("instrument_x", m.summary.instrument_x),
        ("instrument_y", m.summary.instrument_y),
    ] {
        mat.scalar(name, v.unwrap_or(f64::NAN)).map_err(LabError::Internal)?;
    }
    if let Some(o) = m.summary.observer {
        mat.text("observer", o.name()).map_err(LabError::Internal)?;
    }
    mat.text("state", m.summary.state.as_str())
        .map_err(LabError::Internal)?;
    Ok(mat.into_bytes())
}

/// A stored measurement's spectra drawn: the mean, its ±1 SD band and every
/// sample.
pub fn stored_spectrum_chart(m: &MeasurementDetail) -> Result<Vec<u8>, LabError> {
    refuse_without_spectra(m, "a spectral chart")?;
    let wl = sample_grid(m).unwrap_or_default();
    let samples: Vec<Vec<f64>> = m.samples.iter().filter_map(|s| s.radiance.clone()).collect();
    let id = m.summary.id;
    let title = match (&m.summary.scene, &m.summary.target) {
        (Some(s), Some(t)) => format!("measurement {id}: {s} / {t}"),
        _ => format!("measurement {id}"),
    };
    let svg = charts::spectrum_chart(&title, &wl, m.radiance.as_deref(), m.radiance_sd.as_deref(), &samples)
        .map_err(LabError::Internal)?;
    Ok(svg.into_bytes())
}

/// A measurement by an instrument that gives no spectrum (a colorimeter, a
/// luminance meter), when `what` is a spectral view of it: a conflict
/// naming the instrument and what it measures. A spectroradiometer's
/// measurement with no good sample yet is still shown (empty).
fn refuse_without_spectra(m: &MeasurementDetail, what: &str) -> Result<(), LabError> {
    let spectral = m.radiance.is_some() || m.samples.iter().any(|s| s.radiance.is_some());
    let non_spectral = m.samples.iter().any(|s| s.usable && s.radiance.is_none());
    if spectral || !non_spectral {
        return Ok(());
    }
    Err(LabError::Conflict(stored_spectrum(m, what).err().unwrap_or_default()))
}

/// The grid of a measurement: stored with the average, or, for one that
/// never completed, the native grid its samples' length names (101 or 201
/// points; the PR-650's with no sample at all).
fn sample_grid(m: &MeasurementDetail) -> Result<Vec<f64>, LabError> {
    if let Some(wl) = &m.wavelength_nm {
        return Ok(wl.clone());
    }
    let n = m.samples.iter().find_map(|s| s.radiance.as_ref().map(Vec::len));
    match n.map(|len| (len, lightbooth_instrument::native_grid_of_length(len))) {
        None => Ok(Grid::pr650().wavelengths().to_vec()),
        Some((_, Some(grid))) => Ok(grid.wavelengths().to_vec()),
        Some((other, None)) => Err(LabError::Internal(format!(
            "measurement {} has {other}-point samples and no grid",
            m.summary.id
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The CSV the API serves and `lightbooth measure --csv` prints: read
    /// back with the `csv` crate, every column and value as given.
    #[test]
    fn spectrum_csv_reads_back_column_for_column() {
        let wl = [380.0, 381.0, 382.0];
        let (mean, sd) = ([1.0, 2.0, 3.0], [0.1, 0.2, 0.30000000000000004]);
        let s3 = [0.5, 1.5, 2.5];
        let csv = spectrum_csv(
            &wl,
            Some((&mean, &sd)),
            &[SampleSpectrum {
                index: 3,
                radiance: &s3,
            }],
        )
        .unwrap();
        let mut r = csv::Reader::from_reader(csv.as_slice());
        let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
        assert_eq!(header, ["nm", "radiance", "radiance_sd", "sample_3"]);
        let rows: Vec<Vec<f64>> = r
            .records()
            .map(|r| r.unwrap().iter().map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[2], [382.0, 3.0, 0.30000000000000004, 2.5]);
    }

    #[test]
    fn a_column_shorter_than_the_grid_is_refused_with_its_name() {
        let e = spectrum_csv(
            &[380.0, 381.0],
            None,
            &[SampleSpectrum {
                index: 0,
                radiance: &[1.0],
            }],
        )
        .unwrap_err();
        assert!(e.contains("`sample_0` has 1 values for a grid of 2"), "{e}");
    }
}
