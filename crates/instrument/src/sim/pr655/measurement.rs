//! One simulated PR-655/PR-670 measurement: what it reads (through the
//! shared [`crate::sim::model::InstrumentModel`] on this model's
//! grid), the status it ends with, and how long it takes (the sheet's 13.7
//! model: a base time, sync detection under `SS1`, each cycle's exposure and
//! dark exposure, exposures rounded up to whole periods of the source under
//! sync).

use super::{Device, Stored};
use crate::sim::faults::FaultKind;
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};
use lightbooth_science::spectrum::{SpectralUnit, Spectrum};

/// The frequencies sync can lock to (7, −3: "below 20 Hz, above 400 Hz").
const SYNC_RANGE_HZ: std::ops::RangeInclusive<f64> = 20.0..=400.0;

/// Where the time of one `M⟨code⟩` goes, ms at speed 1: section 13.7's
/// model, "a configurable base time, plus cycles × (exposure + dark exposure
/// unless smart dark applies), plus sync detection when `SS1`". Each dark
/// exposure is as long as the exposure (the shutter closes for a dark reading
/// of the same integration, 9). The transfer of the reply is not included
/// (USB speed, 9).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Timing {
    /// Shutter moves and computation, once per measurement ([`super::model::InstrumentModel::base_time_ms`]).
    base_ms: f64,
    /// `SS1`: finding the source's frequency ([`Pr655Switches::sync_detection_ms`]).
    sync_detection_ms: f64,
    /// One cycle's exposure, after sync a whole number of the source's periods.
    exposure_ms: f64,
    /// Exposures taken (`SN`); none when auto sync failed.
    cycles: u32,
    /// Dark exposures taken: one per cycle, or with smart dark one only when
    /// the exposure differs from the last dark's, else none.
    darks: u32,
}

impl Timing {
    fn total_ms(&self) -> f64 {
        self.base_ms + self.sync_detection_ms + f64::from(self.cycles + self.darks) * self.exposure_ms
    }
}

/// `SS1`/`SS3` set the exposure "to a whole number of periods" (5, `SS`):
/// the next whole number up, at least one period, at most as many as fit the
/// model's longest exposure.
fn synced_exposure_ms(exposure_ms: f64, hz: f64, max_ms: f64) -> f64 {
    let period_ms = 1000.0 / hz;
    // 1e-9: an exposure that already is whole periods stays as it is.
    let periods = (exposure_ms / period_ms - 1e-9).ceil().max(1.0);
    let most = (max_ms / period_ms).floor().max(1.0);
    periods.min(most) * period_ms
}

impl Device {
    /// The frequency auto sync (`SS1`) locks to: the source's flicker when it
    /// is in 20–400 Hz (7, −3). None for a steady source (no period to find:
    /// a simulator choice, the sheet leaves `SS1` on a steady source open,
    /// 12.10), one outside that band, or one marked [`MockConfig::unsyncable`].
    fn auto_sync_hz(&self) -> Option<f64> {
        if self.cfg.unsyncable {
            return None;
        }
        self.flicker_in_sync_range()
    }

    /// The source's flicker frequency, when sync can lock to it: what `F` finds.
    pub(super) fn flicker_in_sync_range(&self) -> Option<f64> {
        self.cfg.flicker_hz.filter(|hz| SYNC_RANGE_HZ.contains(hz))
    }

