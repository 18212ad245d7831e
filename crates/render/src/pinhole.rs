//! The renderer's one pinhole camera ([`Pinhole`]): the scene's camera as
//! rays through pixels. Below both image sensors (the preview in
//! [`crate::sensor`] and the measuring camera in [`crate::camera`]), so
//! neither imports the other.

use glam::DVec3;

use crate::geometry::Ray;
use crate::scene::Camera;

/// The one pinhole camera of the renderer (pbrt-v4's `PerspectiveCamera`
/// without a lens): the scene's [`Camera`] as a centre of projection and
/// an image plane at unit distance along the view axis, spanning
/// tan(fov/2) above and below the axis (`fov_deg` is the vertical field of
/// view) and `aspect` = width/height times that to either side. Image
/// points are in pixels, x to the right and y down from the top-left
/// corner; a pixel's ray goes through its jittered point. An ideal pinhole:
/// no lens, no depth of field, no vignetting, no sensor response — the
/// ray's radiance is the pixel's. Both image sensors use it: the
/// dashboard's preview ([`crate::sensor::render_camera`]) and the measuring
/// camera ([`crate::camera::render_camera_image`]).
#[derive(Clone, Debug)]
pub struct Pinhole {
    origin: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half: f64,
    aspect: f64,
    width: usize,
    height: usize,
}

impl Pinhole {
    /// The pinhole of the scene's camera: forward toward `look_at`, right =
    /// forward × up, the image's up completing the right-handed basis.
    pub fn new(camera: &Camera) -> Pinhole {
        let forward = (camera.look_at - camera.position).normalize();
        let right = forward.cross(camera.up).normalize();
        Pinhole {
            origin: camera.position,
            forward,
            right,
            up: right.cross(forward),
            tan_half: (camera.fov_deg.to_radians() / 2.0).tan(),
            aspect: camera.width as f64 / camera.height as f64,
            width: camera.width as usize,
            height: camera.height as usize,
        }
    }

    /// The unit direction through image point (x, y), in pixels from the
    /// top-left corner (a pixel's centre is at + 0.5).
    pub fn direction(&self, x: f64, y: f64) -> DVec3 {
        let px = (2.0 * x / self.width as f64 - 1.0) * self.tan_half * self.aspect;
        let py = (1.0 - 2.0 * y / self.height as f64) * self.tan_half;
        (self.forward + self.right * px + self.up * py).normalize()
    }

    /// The ray of pixel (x, y) through its point (x + jx, y + jy), jitter in [0, 1)².
    pub fn ray(&self, x: usize, y: usize, (jx, jy): (f64, f64)) -> Ray {
        Ray {
            origin: self.origin,
            dir: self.direction(x as f64 + jx, y as f64 + jy),
        }
    }

    /// Where `point` falls in the image, in pixels (x right, y down from
    /// the top-left corner, as [`Pinhole::direction`] takes them): the
    /// inverse of `direction`; `None` for a point on or behind the plane of
    /// the pinhole. The point may fall outside the image.
    pub fn project(&self, point: DVec3) -> Option<(f64, f64)> {
        let v = point - self.origin;
        let depth = v.dot(self.forward);
        if depth <= 0.0 {
            return None;
        }
        let (px, py) = (v.dot(self.right) / depth, v.dot(self.up) / depth);
        Some((
            (px / (self.tan_half * self.aspect) + 1.0) * self.width as f64 / 2.0,
            (1.0 - py / self.tan_half) * self.height as f64 / 2.0,
        ))
    }

    /// The angle between the view axis and the centre of pixel (x, y), degrees.
    pub fn off_axis_deg(&self, x: usize, y: usize) -> f64 {
        self.direction(x as f64 + 0.5, y as f64 + 0.5)
            .dot(self.forward)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }
}
