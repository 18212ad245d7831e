//! Keeps blocking instrument I/O off the async runtime: one dedicated thread
//! owns the instrument (and so its port) and runs requests one at a time, so
//! every command to the port is serialised. Async callers send requests over
//! a channel and await the answer.

use std::sync::mpsc;
use std::thread::JoinHandle;

use tokio::sync::{mpsc as tokio_mpsc, oneshot};

use super::{AveragedMeasurement, CancelToken, InstrumentError, InstrumentInfo, Sample, Spectroradiometer};

/// A request to the instrument thread.
struct Measure {
    n: usize,
    cancel: CancelToken,
    /// Each sample as it is taken, for storing before the next one.
    samples: tokio_mpsc::UnboundedSender<Sample>,
    done: oneshot::Sender<Result<AveragedMeasurement, InstrumentError>>,
}

/// The handle async code holds. Dropping it ends the thread after the
/// current request.
pub struct InstrumentWorker {
    /// Requests, in order; the thread is the only receiver, so requests never
    /// overlap on the port.
    requests: Option<mpsc::Sender<Measure>>,
    info: InstrumentInfo,
    thread: Option<JoinHandle<()>>,
}

impl InstrumentWorker {
    pub fn spawn(mut instrument: Box<dyn Spectroradiometer>) -> std::io::Result<InstrumentWorker> {
        let info = instrument.info().clone();
        let (tx, rx) = mpsc::channel::<Measure>();
        let thread = std::thread::Builder::new().name("instrument".into()).spawn(move || {
            for request in rx {
                tracing::debug!(samples = request.n, "instrument thread: measuring");
                let samples = request.samples;
                let result = instrument.measure_averaged(request.n, &request.cancel, &mut |s: &Sample| {
                    let _ = samples.send(s.clone());
                });
                let _ = request.done.send(result);
            }
            tracing::debug!("instrument thread: no more requests");
        })?;
        Ok(InstrumentWorker {
            requests: Some(tx),
            info,
            thread: Some(thread),
        })
    }

    pub fn info(&self) -> &InstrumentInfo {
        &self.info
    }

    /// An averaged measurement of `n` samples; samples stream to `samples` as
    /// they are taken. Cancel with `cancel`.
    pub async fn measure(
        &self,
        n: usize,
        cancel: CancelToken,
        samples: tokio_mpsc::UnboundedSender<Sample>,
    ) -> Result<AveragedMeasurement, InstrumentError> {
        let (done, answer) = oneshot::channel();
        let gone = || InstrumentError::Io {
            port: self.info.model.clone(),
            source: std::io::Error::other("the instrument thread has stopped"),
        };
        self.requests
            .as_ref()
            .ok_or_else(gone)?
            .send(Measure {
                n,
                cancel,
                samples,
                done,
            })
            .map_err(|_| gone())?;
        answer.await.map_err(|_| gone())?
    }
}

impl Drop for InstrumentWorker {
    fn drop(&mut self) {
        self.requests = None; // closes the channel: the thread's loop ends
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
