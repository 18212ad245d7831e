//! Takes and records one measurement: the one workflow of the daemon's
//! instrument task and of `lightbooth study --measure-simulated`.
//! [`Recorder::start`] marks the queued measurement running;
//! [`Recorder::take`] has the instrument take its samples, writes each raw
//! sample *before* the next is taken (the driver's thread blocks on the
//! write, so a crash keeps every sample taken), and completes it with its
//! average or ends it with the true reason — cancelled, interrupted (a link
//! fault: the port may need reopening) or failed ([`classify`]) — returning
//! the [`Outcome`]: a complete one carries what the comparisons take
//! ([`Comparable`]).
//!
//! Ending a measurement must not be lost to a database that is briefly
//! away: the end (`complete`, `failed`, …) is written again with backoff
//! (0.5 s doubling to 10 s) for as long as the database is unavailable
//! ([`StoreError::is_unavailable`]), until it answers or the caller gives
//! up (the daemon shutting down: its lease then hands the measurement to
//! recovery). A sample that could not be written stops the measurement: it
//! ends `failed`, saying which sample and why, never `complete`.
//!
//! It knows nothing of HTTP or events; callers publish those from what it
//! returns. Blocking: call it from the instrument's thread (or inside
//! `tokio::task::block_in_place`), never from an async task.

use std::time::Duration;

use tokio::runtime::Handle;
use tokio_util::sync::CancellationToken;

use lightbooth_instrument::{AveragedMeasurement, InstrumentError, Reading, Sample, Spectroradiometer};
use lightbooth_science::colorimetry::{xyz_from_radiance, Observer, Xyz};
use lightbooth_store::{unix_seconds, Average, MeasurementState, NewSample, Store, StoreError};

/// The first wait before writing the end of a measurement again.
const FIRST_RETRY: Duration = Duration::from_millis(500);
/// The longest wait between two tries.
const LONGEST_RETRY: Duration = Duration::from_secs(10);

/// One measurement being recorded (see the module doc).
pub struct Recorder {
    store: Store,
    runtime: Handle,
    id: i64,
    taken: usize,
    usable: usize,
    /// Why the first sample that could not be written was not.
    write_failed: Option<String>,
}

impl Recorder {
    /// Marks queued measurement `id` running on `instrument_id` and starts
    /// recording it, retrying while the database is away. An error when it
    /// is no longer queued (cancelled, or taken by another) or the database
    /// refused.
    pub fn start(
        store: &Store,
        runtime: &Handle,
        id: i64,
        instrument_id: Option<i64>,
        shutdown: &CancellationToken,
    ) -> Result<Recorder, StoreError> {
        retry_while_unavailable(runtime, id, "its start", shutdown, || {
            store.mark_running(id, instrument_id)
        })?;
        Ok(Recorder {
            store: store.clone(),
            runtime: runtime.clone(),
            id,
            taken: 0,
            usable: 0,
            write_failed: None,
        })
    }

    pub fn id(&self) -> i64 {
        self.id
    }

    /// Samples taken so far (written or not), and how many of them were usable.
    pub fn taken(&self) -> (usize, usize) {
        (self.taken, self.usable)
    }

    /// Writes sample `s` of an instrument that reads `reading`, blocking
    /// until it is on disk; its row. After a
    /// failed write the error says which sample and why (also kept for
    /// [`Recorder::write_failed`]); the caller stops the measurement.
    pub fn store_sample(&mut self, s: &Sample, reading: Reading) -> Result<NewSample, String> {
        let row = sample_row(s, reading);
        self.taken += 1;
        self.usable += usize::from(row.usable);
        match self.runtime.block_on(self.store.insert_sample(self.id, &row)) {
            Ok(()) => Ok(row),
            Err(e) => {
                let why = format!("sample {} could not be written to the database: {e}", s.index);
                self.write_failed.get_or_insert_with(|| why.clone());
                Err(why)
            }
        }
    }

