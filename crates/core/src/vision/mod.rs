//! The sensing models of both papers: the runway classifier and green-pixel measurements,
//! the per-cell vote book, camera footprint geometry, and image loading with limits.
//!
//! Public entry points (all pure: no clock, no sockets; files are opened at the edge, `files`):
//!
//! | item | what |
//! |---|---|
//! | [`runway::classify`] | one image + heading → black fractions of the 5 regions and labels of the cell and its 4 neighbours (runway paper §7) |
//! | `runway::classify_many` | the same for several images in parallel (rayon) |
//! | [`runway::votes::VoteBook`] | 3-of-5 votes per cell and visit, sticky positives, every detection kept |
//! | [`green::green_fraction`], [`green::measure`] | share of green pixels, one Bernoulli measurement per image (bandit paper §V) |
//! | [`crop::crop_to_cells`], [`crop::crop_to_cell`] | the centre crops both missions measure (3 × 3 cells; a share of one cell) |
//! | [`meta::ImageMeta`] | what a capture says about itself, in a JPEG COM segment |
//! | [`onboard::OnboardMeasurement`] | a green share measured on board, as a DEBUG_FLOAT_ARRAY |
//! | [`runway::onboard::RunwaySpec`], [`runway::onboard::RunwayMeasurement`] | a runway picture classified on board (cell, five region counts, labels) and the run's grid announced to the cameras, as DEBUG_FLOAT_ARRAYs |
//! | [`camera::CameraModel`] | footprint and the altitude at which the centre ninth covers one cell |
//! | [`geometry::orthophoto`], [`geometry::CameraView`] | pinhole camera at the capture attitude (nalgebra): ground ↔ pixel, the 3 × 3 cells resampled north-up |
//! | [`sanity::check_capture`] | whether a picture was taken where it is credited (position, altitude, tilt, heading) |
//! | [`load::load_image_bytes`] | PNG/JPEG bytes → RGB image, dimensions checked before decoding |
//! | [`synth`], [`runway::synth`] | deterministic synthetic green-tile and runway / grass images for tests and benches |
//!
//! Every step that OpenCV also does is pixel-exact with OpenCV (see [`color`] and
//! [`runway`]); `tests/py/test_vision_opencv.py` checks it against `cv2`.

pub mod camera;
pub mod color;
pub mod crop;
pub mod fast;
pub mod geometry;
pub mod green;
pub mod load;
pub mod meta;
pub mod onboard;
pub mod reference;
pub mod regions;
pub mod sanity;
pub mod synth;

/// The kinds' own vision modules (the runway classifier, its votes and its on-board
/// measurement: `runway`), from the list of kinds ([`crate::for_each_kind!`]).
macro_rules! kind_modules {
    ($([$($module:ident)?])+) => {
        $($(pub mod $module;)?)+
    };
}
crate::for_each_kind!(vision => kind_modules);

/// FNV-1a over `bytes`, folded to 24 bits so that a 32-bit float holds it exactly: the
/// fingerprints of the on-board definitions ([`onboard::GreenSpec::fingerprint`],
/// [`runway::onboard::RunwaySpec::fingerprint`]).
pub(crate) fn fingerprint24(bytes: &[u8]) -> u32 {
    let h = bytes.iter().fold(0x811c_9dc5_u32, |h, &b| {
        (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
    });
    (h >> 24) ^ (h & 0x00ff_ffff)
}

/// Errors of the vision module.
#[derive(Debug, thiserror::Error)]
pub enum VisionError {
    /// The image file could not be read.
    #[error("cannot read image file: {0}")]
    Io(#[from] std::io::Error),
    /// The file is larger than the configured limit.
    #[error("image file is {bytes} bytes, more than the limit of {limit} bytes")]
    FileTooLarge {
        /// Size of the file (bytes), or a lower bound of it.
        bytes: u64,
        /// The limit (bytes).
        limit: u64,
    },
    /// The file or buffer is empty.
    #[error("image is empty (0 bytes)")]
    Empty,
    /// Not a PNG or JPEG image.
    #[error("unsupported image format: {0} (expected PNG or JPEG)")]
    UnsupportedFormat(String),
    /// The header announces more pixels than allowed; nothing was decoded.
    #[error(
        "image is {width}×{height} pixels, more than the limit of {limit} pixels (checked from the header, not decoded)"
    )]
    TooManyPixels {
        /// Width from the header (pixels).
        width: u32,
        /// Height from the header (pixels).
        height: u32,
        /// The limit (pixels).
        limit: u64,
    },
    /// The image data is corrupt or truncated.
    #[error("cannot decode image: {0}")]
    Decode(String),
    /// The image is too small to be split into 3×3 regions.
    #[error("image is {width}×{height} pixels; at least 3×3 is needed for the 3×3 regions")]
    TooSmall {
        /// Width (pixels).
        width: u32,
        /// Height (pixels).
        height: u32,
    },
    /// The heading is not a finite number.
    #[error("heading must be a finite number of degrees, got {0}")]
    InvalidHeading(f64),
    /// A parameter is out of range.
    #[error("invalid vision parameter: {0}")]
    InvalidParams(String),
}
