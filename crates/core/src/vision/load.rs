//! Decoding camera images safely: PNG or JPEG bytes → 8-bit RGB.
//!
//! An image from a vehicle or a directory can be anything: empty, truncated, corrupt, of
//! another format, or a small file whose header claims 30000×30000 pixels (2.7 GB of RGB).
//! [`load_image_bytes`] never panics and never allocates more than the limits allow. This
//! module opens no file: reading one (with its size checked and the read capped before the
//! bytes come here) is the edge's `files::load_image_file`.
//!
//! 1. the size is checked against [`LoadLimits::max_file_bytes`];
//! 2. the format is recognised from the content (magic bytes), not the file name;
//! 3. the decoder reads only the header, and the width, height and pixel count are checked
//!    against [`LoadLimits`] **before** any pixel is decoded (`image::ImageReader` with
//!    `image::Limits`, plus our own pixel limit);
//! 4. the pixels are decoded and converted to RGB the way `cv2.imread(path, IMREAD_COLOR)`
//!    does, so that the classifier sees the same pixels as OpenCV: alpha is dropped (not
//!    blended), grey is replicated into R = G = B, 16-bit samples keep their high byte
//!    (libpng's `png_set_strip_16`, which OpenCV's PNG decoder uses). EXIF orientation is
//!    not applied (camera images are used as the sensor delivers them: top = nose).

use super::VisionError;
use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader, RgbImage};
use std::io::Cursor;

/// Limits applied while loading an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct LoadLimits {
    /// Largest accepted width × height (pixels). Default 50 000 000 (a 50 MP camera;
    /// 150 MB of RGB).
    pub max_pixels: u64,
    /// Largest accepted file (bytes). Default 256 MiB.
    pub max_file_bytes: u64,
    /// Largest allocation the decoder may make (bytes), passed to `image::Limits`.
    /// Default 512 MiB.
    pub max_alloc_bytes: u64,
}

impl Default for LoadLimits {
    fn default() -> LoadLimits {
        LoadLimits {
            max_pixels: 50_000_000,
            max_file_bytes: 256 << 20,
            max_alloc_bytes: 512 << 20,
        }
    }
}

/// Decode an encoded image (PNG or JPEG) held in memory.
pub fn load_image_bytes(bytes: &[u8], limits: &LoadLimits) -> Result<RgbImage, VisionError> {
    if bytes.is_empty() {
        return Err(VisionError::Empty);
    }
    if bytes.len() as u64 > limits.max_file_bytes {
        return Err(VisionError::FileTooLarge {
            bytes: bytes.len() as u64,
            limit: limits.max_file_bytes,
        });
    }
    let mut reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(VisionError::Io)?;
    match reader.format() {
        Some(ImageFormat::Png | ImageFormat::Jpeg) => {}
        Some(other) => {
            return Err(VisionError::UnsupportedFormat(format!("{other:?}")));
        }
        None => {
            return Err(VisionError::UnsupportedFormat(
                "not recognised from its first bytes".to_string(),
            ));
        }
    }
    // Width and height limits: no side can exceed the pixel limit (saturated to u32).
    let side = u32::try_from(limits.max_pixels).unwrap_or(u32::MAX);
    let mut il = image::Limits::default();
    il.max_image_width = Some(side);
    il.max_image_height = Some(side);
    il.max_alloc = Some(limits.max_alloc_bytes);
    reader.limits(il.clone());
    // Only the header is parsed here.
    let decoder = reader.into_decoder().map_err(map_image_error)?;
    let (width, height) = decoder.dimensions();
    if u64::from(width) * u64::from(height) > limits.max_pixels {
        return Err(VisionError::TooManyPixels {
            width,
            height,
            limit: limits.max_pixels,
        });
    }
    if width == 0 || height == 0 {
        return Err(VisionError::Decode(format!(
            "the header says {width}×{height} pixels"
        )));
    }
    il.reserve(decoder.total_bytes()).map_err(map_image_error)?;
    let img = DynamicImage::from_decoder(decoder).map_err(map_image_error)?;
    Ok(to_rgb_like_opencv(img))
}

fn map_image_error(e: image::ImageError) -> VisionError {
    use image::ImageError as E;
    match e {
        E::Unsupported(u) => VisionError::UnsupportedFormat(u.to_string()),
        E::Limits(l) => VisionError::Decode(format!("over the decoding limits: {l}")),
        E::IoError(io) => VisionError::Decode(format!("truncated or unreadable data: {io}")),
        other => VisionError::Decode(other.to_string()),
    }
}

