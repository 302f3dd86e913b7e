//! Where the camera program's pictures come from (`--source`), when it does not render them.
//! Each is blocking: the serve loop calls it from a blocking thread, one shot at a time.
//!
//! | source | what |
//! |---|---|
//! | `folder:DIR` | a folder a camera writes into: each shot takes the oldest picture not used yet ([`fleetmap_io::files::pictures`]) |
//! | `command:CMD` | a program run per shot that writes a JPEG (or PNG) to `{out}`, e.g. `command:libcamera-still -n -o {out}` ([`command`]) |
//! | `v4l2:DEVICE` | a frame grabbed from a Video4Linux2 device, e.g. `v4l2:/dev/video0` (cargo feature `v4l2`; `source::v4l2`) |
//! | `render` | drawn from a world file at the reported pose (cargo feature `render`: `crate::render`) |

pub mod command;
#[cfg(feature = "v4l2")]
pub mod v4l2;

use fleetmap_io::files::pictures::FolderSource;
use image::RgbImage;
use std::path::PathBuf;
use std::str::FromStr;

/// A `--source` as written.
#[derive(Clone, Debug, PartialEq)]
pub enum SourceSpec {
    /// Rendered from `--world` at the pose the autopilot reports (a camera for SITL).
    Render,
    /// Taken from a folder a camera writes into.
    Folder(PathBuf),
    /// A command line run by `sh -c` for every shot, `{out}` replaced by the file to write.
    Command(String),
    /// A Video4Linux2 capture device.
    V4l2(PathBuf),
}

/// A `--source` that is none of the known forms (the text given).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown picture source {0:?}: expected `render`, `folder:DIR`, `command:CMD` (CMD writes a picture to {{out}}) or `v4l2:DEVICE`"
)]
pub struct UnknownSource(pub String);

impl FromStr for SourceSpec {
    type Err = UnknownSource;

    fn from_str(s: &str) -> Result<SourceSpec, UnknownSource> {
        match s.split_once(':') {
            _ if s == "render" => Ok(SourceSpec::Render),
            Some(("folder", dir)) if !dir.is_empty() => Ok(SourceSpec::Folder(PathBuf::from(dir))),
            Some(("command", cmd)) if cmd.contains(command::OUT) => {
                Ok(SourceSpec::Command(cmd.to_string()))
            }
            Some(("v4l2", dev)) if !dev.is_empty() => Ok(SourceSpec::V4l2(PathBuf::from(dev))),
            _ => Err(UnknownSource(s.to_string())),
        }
    }
}

/// An open picture source (every form but `render`).
#[derive(Debug)]
pub enum PictureSource {
    /// A folder a camera writes into.
    Folder(FolderSource),
    /// A command run per shot.
    Command(command::CommandSource),
    /// A Video4Linux2 device.
    #[cfg(feature = "v4l2")]
    V4l2(v4l2::V4l2Source),
}

/// Why a shot got no picture.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The folder could not be read.
    #[error(transparent)]
    Folder(#[from] fleetmap_io::files::pictures::PictureFolderError),
    /// The command failed, timed out or wrote no picture.
    #[error(transparent)]
    Command(#[from] command::CommandError),
    /// The device could not give a frame.
    #[cfg(feature = "v4l2")]
    #[error(transparent)]
    V4l2(#[from] v4l2::V4l2Error),
}

impl PictureSource {
    /// The next shot's picture; `Ok(None)` when the source has none (a folder with no new
    /// picture within its wait). Blocking.
    pub fn next_picture(&mut self) -> Result<Option<RgbImage>, SourceError> {
        match self {
            PictureSource::Folder(f) => Ok(f.next_picture()?.map(|p| p.image)),
            PictureSource::Command(c) => Ok(Some(c.take()?)),
            #[cfg(feature = "v4l2")]
            PictureSource::V4l2(d) => Ok(Some(d.grab()?)),
        }
    }

    /// What went wrong without failing the shot since the last call (pictures of a folder
    /// skipped as unreadable), to log.
    pub fn drain_warnings(&mut self) -> Vec<String> {
        match self {
            PictureSource::Folder(f) => f
                .skipped
                .drain(..)
                .map(|s| format!("picture skipped: {s}"))
                .collect(),
            _ => Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_parse() {
        assert_eq!("render".parse::<SourceSpec>(), Ok(SourceSpec::Render));
        assert_eq!(
            "folder:/media/cam".parse::<SourceSpec>(),
            Ok(SourceSpec::Folder("/media/cam".into()))
        );
        assert_eq!(
            "command:libcamera-still -n -o {out}".parse::<SourceSpec>(),
            Ok(SourceSpec::Command("libcamera-still -n -o {out}".into()))
        );
        assert_eq!(
            "v4l2:/dev/video0".parse::<SourceSpec>(),
            Ok(SourceSpec::V4l2("/dev/video0".into()))
        );
        assert!("folder:".parse::<SourceSpec>().is_err());
        assert!("v4l2:".parse::<SourceSpec>().is_err());
        // a command that names no output file cannot give the camera a picture
        let e = "command:libcamera-still -o x.jpg"
            .parse::<SourceSpec>()
            .unwrap_err();
        assert!(e.to_string().contains("{out}"), "{e}");
    }
}
