//! Bounded reading of the files a user names: only regular files are opened (a FIFO would
//! block forever, `/dev/zero` never ends, a folder is not a file), and never more than a cap
//! is read, so a wrong path fails at once with an error that names the file, what it was
//! expected to be and the cap — never a hang or gigabytes read before a parse fails.

use std::fs::File;
use std::io::Read;
use std::os::unix::fs::OpenOptionsExt as _;
use std::path::{Component, Path, PathBuf};

use crate::error::{Error, Result};

/// The largest text input (scene, experiment, pbrt file, `.vp`, `.vp.json`, PGM, NRRD or
/// MetaImage header) read: 16 MiB. The thesis's largest text input, its 256×256 ASCII PGM,
/// is about 250 KiB; every scene and experiment file here is under 10 KiB.
pub const TEXT_INPUT_CAP: u64 = 16 << 20;

/// A file's kind for messages: "a folder", "a FIFO", "a character device", ….
pub(crate) fn file_kind(file_type: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if file_type.is_dir() {
        "a folder"
    } else if file_type.is_fifo() {
        "a FIFO (named pipe)"
    } else if file_type.is_char_device() {
        "a character device"
    } else if file_type.is_block_device() {
        "a block device"
    } else if file_type.is_socket() {
        "a socket"
    } else if file_type.is_symlink() {
        "a dangling symbolic link"
    } else {
        "not a regular file"
    }
}

/// Opens `path` for reading if it is a regular file (symbolic links are followed to one);
/// returns the file and its length. `what` names what the file should be ("scene file").
pub fn open_regular(path: &Path, what: &str) -> Result<(File, u64)> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::format(
            path,
            format!(
                "is {}; expected a {what} (a regular file)",
                file_kind(meta.file_type())
            ),
        ));
    }
    // Opened without blocking: had the path been replaced by a FIFO since the check above,
    // a plain open would wait for a writer forever. Reads of a regular file ignore the flag.
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    // The path may have been replaced between the two calls: check what was opened.
    let opened = file.metadata().map_err(|e| Error::io(path, e))?;
    if !opened.is_file() {
        return Err(Error::format(
            path,
            format!(
                "is {}; expected a {what} (a regular file)",
                file_kind(opened.file_type())
            ),
        ));
    }
    Ok((file, opened.len()))
}

/// The error for a file longer than `cap` bytes.
fn too_large(path: &Path, length: u64, cap: u64, what: &str) -> Error {
    Error::format(
        path,
        format!(
            "{length} bytes is more than the {} allowed for a {what}; is this the right file?",
            byte_size(cap)
        ),
    )
}

/// `16 MiB`, `4 KiB`, `300 bytes`.
pub fn byte_size(bytes: u64) -> String {
    if bytes >= 1 << 20 && bytes.is_multiple_of(1 << 20) {
        format!("{} MiB", bytes >> 20)
    } else if bytes >= 1 << 10 && bytes.is_multiple_of(1 << 10) {
        format!("{} KiB", bytes >> 10)
    } else {
        format!("{bytes} bytes")
    }
}

/// Reads a regular file of at most `cap` bytes whole. A file that grows while it is read
/// is cut at `cap + 1` bytes and refused, so the cap holds whatever the file claims.
pub fn read_bytes_capped(path: &Path, cap: u64, what: &str) -> Result<Vec<u8>> {
    let (file, length) = open_regular(path, what)?;
    if length > cap {
        return Err(too_large(path, length, cap, what));
    }
    let mut bytes = Vec::with_capacity(length as usize);
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > cap {
        return Err(too_large(path, bytes.len() as u64, cap, what));
    }
    Ok(bytes)
}

/// Reads a UTF-8 text file of at most `cap` bytes ([`TEXT_INPUT_CAP`] for every text input
/// of a scene). A file that is not UTF-8 is refused by the offset of its first bad byte,
/// without quoting its content (it may be a file the user did not mean to show).
pub fn read_text_capped(path: &Path, cap: u64, what: &str) -> Result<String> {
    let bytes = read_bytes_capped(path, cap, what)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        Error::format(
            path,
            format!("is not UTF-8 text (byte {at} is not valid UTF-8); expected a {what}"),
        )
    })
}