    /// Why the first sample that could not be written was not, if one was not.
    pub fn write_failed(&self) -> Option<&str> {
        self.write_failed.as_deref()
    }

    /// Completes the measurement with its average (lightbooth's XYZ for
    /// `observer`), retrying while the database is away. Refused (an error)
    /// when a sample could not be written: a measurement without all its
    /// samples on disk is never complete.
    pub fn complete(
        &self,
        avg: &AveragedMeasurement,
        observer: Observer,
        shutdown: &CancellationToken,
    ) -> Result<(), String> {
        if let Some(why) = &self.write_failed {
            return Err(format!(
                "{why}; a measurement without all its samples on disk is not complete"
            ));
        }
        let average = average_row(avg, observer);
        self.retry("its average", shutdown, || {
            self.store.complete_measurement(self.id, &average)
        })
        .map_err(|e| format!("cannot store the average: {e}"))
    }

    /// Ends the measurement `state` with `message`, retrying while the
    /// database is away (see the module doc).
    pub fn end(&self, state: MeasurementState, message: &str, shutdown: &CancellationToken) -> Result<(), StoreError> {
        end_measurement(&self.store, &self.runtime, self.id, state, message, shutdown)
    }

    /// Takes the measurement: `samples` samples from `instrument`, each
    /// written before the next is taken and then handed to `on_sample` (the
    /// daemon publishes it); then completes it with its average in
    /// `observer`, or ends it with the reason (see the module doc). The
    /// first sample that cannot be written stops it, `failed`. `cancel`
    /// stops it between instrument commands; `shutdown` (the daemon's
    /// token, whose child `cancel` is) tells an operator's cancel from a
    /// daemon shutting down (`interrupted`) and stops retrying a database
    /// that is away.
    pub fn take(
        mut self,
        instrument: &mut dyn Spectroradiometer,
        samples: usize,
        observer: Observer,
        cancel: &CancellationToken,
        shutdown: &CancellationToken,
        on_sample: &mut dyn FnMut(&Sample, &NewSample),
    ) -> Outcome {
        let reading = instrument.capabilities().reading;
        let stop = cancel.clone();
        let result = instrument.measure_averaged(samples, cancel, &mut |s| match self.store_sample(s, reading) {
            Ok(row) => {
                tracing::info!(
                    index = s.index,
                    code = s.code.code,
                    usable = row.usable,
                    "sample stored"
                );
                on_sample(s, &row);
            }
            Err(why) => {
                tracing::error!(error = %why, index = s.index, "cannot store a sample; stopping the measurement");
                stop.cancel();
            }
        });
        if let Some(why) = self.write_failed.clone() {
            // Not every sample is on disk: never `complete`, whatever the instrument said.
            let message = format!("{why}; a measurement without all its samples on disk is not complete");
            return self.ended(MeasurementState::Failed, message, None, shutdown);
        }
        match result {
            Ok(average) => match self.complete(&average, observer, shutdown) {
                Ok(()) => {
                    tracing::info!(
                        luminance_cd_m2 = average.luminance_cd_m2,
                        x = average.x,
                        y = average.y,
                        "measurement complete"
                    );
                    let comparable = comparable(&average, observer);
                    Outcome::Complete {
                        average: Box::new(average),
                        comparable,
                    }
                }
                Err(why) => self.ended(MeasurementState::Failed, why, None, shutdown),
            },
            Err(e) => {
                let shutting = shutdown.is_cancelled();
                let (state, lost) = classify(&e, shutting);
                let message = if shutting {
                    format!("the daemon shut down during the measurement ({e})")
                } else if state == MeasurementState::Cancelled {
                    cancelled_message(self.taken, self.usable, samples)
                } else {
                    e.to_string()
                };
                self.ended(state, message, lost.then(|| e.to_string()), shutdown)
            }
        }
    }

