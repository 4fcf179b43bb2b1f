//! Who owns what in an output folder. A run lists every file (and folder) it creates in the
//! folder's manifest, `hydrofrac-manifest.txt`, before it writes it; the next run into the
//! folder removes exactly those (when they still exist, with the temporary `<stem>.tmp.<ext>`
//! a killed write may have left beside them) and nothing else. A non-empty folder without a
//! manifest holds someone else's files: it is refused unless `force`, and then nothing in it
//! is deleted either; only files with the names the run writes are overwritten (and listed as
//! the run's from then on).
//!
//! Steps: [`Plan::check`] inspects the folder (creating it when missing, which deletes
//! nothing), the caller checks its other paths (the trace file), then [`Plan::open`] removes the
//! listed files and starts a fresh manifest. Nothing is removed before every check passed.

use std::collections::{BTreeMap, HashSet};
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;
use std::time::SystemTime;

/// The manifest's file name in an output folder.
pub const MANIFEST: &str = "hydrofrac-manifest.txt";

/// First line of a manifest; the following lines are relative paths (`/`-separated, folders
/// end with `/`).
const HEADER: &str = "# hydrofrac output manifest v1: the files the last run wrote here, relative to this folder; the next run into this folder removes these and nothing else";

/// An output folder that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    #[error("cannot {what} {}: {source}", .path.display())]
    Io {
        what: &'static str,
        path: PathBuf,
        source: io::Error,
    },
    #[error(
        "output folder {} is not empty and has no {MANIFEST}, so its files were not written by \
         hydrofrac ({examples}); refused so that none of them is deleted or overwritten: choose \
         a new or empty folder with --out, or pass --force to write alongside them (nothing is \
         deleted; files with the names the run writes are overwritten)",
        .dir.display()
    )]
    Foreign { dir: PathBuf, examples: String },
    #[error("output folder {}: {why}", .dir.display())]
    NotUsable { dir: PathBuf, why: String },
}

impl FolderError {
    fn io(what: &'static str, path: &Path) -> impl FnOnce(io::Error) -> FolderError + use<> {
        let path = path.to_path_buf();
        move |source| FolderError::Io { what, path, source }
    }
}

/// A folder checked for a run: what the previous run listed and will be removed by [`open`].
///
/// [`open`]: Plan::open
#[derive(Debug)]
pub struct Plan {
    dir: PathBuf,
    /// Listed paths of the previous run (relative), to remove.
    previous: Vec<String>,
}