/// RGB the way `cv2.imread(…, IMREAD_COLOR)` produces it (then reordered from BGR).
pub(crate) fn to_rgb_like_opencv(img: DynamicImage) -> RgbImage {
    let (w, h) = (img.width(), img.height());
    let from = |data: Vec<u8>| RgbImage::from_raw(w, h, data);
    let converted = match img {
        DynamicImage::ImageRgb8(i) => return i,
        DynamicImage::ImageRgba8(i) => from(
            i.as_raw()
                .chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect(),
        ),
        DynamicImage::ImageLuma8(i) => from(i.as_raw().iter().flat_map(|&v| [v, v, v]).collect()),
        DynamicImage::ImageLumaA8(i) => from(
            i.as_raw()
                .chunks_exact(2)
                .flat_map(|p| [p[0], p[0], p[0]])
                .collect(),
        ),
        DynamicImage::ImageRgb16(i) => from(i.as_raw().iter().map(|&v| (v >> 8) as u8).collect()),
        DynamicImage::ImageRgba16(i) => from(
            i.as_raw()
                .chunks_exact(4)
                .flat_map(|p| [(p[0] >> 8) as u8, (p[1] >> 8) as u8, (p[2] >> 8) as u8])
                .collect(),
        ),
        DynamicImage::ImageLuma16(i) => from(
            i.as_raw()
                .iter()
                .flat_map(|&v| {
                    let b = (v >> 8) as u8;
                    [b, b, b]
                })
                .collect(),
        ),
        DynamicImage::ImageLumaA16(i) => from(
            i.as_raw()
                .chunks_exact(2)
                .flat_map(|p| {
                    let b = (p[0] >> 8) as u8;
                    [b, b, b]
                })
                .collect(),
        ),
        other => return other.to_rgb8(),
    };
    // The lengths above are w·h·3 by construction; fall back to the crate's conversion.
    converted.unwrap_or_else(|| RgbImage::new(w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png_bytes(img: &DynamicImage) -> Vec<u8> {
        let mut out = Vec::new();
        img.write_to(&mut Cursor::new(&mut out), ImageFormat::Png)
            .unwrap();
        out
    }

    #[test]
    fn round_trip_png() {
        let img = RgbImage::from_fn(5, 4, |x, y| image::Rgb([x as u8 * 10, y as u8 * 20, 7]));
        let bytes = png_bytes(&DynamicImage::ImageRgb8(img.clone()));
        let back = load_image_bytes(&bytes, &LoadLimits::default()).unwrap();
        assert_eq!(back, img);
    }

    #[test]
    fn sixteen_bit_keeps_the_high_byte() {
        let img = image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(3, 2, |x, y| {
            image::Rgb([0x12ff, (x * 1000 + y) as u16, 0xff80])
        });
        let bytes = png_bytes(&DynamicImage::ImageRgb16(img));
        let back = load_image_bytes(&bytes, &LoadLimits::default()).unwrap();
        assert_eq!(back.get_pixel(0, 0).0, [0x12, 0, 0xff]);
        assert_eq!(
            back.get_pixel(2, 1).0,
            [0x12, ((2000 + 1) >> 8) as u8, 0xff]
        );
    }

    #[test]
    fn errors_are_reported_not_panicked() {
        let l = LoadLimits::default();
        assert!(matches!(load_image_bytes(&[], &l), Err(VisionError::Empty)));
        assert!(matches!(
            load_image_bytes(b"hello world, not an image", &l),
            Err(VisionError::UnsupportedFormat(_))
        ));
        let img = RgbImage::from_fn(40, 30, |x, y| image::Rgb([x as u8, y as u8, 0]));
        let bytes = png_bytes(&DynamicImage::ImageRgb8(img));
        let cut = &bytes[..bytes.len() / 2];
        assert!(matches!(
            load_image_bytes(cut, &l),
            Err(VisionError::Decode(_))
        ));
        let small = LoadLimits {
            max_pixels: 100,
            ..l
        };
        assert!(matches!(
            load_image_bytes(&bytes, &small),
            Err(VisionError::TooManyPixels {
                width: 40,
                height: 30,
                ..
            })
        ));
    }
}
