//! File-system helpers: atomic writes of files (temp file in the same directory + rename) and of
//! whole directories (temp sibling directory + swap, under a lock), and bounded reads.

use std::io::Write;
use std::path::Path;

pub use crate::error::IoError;

fn io_err(path: &Path, source: std::io::Error) -> IoError {
    IoError { path: path.to_path_buf(), source }
}

/// Write a file atomically: the content goes to a temporary file next to `path`, is flushed to
/// disk, then renamed over `path`. A crash leaves either the old file or the new one, never a mix.
/// Missing parent directories are created, as for a panorama directory.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(|e| io_err(path, e))?;
    let mut builder = tempfile::Builder::new();
    builder.prefix(".pomc-tmp-");
    // Temp files are private (0600) by default; the file we leave behind is an ordinary output,
    // so it gets the mode `open` would give it (0666 less the umask).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir).map_err(|e| io_err(path, e))?;
    {
        let mut buf = std::io::BufWriter::new(tmp.as_file_mut());
        write(&mut buf).map_err(|e| io_err(path, e))?;
        buf.flush().map_err(|e| io_err(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| io_err(path, e))?;
    tmp.persist(path).map_err(|e| io_err(path, e.error))?;
    Ok(())
}

/// Write bytes atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// Refuse anything but a regular file (after symbolic links) before opening it: opening a FIFO
/// blocks until a writer comes, and a device such as `/dev/zero` never ends.
pub fn check_regular(path: &Path) -> std::io::Result<std::fs::Metadata> {
    let meta = std::fs::metadata(path)?;
    if meta.is_file() {
        return Ok(meta);
    }
    let what = if meta.is_dir() { "a directory" } else { "not a regular file (a FIFO, socket or device)" };
    Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{what}; give a file")))
}

/// Read a whole file, refusing files larger than `limit` bytes before reading them.
pub fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>, IoError> {
    let meta = check_regular(path).map_err(|e| io_err(path, e))?;
    if meta.len() > limit {
        return Err(io_err(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("file is {} bytes, more than the {} byte limit", meta.len(), limit),
            ),
        ));
    }
    std::fs::read(path).map_err(|e| io_err(path, e))
}

/// An exclusive lock on writing directory `dir`, held until dropped: the hidden file
/// `.NAME.pomc-lock` beside it, locked with `flock` (released by the OS if the process dies).
/// The file itself is left in place: deleting it would let a waiting writer and a new one each
/// lock a different file.
pub struct DirLock {
    _file: std::fs::File,
}

/// The parent and file name of `dir` as absolute paths (`.` and `..` resolved when they exist).
fn split_dir(dir: &Path) -> Result<(std::path::PathBuf, std::ffi::OsString), IoError> {
    let abs = std::path::absolute(dir).map_err(|e| io_err(dir, e))?;
    let abs = abs.canonicalize().unwrap_or(abs);
    match (abs.parent(), abs.file_name()) {
        (Some(p), Some(n)) => Ok((p.to_path_buf(), n.to_os_string())),
        _ => Err(io_err(dir, std::io::Error::other("cannot write a panorama over the root directory"))),
    }
}

fn sibling(parent: &Path, name: &std::ffi::OsStr, tag: &str) -> std::path::PathBuf {
    let mut s = std::ffi::OsString::from(".");
    s.push(name);
    s.push(tag);
    parent.join(s)
}

