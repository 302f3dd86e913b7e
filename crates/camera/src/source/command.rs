//! `command:CMD`: a program run for every shot that writes the picture to a file, e.g.
//! `command:libcamera-still -n --immediate -o {out}` (a Raspberry Pi camera module),
//! `command:gphoto2 --capture-image-and-download --filename {out}` (a tethered camera) or
//! `command:fswebcam --no-banner {out}` (a USB webcam).
//!
//! The command line is run by `sh -c` with every `{out}` replaced by the (quoted) path of a
//! fresh file in the camera's work folder; the shot's picture is what the program wrote there
//! (JPEG or PNG, decoded with the ground station's limits,
//! [`fleetmap_core::vision::load`]), and the file is removed once read. The shot fails with a
//! [`CommandError`] that says why — the program could not be started, it ran longer than the
//! timeout (it is killed, with every process it started: it runs in its own process group),
//! it exited with an error (the end of what it wrote on stderr is quoted), or it wrote
//! nothing or something that is not a picture — and the camera announces a failed capture,
//! as a camera that did not fire would.

use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use image::RgbImage;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The placeholder the command line names its output file with.
pub const OUT: &str = "{out}";

/// How often a running command is checked for its exit.
const POLL: Duration = Duration::from_millis(5);

/// How much of the command's stderr an error quotes, bytes (its end).
const STDERR_TAIL: usize = 400;

/// A command run per shot. See the module documentation.
#[derive(Debug)]
pub struct CommandSource {
    command: String,
    dir: PathBuf,
    /// Longest a shot's command may run (wall time) before it is killed.
    pub timeout: Duration,
    shots: u64,
    limits: LoadLimits,
}

/// Why a command gave no picture.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// The work folder could not be made, or the shell could not be started.
    #[error("picture command {command:?}: {what}: {source}")]
    Io {
        /// The command line.
        command: String,
        /// What failed.
        what: &'static str,
        /// The OS error.
        source: std::io::Error,
    },
    /// The command ran longer than the timeout and was killed.
    #[error("picture command {command:?} took longer than {:.1} s: killed", timeout.as_secs_f64())]
    Timeout {
        /// The command line.
        command: String,
        /// The timeout.
        timeout: Duration,
    },
    /// The command exited with an error.
    #[error("picture command {command:?} failed ({status}){}", stderr_note(stderr))]
    Failed {
        /// The command line.
        command: String,
        /// Its exit status.
        status: std::process::ExitStatus,
        /// The end of its stderr.
        stderr: String,
    },
    /// The command succeeded but wrote no picture to `{out}`.
    #[error("picture command {command:?} wrote nothing to {}{}", out.display(), stderr_note(stderr))]
    NoPicture {
        /// The command line.
        command: String,
        /// The file it was to write.
        out: PathBuf,
        /// The end of its stderr.
        stderr: String,
    },
    /// What the command wrote is not a picture the camera can decode.
    #[error("picture command {command:?} wrote {}, which is not a usable picture: {why}", out.display())]
    NotAPicture {
        /// The command line.
        command: String,
        /// The file.
        out: PathBuf,
        /// The decoder's reason.
        why: String,
    },
}

fn stderr_note(stderr: &str) -> String {
    if stderr.trim().is_empty() {
        String::new()
    } else {
        format!(": {}", stderr.trim())
    }
}

/// `path` quoted for `sh` (single quotes; a single quote inside becomes `'\''`).
fn sh_quote(path: &Path) -> String {
    format!("'{}'", path.display().to_string().replace('\'', r"'\''"))
}

impl CommandSource {
    /// Run `command` (which names `{out}`) for every shot, writing into a fresh work folder
    /// under `work` (created; e.g. the system's temporary folder), killed after `timeout`.
    pub fn new(
        command: &str,
        work: &Path,
        timeout: Duration,
    ) -> Result<CommandSource, CommandError> {
        let dir = work.join(format!("fleetmap-camera-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|source| CommandError::Io {
            command: command.to_string(),
            what: "cannot create its work folder",
            source,
        })?;
        Ok(CommandSource {
            command: command.to_string(),
            dir,
            timeout,
            shots: 0,
            limits: LoadLimits::default(),
        })
    }

