//! The renderer's workflows as the HTTP layer calls them: one trait,
//! [`RenderService`], that the daemon's renderer implements, so the HTTP
//! layer knows the lab only through it (and tests can stand in a daemon
//! without scenes).

use std::future::Future;
use std::sync::Arc;

use super::error::LabError;
use super::requests::{RenderRequest, SceneInfo, StudyRequest};

/// A boxed future, for the async methods of the traits below.
pub type BoxFuture<T> = std::pin::Pin<Box<dyn Future<Output = T> + Send>>;

/// The renderer as the service sees it; the daemon provides it.
pub trait RenderService: Send + Sync {
    /// The scenes available under `scenes_dir`, in the study's order.
    fn scenes(&self) -> Vec<SceneInfo>;
    /// Records a render of a scene and starts it; resolves to its id at once.
    fn start_render(self: Arc<Self>, scene: String, request: RenderRequest) -> BoxFuture<Result<i64, LabError>>;
    /// Checks a study request field by field without starting anything.
    fn check_study(&self, request: &StudyRequest) -> Result<(), LabError>;
    /// Records a study and starts it in the background; resolves to its id at once.
    fn start_study(self: Arc<Self>, request: StudyRequest) -> BoxFuture<Result<i64, LabError>>;
    /// Cancels a queued or running render or study (409 once it has ended).
    fn cancel(self: Arc<Self>, job: lightbooth_store::Job, id: i64) -> BoxFuture<Result<(), LabError>>;
    /// Queues a new render or study with the request of an interrupted,
    /// failed or cancelled one; resolves to the new id.
    fn retry(self: Arc<Self>, job: lightbooth_store::Job, id: i64) -> BoxFuture<Result<i64, LabError>>;
    /// Queues a camera image of a render (or finds the one already made
    /// with the same settings); resolves to its id and whether it was reused.
    fn start_image(
        self: Arc<Self>,
        _render_id: i64,
        _request: crate::images::ImageRequest,
    ) -> BoxFuture<Result<(i64, bool), LabError>> {
        Box::pin(async { Err(LabError::Unavailable("this daemon renders no camera images".into())) })
    }
    /// The camera images this daemon keeps (see `lab::images`); `None`
    /// when it renders none.
    fn images(&self) -> Option<&crate::images::ImageJobs> {
        None
    }
    /// How far its running renders and studies have got; `None` when it
    /// does not follow them.
    fn progress(&self) -> Option<&crate::progress::ProgressBoard> {
        None
    }
    /// The CIELAB white of a scene in a booth now, with its source (see
    /// `lab::comparisons`).
    fn cielab_white(
        self: Arc<Self>,
        _scene: String,
        _booth: lightbooth_store::Booth,
    ) -> BoxFuture<Result<(lightbooth_science::colorimetry::Xyz, String), LabError>> {
        Box::pin(async { Err(LabError::Unavailable("this daemon has no scenes".into())) })
    }
}
