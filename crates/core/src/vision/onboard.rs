//! Measurements a camera makes on board, and the small MAVLink message that carries one.
//!
//! A picture of the bandit field is 45–70 kB; what the GCS takes from it is one number, the
//! green share of the centre of the cell under the drone (bandit paper §V). A camera that
//! measures on board sends that number instead of the picture: 30 samples of a cell then
//! cost about 3 kB on the link instead of 1.5 MB, which a 57,600-baud radio (≈ 5 kB/s)
//! carries.
//!
//! **The message** is the standard DEBUG_FLOAT_ARRAY (id 350, common.xml), sent by the camera
//! component right after the CAMERA_IMAGE_CAPTURED of the same picture:
//!
//! | field | value |
//! |---|---|
//! | `time_usec` | the capture's `time_boot_ms` × 1000 (CAMERA_IMAGE_CAPTURED.time_boot_ms) |
//! | `array_id` | the capture's `image_index`, low 16 bits |
//! | `name` | `"fm.green"` (`GREEN_NAME`) |
//! | `data[0]` | format version, 1 |
//! | `data[1]` | the measurement definition's fingerprint ([`GreenSpec::fingerprint`], 24 bits) |
//! | `data[2]` | the picture's size in bytes (the camera sends it on request: a DATA_TRANSMISSION_HANDSHAKE naming this size) |
//! | `data[3]` | green share of the measured square, 0..=1 |
//! | `data[4]` | pixels in the measured square (0: nothing measured) |
//!
//! Why this message: it is in common.xml, so ArduPilot's and PX4's routers forward it from a
//! companion computer's port to the GCS like any other message without a target
//! (ArduPilot `MAVLink_routing::check_and_forward` sends untargeted messages to every other
//! channel with a known route; PX4 forwards on instances with `MAV_x_FORWARD`), and every
//! MAVLink library decodes it. It carries a timestamp and a 16-bit id, which together with
//! the capture's `time_boot_ms` tie the numbers to one picture exactly. NAMED_VALUE_FLOAT
//! carries one value and no id; CAMERA_IMAGE_CAPTURED has no field for a measurement (its
//! `file_url` is a URL); a custom dialect message would be dropped by routers built without
//! it. With MAVLink 2's trailing-zero truncation the frame is 52 bytes on the wire (40 of payload).
//!
//! **The definition** must be the GCS's own: the camera measures with the mission file it was
//! given (`fleetmap camera --mission`), and the fingerprint says which definition it used. A
//! GCS whose mission gives a different fingerprint does not use the number; it asks for the
//! picture and measures it itself.

use crate::vision::camera::CameraModel;
use crate::vision::crop::crop_to_cell;
use crate::vision::fingerprint24;
use crate::vision::green::{GreenParams, green_fraction};
use image::RgbImage;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use serde::{Deserialize, Serialize};

/// DEBUG_FLOAT_ARRAY.name of a green-share measurement.
pub(crate) const GREEN_NAME: &str = "fm.green";

/// Version of the layout of `data` (see the module documentation).
const FORMAT_VERSION: f32 = 1.0;

/// How the bandit mission measures a picture: the green share of a centred square covering
/// `crop_fraction` of a `cell_m` cell on the ground, for a camera `camera` at the capture
/// altitude, with the HSV box and threshold of `green` (the mission file's
/// `[classification.green]`, the camera model and the grid's cell size).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GreenSpec {
    /// The HSV box and the positive threshold.
    pub green: GreenParams,
    /// The camera's optics and resolution.
    pub camera: CameraModel,
    /// Cell side, metres.
    pub cell_m: f64,
    /// Side of the measured square as a fraction of the cell side.
    pub crop_fraction: f64,
}

/// The green share of one picture, as measured on board or by the GCS.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GreenShare {
    /// Share of green pixels in the measured square, 0..=1.
    pub share: f64,
    /// Pixels in the measured square (0: an empty picture).
    pub pixels: u32,
}

impl GreenShare {
    /// The Bernoulli realisation: a positive sample when the share reaches `min_fraction`
    /// (and something was measured).
    pub fn positive(&self, green: &GreenParams) -> bool {
        self.pixels > 0 && self.share >= green.min_fraction
    }
}

