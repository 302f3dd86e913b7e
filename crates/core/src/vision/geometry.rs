//! Where a camera fixed to the airframe really looked, and the image resampled onto the
//! ground: a pinhole camera rotated by the vehicle's attitude and intersected with flat
//! ground.
//!
//! Frames (the simulator renders with the same ones, `sim::render` and
//! `fleetmap_camera::camera::attitude_quaternion`):
//!
//! * **NED**: x north, y east, z down, origin at the camera.
//! * **Body**: x forward (the nose), y right, z down. The attitude `R` rotates body vectors
//!   into NED: `R = Rz(yaw) · Ry(pitch) · Rx(roll)` (ZYX Euler angles; roll right wing down,
//!   pitch nose up, yaw clockwise from north), which is what MAVLink's ATTITUDE gives and
//!   CAMERA_IMAGE_CAPTURED.q carries for a camera without a gimbal.
//! * **Camera**: the optical axis is the body z axis (the camera looks down the belly); the
//!   image's top is the nose and its right the right wing, so image x (right) is body y and
//!   image y (down) is body −x.
//! * **Pixels**: continuous coordinates, 0 at the left / top edge, pixel `i` spans
//!   `[i, i + 1)` with its centre at `i + 0.5` (as `CameraModel::ground_offset`). The focal
//!   length in pixels is `f = (W / 2) / tan(hfov / 2)`; pixels are square.
//!
//! A pixel (u, v) looks along `d_cam = ((u − W/2)/f, (v − H/2)/f, 1)`, that is
//! `d_body = (−d_cam.y, d_cam.x, 1)` and `d_ned = R · d_body`; it sees the ground at
//! `t · d_ned` with `t = h / d_ned.z` for a camera `h` metres above flat ground. The inverse
//! takes a ground point `g = (north, east, h)` to `R⁻¹ g` in the body frame and divides by the
//! depth. Level and facing north this is exactly `CameraModel::ground_offset`; tilted by θ
//! the view centre moves `h · tan θ` (nose up looks forward, right wing down looks left), as
//! the simulator renders it.

use super::VisionError;
use super::camera::CameraModel;
use image::RgbImage;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// A reported quaternion counts as an attitude when its norm is within this of 1: a real
/// autopilot sends unit quaternions to float precision, while all zeros is the old MAVLink
/// definition of "no orientation" and anything far from 1 is not a rotation.
pub(crate) const QUATERNION_NORM_TOLERANCE: f64 = 0.1;

/// The attitude in CAMERA_IMAGE_CAPTURED.q (`[w, x, y, z]`, body → NED), or `None` when
/// it is not a rotation (not finite, all zeros, norm off 1 by more than
/// `QUATERNION_NORM_TOLERANCE`).
pub fn attitude_of_quaternion(q: [f32; 4]) -> Option<UnitQuaternion<f64>> {
    let [w, x, y, z] = q.map(f64::from);
    let n = (w * w + x * x + y * y + z * z).sqrt();
    if !n.is_finite() || (n - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
        return None;
    }
    Some(UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)))
}

/// The attitude (body → NED) of ZYX Euler angles in degrees: roll right wing down, pitch
/// nose up, yaw clockwise from north.
pub fn attitude_from_euler_deg(roll_deg: f64, pitch_deg: f64, yaw_deg: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(
        roll_deg.to_radians(),
        pitch_deg.to_radians(),
        yaw_deg.to_radians(),
    )
}

/// ZYX Euler angles of `attitude`, degrees: (roll, pitch, yaw), yaw in [0, 360).
pub(crate) fn euler_deg(attitude: &UnitQuaternion<f64>) -> (f64, f64, f64) {
    let (r, p, y) = attitude.euler_angles();
    (
        r.to_degrees(),
        p.to_degrees(),
        y.to_degrees().rem_euclid(360.0),
    )
}

/// Angle between the optical axis (body z) and the vertical, degrees: how far off nadir the
/// camera looks, whatever the direction (`acos(cos roll · cos pitch)` for ZYX angles).
pub(crate) fn tilt_deg(attitude: &UnitQuaternion<f64>) -> f64 {
    let down = attitude.transform_vector(&Vector3::z());
    down.z.clamp(-1.0, 1.0).acos().to_degrees()
}

