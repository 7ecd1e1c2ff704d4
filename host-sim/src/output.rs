//! Writing outputs safely: an interrupted run (Ctrl-C, a kill, a crash) never leaves a
//! half-written file, and leaves no temporary behind.
//!
//! On Linux the content goes into an unnamed file in the target's folder (`O_TMPFILE`), which
//! is given a name only once complete and flushed: `linkat` straight to the target when it does
//! not exist yet (atomic), else to a temporary name renamed over the target, so the target is
//! always either the old or the new complete file. Killed before the link, the unnamed file
//! simply vanishes; only the few microseconds between that link and the rename can leave a
//! named temporary, which the next run removes ([`remove_stale_temporaries`]). Where the
//! file system has no `O_TMPFILE`, a named temporary beside the target is written and renamed.

use std::io::Write;
use std::path::{Path, PathBuf};

fn tmp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map_or("out".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

fn folder_of(path: &Path) -> std::io::Result<&Path> {
    match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(dir) => {
            std::fs::create_dir_all(dir)?;
            Ok(dir)
        }
        None => Ok(Path::new(".")),
    }
}

/// Writes through `f` into `path` atomically.
pub fn write_atomic(path: &Path, f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> std::io::Result<()> {
    let dir = folder_of(path)?;
    #[cfg(target_os = "linux")]
    {
        use rustix::fs::{AtFlags, Mode, OFlags, CWD};
        match rustix::fs::open(dir, OFlags::TMPFILE | OFlags::WRONLY | OFlags::CLOEXEC, Mode::from_raw_mode(0o644)) {
            Ok(fd) => {
                let mut w = std::io::BufWriter::new(std::fs::File::from(fd));
                f(&mut w)?;
                w.flush()?;
                let file = w.into_inner().map_err(|e| e.into_error())?;
                file.sync_all()?;
                use std::os::fd::AsRawFd;
                let proc = format!("/proc/self/fd/{}", file.as_raw_fd());
                return match rustix::fs::linkat(CWD, &proc, CWD, path, AtFlags::SYMLINK_FOLLOW) {
                    Ok(()) => Ok(()),
                    Err(rustix::io::Errno::EXIST) => {
                        let tmp = tmp_path(path);
                        let _ = std::fs::remove_file(&tmp);
                        rustix::fs::linkat(CWD, &proc, CWD, &tmp, AtFlags::SYMLINK_FOLLOW)?;
                        std::fs::rename(&tmp, path).inspect_err(|_| {
                            let _ = std::fs::remove_file(&tmp);
                        })
                    }
                    Err(e) => Err(e.into()),
                };
            }
            // No O_TMPFILE on this file system: the named temporary below.
            Err(rustix::io::Errno::OPNOTSUPP | rustix::io::Errno::ISDIR | rustix::io::Errno::INVAL) => {}
            Err(e) => return Err(e.into()),
        }
    }
    let tmp = tmp_path(path);
    let res = (|| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        f(&mut w)?;
        w.flush()?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if res.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    res
}

/// Is this name one of our temporaries?
pub fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.ends_with(".tmp")
}

/// Removes temporary files an interrupted earlier run left in `dir` (not recursive).
pub fn remove_stale_temporaries(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else { return };
    for e in rd.flatten() {
        if is_temporary(&e.file_name().to_string_lossy()) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_replace_and_leave_nothing_else() {
        let dir = std::env::temp_dir().join(format!("gnss-guard-output-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let p = dir.join("a.txt");
        write_atomic(&p, |w| w.write_all(b"one")).unwrap();
        write_atomic(&p, |w| w.write_all(b"two")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        // A writer that fails leaves the old content and no temporary.
        assert!(write_atomic(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("interrupted"))
        })
        .is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("a.txt")]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
