//! How a trial of the oddity experiment is shown: the pie's size on the
//! screen and the trial's timeline, with the study's values as defaults.
//!
//! Ruppertsberg & Bloj (2006, section 4.B): three 120° pie pieces forming a
//! disc of 5.7° visual angle; a fixation cross for 1000 ms, the pie for
//! 300 ms, then the fixation cross until the observer answers (left, top or
//! right); a grey background of the stimuli's mean luminance; two minutes of
//! adaptation before each block. The study does not give its viewing
//! distance or its screen's pixel pitch; the defaults here (570 mm, where
//! 1 cm is about 1°, and 0.25 mm) are stated on every session page and
//! belong in the experiment record, measured for the lab's own screen.
//!
//! A display shows whole frames, so every duration becomes a whole number
//! of frames at the refresh rate the session page measures
//! ([`Presentation::frames`]); the page shows the duration that number of
//! frames really lasts.
//!
//! ```
//! use lightbooth_science::psychophysics::presentation::Presentation;
//!
//! let p = Presentation::default();
//! // 5.7° at 570 mm is 56.7 mm: 227 pixels of 0.25 mm.
//! assert_eq!(p.pie_diameter_px().round(), 227.0);
//! // 300 ms at 60 Hz is 18 frames; at 85 Hz, 25.5 rounds to 26 (306 ms).
//! assert_eq!(p.frames(p.stimulus_ms, 60.0), 18);
//! assert_eq!(p.frames(p.stimulus_ms, 85.0), 26);
//! ```

use serde::{Deserialize, Serialize};

use super::design::MAX_REPEATS;

/// The pie and the timeline of every trial (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields, default)]
pub struct Presentation {
    /// Diameter of the disc the three pieces form, degrees of visual angle (study: 5.7).
    pub pie_diameter_deg: f64,
    /// Eye to screen, mm (not given by the study; 570 mm by default).
    pub viewing_distance_mm: f64,
    /// Width of one screen pixel, mm (0.25 by default: measure yours).
    pub pixel_pitch_mm: f64,
    /// Fixation cross before the pie, ms (study: 1000).
    pub fixation_ms: f64,
    /// The pie, ms (study: 300).
    pub stimulus_ms: f64,
    /// Adaptation to the background before each block, s (study: 120).
    pub adaptation_s: f64,
    /// Repeats of each of the six configurations per approximation (study: 6, so 36 trials).
    pub repeats: u32,
}

impl Default for Presentation {
    fn default() -> Presentation {
        Presentation {
            pie_diameter_deg: 5.7,
            viewing_distance_mm: 570.0,
            pixel_pitch_mm: 0.25,
            fixation_ms: 1000.0,
            stimulus_ms: 300.0,
            adaptation_s: 120.0,
            repeats: 6,
        }
    }
}

/// Refresh rates a session accepts, Hz: below this a 300 ms pie is under
/// ten frames and a browser is not drawing at the display's rate.
pub const MIN_REFRESH_HZ: f64 = 20.0;
/// Above this no display refreshes.
pub const MAX_REFRESH_HZ: f64 = 1000.0;