impl Plan {
    /// Check `dir` for a run: create it when missing, check it is a writable folder, read its
    /// manifest, and refuse a non-empty folder without one unless `force`. Deletes nothing.
    pub fn check(dir: &Path, force: bool) -> Result<Plan, FolderError> {
        if dir.as_os_str().is_empty() {
            return Err(FolderError::NotUsable {
                dir: dir.into(),
                why: "empty path".into(),
            });
        }
        fs::create_dir_all(dir).map_err(FolderError::io("create output folder", dir))?;
        if !dir.is_dir() {
            return Err(FolderError::NotUsable {
                dir: dir.into(),
                why: "not a folder".into(),
            });
        }
        let manifest = dir.join(MANIFEST);
        let previous = if manifest.is_file() {
            let text = fs::read_to_string(&manifest)
                .map_err(FolderError::io("read the manifest", &manifest))?;
            text.lines()
                .skip(1)
                .filter(|l| safe_relative(l))
                .map(str::to_string)
                .collect()
        } else {
            let mut names: Vec<String> = fs::read_dir(dir)
                .map_err(FolderError::io("list output folder", dir))?
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            if !names.is_empty() && !force {
                names.sort();
                let more = names.len().saturating_sub(3);
                names.truncate(3);
                let mut examples = names.join(", ");
                if more > 0 {
                    examples += &format!(" and {more} more");
                }
                return Err(FolderError::Foreign {
                    dir: dir.into(),
                    examples,
                });
            }
            Vec::new()
        };
        // Writable, checked after any refusal (a refused folder is not touched): a probe file
        // of our own name, created new (never over an existing file).
        let probe = dir.join(format!(".hydrofrac-write-test-{}", std::process::id()));
        OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&probe)
            .map_err(FolderError::io("write to output folder", dir))?;
        let _ = fs::remove_file(&probe);
        Ok(Plan {
            dir: dir.to_path_buf(),
            previous,
        })
    }

    /// Refuse a folder whose `rel` (a sub-folder the run writes into) exists but is not a real
    /// folder (a file, or a link that would lead the writes elsewhere): caught now rather than
    /// at the first frame.
    pub fn require_folder(&self, rel: &str) -> Result<(), FolderError> {
        let p = self.dir.join(rel);
        if fs::symlink_metadata(&p).is_ok_and(|m| !m.is_dir()) {
            return Err(FolderError::NotUsable {
                dir: self.dir.clone(),
                why: format!(
                    "{rel} exists and is not a folder (or is a link; the run writes its frames there)"
                ),
            });
        }
        Ok(())
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The relative path of `path` inside the folder, when it is inside (both must exist or
    /// have an existing parent; compared after resolving links).
    pub fn inside(&self, path: &Path) -> Option<String> {
        let dir = fs::canonicalize(&self.dir).ok()?;
        let name = path.file_name()?;
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let parent = fs::canonicalize(parent).ok()?;
        let rel = parent.strip_prefix(&dir).ok()?.join(name);
        let rel: Vec<String> = rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        Some(rel.join("/"))
    }

    /// Keep `rel` although the previous run listed it (the caller writes it again and lists it).
    pub fn keep(&mut self, rel: &str) {
        self.previous.retain(|p| p != rel);
    }

    /// Remove what the previous run listed (files that still exist, their temporary siblings,
    /// then its folders when empty) and start this run's manifest.
    pub fn open(self) -> Result<Folder, FolderError> {
        let (mut files, mut dirs): (Vec<&String>, Vec<&String>) =
            self.previous.iter().partition(|p| !p.ends_with('/'));
        files.sort();
        for rel in files {
            let path = self.dir.join(rel);
            if !real_folders_between(&self.dir, rel) {
                continue;
            }
            for p in [Some(path.clone()), crate::atomic::tmp_path(&path).ok()]
                .into_iter()
                .flatten()
            {
                // Only regular files: this engine writes no links or special files.
                if fs::symlink_metadata(&p).is_ok_and(|m| m.is_file()) {
                    fs::remove_file(&p).map_err(FolderError::io("remove a previous result", &p))?;
                }
            }
        }
        // Deepest first, and only when empty: a folder that holds anything else stays.
        dirs.sort_by_key(|d| std::cmp::Reverse(d.matches('/').count()));
        for rel in dirs {
            let rel = rel.trim_end_matches('/');
            let path = self.dir.join(rel);
            if real_folders_between(&self.dir, rel)
                && fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir())
            {
                let _ = fs::remove_dir(path);
            }
        }
        let path = self.dir.join(MANIFEST);
        let mut w = BufWriter::new(
            File::create(&path).map_err(FolderError::io("write the manifest", &path))?,
        );
        writeln!(w, "{HEADER}")
            .and_then(|()| w.flush())
            .map_err(FolderError::io("write the manifest", &path))?;
        Ok(Folder {
            dir: self.dir,
            manifest: Mutex::new(Manifest {
                writer: w,
                listed: HashSet::new(),
            }),
        })
    }
}

/// Whether every folder between `dir` and `rel` is a real folder, not a link: a listed
/// `frames/x.vtu` is never removed through a `frames` that was replaced by a link elsewhere.
fn real_folders_between(dir: &Path, rel: &str) -> bool {
    let mut p = dir.to_path_buf();
    let parts: Vec<&str> = rel.split('/').collect();
    parts[..parts.len() - 1].iter().all(|part| {
        p.push(part);
        fs::symlink_metadata(&p).is_ok_and(|m| m.is_dir())
    })
}

/// A relative path with only normal components (no `..`, root or prefix) and `/` separators:
/// what a manifest may list. Anything else in a manifest is ignored, never removed.
fn safe_relative(line: &str) -> bool {
    let p = line.trim_end_matches('/');
    !p.is_empty()
        && p != MANIFEST
        && !p.contains('\\')
        && Path::new(p)
            .components()
            .all(|c| matches!(c, Component::Normal(_)))
}

struct Manifest {
    writer: BufWriter<File>,
    listed: HashSet<String>,
}

/// An output folder in use: every path a run writes is claimed here first, which lists it in
/// the manifest (flushed at once, so a killed run's files are listed too).
pub struct Folder {
    pub dir: PathBuf,
    manifest: Mutex<Manifest>,
}

impl std::fmt::Debug for Folder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Folder").field("dir", &self.dir).finish()
    }
}

/// Size and modification time of the files in a folder (see [`Folder::snapshot`]).
pub type Snapshot = BTreeMap<String, (u64, Option<SystemTime>)>;

impl Folder {
    /// Check and open `dir` in one go (no other paths to check).
    pub fn prepare(dir: &Path, force: bool) -> Result<Folder, FolderError> {
        Plan::check(dir, force)?.open()
    }