impl GreenSpec {
    /// Measure `img`, taken at `altitude_m` above the ground: the same computation whether a
    /// camera runs it on board or the GCS on a received picture.
    pub fn measure(&self, img: &RgbImage, altitude_m: f64) -> GreenShare {
        let crop = crop_to_cell(
            img,
            &self.camera,
            altitude_m,
            self.cell_m,
            self.crop_fraction,
        );
        GreenShare {
            share: green_fraction(&crop, &self.green),
            pixels: crop.width().saturating_mul(crop.height()),
        }
    }

    /// A 24-bit fingerprint of the definition (FNV-1a over its fields, folded to 24 bits so
    /// that a 32-bit float holds it exactly): equal definitions give equal fingerprints.
    pub fn fingerprint(&self) -> u32 {
        let mut bytes = Vec::with_capacity(64);
        bytes.extend_from_slice(&self.green.lower);
        bytes.extend_from_slice(&self.green.upper);
        bytes.extend_from_slice(&self.green.min_fraction.to_bits().to_le_bytes());
        bytes.extend_from_slice(&self.camera.hfov_deg.to_bits().to_le_bytes());
        bytes.extend_from_slice(&self.camera.width_px.to_le_bytes());
        bytes.extend_from_slice(&self.camera.height_px.to_le_bytes());
        bytes.extend_from_slice(&self.cell_m.to_bits().to_le_bytes());
        bytes.extend_from_slice(&self.crop_fraction.to_bits().to_le_bytes());
        fingerprint24(&bytes)
    }
}

/// One message type of an on-board measurement, as the list below registers it.
pub trait OnboardMessage: Sized {
    /// The message, when `o` is one of this type.
    fn of(o: &Onboard) -> Option<&Self>;
}