impl Presentation {
    /// Every value in its range; the error names the key and its range.
    pub fn validate(&self) -> Result<(), String> {
        let check = |key: &str, v: f64, lo: f64, hi: f64, unit: &str| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(format!("presentation.{key} = {v}: give {lo}–{hi} {unit}"))
            }
        };
        check("pie_diameter_deg", self.pie_diameter_deg, 0.5, 40.0, "degrees")?;
        check("viewing_distance_mm", self.viewing_distance_mm, 100.0, 5000.0, "mm")?;
        check("pixel_pitch_mm", self.pixel_pitch_mm, 0.02, 2.0, "mm")?;
        check("fixation_ms", self.fixation_ms, 0.0, 10_000.0, "ms")?;
        check("stimulus_ms", self.stimulus_ms, 10.0, 10_000.0, "ms")?;
        check("adaptation_s", self.adaptation_s, 0.0, 1800.0, "s")?;
        if self.repeats == 0 || self.repeats > MAX_REPEATS {
            return Err(format!(
                "presentation.repeats = {}: give 1–{MAX_REPEATS} repeats of each configuration (the study used 6)",
                self.repeats
            ));
        }
        let px = self.pie_diameter_px();
        if !(16.0..=4096.0).contains(&px) {
            return Err(format!(
                "the pie would be {px:.0} pixels wide ({}° at {} mm with {} mm pixels): give a size of 16–4096 pixels",
                self.pie_diameter_deg, self.viewing_distance_mm, self.pixel_pitch_mm
            ));
        }
        Ok(())
    }

    /// The disc's diameter on the screen, pixels: 2·D·tan(θ/2)/pitch.
    pub fn pie_diameter_px(&self) -> f64 {
        2.0 * self.viewing_distance_mm * (self.pie_diameter_deg.to_radians() / 2.0).tan() / self.pixel_pitch_mm
    }

    /// The radius on the screen, pixels, of an instrument's circular field
    /// of full angle `field_deg` aimed at the screen from the viewing
    /// distance (the instrument where the observer's eye is): D·tan(θ/2)/pitch.
    /// A PR-650's 1° at 570 mm with 0.25 mm pixels: 19.9 px.
    pub fn field_radius_px(&self, field_deg: f64) -> f64 {
        self.viewing_distance_mm * (field_deg.to_radians() / 2.0).tan() / self.pixel_pitch_mm
    }

    /// Pixels of one 120° piece (a third of the disc).
    pub fn piece_pixels(&self) -> f64 {
        let r = self.pie_diameter_px() / 2.0;
        std::f64::consts::PI * r * r / 3.0
    }

    /// `ms` as whole frames at `refresh_hz`: the nearest whole number, at
    /// least one (a duration of 0 stays 0).
    pub fn frames(&self, ms: f64, refresh_hz: f64) -> u32 {
        if ms <= 0.0 {
            return 0;
        }
        ((ms * refresh_hz / 1000.0).round() as u32).max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_the_studys_and_valid() {
        let p = Presentation::default();
        assert_eq!(
            (p.pie_diameter_deg, p.fixation_ms, p.stimulus_ms, p.repeats),
            (5.7, 1000.0, 300.0, 6)
        );
        p.validate().unwrap();
        // π r² / 3 with r = 113.4 px.
        assert!((p.piece_pixels() - 13_470.0).abs() < 30.0, "{}", p.piece_pixels());
    }

    #[test]
    fn the_pie_subtends_its_angle_exactly() {
        // At 1000 mm a 0.1 mm pitch and 2·atan(0.05) rad: exactly 1000 px.
        let p = Presentation {
            pie_diameter_deg: (2.0 * (0.05f64).atan()).to_degrees(),
            viewing_distance_mm: 1000.0,
            pixel_pitch_mm: 0.1,
            ..Presentation::default()
        };
        assert!((p.pie_diameter_px() - 1000.0).abs() < 1e-9);
    }

    #[test]
    fn a_bad_value_is_named_with_its_range() {
        let e = Presentation {
            stimulus_ms: f64::NAN,
            ..Presentation::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.contains("presentation.stimulus_ms = NaN"), "{e}");
        let e = Presentation {
            repeats: 0,
            ..Presentation::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.contains("the study used 6"), "{e}");
        let e = Presentation {
            pixel_pitch_mm: 0.02,
            pie_diameter_deg: 40.0,
            viewing_distance_mm: 5000.0,
            ..Presentation::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.contains("pixels wide"), "{e}");
    }

    #[test]
    fn durations_become_whole_frames() {
        let p = Presentation::default();
        assert_eq!(p.frames(1000.0, 60.0), 60);
        assert_eq!(p.frames(300.0, 144.0), 43); // 43.2
        assert_eq!(p.frames(1.0, 60.0), 1);
        assert_eq!(p.frames(0.0, 60.0), 0);
    }

    /// A 1° field at 570 mm with 0.25 mm pixels: 570·tan(0.5°)/0.25 =
    /// 19.897 px of radius (the PR-650's field where the observer sits).
    #[test]
    fn an_instruments_field_on_the_screen_follows_distance_and_pitch() {
        let p = Presentation::default();
        assert_eq!((p.viewing_distance_mm, p.pixel_pitch_mm), (570.0, 0.25));
        assert!(
            (p.field_radius_px(1.0) - 19.897).abs() < 1e-3,
            "{}",
            p.field_radius_px(1.0)
        );
        // tan(1°)/tan(0.5°) = 2.00015: nearly proportional to the angle.
        assert!((p.field_radius_px(2.0) / p.field_radius_px(1.0) - 2.00015).abs() < 1e-5);
    }
}
