//! SRTM tiles from a folder: `DIR/N47E008.hgt`, or `DIR/N47E008.hgt.zip` as the SRTM
//! mirrors publish them (a zip archive whose one entry is the `.hgt`, stored or deflated).
//! The bytes are parsed by [`fleetmap_core::terrain::hgt::Tile::from_hgt`].
//!
//! The zip container is read here (its central directory, then the entry's local header,
//! PKWARE APPNOTE sections 4.3.7, 4.3.12 and 4.3.16) and inflated with `flate2`; a full zip
//! crate would bring encryption and other codecs a tile never uses. Multi-disk archives,
//! zip64 and encrypted entries are refused with a clear error.

use fleetmap_core::terrain::hgt::{HgtError, SRTM1_SIDE, Tile, TileId};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Why a tile could not be read.
#[derive(Debug, thiserror::Error)]
pub enum TileFileError {
    /// The file exists and could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The zip archive is not one this reader takes.
    #[error("{}: {message}", path.display())]
    Zip {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The bytes are not a tile.
    #[error("{}: {source}", path.display())]
    Hgt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: HgtError,
    },
}

/// The largest tile, bytes (SRTM1): nothing bigger is inflated.
const MAX_TILE: usize = SRTM1_SIDE * SRTM1_SIDE * 2;

/// Tile `id` from folder `dir`: `Ok(None)` when the folder has neither `NAME.hgt` nor
/// `NAME.hgt.zip` (nor their lower-case names).
pub fn read_tile(dir: &Path, id: TileId) -> Result<Option<Tile>, TileFileError> {
    let name = id.to_string();
    for base in [name.clone(), name.to_ascii_lowercase()] {
        let plain = dir.join(format!("{base}.hgt"));
        if let Some(bytes) = read_if_exists(&plain)? {
            return parse(&plain, id, &bytes).map(Some);
        }
        let zipped = dir.join(format!("{base}.hgt.zip"));
        if let Some(bytes) = read_if_exists(&zipped)? {
            let hgt = unzip_one(&bytes).map_err(|message| TileFileError::Zip {
                path: zipped.clone(),
                message,
            })?;
            return parse(&zipped, id, &hgt).map(Some);
        }
    }
    Ok(None)
}

fn read_if_exists(path: &Path) -> Result<Option<Vec<u8>>, TileFileError> {
    match std::fs::read(path) {
        Ok(b) => Ok(Some(b)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(TileFileError::Io {
            path: path.to_path_buf(),
            source,
        }),
    }
}

fn parse(path: &Path, id: TileId, bytes: &[u8]) -> Result<Tile, TileFileError> {
    Tile::from_hgt(id, bytes).map_err(|source| TileFileError::Hgt {
        path: path.to_path_buf(),
        source,
    })
}

fn u16_at(b: &[u8], at: usize) -> Result<u16, String> {
    b.get(at..at + 2)
        .map(|s| u16::from_le_bytes([s[0], s[1]]))
        .ok_or_else(|| "truncated zip archive".to_string())
}

fn u32_at(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 4)
        .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
        .ok_or_else(|| "truncated zip archive".to_string())
}