/// The on-board measurements, one per kind that has one, from the list of kinds
/// ([`crate::for_each_kind!`]'s `onboard` part: `Name(definition, message)` and the camera's
/// module that makes it; the kind's documentation documents its variants). It
/// declares what a camera is given ([`OnboardSpec`]), which measurement a message is
/// ([`OnboardKind`]) and any camera's message ([`Onboard`]), whose methods call the
/// message type's own: `from_message`, `to_message`, `capture()` (the capture it is about;
/// `None`: a status, about no picture), `has_result()` (whether the GCS can use it instead
/// of the picture), and its fields `spec` (the definition's fingerprint) and
/// `picture_bytes`. Messages are read in the list's order.
macro_rules! measurements {
    ($([$(#[$doc:meta])*] [$name:ident ($spec:path) ($msg:path) $camera:ident])+) => {
        /// What a camera that measures on board is given: the definition of one mission's
        /// measurement.
        #[derive(Clone, Debug, PartialEq)]
        pub enum OnboardSpec {
            $($(#[$doc])* $name($spec),)+
        }

        /// Which on-board measurement a message is.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum OnboardKind {
            $($(#[$doc])* $name,)+
        }

        /// A message a camera sent about a picture it measured on board (or a status).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub enum Onboard {
            $($(#[$doc])* $name($msg),)+
        }

        impl OnboardSpec {
            /// Which measurement this is.
            pub fn kind(&self) -> OnboardKind {
                match self {
                    $(OnboardSpec::$name(_) => OnboardKind::$name,)+
                }
            }
        }

        impl Onboard {
            /// Read a DEBUG_FLOAT_ARRAY: `None` when it is no on-board message of a known
            /// layout.
            pub fn from_message(d: &mav::DEBUG_FLOAT_ARRAY_DATA) -> Option<Onboard> {
                $(if let Some(m) = <$msg>::from_message(d) {
                    return Some(Onboard::$name(m));
                })+
                None
            }

            /// Which measurement this is.
            pub fn kind(&self) -> OnboardKind {
                match self {
                    $(Onboard::$name(_) => OnboardKind::$name,)+
                }
            }

            /// The DEBUG_FLOAT_ARRAY that carries it.
            pub fn to_message(&self) -> MavMessage {
                match self {
                    $(Onboard::$name(m) => m.to_message(),)+
                }
            }

            /// The capture it is about, (time_boot_ms, image index's low 16 bits); `None`: a
            /// status, about no picture.
            pub fn capture(&self) -> Option<(u32, u16)> {
                match self {
                    $(Onboard::$name(m) => m.capture(),)+
                }
            }

            /// Whether it is the result of the capture (`time_boot_ms`, `image_index`).
            pub fn is_of(&self, time_boot_ms: u32, image_index: i32) -> bool {
                self.capture() == Some((time_boot_ms, image_index as u16))
            }

            /// Whether it carries a result the GCS can use instead of the picture.
            pub fn has_result(&self) -> bool {
                match self {
                    $(Onboard::$name(m) => m.has_result(),)+
                }
            }

            /// The fingerprint of the definition the camera measured with (0: none).
            pub fn spec(&self) -> u32 {
                match self {
                    $(Onboard::$name(m) => m.spec,)+
                }
            }

            /// Size of the picture, bytes (what to ask for to get it; 0 in a status).
            pub fn picture_bytes(&self) -> u32 {
                match self {
                    $(Onboard::$name(m) => m.picture_bytes,)+
                }
            }

            /// The message, when it is of type `M`.
            pub fn get<M: OnboardMessage>(&self) -> Option<&M> {
                M::of(self)
            }
        }

        $(impl OnboardMessage for $msg {
            #[allow(unreachable_patterns)]
            fn of(o: &Onboard) -> Option<&Self> {
                match o {
                    Onboard::$name(m) => Some(m),
                    _ => None,
                }
            }
        }

        impl From<$msg> for Onboard {
            fn from(m: $msg) -> Onboard {
                Onboard::$name(m)
            }
        })+
    };
}

crate::for_each_kind!(onboard => measurements);

/// A measurement made on board, tied to its picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OnboardMeasurement {
    /// The capture's time since the vehicle booted, ms (CAMERA_IMAGE_CAPTURED.time_boot_ms).
    pub time_boot_ms: u32,
    /// The capture's image index, low 16 bits.
    pub image_index_lo: u16,
    /// [`GreenSpec::fingerprint`] of the definition the camera measured with.
    pub spec: u32,
    /// Size of the picture, bytes (what to ask for to get it).
    pub picture_bytes: u32,
    /// The green share.
    pub value: GreenShare,
}

impl OnboardMeasurement {
    /// Whether this measurement is of the capture (`time_boot_ms`, `image_index`).
    pub fn is_of(&self, time_boot_ms: u32, image_index: i32) -> bool {
        self.time_boot_ms == time_boot_ms && self.image_index_lo == image_index as u16
    }

    /// The capture it is about: (time_boot_ms, image index's low 16 bits); a green share is
    /// always about a picture.
    pub fn capture(&self) -> Option<(u32, u16)> {
        Some((self.time_boot_ms, self.image_index_lo))
    }

    /// Whether the GCS can use it instead of the picture: always (a share of 0 pixels is a
    /// measurement too).
    pub fn has_result(&self) -> bool {
        true
    }

    /// The DEBUG_FLOAT_ARRAY that carries it (layout in the module documentation).
    pub fn to_message(&self) -> MavMessage {
        let mut data = [0f32; 58];
        data[0] = FORMAT_VERSION;
        data[1] = self.spec as f32;
        data[2] = self.picture_bytes as f32;
        data[3] = self.value.share as f32;
        data[4] = self.value.pixels as f32;
        MavMessage::DEBUG_FLOAT_ARRAY(mav::DEBUG_FLOAT_ARRAY_DATA {
            time_usec: u64::from(self.time_boot_ms) * 1000,
            array_id: self.image_index_lo,
            name: GREEN_NAME.into(),
            data,
        })
    }

    /// Read a DEBUG_FLOAT_ARRAY: `None` when it is not a fleetmap green-share measurement of
    /// a known layout, or its numbers are out of range.
    pub fn from_message(m: &mav::DEBUG_FLOAT_ARRAY_DATA) -> Option<OnboardMeasurement> {
        let name: String = m
            .name
            .iter()
            .map(|&b| b as char)
            .take_while(|&c| c != '\0')
            .collect();
        if name != GREEN_NAME || m.data[0] != FORMAT_VERSION {
            return None;
        }
        let whole =
            |x: f32, max: f32| x.is_finite() && (0.0..=max).contains(&x) && x.fract() == 0.0;
        let (spec, size, share, pixels) = (m.data[1], m.data[2], m.data[3], m.data[4]);
        let valid = whole(spec, 16_777_215.0)
            && whole(size, 16_777_216.0)
            && whole(pixels, 16_777_216.0)
            && share.is_finite()
            && (0.0..=1.0).contains(&share);
        if !valid {
            return None;
        }
        Some(OnboardMeasurement {
            time_boot_ms: u32::try_from(m.time_usec / 1000).ok()?,
            image_index_lo: m.array_id,
            spec: spec as u32,
            picture_bytes: size as u32,
            value: GreenShare {
                share: f64::from(share),
                pixels: pixels as u32,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> GreenSpec {
        GreenSpec {
            green: GreenParams::default(),
            camera: CameraModel::paper(),
            cell_m: 5.0,
            crop_fraction: 0.6,
        }
    }

    // The round trip through the GCS's MAVLink codec: tests/suite/vision.rs.

    #[test]
    fn other_arrays_and_bad_numbers_are_not_measurements() {
        let m = OnboardMeasurement {
            time_boot_ms: 10,
            image_index_lo: 1,
            spec: 5,
            picture_bytes: 100,
            value: GreenShare {
                share: 0.5,
                pixels: 9,
            },
        };
        let MavMessage::DEBUG_FLOAT_ARRAY(good) = m.to_message() else {
            unreachable!()
        };
        let mut other = good.clone();
        other.name = "other".into();
        assert_eq!(OnboardMeasurement::from_message(&other), None);
        let mut nan = good.clone();
        nan.data[3] = f32::NAN;
        assert_eq!(OnboardMeasurement::from_message(&nan), None);
        let mut v2 = good.clone();
        v2.data[0] = 2.0;
        assert_eq!(OnboardMeasurement::from_message(&v2), None);
        let mut frac = good;
        frac.data[4] = 1.5;
        assert_eq!(OnboardMeasurement::from_message(&frac), None);
    }

    #[test]
    fn fingerprints_tell_definitions_apart_and_fit_a_float() {
        let a = spec();
        let b = GreenSpec {
            crop_fraction: 0.5,
            ..a
        };
        let c = GreenSpec { cell_m: 4.0, ..a };
        assert_eq!(a.fingerprint(), spec().fingerprint());
        assert_ne!(a.fingerprint(), b.fingerprint());
        assert_ne!(a.fingerprint(), c.fingerprint());
        for s in [a, b, c] {
            let f = s.fingerprint();
            assert!(f < 1 << 24);
            assert_eq!(f as f32 as u32, f);
        }
    }

    #[test]
    fn measures_the_centre_square_of_the_cell() {
        // 480 px over 10 m at 10 m altitude (53.13° field of view): a 5 m cell at 0.6 is
        // 3 m = 144 px; the centre is green, the rest grey
        let img = RgbImage::from_fn(480, 480, |x, y| {
            if (168..312).contains(&x) && (168..312).contains(&y) {
                image::Rgb([40, 160, 50])
            } else {
                image::Rgb([128, 128, 128])
            }
        });
        let s = spec();
        let m = s.measure(&img, 10.0);
        assert_eq!(m.pixels, 144 * 144);
        assert!((m.share - 1.0).abs() < 1e-12, "{m:?}");
        assert!(m.positive(&s.green));
        let grey = RgbImage::from_pixel(480, 480, image::Rgb([128, 128, 128]));
        assert!(!s.measure(&grey, 10.0).positive(&s.green));
        assert!(
            !GreenShare {
                share: 1.0,
                pixels: 0
            }
            .positive(&s.green)
        );
    }
}