    /// One measurement, taking [`Timing::total_ms`] scaled by the speed.
    /// Returns false if the cable was pulled.
    pub(super) fn measure(&mut self) -> bool {
        let truth = self.unit.shared().truth_1nm.clone();
        let model = &self.cfg.model;
        let mut reading = match model.reading(&truth, self.state.setup.exposure_ms) {
            Ok(r) => r,
            Err(e) => {
                tracing::error!(error = %e, "simulated instrument: cannot model the target");
                return true;
            }
        };
        let auto_sync = self.state.setup.sync == 1;
        let lock_hz = match self.state.setup.sync {
            1 => self.auto_sync_hz(),
            3 => Some(f64::from(self.state.setup.user_sync_hz)),
            _ => None,
        };
        let sync_failed = auto_sync && lock_hz.is_none();
        let mut exposure_ms = reading.integration_ms;
        if let Some(hz) = lock_hz {
            let longest = f64::from(*self.sw.model.exposure_range_ms().end());
            exposure_ms = synced_exposure_ms(reading.integration_ms, hz, longest);
            // The detector model takes whole milliseconds; the timing keeps the exact periods.
            match model.reading(&truth, exposure_ms.round().max(1.0) as u32) {
                Ok(r) => reading = r,
                Err(e) => tracing::error!(error = %e, "simulated instrument: cannot model the target"),
            }
        }
        let cycles = if sync_failed { 0 } else { self.state.setup.cycles.max(1) };
        let darks = if cycles == 0 {
            0
        } else if self.state.setup.smart_dark {
            u32::from(self.state.last_dark_exposure_ms != Some(exposure_ms))
        } else {
            cycles
        };
        let timing = Timing {
            base_ms: model.base_time_ms,
            sync_detection_ms: if auto_sync {
                self.sw.sync_detection_ms as f64
            } else {
                0.0
            },
            exposure_ms,
            cycles,
            darks,
        };
        let total_ms = timing.total_ms();
        tracing::debug!(?timing, total_ms, sync_hz = ?lock_hz, "simulated measurement time");
        if self.unit.cable_pulled_during(total_ms, "USB cable pulled") {
            return false;
        }
        self.unit.shared().last_measurement_ms = Some(total_ms);
        self.unit.sleep_scaled(total_ms);
        if darks > 0 {
            self.state.last_dark_exposure_ms = Some(exposure_ms);
        }
        let mut status = match reading.code {
            0 => 0,
            19 => -2,
            _ => -8,
        };
        if sync_failed {
            tracing::info!(
                status = self.sw.sync_failure.status(),
                "simulated instrument: cannot auto-sync"
            );
            status = self.sw.sync_failure.status();
        }
        if self.unit.fires(FaultKind::ErrorCode) {
            status = self.sw.error_status;
        }
        let stored = if status == 0 {
            // Averaging `cycles` readings divides the noise by √cycles.
            let cycles = f64::from(self.state.setup.cycles.max(1));
            let mut values = vec![0.0; reading.expected.len()];
            for _ in 0..self.state.setup.cycles.max(1) {
                for (acc, v) in values
                    .iter_mut()
                    .zip(self.cfg.model.sample(&reading, &mut self.unit.rng))
                {
                    *acc += v / cycles;
                }
            }
            let xyz = Spectrum::new(
                self.cfg.model.grid.clone(),
                SpectralUnit::SpectralRadiance,
                values.clone(),
            )
            .ok()
            .and_then(|s| xyz_from_radiance(&s, Observer::Cie1931).ok())
            .map_or([0.0; 3], |x| x.to_array());
            Stored {
                status,
                values,
                xyz,
                exposure_ms,
            }
        } else {
            Stored {
                status,
                values: Vec::new(),
                xyz: [0.0; 3],
                exposure_ms,
            }
        };
        if status == 0 {
            self.state.last_good = Some(stored.clone());
        }
        self.state.last = Some(stored);
        self.unit.shared().measurements += 1;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sync rounds the exposure up to whole periods of the source (sheet 5, `SS`).
    #[test]
    fn sync_sets_the_exposure_to_whole_periods_within_the_longest_exposure() {
        let period = 1000.0 / 60.0;
        assert!(
            (synced_exposure_ms(100.0, 60.0, 6000.0) - 100.0).abs() < 1e-9,
            "6 periods already"
        );
        assert!((synced_exposure_ms(101.0, 60.0, 6000.0) - 7.0 * period).abs() < 1e-9);
        assert!(
            (synced_exposure_ms(3.0, 60.0, 6000.0) - period).abs() < 1e-9,
            "at least one period"
        );
        assert!((synced_exposure_ms(5990.0, 20.0, 6000.0) - 6000.0).abs() < 1e-9);
        assert!(
            (synced_exposure_ms(5990.0, 7.0, 6000.0) - 42.0 * 1000.0 / 7.0).abs() < 1e-9,
            "capped"
        );
    }

    /// 13.7: base + sync detection + cycles × exposure + darks × exposure.
    #[test]
    fn measurement_time_is_base_plus_sync_detection_plus_exposures_and_darks() {
        let t = Timing {
            base_ms: 1500.0,
            sync_detection_ms: 1000.0,
            exposure_ms: 50.0,
            cycles: 3,
            darks: 1,
        };
        assert_eq!(t.total_ms(), 1500.0 + 1000.0 + 4.0 * 50.0);
    }
}
