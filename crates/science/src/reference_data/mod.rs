//! Standard tables compiled into the binary: colour-matching functions,
//! CIE illuminants and reflectance sets.
//!
//! The CSV files next to this module are copies of published data; where each
//! comes from (source, version, licence) is in `PROVENANCE.md` beside them.
//! They are parsed once, on first use, with the same CSV reader as user files,
//! so the embedded data obeys the same checks.
//!
//! ```
//! use lightbooth_science::reference_data::{illuminant, Illuminant};
//! let d65 = illuminant(Illuminant::D65);
//! assert_eq!(d65.value_at(560.0), Some(100.0));
//! ```

use std::str::FromStr;
use std::sync::OnceLock;

use crate::spectrum::table::SpectraTable;
use crate::spectrum::{SpectralUnit, Spectrum};

const JUDD_VOS_CSV: &str = include_str!("judd_vos_1978_cmf.csv");
const CIE1931_CSV: &str = include_str!("cie1931_2deg_cmf.csv");
const ILLUMINANTS_CSV: &str = include_str!("illuminants.csv");
const ILLUMINANTS_1NM_CSV: &str = include_str!("illuminants_1nm.csv");
const COLORCHECKER_CSV: &str = include_str!("colorchecker_classic.csv");
const MUNSELL_CSV: &str = include_str!("munsell_matt.csv");
const NATURAL_CSV: &str = include_str!("natural_reflectances.csv");
const CIE1964_10_CSV: &str = include_str!("cie1964_10deg_cmf.csv");
const CIE2015_2_CSV: &str = include_str!("cie2015_2deg_cmf.csv");
const CIE2015_10_CSV: &str = include_str!("cie2015_10deg_cmf.csv");
const CONE_FUNDAMENTALS_CSV: &str = include_str!("stockman_sharpe_2deg_cone_fundamentals.csv");
const CONE_FUNDAMENTALS_10_CSV: &str = include_str!("stockman_sharpe_10deg_cone_fundamentals.csv");

/// Parses an embedded table; these files ship with the binary and are tested,
/// so a failure here is a build defect, not user error.
fn embedded(text: &str, name: &str) -> SpectraTable {
    SpectraTable::parse(text, name).unwrap_or_else(|e| panic!("embedded data is corrupt: {e}"))
}

/// Every table compiled in, by its file name without `.csv` (the file
/// beside this module): what `lightbooth color builtin:NAME` reads, so the
/// manual's examples need no copy of the source tree.
pub const BUILTIN_TABLES: [(&str, &str); 12] = [
    ("colorchecker_classic", COLORCHECKER_CSV),
    ("munsell_matt", MUNSELL_CSV),
    ("natural_reflectances", NATURAL_CSV),
    ("illuminants", ILLUMINANTS_CSV),
    ("illuminants_1nm", ILLUMINANTS_1NM_CSV),
    ("judd_vos_1978_cmf", JUDD_VOS_CSV),
    ("cie1931_2deg_cmf", CIE1931_CSV),
    ("cie1964_10deg_cmf", CIE1964_10_CSV),
    ("cie2015_2deg_cmf", CIE2015_2_CSV),
    ("cie2015_10deg_cmf", CIE2015_10_CSV),
    ("stockman_sharpe_2deg_cone_fundamentals", CONE_FUNDAMENTALS_CSV),
    ("stockman_sharpe_10deg_cone_fundamentals", CONE_FUNDAMENTALS_10_CSV),
];

/// The compiled-in table `name` (see [`BUILTIN_TABLES`]; a trailing `.csv`
/// is ignored), if there is one.
pub fn builtin_table(name: &str) -> Option<SpectraTable> {
    let name = name.strip_suffix(".csv").unwrap_or(name);
    BUILTIN_TABLES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(n, text)| embedded(text, &format!("builtin:{n}")))
}

/// The CIE illuminants lightbooth ships.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Illuminant {
    /// Tungsten, 2856 K Planckian (CIE formula).
    A,
    /// Average daylight.
    D65,
    /// Cool white fluorescent (FL2).
    F2,
    /// Narrow-band tri-phosphor fluorescent (FL11): the spiky one.
    F11,
    /// Equal energy.
    E,
}

impl Illuminant {
    pub const ALL: [Illuminant; 5] = [
        Illuminant::A,
        Illuminant::D65,
        Illuminant::F2,
        Illuminant::F11,
        Illuminant::E,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Illuminant::A => "A",
            Illuminant::D65 => "D65",
            Illuminant::F2 => "F2",
            Illuminant::F11 => "F11",
            Illuminant::E => "E",
        }
    }
}

impl FromStr for Illuminant {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Illuminant::ALL
            .into_iter()
            .find(|i| {
                i.name().eq_ignore_ascii_case(s)
                    || (s.eq_ignore_ascii_case("FL2") && *i == Illuminant::F2)
                    || (s.eq_ignore_ascii_case("FL11") && *i == Illuminant::F11)
            })
            .ok_or_else(|| format!("unknown illuminant `{s}`: choose A, D65, F2, F11 or E"))
    }
}