    /// List `rel` (`/`-separated, inside the folder) as this run's and return its full path.
    /// Its parent folders are created, and listed when this run created them.
    pub fn claim(&self, rel: &str) -> io::Result<PathBuf> {
        debug_assert!(safe_relative(rel), "{rel}");
        let mut m = self.manifest.lock().expect("manifest lock");
        let mut parent = String::new();
        let parts: Vec<&str> = rel.split('/').collect();
        for part in &parts[..parts.len() - 1] {
            parent += part;
            parent.push('/');
            let dir = self.dir.join(&parent);
            if !dir.is_dir() {
                fs::create_dir(&dir)?;
                m.list(&parent)?;
            }
        }
        m.list(rel)?;
        Ok(self.dir.join(rel))
    }

    /// Remove the temporary `<stem>.tmp.<ext>` beside every file this run listed, when one is
    /// there (a write that was cut short; a finished write renamed its temporary away). Only
    /// regular files, never through a link; returns how many were removed.
    pub fn remove_temporaries(&self) -> usize {
        let m = self.manifest.lock().expect("manifest lock");
        let mut removed = 0;
        for rel in m.listed.iter().filter(|r| !r.ends_with('/')) {
            if !real_folders_between(&self.dir, rel) {
                continue;
            }
            let Ok(tmp) = crate::atomic::tmp_path(&self.dir.join(rel)) else {
                continue;
            };
            if fs::symlink_metadata(&tmp).is_ok_and(|m| m.is_file())
                && fs::remove_file(&tmp).is_ok()
            {
                removed += 1;
            }
        }
        removed
    }

    /// The regular files directly in the folder and one level below, with size and
    /// modification time: compare with [`Folder::adopt_changed`] to list what a writer that does
    /// not claim its files (the verification cases) wrote.
    pub fn snapshot(&self) -> Snapshot {
        let mut s = Snapshot::new();
        let mut walk = |sub: &str| {
            let Ok(rd) = fs::read_dir(self.dir.join(sub)) else {
                return Vec::new();
            };
            let mut dirs = Vec::new();
            for e in rd.filter_map(|e| e.ok()) {
                let name = e.file_name().to_string_lossy().into_owned();
                let rel = format!("{sub}{name}");
                match e.metadata() {
                    Ok(m) if m.is_file() => {
                        s.insert(rel, (m.len(), m.modified().ok()));
                    }
                    Ok(m) if m.is_dir() => dirs.push(format!("{rel}/")),
                    _ => {}
                }
            }
            dirs
        };
        for d in walk("") {
            walk(&d);
        }
        s.remove(MANIFEST);
        s
    }

    /// List every file that is new or changed since `before` (a [`Folder::snapshot`]).
    pub fn adopt_changed(&self, before: &Snapshot) -> io::Result<()> {
        for (rel, meta) in self.snapshot() {
            if before.get(&rel) != Some(&meta) && safe_relative(&rel) {
                self.claim(&rel)?;
            }
        }
        Ok(())
    }
}

impl Manifest {
    fn list(&mut self, rel: &str) -> io::Result<()> {
        if self.listed.insert(rel.to_string()) {
            writeln!(self.writer, "{rel}")?;
            self.writer.flush()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_lines_outside_the_folder_are_ignored() {
        for bad in [
            "../x",
            "/etc/passwd",
            "a/../../b",
            "",
            "/",
            MANIFEST,
            "a\\..\\b",
        ] {
            assert!(!safe_relative(bad), "{bad}");
        }
        for good in ["summary.json", "frames/", "frames/solid_00000.vtu"] {
            assert!(safe_relative(good), "{good}");
        }
    }

    /// A listed file behind a folder that was replaced by a link is not removed (the link
    /// points outside the output folder), and `frames` as a link is refused up front.
    #[cfg(unix)]
    #[test]
    fn nothing_is_removed_through_a_link() {
        let base = std::env::temp_dir().join(format!("hydrofrac-link-{}", std::process::id()));
        let _ = fs::remove_dir_all(&base);
        let (out, elsewhere) = (base.join("out"), base.join("elsewhere"));
        fs::create_dir_all(&out).unwrap();
        fs::create_dir_all(&elsewhere).unwrap();
        fs::write(elsewhere.join("a.vtu"), "mine").unwrap();
        std::os::unix::fs::symlink(&elsewhere, out.join("frames")).unwrap();
        fs::write(
            out.join(MANIFEST),
            format!("{HEADER}\nframes/\nframes/a.vtu\n"),
        )
        .unwrap();
        let plan = Plan::check(&out, false).unwrap();
        assert!(plan.require_folder("frames").is_err());
        plan.open().unwrap();
        assert_eq!(fs::read_to_string(elsewhere.join("a.vtu")).unwrap(), "mine");
        fs::remove_dir_all(&base).unwrap();
    }
}