/// `attitude` with its heading replaced by `yaw_deg` (roll and pitch kept): ZYX angles
/// separate the heading from the tilt, so a camera whose heading is better known from
/// another source keeps its own tilt.
pub fn with_yaw_deg(attitude: &UnitQuaternion<f64>, yaw_deg: f64) -> UnitQuaternion<f64> {
    let (r, p, _) = euler_deg(attitude);
    attitude_from_euler_deg(r, p, yaw_deg)
}

/// Where the optical axis of a camera at `attitude`, `altitude_m` above flat ground, meets
/// the ground: (north, east) metres from the point under the camera (`altitude · tan(tilt)`
/// towards where it leans); `None` when it does not point down.
pub fn view_centre_offset(attitude: &UnitQuaternion<f64>, altitude_m: f64) -> Option<(f64, f64)> {
    let d = attitude.transform_vector(&Vector3::z());
    if d.z <= 1e-9 || !altitude_m.is_finite() {
        return None;
    }
    Some((altitude_m * d.x / d.z, altitude_m * d.y / d.z))
}

/// A true (north, east) offset in the frame of a grid whose north is at true bearing
/// `grid_north_deg`: (east, north) grid metres.
pub fn true_to_grid(north: f64, east: f64, grid_north_deg: f64) -> (f64, f64) {
    let (sg, cg) = grid_north_deg.to_radians().sin_cos();
    (east * cg - north * sg, north * cg + east * sg)
}

/// A pinhole camera (square pixels, optical axis down the body z axis) at a known attitude,
/// `altitude_m` metres above flat ground, taking `width × height` pixel images.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraView {
    /// Focal length, pixels: (width / 2) / tan(hfov / 2).
    focal_px: f64,
    /// Image width, pixels.
    width: f64,
    /// Image height, pixels.
    height: f64,
    /// Body → NED rotation matrix.
    r: Matrix3<f64>,
    /// Height of the camera above the ground, metres.
    altitude_m: f64,
}

impl CameraView {
    /// The view of `camera`'s optics (its horizontal field of view) on an image of
    /// `width × height` pixels (the decoded image's size, which may differ from the model's),
    /// at `attitude`, `altitude_m` above the ground. Checked: a valid camera model, pixels
    /// both ways, a finite altitude above 1 cm.
    pub fn new(
        camera: &CameraModel,
        width: u32,
        height: u32,
        attitude: &UnitQuaternion<f64>,
        altitude_m: f64,
    ) -> Result<CameraView, VisionError> {
        camera.validate()?;
        if width == 0 || height == 0 {
            return Err(VisionError::TooSmall { width, height });
        }
        if !(altitude_m.is_finite() && altitude_m > 0.01) {
            return Err(VisionError::InvalidParams(format!(
                "camera altitude must be above the ground, got {altitude_m} m"
            )));
        }
        let w = f64::from(width);
        Ok(CameraView {
            focal_px: w / 2.0 / (camera.hfov_deg.to_radians() / 2.0).tan(),
            width: w,
            height: f64::from(height),
            r: *attitude.to_rotation_matrix().matrix(),
            altitude_m,
        })
    }

    #[cfg(test)]
    /// Focal length, pixels.
    pub(crate) fn focal_px(&self) -> f64 {
        self.focal_px
    }

    /// The NED direction (not normalised) pixel (`u`, `v`) looks along.
    pub(crate) fn ray(&self, u: f64, v: f64) -> Vector3<f64> {
        let x = (u - self.width / 2.0) / self.focal_px;
        let y = (v - self.height / 2.0) / self.focal_px;
        self.r * Vector3::new(-y, x, 1.0)
    }

    /// The ground point pixel (`u`, `v`) sees: (north, east) metres from the point right
    /// under the camera; `None` when its ray does not go down to the ground.
    pub fn ground_of_pixel(&self, u: f64, v: f64) -> Option<(f64, f64)> {
        let d = self.ray(u, v);
        if d.z <= 1e-9 {
            return None;
        }
        let t = self.altitude_m / d.z;
        Some((t * d.x, t * d.y))
    }