/// An illuminant's relative power on the 380–780 nm, 5 nm grid (the CIE
/// publishes F2 and F11 only at 5 nm).
pub fn illuminant(which: Illuminant) -> Spectrum {
    static T: OnceLock<SpectraTable> = OnceLock::new();
    let t = T.get_or_init(|| embedded(ILLUMINANTS_CSV, "illuminants.csv"));
    t.spectrum(which.name(), SpectralUnit::RelativePower)
        .expect("embedded illuminant")
}

/// A, D65 or E at 1 nm (the CIE 1 nm tables); `None` for the fluorescent
/// illuminants, which have no 1 nm table.
pub fn illuminant_1nm(which: Illuminant) -> Option<Spectrum> {
    static T: OnceLock<SpectraTable> = OnceLock::new();
    let t = T.get_or_init(|| embedded(ILLUMINANTS_1NM_CSV, "illuminants_1nm.csv"));
    t.spectrum(which.name(), SpectralUnit::RelativePower).ok()
}

/// The reflectance sets lightbooth ships.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReflectanceSet {
    /// The 24 ColorChecker Classic patches (Ohta), chart order.
    ColorChecker,
    /// 1269 Munsell matt chips (Joensuu).
    Munsell,
    /// 23 natural objects (TM-30 nature + MCRI).
    Natural,
}

impl FromStr for ReflectanceSet {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "colorchecker" => Ok(ReflectanceSet::ColorChecker),
            "munsell" => Ok(ReflectanceSet::Munsell),
            "natural" => Ok(ReflectanceSet::Natural),
            _ => Err(format!(
                "unknown reflectance set `{s}`: choose colorchecker, munsell or natural"
            )),
        }
    }
}

/// Every spectrum of a set, named, on 380–780 nm at 5 nm.
pub fn reflectances(set: ReflectanceSet) -> &'static [(String, Spectrum)] {
    static CC: OnceLock<Vec<(String, Spectrum)>> = OnceLock::new();
    static MU: OnceLock<Vec<(String, Spectrum)>> = OnceLock::new();
    static NA: OnceLock<Vec<(String, Spectrum)>> = OnceLock::new();
    let (cell, text, name) = match set {
        ReflectanceSet::ColorChecker => (&CC, COLORCHECKER_CSV, "colorchecker_classic.csv"),
        ReflectanceSet::Munsell => (&MU, MUNSELL_CSV, "munsell_matt.csv"),
        ReflectanceSet::Natural => (&NA, NATURAL_CSV, "natural_reflectances.csv"),
    };
    cell.get_or_init(|| {
        embedded(text, name)
            .spectra(SpectralUnit::Reflectance)
            .unwrap_or_else(|e| panic!("embedded data is corrupt: {e}"))
    })
}

/// One ColorChecker patch by chart number (1 = dark skin … 24 = black).
pub fn colorchecker_patch(number: usize) -> Option<&'static (String, Spectrum)> {
    reflectances(ReflectanceSet::ColorChecker).get(number.checked_sub(1)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::Grid;

    #[test]
    fn every_embedded_table_parses_on_the_expected_grid() {
        for set in [
            ReflectanceSet::ColorChecker,
            ReflectanceSet::Munsell,
            ReflectanceSet::Natural,
        ] {
            let r = reflectances(set);
            assert!(!r.is_empty());
            assert!(r.iter().all(|(_, s)| s.grid().same_as(&Grid::analysis())));
        }
        assert_eq!(reflectances(ReflectanceSet::ColorChecker).len(), 24);
        assert_eq!(reflectances(ReflectanceSet::Munsell).len(), 1269);
        assert_eq!(colorchecker_patch(14).unwrap().0, "p14_green");
        for i in Illuminant::ALL {
            assert!(illuminant(i).grid().same_as(&Grid::analysis()));
        }
        assert!(illuminant_1nm(Illuminant::D65).unwrap().grid().same_as(&Grid::one_nm()));
        assert!(illuminant_1nm(Illuminant::F11).is_none());
        let lms = crate::colorimetry::ConeFundamentals::StockmanSharpe2.on_1nm_grid();
        assert!(lms.iter().all(|c| c.len() == 401));
        // Peaks of 1 (the table's normalisation) at the published wavelengths:
        // L 570 nm, M 543 nm, S 442 nm (Stockman & Sharpe 2000, 2°).
        for (c, peak_nm) in lms.iter().zip([570, 543, 442]) {
            let (i, max) = c
                .iter()
                .enumerate()
                .fold((0, 0.0), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
            assert!(
                (max - 1.0).abs() < 1e-3 && (380 + i as i32 - peak_nm).abs() <= 2,
                "{i} {max}"
            );
        }
        assert_eq!(lms[0][0], 0.0);
        assert!(lms[0][10] > 0.0);
    }
}
