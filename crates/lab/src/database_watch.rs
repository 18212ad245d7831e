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

use std::sync::atomic::{AtomicU64, Ordering};
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
    pings: Arc<AtomicU64>,
}

impl DatabaseWatch {
    pub fn new(store: Store) -> DatabaseWatch {
        DatabaseWatch {
            store,
            state: Arc::default(),
            pings: Arc::default(),
        }
    }

    /// The pings sent so far: what the tests count.
    pub fn pings(&self) -> u64 {
        self.pings.load(Ordering::Relaxed)
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
                    return Some(format!("the database did not answer within {} s", NO_ANSWER.as_secs()))
                }
                (Some(_), Some((_, last))) => return last.clone(),
                // The first ping: wait for it with the others.
                (Some((_, rx)), None) => rx.clone(),
                (None, _) => {
                    let (tx, rx) = watch::channel(None);
                    s.pinging = Some((Instant::now(), rx.clone()));
                    let (store, state) = (self.store.clone(), self.state.clone());
                    self.pings.fetch_add(1, Ordering::Relaxed);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::store_in;

    /// Regression (issue 46): each `/api/health` pinged the database, so
    /// 200 pollers queued for its connections and health took 1.7 s. A
    /// hundred at once are answered by one ping.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_hundred_health_checks_at_once_send_one_ping() {
        let dir = tempfile::tempdir().unwrap();
        let watch = DatabaseWatch::new(store_in(dir.path()).await);
        let asks: Vec<_> = (0..100)
            .map(|_| {
                let watch = watch.clone();
                tokio::spawn(async move { watch.error().await })
            })
            .collect();
        for a in asks {
            assert_eq!(a.await.unwrap(), None);
        }
        assert_eq!(watch.pings(), 1);
    }

    /// A database gone is said within a moment: the next answer after
    /// `FRESH_FOR` is a ping's, and it says why.
    #[tokio::test]
    async fn a_closed_database_is_said_after_the_last_answer_ages() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let watch = DatabaseWatch::new(store.clone());
        assert_eq!(watch.error().await, None);
        store.close().await;
        assert_eq!(watch.error().await, None, "the last answer stands for a moment");
        tokio::time::sleep(FRESH_FOR + Duration::from_millis(50)).await;
        let error = watch.error().await.expect("a closed pool does not answer");
        assert!(error.contains("closed"), "{error}");
        assert_eq!(watch.pings(), 2);
    }
}