    /// Ends the measurement `failed` with `message` before the instrument
    /// took a sample (a simulated instrument that could not be aimed).
    pub fn fail(self, message: String, shutdown: &CancellationToken) -> Outcome {
        self.ended(MeasurementState::Failed, message, None, shutdown)
    }

    fn ended(
        self,
        state: MeasurementState,
        message: String,
        port_lost: Option<String>,
        shutdown: &CancellationToken,
    ) -> Outcome {
        tracing::warn!(error = %message, state = state.as_str(), "measurement did not complete");
        // A failure to write the end is logged by the retry; recovery ends it later.
        let _ = self.end(state, &message, shutdown);
        Outcome::Ended {
            state,
            message,
            port_lost,
        }
    }

    fn retry<F, Fut>(&self, what: &str, shutdown: &CancellationToken, write: F) -> Result<(), StoreError>
    where
        F: Fn() -> Fut,
        Fut: std::future::Future<Output = Result<(), StoreError>>,
    {
        retry_while_unavailable(&self.runtime, self.id, what, shutdown, write)
    }
}

/// How a measurement taken by [`Recorder::take`] ended; its row already says so.
#[derive(Debug)]
pub enum Outcome {
    /// Every sample is on disk and the average is stored. `comparable` is
    /// what the comparisons take, or why the measurement cannot be compared.
    Complete {
        average: Box<AveragedMeasurement>,
        comparable: Result<Comparable, String>,
    },
    /// It ended `state` (failed, cancelled, interrupted) saying `message`.
    /// `port_lost` is the link fault that ended it when the port must be
    /// reopened before the next measurement.
    Ended {
        state: MeasurementState,
        message: String,
        port_lost: Option<String>,
    },
}

/// What a measurement cancelled by the operator says: how many samples it kept.
pub fn cancelled_message(taken: usize, usable: usize, requested: usize) -> String {
    if taken == 0 {
        return format!("cancelled by the operator before the first of {requested} samples; no sample taken");
    }
    let (plural, kept) = if taken == 1 {
        ("", "kept it".to_string())
    } else {
        ("s", format!("kept all {taken}"))
    };
    let averaged = match usable {
        0 => "none usable, so no average".to_string(),
        n => format!("{n} usable, averaged as a partial result"),
    };
    format!("cancelled by the operator after {taken} sample{plural} of the {requested} requested; {kept} ({averaged})")
}

/// The state a measurement the instrument could not finish ends in, and
/// whether the port is lost. Link faults interrupt a measurement (its
/// samples stay, it can be repeated); an instrument that cannot give enough
/// good samples fails it. A cancel while `shutting_down` is an interruption.
pub fn classify(e: &InstrumentError, shutting_down: bool) -> (MeasurementState, bool) {
    match e {
        InstrumentError::Cancelled if shutting_down => (MeasurementState::Interrupted, false),
        InstrumentError::Cancelled => (MeasurementState::Cancelled, false),
        InstrumentError::PortClosed { .. } | InstrumentError::Io { .. } | InstrumentError::Open { .. } => {
            (MeasurementState::Interrupted, true)
        }
        InstrumentError::NotInRemoteMode { .. }
        | InstrumentError::NoBanner { .. }
        | InstrumentError::Silent { .. }
        | InstrumentError::Unresponsive { .. } => (MeasurementState::Interrupted, true),
        InstrumentError::NoReply { .. }
        | InstrumentError::Timeout { .. }
        | InstrumentError::Truncated { .. }
        | InstrumentError::Protocol { .. } => (MeasurementState::Interrupted, false),
        InstrumentError::Quality { .. }
        | InstrumentError::Setup { .. }
        | InstrumentError::Refused { .. }
        | InstrumentError::Settings(_) => (MeasurementState::Failed, false),
    }
}

