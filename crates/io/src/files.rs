//! The edge's file loaders: the only place where mission files, image files and `file://`
//! image URLs are opened and read.
//!
//! The pure core parses bytes and text ([`MissionDef::from_bytes`],
//! [`fleetmap_core::vision::load::load_image_bytes`], [`fleetmap_core::proto::image_transfer::file_url_path`]);
//! these functions read the file first, with the same checks and the same errors (the path
//! as given plus the reason, never a panic), and hand the bytes over. The command line, the
//! application layer and the tests call them.
//!
//! [`terrain`]: SRTM `.hgt` (and `.hgt.zip`) tiles from the folder given with `--terrain`.
//!
//! [`pictures`]: a folder a real camera writes into, as the pictures of `fleetmap camera`
//! (the simulator's camera server reads it without depending on the GCS's application layer).

mod atomic;
pub mod pictures;
pub mod terrain;

pub use atomic::{atomic_write, sync_dir};

use fleetmap_core::mission::definition::{DefErrors, MissionDef};
use fleetmap_core::proto::image_transfer::{FileUrlError, file_url_path};
use fleetmap_core::vision::VisionError;
use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use fleetmap_core::world::{World, WorldError};
use image::RgbImage;
use std::io::Read;
use std::path::Path;
use std::path::PathBuf;

/// Read, parse and validate the mission file at `path`. Errors name the file as given
/// (an unreadable file: "cannot read the file: `<reason>`"; bytes that are not UTF-8: the line
/// and column of the first bad byte).
pub fn load_mission(path: impl AsRef<Path>) -> Result<MissionDef, DefErrors> {
    read_mission(path).map(|(_, def)| def)
}

/// [`load_mission`], with the file's text as read (a run directory keeps its copy).
pub fn read_mission(path: impl AsRef<Path>) -> Result<(String, MissionDef), DefErrors> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| MissionDef::unreadable(&file, &e))?;
    let def = MissionDef::from_bytes(&bytes, &file)?;
    // `from_bytes` accepted the bytes as UTF-8, so nothing is replaced here.
    Ok((String::from_utf8_lossy(&bytes).into_owned(), def))
}

/// Why a world file cannot be loaded: it cannot be read, or what it says is not a world
/// ([`WorldError`], the core's parse and check). Both name the file as given.
#[derive(Debug, thiserror::Error)]
pub enum WorldFileError {
    /// The file could not be read.
    #[error("cannot read world file {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The text is not a valid world.
    #[error(transparent)]
    World(#[from] WorldError),
}

/// Read and check the world file at `path` (a simulated world, [`World`]). Errors name the
/// file as given.
pub fn load_world(path: &Path) -> Result<World, WorldFileError> {
    read_world(path).map(|(_, w)| w)
}

/// [`load_world`], with the file's text as read (a run directory keeps its copy).
pub fn read_world(path: &Path) -> Result<(String, World), WorldFileError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| WorldFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let world = World::from_toml_file(&text, &file)?;
    Ok((text, world))
}

/// Load an image file (PNG or JPEG): its size is checked against
/// [`LoadLimits::max_file_bytes`] before it is read and the read is capped, then the bytes are
/// decoded by [`load_image_bytes`].
pub fn load_image_file(path: &Path, limits: &LoadLimits) -> Result<RgbImage, VisionError> {
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_dir() {
        return Err(VisionError::Io(std::io::Error::other("is a directory")));
    }
    if meta.len() > limits.max_file_bytes {
        return Err(VisionError::FileTooLarge {
            bytes: meta.len(),
            limit: limits.max_file_bytes,
        });
    }
    // Cap the read as well: the size can change, and special files report 0.
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limits.max_file_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limits.max_file_bytes {
        return Err(VisionError::FileTooLarge {
            bytes: bytes.len() as u64,
            limit: limits.max_file_bytes,
        });
    }
    load_image_bytes(&bytes, limits)
}

/// Read the image a `file://` URL names (CAMERA_IMAGE_CAPTURED.file_url), refusing files over
/// `limit` bytes.
pub fn read_file_url(url: &str, limit: u64) -> Result<Vec<u8>, FileUrlError> {
    let path = file_url_path(url)?;
    let p = path.display().to_string();
    let meta = std::fs::metadata(&path).map_err(|source| FileUrlError::Io {
        path: p.clone(),
        source,
    })?;
    if meta.len() > limit {
        return Err(FileUrlError::TooLarge {
            path: p,
            size: meta.len(),
            limit,
        });
    }
    std::fs::read(&path).map_err(|source| FileUrlError::Io { path: p, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_urls_are_read_within_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.jpg");
        std::fs::write(&p, b"abc").unwrap();
        let url = format!("file://{}", p.display());
        assert_eq!(read_file_url(&url, 10).unwrap(), b"abc");
        assert!(matches!(
            read_file_url(&url, 2),
            Err(FileUrlError::TooLarge { .. })
        ));
    }
}