/// Lock `dir` against other writers (waits for the current one) and remove what killed writers
/// left beside it (`.NAME.pomc-tmp-*` and `.NAME.pomc-old-*` directories).
pub fn lock_dir(dir: &Path) -> Result<DirLock, IoError> {
    let (parent, name) = split_dir(dir)?;
    std::fs::create_dir_all(&parent).map_err(|e| io_err(&parent, e))?;
    let lock_path = sibling(&parent, &name, ".pomc-lock");
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(|e| io_err(&lock_path, e))?;
    // `File::lock` needs Rust 1.89 (MSRV 1.80); elsewhere than Unix writers are not serialised.
    #[cfg(unix)]
    rustix::fs::flock(&file, rustix::fs::FlockOperation::LockExclusive)
        .map_err(|e| io_err(&lock_path, e.into()))?;
    // A writer killed between the two renames of the fallback swap left the old content in
    // `.NAME.pomc-old-*` and no `NAME`: put it back before anything is cleaned.
    let target = parent.join(&name);
    let old_prefix = sibling(Path::new(""), &name, ".pomc-old-").into_os_string();
    if !target.exists() {
        if let Ok(entries) = std::fs::read_dir(&parent) {
            for e in entries.flatten() {
                if e.file_name().as_encoded_bytes().starts_with(old_prefix.as_encoded_bytes()) {
                    let _ = std::fs::rename(e.path(), &target);
                    break;
                }
            }
        }
    }
    let stale: Vec<std::ffi::OsString> = [".pomc-tmp-", ".pomc-old-"]
        .iter()
        .map(|t| sibling(Path::new(""), &name, t).into_os_string())
        .collect();
    if let Ok(entries) = std::fs::read_dir(&parent) {
        for e in entries.flatten() {
            let n = e.file_name();
            let is_stale = stale.iter().any(|s| n.as_encoded_bytes().starts_with(s.as_encoded_bytes()));
            if is_stale && e.file_type().is_ok_and(|t| t.is_dir()) {
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
    }
    Ok(DirLock { _file: file })
}

/// A fresh, empty temporary sibling of `dir` to write its new content into (call with the lock
/// of [`lock_dir`] held); [`swap_in`] then puts it in place.
pub fn temp_sibling(dir: &Path) -> Result<tempfile::TempDir, IoError> {
    let (parent, name) = split_dir(dir)?;
    let prefix = sibling(Path::new(""), &name, ".pomc-tmp-");
    let tmp = tempfile::Builder::new().prefix(&prefix).tempdir_in(&parent).map_err(|e| io_err(dir, e))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Like a directory made by `mkdir` under the usual umask, not the private 0700 of temp dirs.
        std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o755))
            .map_err(|e| io_err(dir, e))?;
    }
    Ok(tmp)
}

/// Put the fully written directory `new` (from [`temp_sibling`]) in place of `dir`, which may
/// exist. On Linux the two are exchanged in one step (`renameat2(RENAME_EXCHANGE)`), so a crash
/// leaves the old directory or the new one; elsewhere the old one is first moved aside. The old
/// content is then deleted.
pub fn swap_in(new: tempfile::TempDir, dir: &Path) -> Result<(), IoError> {
    let (parent, name) = split_dir(dir)?;
    let target = parent.join(&name);
    let new = new.keep();
    sync_dir(&new);
    let result = if target.exists() {
        exchange(&new, &target)
    } else {
        std::fs::rename(&new, &target).map(|()| None).map_err(|e| io_err(dir, e))
    };
    match result {
        Ok(old) => {
            sync_dir(&parent);
            if let Some(old) = old {
                let _ = std::fs::remove_dir_all(old);
            }
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&new);
            Err(e)
        }
    }
}

/// Exchange `new` and `target`; returns where the old content now is.
fn exchange(new: &Path, target: &Path) -> Result<Option<std::path::PathBuf>, IoError> {
    #[cfg(target_os = "linux")]
    {
        use rustix::fs::{renameat_with, RenameFlags, CWD};
        match renameat_with(CWD, new, CWD, target, RenameFlags::EXCHANGE) {
            Ok(()) => return Ok(Some(new.to_path_buf())),
            // Filesystems without RENAME_EXCHANGE fall back to two renames.
            Err(e) if e == rustix::io::Errno::INVAL || e == rustix::io::Errno::NOSYS => {}
            Err(e) => return Err(io_err(target, e.into())),
        }
    }
    let (parent, name) = split_dir(target)?;
    let old = sibling(&parent, &name, &format!(".pomc-old-{}", std::process::id()));
    std::fs::rename(target, &old).map_err(|e| io_err(target, e))?;
    if let Err(e) = std::fs::rename(new, target) {
        let _ = std::fs::rename(&old, target);
        return Err(io_err(target, e));
    }
    Ok(Some(old))
}

/// Flush a directory's entries to disk (best effort: not every platform can open directories).
fn sync_dir(dir: &Path) {
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_bytes_atomic(&p, b"one").unwrap();
        write_bytes_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1, "temp files left behind: {names:?}");
    }

    #[test]
    fn missing_parent_directories_are_created() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a/b/c.png");
        write_bytes_atomic(&p, b"x").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"x");
        // A parent that is a file is an error naming the output, not a panic.
        let blocked = dir.path().join("a/b/c.png/d.png");
        let e = write_bytes_atomic(&blocked, b"x").unwrap_err();
        assert!(e.to_string().contains("d.png"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn written_files_are_not_private() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_bytes_atomic(&p, b"x").unwrap();
        let plain = dir.path().join("b.txt");
        std::fs::write(&plain, b"x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&p), mode(&plain), "same mode as a plainly created file");
    }

    #[test]
    fn failed_write_keeps_old_content() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_bytes_atomic(&p, b"old").unwrap();
        let r = write_atomic(&p, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
    }
}