/// Ends measurement `id` `state` with `message`, retrying while the
/// database is away (the module doc); for a measurement that failed before
/// it was recorded (a panic, a scene that cannot be rendered) as for one a
/// [`Recorder`] records.
pub fn end_measurement(
    store: &Store,
    runtime: &Handle,
    id: i64,
    state: MeasurementState,
    message: &str,
    shutdown: &CancellationToken,
) -> Result<(), StoreError> {
    retry_while_unavailable(runtime, id, "its end", shutdown, || {
        store.end_measurement(id, state, message)
    })
}

/// Runs `write` until it succeeds, fails for a reason other than an
/// unavailable database, or `shutdown` is cancelled; logs each retry.
fn retry_while_unavailable<F, Fut>(
    runtime: &Handle,
    id: i64,
    what: &str,
    shutdown: &CancellationToken,
    write: F,
) -> Result<(), StoreError>
where
    F: Fn() -> Fut,
    Fut: std::future::Future<Output = Result<(), StoreError>>,
{
    let mut wait = FIRST_RETRY;
    let mut tries = 0u32;
    loop {
        match runtime.block_on(write()) {
            Ok(()) => {
                if tries > 0 {
                    tracing::info!(
                        measurement_id = id,
                        tries = tries + 1,
                        "recorded {what} once the database answered again"
                    );
                }
                return Ok(());
            }
            Err(e) if e.is_unavailable() && !shutdown.is_cancelled() => {
                tries += 1;
                tracing::warn!(
                    measurement_id = id,
                    error = %e,
                    retry_in_ms = wait.as_millis() as u64,
                    "the database is unavailable: cannot record {what} of the measurement yet; retrying"
                );
                // The wait ends early when the daemon shuts down. (The
                // timer is made inside the runtime: `timeout` called out
                // here panics, "there is no reactor running".)
                runtime.block_on(async {
                    let _ = tokio::time::timeout(wait, shutdown.cancelled()).await;
                });
                wait = (wait * 2).min(LONGEST_RETRY);
            }
            Err(e) => {
                tracing::error!(measurement_id = id, error = %e, "cannot record {what} of the measurement");
                return Err(e);
            }
        }
    }
}

/// A raw sample as the store keeps it; `reading` is what the instrument's
/// samples carry (a sample is usable when its code is good and it has it).
pub fn sample_row(s: &Sample, reading: Reading) -> NewSample {
    NewSample {
        index: s.index,
        taken_at: unix_seconds(s.time),
        code: i64::from(s.code.code),
        message: s.code.message.clone(),
        usable: s.is_usable(reading),
        radiance: s.radiance.as_ref().map(|r| r.values().to_vec()),
        luminance_cd_m2: s.luminance,
        instrument_xyz: s.instrument_xyz,
    }
}

/// What a complete measurement is compared with the renderings as, with the
/// standard error of its Y and the observer it is in: the one place a
/// measurement becomes the comparisons' input, for the daemon's instrument
/// task, the render workers and the start-up's catch-up alike.
///
/// A render's spectra can be weighted with any observer, a colorimeter's
/// XYZ or a luminance meter's Y only with the instrument's: so a
/// spectroradiometer's measurement is compared in the daemon's observer
/// (`serve --observer`), a colorimeter's and a luminance meter's in their
/// own, whatever the daemon's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Comparable {
    /// A spectroradiometer's (XYZ of the mean spectrum) or a colorimeter's
    /// (its own mean XYZ) colour, compared in x, y, Y and ΔE.
    Colour { xyz: Xyz, y_se: f64, observer: Observer },
    /// A luminance meter's mean Y, compared in luminance alone.
    Luminance { y: f64, y_se: f64, observer: Observer },
}

impl Comparable {
    /// The observer it is compared in.
    pub fn observer(&self) -> Observer {
        match *self {
            Comparable::Colour { observer, .. } | Comparable::Luminance { observer, .. } => observer,
        }
    }
}

