//! The display profile against a display whose truth is known: the
//! simulated CRT of `serve --mock` (crates/science/src/display/simulated.rs), measured by
//! the simulated PR-650's instrument model (8 nm slit, 4 nm grid, shot and
//! read noise). The truth is the simulated display's own spectra and γ, never
//! the fit's code path.

use lightbooth::colorimetry::{xyz_from_radiance, Observer, Xyz};
use lightbooth::display::profile::{FrameBuffer, TransferModel};
use lightbooth::display::{fit_profile, CalibrationPlan, DisplayProfile, MeasuredPatch, SimulatedDisplay};
use lightbooth::instrument::sim::model::{InstrumentModel, Rng};
use lightbooth::spectrum::{Grid, SpectralUnit, Spectrum};

/// What the simulated PR-650 reports for a drive: the mean of `samples` noisy readings.
fn measure(display: &SimulatedDisplay, drive: [f64; 3], samples: usize, rng: &mut Rng) -> Vec<f64> {
    let model = InstrumentModel::default();
    let reading = model.reading(&display.spectrum(drive), 0).unwrap();
    assert_eq!(
        reading.code, 0,
        "drive {drive:?} is not measurable (code {})",
        reading.code
    );
    let mut mean = vec![0.0; reading.expected.len()];
    for _ in 0..samples {
        for (m, v) in mean.iter_mut().zip(model.sample(&reading, rng)) {
            *m += v / samples as f64;
        }
    }
    mean
}

fn calibrate(display: &SimulatedDisplay, seed: u64) -> DisplayProfile {
    let mut rng = Rng::new(seed);
    let plan = CalibrationPlan::new(8).unwrap();
    let patches: Vec<MeasuredPatch> = plan
        .patches
        .iter()
        .enumerate()
        .map(|(i, p)| {
            MeasuredPatch::spectrum(
                p.drive,
                Grid::pr650().wavelengths().to_vec(),
                measure(display, p.drive, 3, &mut rng),
                Some(i as i64 + 1),
            )
        })
        .collect();
    fit_profile(&patches, Observer::JuddVos).unwrap()
}

fn pr650_xyz(values: Vec<f64>) -> Xyz {
    let s = Spectrum::new(Grid::pr650(), SpectralUnit::SpectralRadiance, values).unwrap();
    xyz_from_radiance(&s, Observer::JuddVos).unwrap()
}

#[test]
fn calibrating_the_simulated_display_recovers_its_primaries_and_gamma() {
    let display = SimulatedDisplay::crt().unwrap();
    let profile = calibrate(&display, 7);
    let truth = display.primary_chromaticities(Observer::JuddVos).unwrap();
    let fitted = profile.primary_chromaticities().unwrap();
    for c in 0..3 {
        let d = (fitted[c][0] - truth[c][0]).hypot(fitted[c][1] - truth[c][1]);
        assert!(
            d < 0.002,
            "primary {c}: fitted {:?}, true {:?}, Δxy {d:.5}",
            fitted[c],
            truth[c]
        );
        let (g, t) = (profile.transfer[c].gamma, display.gammas()[c]);
        assert!((g / t - 1.0).abs() < 0.01, "channel {c}: γ {g:.4} against the true {t}");
    }
    // The simulated display is additive by construction: white and R+G+B agree to the noise.
    assert!(
        profile.additivity().unwrap().delta_e00 < 0.5,
        "additivity ΔE00 {}",
        profile.additivity().unwrap().delta_e00
    );
    assert!(
        profile.validation().iter().all(|v| v.delta_e00 < 1.0),
        "{:?}",
        profile.validation()
    );
    assert_eq!(
        profile.measurement_ids.len(),
        CalibrationPlan::new(8).unwrap().patches.len()
    );
    let white = profile.white_xyz().unwrap();
    assert!(
        (white.y - 100.0).abs() < 2.0,
        "white luminance {} cd/m² (Judd–Vos)",
        white.y
    );
}

/// In-gamut colours: mixtures of the true display's own outputs, so that
/// each is reachable (checked below).
fn in_gamut_targets(display: &SimulatedDisplay) -> Vec<Xyz> {
    let mut out = Vec::new();
    for r in [0.15, 0.4, 0.7, 0.93] {
        for g in [0.2, 0.55, 0.85] {
            for b in [0.1, 0.45, 0.8] {
                let s = display.spectrum([r, g, b]);
                out.push(xyz_from_radiance(&s, Observer::JuddVos).unwrap());
            }
        }
    }
    out
}

/// XYZ → frame buffer (through the fitted profile) → simulated display →
/// simulated PR-650 → XYZ: the ΔE00 statistics (mean, max) at a bit depth.
fn round_trip(profile: &DisplayProfile, display: &SimulatedDisplay, bits: u32, noisy: bool) -> (f64, f64) {
    let fb = FrameBuffer::new(bits).unwrap();
    let model = InstrumentModel::default();
    let mut rng = Rng::new(11);
    let targets = in_gamut_targets(display);
    let mut des = Vec::new();
    for xyz in &targets {
        let linear = profile.linear_of_xyz(*xyz).unwrap();
        assert!(
            linear.iter().all(|v| (-0.01..=1.01).contains(v)),
            "{linear:?} out of gamut"
        );
        let codes = profile.codes_of_linear(linear, fb, TransferModel::Gamma);
        let shown = display.spectrum(codes.map(|c| fb.drive(c)));
        let measured = if noisy {
            measure(display, codes.map(|c| fb.drive(c)), 5, &mut rng)
        } else {
            model.expected(&shown).unwrap()
        };
        des.push(profile.delta_e00(*xyz, pr650_xyz(measured)).unwrap());
    }
    let mean = des.iter().sum::<f64>() / des.len() as f64;
    (mean, des.iter().cloned().fold(0.0, f64::max))
}

#[test]
fn round_trip_through_the_simulated_display_and_pr650_is_within_half_a_de00_at_8_bits() {
    let display = SimulatedDisplay::crt().unwrap();
    let profile = calibrate(&display, 3);
    let (mean8, max8) = round_trip(&profile, &display, 8, true);
    let (mean10, _) = round_trip(&profile, &display, 10, true);
    let (mean12, _) = round_trip(&profile, &display, 12, true);
    eprintln!("round trip ΔE00 mean/max: 8 bits {mean8:.3}/{max8:.3}, 10 bits {mean10:.3}, 12 bits {mean12:.3}");
    assert!(max8 < 0.5, "8 bits: max ΔE00 {max8}");
    // Quantisation bound: at 8 bits half a code of a channel moves its output
    // by at most γ·t^(1−1/γ)/(2·255) of full scale; the noise-free trip shows
    // what quantisation alone costs, and more bits cost less.
    let (q8, _) = round_trip(&profile, &display, 8, false);
    let (q10, _) = round_trip(&profile, &display, 10, false);
    let (q12, _) = round_trip(&profile, &display, 12, false);
    eprintln!("noise-free ΔE00 mean: 8 bits {q8:.4}, 10 bits {q10:.4}, 12 bits {q12:.4}");
    assert!(q10 < q8 && q12 < q8, "more bits must not be worse: {q8} {q10} {q12}");
    assert!(mean10 <= mean8 && mean12 <= mean8);
}