    /// Run the command once and read the picture it wrote. Blocking, at most about
    /// [`CommandSource::timeout`].
    pub fn take(&mut self) -> Result<RgbImage, CommandError> {
        self.shots += 1;
        let out = self.dir.join(format!("shot-{:06}.jpg", self.shots));
        let err_path = self.dir.join("stderr.txt");
        let _ = std::fs::remove_file(&out);
        let io = |what: &'static str| {
            let command = self.command.clone();
            move |source| CommandError::Io {
                command,
                what,
                source,
            }
        };
        let stderr =
            std::fs::File::create(&err_path).map_err(io("cannot create its stderr file"))?;
        let line = self.command.replace(OUT, &sh_quote(&out));
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(&line)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            .current_dir(&self.dir)
            // its own process group, so that a timeout kills whatever it started too
            .process_group(0)
            .spawn()
            .map_err(io("cannot start sh"))?;
        let deadline = Instant::now() + self.timeout;
        let status = loop {
            match child.try_wait().map_err(io("cannot wait for it"))? {
                Some(s) => break s,
                None if Instant::now() >= deadline => {
                    // the group's id is the shell's pid (process_group(0))
                    let _ = Command::new("kill")
                        .args(["-KILL", "--", &format!("-{}", child.id())])
                        .stderr(Stdio::null())
                        .status();
                    let _ = child.kill();
                    let _ = child.wait();
                    let _ = std::fs::remove_file(&out);
                    return Err(CommandError::Timeout {
                        command: self.command.clone(),
                        timeout: self.timeout,
                    });
                }
                None => std::thread::sleep(POLL),
            }
        };
        let stderr = stderr_tail(&err_path);
        if !status.success() {
            let _ = std::fs::remove_file(&out);
            return Err(CommandError::Failed {
                command: self.command.clone(),
                status,
                stderr,
            });
        }
        let bytes = match std::fs::read(&out) {
            Ok(b) if !b.is_empty() => b,
            _ => {
                let _ = std::fs::remove_file(&out);
                return Err(CommandError::NoPicture {
                    command: self.command.clone(),
                    out,
                    stderr,
                });
            }
        };
        let _ = std::fs::remove_file(&out);
        load_image_bytes(&bytes, &self.limits).map_err(|e| CommandError::NotAPicture {
            command: self.command.clone(),
            out,
            why: e.to_string(),
        })
    }
}

impl Drop for CommandSource {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The last [`STDERR_TAIL`] bytes of the file at `path` (lossy UTF-8; empty if unreadable).
fn stderr_tail(path: &Path) -> String {
    let bytes = std::fs::read(path).unwrap_or_default();
    let tail = &bytes[bytes.len().saturating_sub(STDERR_TAIL)..];
    String::from_utf8_lossy(tail).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn source(cmd: &str, timeout_ms: u64) -> (tempfile::TempDir, CommandSource) {
        let work = tempfile::tempdir().unwrap();
        let s = CommandSource::new(cmd, work.path(), Duration::from_millis(timeout_ms)).unwrap();
        (work, s)
    }

    #[test]
    fn a_command_that_writes_a_picture_gives_it() {
        let dir = tempfile::tempdir().unwrap();
        let pic = dir.path().join("it's a picture.png");
        RgbImage::from_pixel(8, 6, image::Rgb([10, 200, 30]))
            .save(&pic)
            .unwrap();
        let (_w, mut s) = source(&format!("cp {} {OUT}", sh_quote(&pic)), 5000);
        for _ in 0..2 {
            let img = s.take().unwrap();
            assert_eq!(img.dimensions(), (8, 6));
            assert_eq!(img.get_pixel(3, 3).0, [10, 200, 30]);
        }
        // the files are removed once read
        assert_eq!(
            std::fs::read_dir(&s.dir).unwrap().count(),
            1,
            "only stderr.txt"
        );
    }

    #[test]
    fn failures_say_why() {
        let (_w, mut s) = source("echo no camera detected >&2; exit 3", 5000);
        let e = s.take().unwrap_err().to_string();
        assert!(
            e.contains("exit status: 3") && e.contains("no camera detected"),
            "{e}"
        );
        let (_w, mut s) = source(&format!("true {OUT}"), 5000);
        assert!(matches!(s.take(), Err(CommandError::NoPicture { .. })));
        let (_w, mut s) = source(&format!("echo hello > {OUT}"), 5000);
        assert!(matches!(s.take(), Err(CommandError::NotAPicture { .. })));
        // a command that hangs is killed with what it started, at its timeout
        let t0 = Instant::now();
        let (_w, mut s) = source(&format!("sleep 30; touch {OUT}"), 300);
        assert!(matches!(s.take(), Err(CommandError::Timeout { .. })));
        assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
    }
}
