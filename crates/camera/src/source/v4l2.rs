//! `v4l2:DEVICE`: a frame grabbed from a Video4Linux2 capture device per shot (a USB webcam,
//! an HDMI grabber, a Raspberry Pi camera through its V4L2 driver), through the `v4l` crate.
//!
//! The device is asked for Motion-JPEG at its current size (decoded with the `image` crate),
//! else YUYV 4:2:2 (converted here, ITU-R BT.601 studio range); a device that offers neither
//! is refused when the camera starts. Each shot starts a memory-mapped stream, drops the
//! first frame (a buffer the driver may have filled long before the shutter, with an
//! exposure that has not settled) and keeps the next one, then stops the stream: a camera
//! that streams between shots would hand out stale frames from its queue.
//!
//! Building it needs libclang (Debian: `libclang-dev`), since the `v4l` crate generates its
//! kernel bindings with bindgen; running it needs only the kernel's V4L2 driver and read
//! access to the device (the `video` group).

use image::RgbImage;
use std::path::{Path, PathBuf};
use v4l::FourCC;
use v4l::buffer::Type;
use v4l::io::traits::CaptureStream;
use v4l::prelude::*;
use v4l::video::Capture;

/// Frames the stream is given (one dropped, one kept).
const BUFFERS: u32 = 2;

/// A V4L2 device's frames, one per shot. See the module documentation.
pub struct V4l2Source {
    path: PathBuf,
    device: Device,
    width: u32,
    height: u32,
    mjpeg: bool,
}

impl std::fmt::Debug for V4l2Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("V4l2Source")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("mjpeg", &self.mjpeg)
            .finish()
    }
}

/// Why the device gave no frame.
#[derive(Debug, thiserror::Error)]
pub enum V4l2Error {
    /// Opening, configuring or reading the device failed.
    #[error("V4L2 device {}: {what}: {source}", path.display())]
    Io {
        /// The device.
        path: PathBuf,
        /// What failed.
        what: &'static str,
        /// The OS error.
        source: std::io::Error,
    },
    /// The device offers neither Motion-JPEG nor YUYV.
    #[error("V4L2 device {}: offers {fourcc}, not MJPG or YUYV", path.display())]
    Format {
        /// The device.
        path: PathBuf,
        /// The format it kept.
        fourcc: String,
    },
    /// A frame could not be decoded.
    #[error("V4L2 device {}: a frame could not be decoded: {why}", path.display())]
    Decode {
        /// The device.
        path: PathBuf,
        /// Why.
        why: String,
    },
}

impl V4l2Source {
    /// Open the device at `path` and choose its format (Motion-JPEG, else YUYV).
    pub fn open(path: &Path) -> Result<V4l2Source, V4l2Error> {
        let io = |what: &'static str| {
            let path = path.to_path_buf();
            move |source| V4l2Error::Io { path, what, source }
        };
        let device = Device::with_path(path).map_err(io("cannot open"))?;
        let mut fmt = device.format().map_err(io("cannot read its format"))?;
        let mut chosen = None;
        for fourcc in [b"MJPG", b"YUYV"] {
            fmt.fourcc = FourCC::new(fourcc);
            let set = device
                .set_format(&fmt)
                .map_err(io("cannot set its format"))?;
            if set.fourcc == FourCC::new(fourcc) {
                chosen = Some(set);
                break;
            }
            fmt = set;
        }
        let Some(set) = chosen else {
            return Err(V4l2Error::Format {
                path: path.to_path_buf(),
                fourcc: fmt.fourcc.to_string(),
            });
        };
        Ok(V4l2Source {
            path: path.to_path_buf(),
            device,
            width: set.width,
            height: set.height,
            mjpeg: set.fourcc == FourCC::new(b"MJPG"),
        })
    }

    /// Grab one frame (blocking until the device delivers two).
    pub fn grab(&mut self) -> Result<RgbImage, V4l2Error> {
        let io = |what: &'static str| {
            let path = self.path.clone();
            move |source| V4l2Error::Io { path, what, source }
        };
        let mut stream = MmapStream::with_buffers(&self.device, Type::VideoCapture, BUFFERS)
            .map_err(io("cannot start streaming"))?;
        stream.next().map_err(io("cannot read a frame"))?;
        let (buf, meta) = stream.next().map_err(io("cannot read a frame"))?;
        let used = (meta.bytesused as usize).min(buf.len());
        let data = &buf[..if used > 0 { used } else { buf.len() }];
        let decoded = if self.mjpeg {
            image::load_from_memory_with_format(data, image::ImageFormat::Jpeg)
                .map(|i| i.to_rgb8())
                .map_err(|e| e.to_string())
        } else {
            yuyv_to_rgb(data, self.width, self.height)
        };
        decoded.map_err(|why| V4l2Error::Decode {
            path: self.path.clone(),
            why,
        })
    }
}

/// A YUYV 4:2:2 frame (`Y0 U Y1 V` per two pixels, rows packed) as RGB, BT.601 studio range.
fn yuyv_to_rgb(data: &[u8], width: u32, height: u32) -> Result<RgbImage, String> {
    let need = width as usize * height as usize * 2;
    if !width.is_multiple_of(2) || data.len() < need {
        return Err(format!(
            "{} bytes for a {width} × {height} YUYV frame (needs {need}, even width)",
            data.len()
        ));
    }
    let mut img = RgbImage::new(width, height);
    let px = |y: u8, u: u8, v: u8| {
        let c = (f32::from(y) - 16.0) * 1.164;
        let (d, e) = (f32::from(u) - 128.0, f32::from(v) - 128.0);
        let clamp = |x: f32| x.round().clamp(0.0, 255.0) as u8;
        image::Rgb([
            clamp(c + 1.596 * e),
            clamp(c - 0.392 * d - 0.813 * e),
            clamp(c + 2.017 * d),
        ])
    };
    for (i, q) in data[..need].chunks_exact(4).enumerate() {
        let x = (i * 2) as u32 % width;
        let y = (i * 2) as u32 / width;
        img.put_pixel(x, y, px(q[0], q[1], q[3]));
        img.put_pixel(x + 1, y, px(q[2], q[1], q[3]));
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yuyv_grey_white_and_red() {
        // two pixels per 4 bytes: mid grey, then white; then a saturated red pair
        let frame = [126, 128, 235, 128, 81, 90, 81, 240];
        let img = yuyv_to_rgb(&frame, 2, 2).unwrap();
        let near = |a: [u8; 3], b: [u8; 3]| a.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= 3);
        assert!(near(img.get_pixel(0, 0).0, [128, 128, 128]));
        assert!(near(img.get_pixel(1, 0).0, [255, 255, 255]));
        assert!(
            near(img.get_pixel(0, 1).0, [255, 0, 0]),
            "{:?}",
            img.get_pixel(0, 1)
        );
        assert!(yuyv_to_rgb(&frame, 3, 2).is_err());
        assert!(yuyv_to_rgb(&frame[..6], 2, 2).is_err());
    }
}