/// The measurement as the comparisons take it ([`Comparable`]): a spectrum
/// in `observer` (the daemon's), a colorimeter's XYZ or a luminance
/// meter's Y in the instrument's own observer; or why it cannot be compared.
pub fn comparable(avg: &AveragedMeasurement, observer: Observer) -> Result<Comparable, String> {
    let usable = avg.good_samples().count();
    if let Some((y, own)) = comparable_luminance(avg) {
        return Ok(Comparable::Luminance {
            y,
            y_se: mean_y_standard_error(avg.luminance_cv, y, usable),
            observer: own,
        });
    }
    let (xyz, observer) = comparable_xyz(avg, observer)?;
    Ok(Comparable::Colour {
        xyz,
        y_se: mean_y_standard_error(avg.luminance_cv, xyz.y, usable),
        observer,
    })
}

/// A stored complete measurement as the comparisons take it (as
/// [`comparable`] does for one just taken): its mean spectrum's XYZ in
/// `observer`, a colorimeter's stored XYZ or a luminance meter's stored Y
/// in the observer stored with it. Used to compare measurements left
/// uncompared ([`crate::compare::Comparisons::compare_left_over`]).
pub fn stored_comparable(m: &lightbooth_store::MeasurementDetail, observer: Observer) -> Result<Comparable, String> {
    let s = &m.summary;
    let usable = usize::try_from(s.good_samples).unwrap_or(0);
    let cv = s.luminance_cv.unwrap_or(0.0);
    if m.radiance.is_some() {
        let xyz = crate::compare::white::measured_xyz(m, observer)?
            .ok_or_else(|| format!("measurement {}: no XYZ of its mean spectrum", s.id))?;
        return Ok(Comparable::Colour {
            xyz,
            y_se: mean_y_standard_error(cv, xyz.y, usable),
            observer,
        });
    }
    match (s.xyz, s.luminance_cd_m2, s.observer) {
        (Some(xyz), _, Some(own)) => {
            let xyz = Xyz::from_array(xyz);
            Ok(Comparable::Colour {
                xyz,
                y_se: mean_y_standard_error(cv, xyz.y, usable),
                observer: own,
            })
        }
        (None, Some(y), Some(own)) => Ok(Comparable::Luminance {
            y,
            y_se: mean_y_standard_error(cv, y, usable),
            observer: own,
        }),
        _ => Err(format!(
            "measurement {}: no spectrum, no XYZ and no luminance with its observer",
            s.id
        )),
    }
}

/// The standard error of a measurement's mean Y from the coefficient of
/// variation of its `usable` samples' luminance: CV · Y / √n (the samples
/// are independent readings; one sample, or none, counts as one).
pub fn mean_y_standard_error(luminance_cv: f64, y: f64, usable: usize) -> f64 {
    luminance_cv * y / (usable.max(1) as f64).sqrt()
}

/// The XYZ of an averaged measurement for comparing it with renderings,
/// with the observer it is in: of its mean spectrum in `observer`; or a
/// colorimeter's own mean XYZ in its own observer (a colorimeter's XYZ
/// cannot be recomputed in another observer; the renders are weighted with
/// its observer instead). A luminance meter's Y alone is no colour and is
/// refused.
pub fn comparable_xyz(avg: &AveragedMeasurement, observer: Observer) -> Result<(Xyz, Observer), String> {
    match (&avg.mean, avg.reading) {
        (Some(mean), _) => xyz_from_radiance(mean, observer)
            .map(|xyz| (xyz, observer))
            .map_err(|e| format!("XYZ of the mean spectrum: {e}")),
        (None, Reading::Tristimulus { observer: own }) => avg
            .instrument_xyz
            .map(|xyz| (Xyz::from_array(xyz), own))
            .ok_or_else(|| format!("the {} gave no XYZ", avg.info.model)),
        (None, Reading::Luminance { .. }) => Err(format!(
            "the {} measures luminance only, no colour: x, y and ΔE need a colorimeter or a spectroradiometer",
            avg.info.model
        )),
        (None, Reading::Spectrum) => Err("the measurement has no spectrum".into()),
    }
}