/// The content of the first `.hgt` entry of zip archive `b` (the first entry if none is
/// named so).
pub fn unzip_one(b: &[u8]) -> Result<Vec<u8>, String> {
    // end of central directory: 22 bytes plus a comment of up to 65535
    let from = b.len().saturating_sub(22 + 65_535);
    let eocd = (from..b.len().saturating_sub(21))
        .rev()
        .find(|&i| b[i..i + 4] == [0x50, 0x4b, 0x05, 0x06])
        .ok_or("not a zip archive (no end of central directory)")?;
    let entries = u16_at(b, eocd + 10)?;
    let mut at = u32_at(b, eocd + 16)? as usize;
    if entries == 0xFFFF || at == 0xFFFF_FFFF {
        return Err("zip64 archives are not read; unzip the tile".into());
    }
    let mut chosen = None;
    for _ in 0..entries {
        if u32_at(b, at)? != 0x0201_4b50 {
            return Err("damaged central directory".into());
        }
        let flags = u16_at(b, at + 8)?;
        let method = u16_at(b, at + 10)?;
        let crc = u32_at(b, at + 16)?;
        let csize = u32_at(b, at + 20)? as usize;
        let usize_ = u32_at(b, at + 24)? as usize;
        let (n, x, c) = (
            u16_at(b, at + 28)? as usize,
            u16_at(b, at + 30)? as usize,
            u16_at(b, at + 32)? as usize,
        );
        let local = u32_at(b, at + 42)? as usize;
        let name = b.get(at + 46..at + 46 + n).ok_or("truncated zip archive")?;
        let entry = (flags, method, crc, csize, usize_, local);
        if name.to_ascii_lowercase().ends_with(b".hgt") {
            chosen = Some(entry);
            break;
        }
        chosen.get_or_insert(entry);
        at += 46 + n + x + c;
    }
    let (flags, method, crc, csize, size, local) = chosen.ok_or("empty zip archive")?;
    if flags & 1 != 0 {
        return Err("encrypted zip entry".into());
    }
    if size > MAX_TILE {
        return Err(format!(
            "entry of {size} bytes is larger than any SRTM tile"
        ));
    }
    if u32_at(b, local)? != 0x0403_4b50 {
        return Err("damaged local header".into());
    }
    let start = local + 30 + u16_at(b, local + 26)? as usize + u16_at(b, local + 28)? as usize;
    let data = b.get(start..start + csize).ok_or("truncated zip archive")?;
    let out = match method {
        0 => data.to_vec(),
        8 => {
            let mut out = Vec::with_capacity(size);
            flate2::read::DeflateDecoder::new(data)
                .take(MAX_TILE as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| format!("cannot inflate the tile: {e}"))?;
            out
        }
        m => {
            return Err(format!(
                "compression method {m} is not read (stored or deflate)"
            ));
        }
    };
    if out.len() != size {
        return Err(format!("entry inflates to {} bytes, not {size}", out.len()));
    }
    let mut h = flate2::Crc::new();
    h.update(&out);
    if h.sum() != crc {
        return Err("entry fails its CRC-32".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fleetmap_core::terrain::hgt::SRTM3_SIDE;
    use std::io::Write;

    /// A one-entry zip archive as `zip -9` writes it (deflated, with a central directory).
    fn zip_of(name: &str, content: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(content).unwrap();
        let data = enc.finish().unwrap();
        let mut crc = flate2::Crc::new();
        crc.update(content);
        let mut z = Vec::new();
        let header = |z: &mut Vec<u8>, sig: u32| {
            z.extend(sig.to_le_bytes());
            if sig == 0x0201_4b50 {
                z.extend(20u16.to_le_bytes()); // made by
            }
            z.extend(20u16.to_le_bytes()); // needed
            z.extend(0u16.to_le_bytes()); // flags
            z.extend(8u16.to_le_bytes()); // deflate
            z.extend([0u8; 4]); // time, date
            z.extend(crc.sum().to_le_bytes());
            z.extend((data.len() as u32).to_le_bytes());
            z.extend((content.len() as u32).to_le_bytes());
            z.extend((name.len() as u16).to_le_bytes());
            z.extend(0u16.to_le_bytes()); // extra
        };
        header(&mut z, 0x0403_4b50);
        z.extend(name.as_bytes());
        z.extend(&data);
        let cd = z.len();
        header(&mut z, 0x0201_4b50);
        z.extend([0u8; 2 + 2 + 2 + 4]); // comment, disk, internal, external attrs
        z.extend(0u32.to_le_bytes()); // local header at 0
        z.extend(name.as_bytes());
        let cd_len = z.len() - cd;
        z.extend(0x0605_4b50u32.to_le_bytes());
        z.extend([0u8; 4]);
        z.extend(1u16.to_le_bytes());
        z.extend(1u16.to_le_bytes());
        z.extend((cd_len as u32).to_le_bytes());
        z.extend((cd as u32).to_le_bytes());
        z.extend(0u16.to_le_bytes());
        z
    }

    #[test]
    fn tiles_read_plain_zipped_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let id = TileId { lat: -36, lon: 149 };
        let samples: Vec<i16> = (0..SRTM3_SIDE * SRTM3_SIDE)
            .map(|i| (i % 700) as i16)
            .collect();
        let tile = Tile::from_samples(id, SRTM3_SIDE, samples).unwrap();
        assert!(read_tile(dir.path(), id).unwrap().is_none());
        std::fs::write(
            dir.path().join("S36E149.hgt.zip"),
            zip_of("S36E149.hgt", &tile.to_hgt()),
        )
        .unwrap();
        assert_eq!(read_tile(dir.path(), id).unwrap().unwrap(), tile);
        std::fs::write(dir.path().join("s36e149.hgt"), tile.to_hgt()).unwrap();
        assert_eq!(read_tile(dir.path(), id).unwrap().unwrap(), tile);
        // damage is an error naming the file
        let other = TileId { lat: 47, lon: 8 };
        std::fs::write(dir.path().join("N47E008.hgt"), [0u8; 10]).unwrap();
        let e = read_tile(dir.path(), other).unwrap_err().to_string();
        assert!(e.contains("N47E008.hgt") && e.contains("10 bytes"), "{e}");
        let mut bad = zip_of("N47E009.hgt", &tile.to_hgt());
        let n = bad.len();
        bad[n / 2] ^= 0xFF;
        std::fs::write(dir.path().join("N47E009.hgt.zip"), bad).unwrap();
        let e = read_tile(dir.path(), TileId { lat: 47, lon: 9 })
            .unwrap_err()
            .to_string();
        assert!(e.contains("N47E009.hgt.zip"), "{e}");
        assert!(unzip_one(b"not a zip").is_err());
    }
}
