//! One way to write a result file: into a temporary file beside it, synced, then renamed over
//! the target, so a crash or a failed write never leaves a half-written result (the earlier
//! version, if any, stays readable). The temporary file is removed when the write fails.
//!
//! The temporary name keeps the extension (`summary.tmp.json`, `plot.tmp.png`): writers that
//! pick the format from the extension (the PNG encoder) see the right one.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary file that [`write_with`] and [`write_via_path`] write before the rename:
/// `<stem>.tmp.<ext>` (or `<name>.tmp`) in the same folder.
pub fn tmp_path(path: &Path) -> io::Result<PathBuf> {
    let stem = path.file_stem().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("not a file path: {}", path.display()),
        )
    })?;
    let mut name = stem.to_os_string();
    name.push(".tmp");
    if let Some(ext) = path.extension() {
        name.push(".");
        name.push(ext);
    }
    Ok(path.with_file_name(name))
}

/// Write `bytes` to `path` atomically.
pub fn write(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_with(path, |w| w.write_all(bytes))
}

/// Write `path` atomically through a buffered writer handed to `body`.
pub fn write_with(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = tmp_path(path)?;
    let result = (|| {
        let mut w = BufWriter::with_capacity(1 << 16, File::create(&tmp)?);
        body(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// For writers that take a path (the PNG encoder): `draw` writes the temporary path, which is
/// then synced and renamed to `path`. `io` turns an I/O failure into the caller's error.
pub fn write_via_path<E>(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), E>,
    io: impl Fn(io::Error) -> E,
) -> Result<(), E> {
    let tmp = tmp_path(path).map_err(&io)?;
    let result = draw(&tmp).and_then(|()| {
        fs::OpenOptions::new()
            .write(true)
            .open(&tmp)
            .and_then(|f| f.sync_all())
            .and_then(|()| fs::rename(&tmp, path))
            .map_err(&io)
    });
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tmp_name_keeps_the_extension() {
        assert_eq!(
            tmp_path(Path::new("a/summary.json")).unwrap(),
            Path::new("a/summary.tmp.json")
        );
        assert_eq!(
            tmp_path(Path::new("plot.png")).unwrap(),
            Path::new("plot.tmp.png")
        );
        assert_eq!(tmp_path(Path::new("x")).unwrap(), Path::new("x.tmp"));
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_tmp() {
        let dir = std::env::temp_dir().join(format!("hydrofrac-atomic-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let p = dir.join("r.csv");
        write(&p, b"old").unwrap();
        let e = write_with(&p, |w| {
            w.write_all(b"half")?;
            Err(io::Error::other("disk full"))
        });
        assert!(e.is_err());
        assert_eq!(fs::read(&p).unwrap(), b"old");
        assert!(!tmp_path(&p).unwrap().exists());
        fs::remove_dir_all(&dir).unwrap();
    }
}