    /// The pixel (`u`, `v`) that sees the ground point `north`, `east` metres from the point
    /// under the camera (it may lie outside the image); `None` when the point is behind the
    /// camera.
    pub fn pixel_of_ground(&self, north: f64, east: f64) -> Option<(f64, f64)> {
        let b = self.r.transpose() * Vector3::new(north, east, self.altitude_m);
        if b.z <= 1e-9 {
            return None;
        }
        Some((
            self.width / 2.0 + self.focal_px * b.y / b.z,
            self.height / 2.0 - self.focal_px * b.x / b.z,
        ))
    }

    #[cfg(test)]
    /// The ground point at the centre of the image: (north, east) metres from the point under
    /// the camera (`altitude · tan(tilt)` towards where the optical axis leans).
    pub(crate) fn view_centre(&self) -> Option<(f64, f64)> {
        self.ground_of_pixel(self.width / 2.0, self.height / 2.0)
    }
}

/// What [`orthophoto`] cuts out of an image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoRequest {
    /// Side of one grid cell, grid metres; the orthophoto covers 3 × 3 cells (the level
    /// camera's whole footprint when that is smaller either way, as
    /// [`crate::vision::crop::crop_to_cells`]).
    pub cell_m: f64,
    /// The orthophoto's centre (a cell centre), grid metres (east, north) from the point
    /// under the camera.
    pub centre_east_north_m: (f64, f64),
    /// True bearing of grid north, degrees clockwise from true north (the meridian
    /// convergence γ of the grid at the capture point; 0 on a north-aligned grid).
    pub grid_north_deg: f64,
}

/// An image resampled onto the ground: north-up in the grid's frame, one square ground
/// patch around the requested centre.
#[derive(Clone, Debug)]
pub struct Orthophoto {
    /// The resampled image: top = grid north, right = grid east.
    pub image: RgbImage,
    /// Share of its pixels whose ground the camera saw (the rest repeat the image's nearest
    /// edge pixel), 0–1.
    pub seen_fraction: f64,
    /// Ground size of the patch, grid metres (east–west, north–south).
    pub size_m: (f64, f64),
}

