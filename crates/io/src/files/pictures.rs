//! Where `fleetmap camera` gets its pictures when it is not rendering them (blocking file
//! I/O: call from a blocking thread).
//!
//! **A folder a camera writes into** ([`FolderSource`]): a camera tethered to the companion
//! computer (gphoto2's `--capture-tethered`, a machine-vision camera's SDK, a phone syncing
//! its DCIM folder) or a folder of pictures from an earlier flight. Every shot the autopilot
//! fires takes the next picture of the folder the camera has not used yet — oldest
//! modification time first, then name — waiting up to [`FolderSource::wait`] for one to
//! appear. A shot that finds none fails (CAMERA_IMAGE_CAPTURED with `capture_result` 0), as a
//! camera that did not fire would. Files that are not PNG or JPEG are skipped; a picture that
//! cannot be decoded is skipped with its reason and the next one is taken.

use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use image::RgbImage;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// Pictures from a folder, each used once. See the module documentation.
#[derive(Debug)]
pub struct FolderSource {
    dir: PathBuf,
    used: HashSet<PathBuf>,
    /// Longest wait for a new picture to appear when a shot finds none, wall time.
    pub wait: Duration,
    limits: LoadLimits,
    /// Pictures skipped because they could not be read or decoded, with the reason.
    pub skipped: Vec<String>,
}

/// What a shot took from the folder.
#[derive(Debug)]
pub struct FolderPicture {
    /// The file.
    pub path: PathBuf,
    /// Its pixels.
    pub image: RgbImage,
}

/// Why the picture folder cannot be used. Both name the folder.
#[derive(Debug, thiserror::Error)]
pub enum PictureFolderError {
    /// The folder cannot be read (missing, no permission, …).
    #[error("picture folder {}: {source}", dir.display())]
    Unreadable {
        /// The folder.
        dir: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The path is not a directory.
    #[error("picture folder {}: not a directory", dir.display())]
    NotADirectory {
        /// The path.
        dir: PathBuf,
    },
}

impl FolderSource {
    /// Pictures from `dir`, which must be a readable directory.
    pub fn new(dir: &Path, wait: Duration) -> Result<FolderSource, PictureFolderError> {
        let meta = std::fs::metadata(dir).map_err(|source| PictureFolderError::Unreadable {
            dir: dir.to_path_buf(),
            source,
        })?;
        if !meta.is_dir() {
            return Err(PictureFolderError::NotADirectory {
                dir: dir.to_path_buf(),
            });
        }
        Ok(FolderSource {
            dir: dir.to_path_buf(),
            used: HashSet::new(),
            wait,
            limits: LoadLimits::default(),
            skipped: Vec::new(),
        })
    }

    /// The pictures not used yet, oldest first (modification time, then name).
    fn unused(&self) -> std::io::Result<Vec<PathBuf>> {
        let mut found: Vec<(SystemTime, PathBuf)> = Vec::new();
        for entry in std::fs::read_dir(&self.dir)? {
            let Ok(entry) = entry else { continue };
            let path = entry.path();
            let is_picture = path
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "jpg" | "jpeg" | "png"));
            if !is_picture || self.used.contains(&path) {
                continue;
            }
            let Ok(meta) = entry.metadata() else { continue };
            if !meta.is_file() {
                continue;
            }
            found.push((meta.modified().unwrap_or(SystemTime::UNIX_EPOCH), path));
        }
        found.sort();
        Ok(found.into_iter().map(|(_, p)| p).collect())
    }

    /// The next picture (blocking: lists the folder, reads and decodes a file, and waits up
    /// to [`FolderSource::wait`] for a new one). `Ok(None)`: none appeared in time.
    pub fn next_picture(&mut self) -> Result<Option<FolderPicture>, PictureFolderError> {
        let start = Instant::now();
        loop {
            let unused = self
                .unused()
                .map_err(|source| PictureFolderError::Unreadable {
                    dir: self.dir.clone(),
                    source,
                })?;
            for path in unused {
                self.used.insert(path.clone());
                let read = std::fs::read(&path)
                    .map_err(|e| e.to_string())
                    .and_then(|b| load_image_bytes(&b, &self.limits).map_err(|e| e.to_string()));
                match read {
                    Ok(image) => return Ok(Some(FolderPicture { path, image })),
                    Err(e) => self.skipped.push(format!("{}: {e}", path.display())),
                }
            }
            if start.elapsed() >= self.wait {
                return Ok(None);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(path: &Path, rgb: [u8; 3]) {
        RgbImage::from_pixel(8, 8, image::Rgb(rgb))
            .save(path)
            .unwrap();
    }

    #[test]
    fn takes_each_picture_once_oldest_first_and_skips_what_is_not_one() {
        let dir = tempfile::tempdir().unwrap();
        png(&dir.path().join("b.png"), [0, 255, 0]);
        // same modification time is possible: then the name decides
        std::thread::sleep(Duration::from_millis(20));
        png(&dir.path().join("a.png"), [255, 0, 0]);
        std::fs::write(dir.path().join("notes.txt"), "not a picture").unwrap();
        std::fs::write(dir.path().join("broken.jpg"), b"\xff\xd8 truncated").unwrap();
        let mut src = FolderSource::new(dir.path(), Duration::from_millis(50)).unwrap();
        let mut got = Vec::new();
        while let Some(p) = src.next_picture().unwrap() {
            got.push((
                p.path.file_name().unwrap().to_string_lossy().to_string(),
                p.image.get_pixel(0, 0).0,
            ));
        }
        // broken.jpg was written last but is skipped with its reason
        assert_eq!(
            got,
            [
                ("b.png".to_string(), [0, 255, 0]),
                ("a.png".to_string(), [255, 0, 0])
            ]
        );
        assert_eq!(src.skipped.len(), 1, "{:?}", src.skipped);
        assert!(src.skipped[0].contains("broken.jpg"));
        // a picture written later is taken by the next shot
        png(&dir.path().join("c.png"), [0, 0, 255]);
        let p = src.next_picture().unwrap().unwrap();
        assert!(p.path.ends_with("c.png"));
    }

    #[test]
    fn a_missing_folder_is_a_clear_error() {
        let e = FolderSource::new(Path::new("/nonexistent/pictures"), Duration::ZERO).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/pictures"), "{e}");
    }
}
