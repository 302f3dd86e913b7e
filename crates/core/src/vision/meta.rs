//! Image metadata carried inside the JPEG itself (a COM segment with one JSON object), so an
//! image received over MAVLink image transmission — whose DATA_TRANSMISSION_HANDSHAKE has no
//! image index — or read from a directory still says which capture it is and where it was
//! taken.

use serde::{Deserialize, Serialize};

/// What a capture knew about itself.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImageMeta {
    /// MAVLink system id of the vehicle.
    pub sysid: u8,
    /// Boots of the vehicle so far (1 for the first power-up); image indices restart at 0 on
    /// every boot, so (sysid, boot, image_index) names a capture.
    pub boot: u32,
    /// CAMERA_IMAGE_CAPTURED.image_index.
    pub image_index: i32,
    /// Milliseconds since the vehicle booted when the image was taken.
    pub time_boot_ms: u32,
    /// Latitude the autopilot reported, degrees.
    pub lat: f64,
    /// Longitude the autopilot reported, degrees.
    pub lon: f64,
    /// Altitude above home the autopilot reported, metres.
    pub alt_rel_m: f64,
    /// Heading, degrees clockwise from north (image up).
    pub heading_deg: f64,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

const SOI: [u8; 2] = [0xFF, 0xD8];
const COM: u8 = 0xFE;
const TAG: &str = "fleetmap-image ";

/// Insert `meta` as a COM segment right after the JPEG's SOI marker. Returns `None` when
/// `jpeg` does not start with SOI or the JSON is too long for a segment.
pub fn insert_meta(jpeg: &[u8], meta: &ImageMeta) -> Option<Vec<u8>> {
    if jpeg.len() < 2 || jpeg[..2] != SOI {
        return None;
    }
    let body = format!("{TAG}{}", serde_json::to_string(meta).ok()?);
    let len = u16::try_from(body.len() + 2).ok()?;
    let mut out = Vec::with_capacity(jpeg.len() + body.len() + 4);
    out.extend_from_slice(&SOI);
    out.extend_from_slice(&[0xFF, COM]);
    out.extend_from_slice(&len.to_be_bytes());
    out.extend_from_slice(body.as_bytes());
    out.extend_from_slice(&jpeg[2..]);
    Some(out)
}

/// Read the metadata written by [`insert_meta`], scanning the marker segments before the
/// image data; `None` when the JPEG carries none (or is malformed).
pub fn read_meta(jpeg: &[u8]) -> Option<ImageMeta> {
    if jpeg.len() < 4 || jpeg[..2] != SOI {
        return None;
    }
    let mut i = 2usize;
    while i + 4 <= jpeg.len() {
        if jpeg[i] != 0xFF {
            return None;
        }
        let marker = jpeg[i + 1];
        if marker == 0xDA || marker == 0xD9 {
            return None; // start of scan / end of image: no more headers
        }
        let len = usize::from(u16::from_be_bytes([jpeg[i + 2], jpeg[i + 3]]));
        if len < 2 || i + 2 + len > jpeg.len() {
            return None;
        }
        if marker == COM {
            let body = &jpeg[i + 4..i + 2 + len];
            if let Ok(s) = std::str::from_utf8(body)
                && let Some(json) = s.strip_prefix(TAG)
            {
                return serde_json::from_str(json).ok();
            }
        }
        i += 2 + len;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_decodable() {
        let img = image::RgbImage::from_pixel(16, 8, image::Rgb([10, 200, 30]));
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 80)
            .encode_image(&img)
            .unwrap();
        let meta = ImageMeta {
            sysid: 3,
            boot: 2,
            image_index: 17,
            time_boot_ms: 12345,
            lat: 37.1968,
            lon: -80.5781,
            alt_rel_m: 12.0,
            heading_deg: 58.0,
            width: 16,
            height: 8,
        };
        let tagged = insert_meta(&jpeg, &meta).unwrap();
        assert_eq!(read_meta(&tagged), Some(meta));
        assert_eq!(read_meta(&jpeg), None);
        let back = image::load_from_memory(&tagged).unwrap();
        assert_eq!((back.width(), back.height()), (16, 8));
        assert!(read_meta(&tagged[..10]).is_none());
        assert!(insert_meta(b"not a jpeg", &read_meta(&tagged).unwrap()).is_none());
    }
}