/// The luminance of a luminance meter's averaged measurement, for comparing
/// it with renderings in luminance alone: its mean Y and the observer whose
/// ȳ is the meter's spectral weighting (V(λ): CIE 1931's), which the
/// renders it is compared with are weighted by. `None` for a measurement
/// that is not a luminance meter's (see [`comparable_xyz`]).
pub fn comparable_luminance(avg: &AveragedMeasurement) -> Option<(f64, Observer)> {
    let Reading::Luminance { observer: own } = avg.reading else {
        return None;
    };
    if avg.mean.is_some() {
        return None;
    }
    Some((avg.luminance_cd_m2, own))
}

/// The average of a measurement as the store keeps it. With a spectrum:
/// lightbooth's XYZ of the mean spectrum for `observer`. Without one (a
/// colorimeter): the instrument's own mean XYZ, in the observer its
/// reading is in (which may differ from `observer`: the comparisons
/// refuse to mix them); a luminance meter's has no XYZ.
pub fn average_row(avg: &AveragedMeasurement, observer: Observer) -> Average {
    let (xyz, observer) = match (&avg.mean, avg.reading) {
        (Some(mean), _) => {
            let xyz = xyz_from_radiance(mean, observer).ok().map(|x| x.to_array());
            (xyz, xyz.is_some().then_some(observer))
        }
        (None, Reading::Tristimulus { observer }) => (avg.instrument_xyz, Some(observer)),
        (None, Reading::Luminance { observer }) => (None, Some(observer)),
        (None, Reading::Spectrum) => (None, None),
    };
    Average {
        xyz,
        observer,
        wavelength_nm: avg
            .mean
            .as_ref()
            .map(|m| m.grid().wavelengths().to_vec())
            .unwrap_or_default(),
        radiance: avg.mean.as_ref().map(|m| m.values().to_vec()).unwrap_or_default(),
        radiance_sd: avg.sd.clone(),
        luminance_cd_m2: avg.luminance_cd_m2,
        x: avg.x,
        y: avg.y,
        luminance_cv: avg.luminance_cv,
    }
}

/// The spectroradiometers lightbooth drives, for a refusal's advice.
pub const SPECTRORADIOMETERS: &str = "a PR-650, PR-655, PR-670, CS-2000, CS-2000A, CS-3000, CR-250 or CR-300";

/// The grid and mean spectrum of a stored measurement, for `what` (a
/// reflectance, a display profile, …) that needs one; or why it has none,
/// with the instrument that took it and what it measures (a colorimeter's
/// XYZ, a luminance meter's Y), and which instruments would do.
pub fn stored_spectrum<'a>(
    m: &'a lightbooth_store::MeasurementDetail,
    what: &str,
) -> Result<(&'a [f64], &'a [f64]), String> {
    if let (Some(wl), Some(radiance)) = (&m.wavelength_nm, &m.radiance) {
        return Ok((wl, radiance));
    }
    let id = m.summary.id;
    let model = m.summary.instrument_model.as_deref().unwrap_or("instrument");
    let measures = if m
        .samples
        .iter()
        .any(|s| s.instrument_xyz.is_some() && s.radiance.is_none())
    {
        "XYZ"
    } else if m.samples.iter().all(|s| s.radiance.is_none()) && m.summary.luminance_cd_m2.is_some() {
        "luminance"
    } else {
        "no spectrum that completed"
    };
    Err(if measures == "no spectrum that completed" {
        format!("measurement {id} has no mean spectrum; {what} needs one")
    } else {
        format!(
            "measurement {id} has no spectrum: the {model} that took it measures {measures} only, and {what} needs \
             a spectral radiance; measure it with a spectroradiometer ({SPECTRORADIOMETERS})"
        )
    })
}