/// Resample `img`, taken by `camera` at `attitude` from `altitude_m` above flat ground, into
/// a north-up, grid-aligned orthophoto of the 3 × 3 cells around `req`'s centre: each output
/// pixel's ground point goes through the camera (ground → ray → source pixel) and is sampled
/// bilinearly; ground the camera did not see repeats the nearest image edge. The output has
/// the level camera's ground resolution (so a level, north-facing camera right over the
/// centre gives exactly [`crate::vision::crop::crop_to_cells`]'s centre crop), and covers
/// 3 × 3 cells, or the level camera's footprint at `altitude_m` when that is smaller either
/// way.
pub fn orthophoto(
    img: &RgbImage,
    camera: &CameraModel,
    attitude: &UnitQuaternion<f64>,
    altitude_m: f64,
    req: &OrthoRequest,
) -> Result<Orthophoto, VisionError> {
    let (w, h) = img.dimensions();
    let view = CameraView::new(camera, w, h, attitude, altitude_m)?;
    if !(req.cell_m.is_finite() && req.cell_m > 0.0) {
        return Err(VisionError::InvalidParams(format!(
            "cell size must be positive, got {}",
            req.cell_m
        )));
    }
    let (ce, cn) = req.centre_east_north_m;
    if !(ce.is_finite() && cn.is_finite() && req.grid_north_deg.is_finite()) {
        return Err(VisionError::InvalidParams(
            "orthophoto centre and grid bearing must be finite".into(),
        ));
    }
    // The level camera's footprint and ground resolution at this altitude.
    let fw = altitude_m * f64::from(w) / view.focal_px;
    let gsd = fw / f64::from(w);
    let fh = gsd * f64::from(h);
    // As crop_to_cells: 3 × 3 cells when the footprint is larger both ways, else the whole
    // footprint (the runway paper's classifier then reads a smaller area, as before).
    let want = 3.0 * req.cell_m;
    let (ow, oh, ext_e, ext_n) = if fw <= want * 1.001 || fh <= want * 1.001 {
        (w, h, fw, fh)
    } else {
        let ow = ((f64::from(w) * want / fw).round() as u32).clamp(3.min(w), w);
        let oh = ((f64::from(h) * want / fh).round() as u32).clamp(3.min(h), h);
        (ow, oh, want, want)
    };
    let (px_e, px_n) = (ext_e / f64::from(ow), ext_n / f64::from(oh));
    // Output pixel (i, j) → grid offset from the point under the camera → true NED offset →
    // body frame: affine in (i, j), so the body vector is a + i·bi + j·bj.
    let (sg, cg) = req.grid_north_deg.to_radians().sin_cos();
    let to_ned = |e: f64, n: f64| Vector3::new(n * cg - e * sg, n * sg + e * cg, 0.0);
    let rt = view.r.transpose();
    let e0 = ce + (0.5 - f64::from(ow) / 2.0) * px_e;
    let n0 = cn + (f64::from(oh) / 2.0 - 0.5) * px_n;
    let a = rt * (to_ned(e0, n0) + Vector3::new(0.0, 0.0, altitude_m));
    let bi = rt * to_ned(px_e, 0.0);
    let bj = rt * to_ned(0.0, -px_n);
    let (f, cx, cy) = (view.focal_px, f64::from(w) / 2.0, f64::from(h) / 2.0);
    let (a, bi, bj) = ([a.x, a.y, a.z], [bi.x, bi.y, bi.z], [bj.x, bj.y, bj.z]);
    let src = img.as_raw();
    let stride = w as usize * 3;
    let (wf, hf) = (f64::from(w), f64::from(h));
    let (wm, hm) = (wf - 1.0, hf - 1.0);
    let (ow_us, oh_us) = (ow as usize, oh as usize);
    let mut out = vec![0u8; ow_us * oh_us * 3];
    let mut seen = 0u64;
    let (w1, h1) = (w as usize - 1, h as usize - 1);
    let mut o = 0usize;
    for j in 0..oh_us {
        let jf = j as f64;
        let r = [a[0] + bj[0] * jf, a[1] + bj[1] * jf, a[2] + bj[2] * jf];
        for i in 0..ow_us {
            let fi = i as f64;
            let (bx, by, bz) = (r[0] + bi[0] * fi, r[1] + bi[1] * fi, r[2] + bi[2] * fi);
            let (u, v) = if bz > 1e-9 {
                let k = f / bz;
                let (u, v) = (cx + by * k, cy - bx * k);
                if u >= 0.0 && u <= wf && v >= 0.0 && v <= hf {
                    seen += 1;
                }
                (u, v)
            } else {
                (cx, cy)
            };
            // Bilinear in 8-bit fixed point, pixel i's centre at i + 0.5; outside the image
            // the edge repeats.
            let x = (u - 0.5).clamp(0.0, wm);
            let y = (v - 0.5).clamp(0.0, hm);
            let (x0, y0) = (x as usize, y as usize);
            let wx = ((x - x0 as f64) * 256.0) as u32;
            let wy = ((y - y0 as f64) * 256.0) as u32;
            let (x1, y1) = ((x0 + 1).min(w1), (y0 + 1).min(h1));
            let (k00, k01) = ((256 - wx) * (256 - wy), wx * (256 - wy));
            let (k10, k11) = ((256 - wx) * wy, wx * wy);
            let (r0, r1) = (&src[y0 * stride..], &src[y1 * stride..]);
            let (a0, a1) = (&r0[x0 * 3..x0 * 3 + 3], &r0[x1 * 3..x1 * 3 + 3]);
            let (c0, c1) = (&r1[x0 * 3..x0 * 3 + 3], &r1[x1 * 3..x1 * 3 + 3]);
            let dst = &mut out[o..o + 3];
            for c in 0..3 {
                let sum = u32::from(a0[c]) * k00
                    + u32::from(a1[c]) * k01
                    + u32::from(c0[c]) * k10
                    + u32::from(c1[c]) * k11;
                dst[c] = ((sum + (1 << 15)) >> 16) as u8;
            }
            o += 3;
        }
    }
    let image = RgbImage::from_raw(ow, oh, out)
        .ok_or_else(|| VisionError::InvalidParams("orthophoto buffer size".into()))?;
    Ok(Orthophoto {
        image,
        seen_fraction: seen as f64 / (f64::from(ow) * f64::from(oh)),
        size_m: (ext_e, ext_n),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn paper_view(att: &UnitQuaternion<f64>, alt: f64) -> CameraView {
        CameraView::new(&CameraModel::paper(), 480, 480, att, alt).unwrap()
    }

    #[test]
    fn a_level_camera_facing_north_is_the_footprint_model() {
        let cam = CameraModel::paper();
        let view = paper_view(&UnitQuaternion::identity(), 12.0);
        // 40 px per metre at 12 m, image top = north, right = east
        for (u, v) in [(240.0, 240.0), (0.0, 0.0), (480.0, 240.0), (123.5, 401.25)] {
            let (n, e) = view.ground_of_pixel(u, v).unwrap();
            let (n2, e2) = cam.ground_offset(u, v, 12.0, 0.0);
            assert!((n - n2).abs() < 1e-9 && (e - e2).abs() < 1e-9, "{u},{v}");
        }
        assert!((view.focal_px() - 480.0).abs() < 1e-9);
    }

    #[test]
    fn the_view_centre_moves_as_the_simulator_renders_it() {
        // Nose up 5° looks forward: at 12 m the centre is 12·tan 5° ahead (north at yaw 0).
        let v = paper_view(&attitude_from_euler_deg(0.0, 5.0, 0.0), 12.0);
        let (n, e) = v.view_centre().unwrap();
        assert!((n - 12.0 * 5f64.to_radians().tan()).abs() < 1e-9 && e.abs() < 1e-9);
        // Right wing down 5° looks left (west when facing north).
        let v = paper_view(&attitude_from_euler_deg(5.0, 0.0, 0.0), 12.0);
        let (n, e) = v.view_centre().unwrap();
        assert!(n.abs() < 1e-9 && (e + 12.0 * 5f64.to_radians().tan()).abs() < 1e-9);
        // Facing east, nose up: forward is east.
        let a = attitude_from_euler_deg(0.0, 5.0, 90.0);
        let v = paper_view(&a, 12.0);
        let (n, e) = v.view_centre().unwrap();
        assert!(n.abs() < 1e-9 && (e - 12.0 * 5f64.to_radians().tan()).abs() < 1e-9);
        let (n2, e2) = view_centre_offset(&a, 12.0).unwrap();
        assert!((n - n2).abs() < 1e-9 && (e - e2).abs() < 1e-9);
        // 1 m true north on a grid whose north is 90° (east): 1 m grid west... i.e. the
        // grid's −east axis points true north.
        let (ge, gn) = true_to_grid(1.0, 0.0, 90.0);
        assert!((ge + 1.0).abs() < 1e-12 && gn.abs() < 1e-12);
        let (ge, gn) = true_to_grid(0.3, -0.2, 0.0);
        assert!((ge + 0.2).abs() < 1e-12 && (gn - 0.3).abs() < 1e-12);
    }

    #[test]
    fn quaternions_that_are_not_rotations_are_unknown() {
        assert!(attitude_of_quaternion([0.0; 4]).is_none());
        assert!(attitude_of_quaternion([f32::NAN, 0.0, 0.0, 0.0]).is_none());
        assert!(attitude_of_quaternion([2.0, 0.0, 0.0, 0.0]).is_none());
        let q = attitude_of_quaternion([1.0, 0.0, 0.0, 0.0]).unwrap();
        assert!(tilt_deg(&q).abs() < 1e-9);
        // The simulator's convention (fleetmap_camera::camera::attitude_quaternion) reads back.
        let a = attitude_from_euler_deg(3.0, -4.0, 250.0);
        let c = a.coords;
        let q = attitude_of_quaternion([c.w as f32, c.x as f32, c.y as f32, c.z as f32]).unwrap();
        let (r, p, y) = euler_deg(&q);
        assert!((r - 3.0).abs() < 1e-4 && (p + 4.0).abs() < 1e-4 && (y - 250.0).abs() < 1e-4);
        let t = tilt_deg(&q);
        let want = (3f64.to_radians().cos() * 4f64.to_radians().cos())
            .acos()
            .to_degrees();
        assert!((t - want).abs() < 1e-3, "{t} {want}");
        let (_, _, y2) = euler_deg(&with_yaw_deg(&q, 90.0));
        assert!((y2 - 90.0).abs() < 1e-9);
    }

    #[test]
    fn bad_views_are_refused() {
        let cam = CameraModel::paper();
        let id = UnitQuaternion::identity();
        assert!(CameraView::new(&cam, 480, 480, &id, 0.0).is_err());
        assert!(CameraView::new(&cam, 480, 480, &id, f64::NAN).is_err());
        assert!(CameraView::new(&cam, 0, 480, &id, 12.0).is_err());
        let img = RgbImage::new(48, 48);
        let req = OrthoRequest {
            cell_m: 0.0,
            centre_east_north_m: (0.0, 0.0),
            grid_north_deg: 0.0,
        };
        assert!(orthophoto(&img, &cam, &id, 12.0, &req).is_err());
    }

    /// An image whose red channel is x and green channel y (pixel indices), so the
    /// resampled value says where it came from.
    fn coordinate_image(w: u32, h: u32) -> RgbImage {
        RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8, y as u8, 0]))
    }

    #[test]
    fn rotated_grid_and_heading_cancel() {
        // A camera facing 30° on a grid whose north is at 30°: the grid-aligned orthophoto
        // is the image itself.
        let cam = CameraModel {
            hfov_deg: CameraModel::paper().hfov_deg,
            width_px: 240,
            height_px: 240,
        };
        let img = coordinate_image(240, 240);
        let req = OrthoRequest {
            cell_m: 4.0,
            centre_east_north_m: (0.0, 0.0),
            grid_north_deg: 30.0,
        };
        let att = attitude_from_euler_deg(0.0, 0.0, 30.0);
        let o = orthophoto(&img, &cam, &att, 12.0, &req).unwrap();
        assert_eq!(o.image.dimensions(), (240, 240));
        for (x, y, p) in o.image.enumerate_pixels() {
            assert!((i32::from(p[0]) - x as i32).abs() <= 1, "{x},{y} {p:?}");
            assert!((i32::from(p[1]) - y as i32).abs() <= 1, "{x},{y} {p:?}");
        }
    }

    #[test]
    fn a_tilted_view_is_cut_where_the_camera_looked() {
        // Nose up 5° at 12 m facing north: the ground under the camera is 12·tan 5° = 1.05 m
        // below the image centre, i.e. 42 px at 40 px/m; the orthophoto's centre pixel samples
        // it, and the strip beyond the image's bottom edge is unseen.
        let cam = CameraModel::paper();
        let img = RgbImage::from_fn(480, 480, |x, y| {
            image::Rgb([(x / 2) as u8, (y / 2) as u8, 0])
        });
        let req = OrthoRequest {
            cell_m: 4.0,
            centre_east_north_m: (0.0, 0.0),
            grid_north_deg: 0.0,
        };
        let att = attitude_from_euler_deg(0.0, 5.0, 0.0);
        let o = orthophoto(&img, &cam, &att, 12.0, &req).unwrap();
        let view = paper_view(&att, 12.0);
        let (_, v) = view.pixel_of_ground(0.0, 0.0).unwrap();
        assert!((v - 240.0 - 42.0).abs() < 1.5, "{v}");
        let p = o.image.get_pixel(240, 240);
        assert!(
            (f64::from(p[1]) - (v - 0.5) / 2.0).abs() <= 1.0,
            "{p:?} {v}"
        );
        assert!(
            o.seen_fraction < 0.95 && o.seen_fraction > 0.85,
            "{}",
            o.seen_fraction
        );
    }

    proptest! {
        /// Any attitude within 30° of level, any heading: a ground point in view projected
        /// into the image and back lands where it started.
        #[test]
        fn ground_to_pixel_and_back(
            roll in -30.0f64..30.0,
            pitch in -30.0f64..30.0,
            yaw in 0.0f64..360.0,
            alt in 2.0f64..60.0,
            north in -0.5f64..0.5,
            east in -0.5f64..0.5,
        ) {
            let view = paper_view(&attitude_from_euler_deg(roll, pitch, yaw), alt);
            let (n, e) = (north * alt, east * alt);
            let (u, v) = view.pixel_of_ground(n, e).unwrap();
            let (n2, e2) = view.ground_of_pixel(u, v).unwrap();
            prop_assert!((n - n2).abs() < 1e-6 * alt && (e - e2).abs() < 1e-6 * alt,
                "({n}, {e}) → ({u}, {v}) → ({n2}, {e2})");
        }

        /// And the other way: any pixel of the image to the ground and back.
        #[test]
        fn pixel_to_ground_and_back(
            roll in -30.0f64..30.0,
            pitch in -30.0f64..30.0,
            yaw in 0.0f64..360.0,
            alt in 2.0f64..60.0,
            u in 0.0f64..480.0,
            v in 0.0f64..480.0,
        ) {
            let view = paper_view(&attitude_from_euler_deg(roll, pitch, yaw), alt);
            let (n, e) = view.ground_of_pixel(u, v).unwrap();
            let (u2, v2) = view.pixel_of_ground(n, e).unwrap();
            prop_assert!((u - u2).abs() < 1e-6 && (v - v2).abs() < 1e-6);
        }

        /// The orthophoto samples every ground point from the pixel that saw it: a marker
        /// pixel's colour ends up at the marker's ground position in the orthophoto.
        #[test]
        fn orthophoto_puts_ground_points_where_they_are(
            roll in -10.0f64..10.0,
            pitch in -10.0f64..10.0,
            yaw in 0.0f64..360.0,
            off_e in -1.0f64..1.0,
            off_n in -1.0f64..1.0,
            gamma in -3.0f64..3.0,
            pe in -5.0f64..5.0,
            pn in -5.0f64..5.0,
        ) {
            let cam = CameraModel::paper();
            let att = attitude_from_euler_deg(roll, pitch, yaw);
            let alt = 12.0;
            let view = paper_view(&att, alt);
            // The ground point (pe, pn) grid metres from the orthophoto centre, in true NED
            // metres from the point under the camera.
            let (e, n) = (off_e + pe, off_n + pn);
            let (sg, cg) = gamma.to_radians().sin_cos();
            let (nt, et) = (n * cg - e * sg, n * sg + e * cg);
            let (u, v) = view.pixel_of_ground(nt, et).unwrap();
            prop_assume!(u > 8.0 && u < 472.0 && v > 8.0 && v < 472.0);
            // A white 5×5 marker on black at that pixel.
            let (ux, vy) = (u.floor() as i64, v.floor() as i64);
            let img = RgbImage::from_fn(480, 480, |x, y| {
                let on = (i64::from(x) - ux).abs() <= 2 && (i64::from(y) - vy).abs() <= 2;
                image::Rgb(if on { [255; 3] } else { [0; 3] })
            });
            let req = OrthoRequest {
                cell_m: 4.0,
                centre_east_north_m: (off_e, off_n),
                grid_north_deg: gamma,
            };
            let o = orthophoto(&img, &cam, &att, alt, &req).unwrap();
            let (ow, oh) = o.image.dimensions();
            let px = o.size_m.0 / f64::from(ow);
            let i = (pe / px + f64::from(ow) / 2.0).floor() as u32;
            let j = (f64::from(oh) / 2.0 - pn / px).floor() as u32;
            prop_assert!(o.image.get_pixel(i.min(ow - 1), j.min(oh - 1))[0] > 100,
                "marker at ({pe}, {pn}) not at ortho pixel ({i}, {j})");
        }
    }
}
