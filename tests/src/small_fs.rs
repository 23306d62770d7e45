//! A small tmpfs for tests of a full disk: mounted on a folder of its own (root only),
//! filled on demand, unmounted when dropped.

use std::path::Path;

/// A small tmpfs mounted on a folder of its own, unmounted when dropped.
pub struct SmallFs {
    dir: tempfile::TempDir,
}

impl SmallFs {
    /// Mounts a tmpfs of `size` (as mount(8) says it: "10m") or says why it cannot.
    pub fn mount(size: &str) -> Result<SmallFs, String> {
        use std::ffi::CString;
        use std::os::unix::ffi::OsStrExt;
        let dir = tempfile::tempdir().unwrap();
        let target = CString::new(dir.path().as_os_str().as_bytes()).unwrap();
        let tmpfs = CString::new("tmpfs").unwrap();
        let data = CString::new(format!("size={size},mode=0755")).unwrap();
        // SAFETY: every pointer is a NUL-terminated string that outlives the call.
        let rc = unsafe {
            libc::mount(
                tmpfs.as_ptr(),
                target.as_ptr(),
                tmpfs.as_ptr(),
                0,
                data.as_ptr().cast(),
            )
        };
        if rc != 0 {
            return Err(std::io::Error::last_os_error().to_string());
        }
        Ok(SmallFs { dir })
    }

    /// [`SmallFs::mount`] where this process is root; elsewhere `None`, having said that the
    /// test is skipped (only root mounts). As root, a failure is the test's.
    pub fn mount_as_root(size: &str) -> Option<SmallFs> {
        match SmallFs::mount(size) {
            Ok(fs) => Some(fs),
            // SAFETY: geteuid(2) has no preconditions.
            Err(why) if unsafe { libc::geteuid() } != 0 => {
                eprintln!("skipped: not root, so no small tmpfs can be mounted here ({why})");
                None
            }
            Err(why) => panic!("as root, mounting a tmpfs of {size} failed: {why}"),
        }
    }

    /// Writes a file that takes every byte left, so that any other write fails (ENOSPC).
    pub fn fill(&self) {
        use std::io::Write;
        let mut f = std::fs::File::create(self.path().join("filler")).unwrap();
        let block = vec![0u8; 64 << 10];
        while f.write_all(&block).is_ok() {}
        let _ = f.write_all(&[0u8; 1]);
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

impl Drop for SmallFs {
    fn drop(&mut self) {
        let target = std::ffi::CString::new(self.dir.path().to_string_lossy().as_bytes()).unwrap();
        // SAFETY: a NUL-terminated path; a lazy unmount has no other precondition.
        unsafe {
            libc::umount2(target.as_ptr(), libc::MNT_DETACH);
        }
    }
}
