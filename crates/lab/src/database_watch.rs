//! Does the database answer: `/api/health`'s question, answered without a
//! query per request, so 200 clients polling health never queue for the
//! store's connections behind a measurement's sample writes.
//!
//! The answer of the last ping is reused for [`FRESH_FOR`]; the first
//! request after that starts one ping (a task of its own, so a request that
//! is dropped does not leave it unfinished) and waits for it; requests
//! while it runs are given the last answer, or, once the ping has gone
//! unanswered for [`NO_ANSWER`], "the database did not answer". So an
//! outage shows in health within about `FRESH_FOR + NO_ANSWER`.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::watch;
use tokio::time::Instant;

use lightbooth_store::Store;

/// How long a ping's answer stands for the next requests.
pub const FRESH_FOR: Duration = Duration::from_millis(500);

/// How long a ping may go unanswered before the database counts as not
/// answering.
pub const NO_ANSWER: Duration = Duration::from_secs(2);

/// An answer: `None` when the database answered, or why not.
type Answer = Option<String>;

#[derive(Default)]
struct State {
    /// The last ping's answer, and when it came.
    last: Option<(Instant, Answer)>,
    /// The ping under way: when it started, and where its answer comes.
    pinging: Option<(Instant, watch::Receiver<Option<Answer>>)>,
}

/// The database's answers (see the module doc); cheap to clone.
#[derive(Clone)]
pub struct DatabaseWatch {
    store: Store,
    state: Arc<Mutex<State>>,
}

impl DatabaseWatch {
    pub fn new(store: Store) -> DatabaseWatch {
        DatabaseWatch {
            store,
            state: Arc::default(),
        }
    }

    /// Whether the database answers (`None`) or why not, as of at most
    /// [`FRESH_FOR`] ago (see the module doc).
    pub async fn error(&self) -> Answer {
        let mut answer = {
            let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
            if let Some((at, last)) = &s.last {
                if at.elapsed() < FRESH_FOR {
                    return last.clone();
                }
            }
            match (&s.pinging, &s.last) {
                (Some((since, _)), _) if since.elapsed() >= NO_ANSWER => {
                    return Some(format!(
                        "the database did not answer within {} s",
                        NO_ANSWER.as_secs()
                    ))
                }
                (Some(_), Some((_, last))) => return last.clone(),
                // The first ping: wait for it with the others.
                (Some((_, rx)), None) => rx.clone(),
                (None, _) => {
                    let (tx, rx) = watch::channel(None);
                    s.pinging = Some((Instant::now(), rx.clone()));
                    let (store, state) = (self.store.clone(), self.state.clone());
                    tokio::spawn(async move {
                        let answer = match tokio::time::timeout(NO_ANSWER * 4, store.ping()).await {
                            Ok(Ok(())) => None,
                            Ok(Err(e)) => Some(e.to_string()),
                            Err(_) => Some(format!(
                                "the database did not answer within {} s",
                                (NO_ANSWER * 4).as_secs()
                            )),
                        };
                        let mut s = state.lock().unwrap_or_else(|e| e.into_inner());
                        s.last = Some((Instant::now(), answer.clone()));
                        s.pinging = None;
                        let _ = tx.send(Some(answer));
                    });
                    rx
                }
            }
        };
        let answered = answer.wait_for(Option::is_some).await.map(|a| a.clone().flatten());
        answered.unwrap_or_else(|_| Some("the database ping stopped before it answered".into()))
    }
}