/// What a stored measurement gives a display calibration: its mean
/// spectrum (a spectroradiometer's; any observer will do), else the
/// instrument's own mean XYZ (a colorimeter's) or luminance (a luminance
/// meter's) with the observer it is in, which the profile must then use.
pub fn display_patch_light(
    m: &lightbooth_store::MeasurementDetail,
) -> Result<(lightbooth_science::display::PatchLight, Option<Observer>), String> {
    use lightbooth_science::display::PatchLight;
    if let (Some(wl), Some(radiance)) = (&m.wavelength_nm, &m.radiance) {
        let light = PatchLight::Spectrum {
            wavelength_nm: wl.clone(),
            radiance: radiance.clone(),
        };
        return Ok((light, None));
    }
    let s = &m.summary;
    let model = s.instrument_model.as_deref().unwrap_or("instrument");
    match (s.xyz, s.luminance_cd_m2, s.observer) {
        (Some(xyz), _, Some(observer)) => Ok((PatchLight::Xyz(xyz), Some(observer))),
        (None, Some(y), Some(observer)) => Ok((PatchLight::Luminance(y), Some(observer))),
        _ => Err(format!(
            "measurement {} (the {model}'s) has neither a mean spectrum, XYZ nor a luminance with its observer",
            s.id
        )),
    }
}