/// The file that a document (a scene, a header, a pbrt file) in folder `base` names as
/// `named`. The name as written may lead anywhere — it is there for whoever reads the
/// document — but symbolic links must not carry a name that the text places inside the
/// folder out of it: a scene's folder, copied or downloaded, could otherwise hold
/// `sky.hdr -> ~/.ssh/id_rsa` and have that file read (and parts of it shown in an error,
/// or exported). `folder` names the folder in the error ("the scene's folder"). A name
/// that does not exist is returned joined (opening it says so).
pub fn confined(base: &Path, named: &Path, folder: &str) -> Result<PathBuf> {
    let path = base.join(named);
    let base = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    let (Ok(root), Ok(real)) = (std::fs::canonicalize(base), std::fs::canonicalize(&path)) else {
        return Ok(path);
    };
    let written = lexically_normal(&root.join(named));
    if !written.starts_with(&root) || real.starts_with(&root) {
        return Ok(path);
    }
    Err(Error::format(
        &path,
        format!(
            "leads out of {folder} {} through a symbolic link (to {}); a file named inside the folder is read only inside it. Name the file by its own path (`{}`) or copy it into the folder",
            root.display(),
            real.display(),
            real.display()
        ),
    ))
}

/// `path` with `.` dropped and each `..` taking off the component before it, without
/// asking the file system (so links are not followed): where the text of a name points.
fn lexically_normal(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// Up to `n` leading bytes of `bytes`, escaped (`\x00`, `\n`): enough to show what a file
/// that is of the wrong kind starts with (its magic), never its content beyond that.
pub fn escaped_prefix(bytes: &[u8], n: usize) -> String {
    let shown: String = bytes
        .iter()
        .take(n)
        .flat_map(|&b| std::ascii::escape_default(b))
        .map(char::from)
        .collect();
    if bytes.len() > n {
        format!("{shown}…")
    } else {
        shown
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_devices_fifos_and_folders_by_kind() {
        let err = read_text_capped(Path::new("/dev/zero"), TEXT_INPUT_CAP, "scene file")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("/dev/zero") && err.contains("character device"),
            "{err}"
        );
        let dir = tempfile::tempdir().unwrap();
        let err = read_text_capped(dir.path(), TEXT_INPUT_CAP, "scene file")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("a folder") && err.contains("scene file"),
            "{err}"
        );
        let fifo = dir.path().join("zz.toml");
        let status = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo");
        assert!(status.success());
        // Would block forever if it were opened.
        let err = read_text_capped(&fifo, TEXT_INPUT_CAP, "scene file")
            .unwrap_err()
            .to_string();
        assert!(err.contains("FIFO"), "{err}");
    }

    #[test]
    fn refuses_past_the_cap_without_reading_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        // Sparse: 1 GiB long, no blocks written, so only its length can be checked cheaply.
        let file = File::create(&path).unwrap();
        file.set_len(1 << 30).unwrap();
        let err = read_text_capped(&path, TEXT_INPUT_CAP, "scene file")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("1073741824 bytes") && err.contains("16 MiB") && err.contains("big.toml"),
            "{err}"
        );
        std::fs::write(&path, "a = 1\n").unwrap();
        assert_eq!(read_text_capped(&path, 6, "x").unwrap(), "a = 1\n");
        assert!(read_text_capped(&path, 5, "x").is_err());
    }

    #[test]
    fn binary_content_is_refused_without_quoting_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("secret.toml");
        std::fs::write(&path, b"root:x:0:0\xff\xfe").unwrap();
        let err = read_text_capped(&path, TEXT_INPUT_CAP, "scene file")
            .unwrap_err()
            .to_string();
        assert!(err.contains("byte 10") && !err.contains("root"), "{err}");
        assert_eq!(escaped_prefix(b"\x00ab\ncd", 4), "\\x00ab\\n…");
    }
}