#[cfg(test)]
mod tests {
    //! [`Recorder::take`] with the simulated PR-650 on a pty, through the
    //! real driver: the ends of a measurement (its last sample, an
    //! operator's cancel, a pulled cable) as the store records them.
    use super::*;
    use crate::testing::store_in;
    use lightbooth_instrument::sim::{spawn_mock, Fault, MockConfig, MockHandle};
    use lightbooth_instrument::{open_pr650, Pr650Settings};
    use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};
    use lightbooth_store::{Booth, NewMeasurement};

    /// The retry of a write while the database is away waits for the next
    /// try with a tokio timer, on the instrument task's own thread: the
    /// timer made outside the runtime panicked ("there is no reactor
    /// running") and killed the task mid-measurement, which stayed
    /// `running` (daemon_recovery's PostgreSQL outage test found it). A
    /// closed pool is an unavailable database; a shutdown ends the wait.
    #[test]
    fn a_retry_while_the_database_is_away_panicked_without_a_reactor() {
        let runtime = tokio::runtime::Runtime::new().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let store = runtime.block_on(store_in(dir.path()));
        runtime.block_on(store.close());
        let shutdown = CancellationToken::new();
        let stop = shutdown.clone();
        let stopper = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(700));
            stop.cancel();
        });
        // Fails (pool closed), waits 0.5 s, fails, waits until the shutdown
        // at 0.7 s, fails once more and gives up with the error.
        let result = end_measurement(
            &store,
            runtime.handle(),
            1,
            MeasurementState::Failed,
            "the cable was pulled",
            &shutdown,
        );
        stopper.join().unwrap();
        let error = result.unwrap_err();
        assert!(error.is_unavailable(), "{error}");
    }

    /// A queued measurement of `samples` samples, and the simulated PR-650
    /// (instant, seeded, with `faults`) looking at a flat spectrum.
    async fn queued(store: &Store, samples: usize, faults: &str) -> (i64, MockHandle) {
        let id = store
            .create_measurement(&NewMeasurement {
                booth: Booth::default(),
                session_id: None,
                scene: None,
                target: None,
                samples,
                settings_json: serde_json::json!({}),
                note: String::new(),
            })
            .await
            .unwrap();
        let flat = Spectrum::constant(Grid::one_nm(), SpectralUnit::SpectralRadiance, 0.01).unwrap();
        let mut config = MockConfig::new(flat);
        config.speed = 0.0;
        config.seed = 7;
        config.faults = faults
            .split(',')
            .filter(|f| !f.is_empty())
            .map(|f| f.parse::<Fault>().unwrap())
            .collect();
        (id, spawn_mock(config).unwrap())
    }

    /// Takes measurement `id` (`samples` samples) with the simulator,
    /// calling `on_sample` with the store's sample count at each sample.
    fn take(
        store: &Store,
        id: i64,
        mock: &MockHandle,
        samples: usize,
        cancel: &CancellationToken,
        on_sample: &mut dyn FnMut(&Sample, usize),
    ) -> Outcome {
        let port = mock.device_path().display().to_string();
        let mut instrument = open_pr650(&port, &Pr650Settings::default()).unwrap();
        tokio::task::block_in_place(|| {
            let runtime = Handle::current();
            let recorder = Recorder::start(store, &runtime, id, None, &CancellationToken::new()).unwrap();
            recorder.take(
                instrument.as_mut(),
                samples,
                Observer::Cie1931,
                cancel,
                &CancellationToken::new(),
                &mut |s, _| {
                    let stored = runtime
                        .block_on(store.get_measurement(id))
                        .unwrap()
                        .unwrap()
                        .samples
                        .len();
                    on_sample(s, stored)
                },
            )
        })
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn every_sample_is_stored_before_the_next_and_the_last_before_complete() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (id, mock) = queued(&store, 3, "").await;
        let mut seen = Vec::new();
        let outcome = take(&store, id, &mock, 3, &CancellationToken::new(), &mut |s, stored| {
            seen.push((s.index, stored))
        });
        assert_eq!(
            seen,
            [(0, 1), (1, 2), (2, 3)],
            "(sample, rows stored when it is handed on)"
        );
        let Outcome::Complete {
            comparable: Ok(Comparable::Colour { xyz, y_se, .. }),
            ..
        } = outcome
        else {
            panic!("not complete with a colour: {outcome:?}")
        };
        let m = store.get_measurement(id).await.unwrap().unwrap();
        assert_eq!(m.summary.state, MeasurementState::Complete);
        assert_eq!(m.samples.len(), 3);
        // What the comparisons take is the stored average's colour.
        assert!((xyz.y - m.summary.luminance_cd_m2.unwrap()).abs() < 1e-9 * xyz.y);
        assert!(y_se > 0.0 && y_se < 0.05 * xyz.y, "y_se {y_se} of Y {}", xyz.y);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_cancel_after_the_second_of_three_samples_keeps_both_and_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (id, mock) = queued(&store, 3, "").await;
        let cancel = CancellationToken::new();
        let operator = cancel.clone();
        let outcome = take(&store, id, &mock, 3, &cancel, &mut |s, _| {
            if s.index == 1 {
                operator.cancel();
            }
        });
        let Outcome::Ended {
            state,
            message,
            port_lost,
        } = outcome
        else {
            panic!("a cancelled measurement completed")
        };
        assert_eq!((state, port_lost), (MeasurementState::Cancelled, None));
        assert_eq!(
            message,
            "cancelled by the operator after 2 samples of the 3 requested; kept all 2 (2 usable, averaged as a \
             partial result)"
        );
        let m = store.get_measurement(id).await.unwrap().unwrap();
        assert_eq!(m.summary.state, MeasurementState::Cancelled);
        assert_eq!(m.samples.len(), 2);
        assert_eq!(m.summary.error.as_deref(), Some(message.as_str()));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_pulled_cable_interrupts_the_measurement_and_asks_for_the_port_again() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (id, mock) = queued(&store, 3, "cable-pull").await;
        let outcome = take(&store, id, &mock, 3, &CancellationToken::new(), &mut |_, _| {});
        let Outcome::Ended { state, port_lost, .. } = outcome else {
            panic!("a measurement whose cable was pulled completed")
        };
        assert_eq!(state, MeasurementState::Interrupted);
        assert!(port_lost.is_some(), "the port must be reopened");
        let m = store.get_measurement(id).await.unwrap().unwrap();
        assert_eq!(m.summary.state, MeasurementState::Interrupted);
    }
}
