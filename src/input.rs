//! Reading user files safely: every file a run reads (config, OBJ, MTL,
//! probe file, earlier outputs) goes through [`open`], which refuses what
//! is not a regular file before reading a byte, and through bounded reads,
//! so that a FIFO, a device, a directory or a file of endless or binary
//! bytes gets one clear line instead of a hang or an out-of-memory abort.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufRead, Read};
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::Path;

/// Longest line the text readers (OBJ, MTL) accept: 4 MiB. A face of
/// [`crate::scene::obj::MAX_FACE_VERTICES`] vertices written `i/t/n` fits.
pub const MAX_LINE_BYTES: usize = 4 << 20;

/// Opens `path` (a `what`: "scene file", "material library", …) for
/// reading and returns it with its size.
///
/// Contract: the file is opened non-blocking and checked with `fstat` on
/// the open descriptor, so a FIFO without a writer neither blocks nor
/// slips through a race between a check and the open. A missing file, a
/// directory, a FIFO, a socket or a device is a user error naming `path`
/// in words; a file over `limit` bytes is one too, naming both sizes.
pub fn open(path: &Path, what: &str, limit: u64) -> Result<(File, u64)> {
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => Error::user_file(path, format!("{what} not found")),
            _ if e.raw_os_error() == Some(libc::ELOOP) => Error::user_file(
                path,
                format!("{what} cannot be opened: a symbolic-link loop (ELOOP)"),
            ),
            _ if path.is_dir() => Error::user_file(path, format!("is a directory, not a {what}")),
            _ => Error::user_file(path, format!("cannot read {what}: {e}")),
        })?;
    let meta = file
        .metadata()
        .map_err(|e| Error::user_file(path, format!("cannot read {what}: {e}")))?;
    let kind = meta.file_type();
    let not_regular = if kind.is_dir() {
        Some("a directory")
    } else if kind.is_fifo() {
        Some("a FIFO (named pipe)")
    } else if kind.is_socket() {
        Some("a socket")
    } else if kind.is_char_device() || kind.is_block_device() {
        Some("a device")
    } else {
        None
    };
    if let Some(kind) = not_regular {
        return Err(Error::user_file(
            path,
            format!("is {kind}, not a {what} (a regular file)"),
        ));
    }
    if meta.len() > limit {
        return Err(Error::user_file(
            path,
            format!(
                "{what} is {}, over the limit of {}",
                bytes_text(meta.len()),
                bytes_text(limit)
            ),
        ));
    }
    Ok((file, meta.len()))
}

/// The whole of `path` (see [`open`]), at most `limit` bytes: a file that
/// grows past the limit while it is read is refused as well.
pub fn read(path: &Path, what: &str, limit: u64) -> Result<Vec<u8>> {
    let (file, size) = open(path, what, limit)?;
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::user_file(path, format!("cannot read {what}: {e}")))?;
    if bytes.len() as u64 > limit {
        return Err(Error::user_file(
            path,
            format!("{what} grew past the limit of {}", bytes_text(limit)),
        ));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text; invalid UTF-8 is a user error naming the byte
/// offset.
pub fn read_text(path: &Path, what: &str, limit: u64) -> Result<String> {
    String::from_utf8(read(path, what, limit)?).map_err(|e| {
        Error::user_file(
            path,
            format!(
                "{what} is not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Why a line could not be read: too long, or binary.
#[derive(Debug, PartialEq)]
pub enum LineError {
    /// The line exceeds [`MAX_LINE_BYTES`].
    TooLong,
    /// The line holds a NUL byte: the file is binary, not text.
    Binary,
}

/// Reads the next line of `reader` into `line` (without its `\n` or
/// `\r\n`), never holding more than [`MAX_LINE_BYTES`] of it.
///
/// Contract: `Ok(false)` at the end of input; a line longer than the
/// limit, or one holding a NUL byte, is refused as soon as the offending
/// byte is buffered, so a file of endless or binary bytes costs no more
/// than the limit in memory and stops at once.
pub fn next_line(
    reader: &mut impl BufRead,
    line: &mut Vec<u8>,
) -> std::io::Result<Result<bool, LineError>> {
    line.clear();
    let mut any = false;
    loop {
        let buf = reader.fill_buf()?;
        if buf.is_empty() {
            break;
        }
        any = true;
        let (chunk, done) = match memchr::memchr(b'\n', buf) {
            Some(i) => (&buf[..i], Some(i + 1)),
            None => (buf, None),
        };
        if memchr::memchr(0, chunk).is_some() {
            return Ok(Err(LineError::Binary));
        }
        if line.len() + chunk.len() > MAX_LINE_BYTES {
            return Ok(Err(LineError::TooLong));
        }
        line.extend_from_slice(chunk);
        let used = done.unwrap_or(buf.len());
        reader.consume(used);
        if done.is_some() {
            break;
        }
    }
    if line.last() == Some(&b'\r') {
        line.pop();
    }
    Ok(Ok(any))
}

/// The one message for a text file (`kind`: "an OBJ", "an MTL") that holds
/// a NUL byte on line `line`.
pub fn not_text(path: &Path, line: usize, kind: &str) -> Error {
    Error::User(format!(
        "{}:{line}: binary data (a NUL byte): not {kind} text file",
        path.display()
    ))
}

/// The line (1-based) of byte `offset` of `path`: counted again from the
/// start, for messages about a byte found while the file was streamed.
pub fn line_at(path: &Path, offset: u64) -> usize {
    let Ok(file) = std::fs::File::open(path) else {
        return 1;
    };
    let mut prefix = Vec::new();
    let _ = file.take(offset).read_to_end(&mut prefix);
    1 + prefix.iter().filter(|&&b| b == b'\n').count()
}

/// `bytes` in words, binary units with three significant digits
/// (`1.50 GiB`, `512 KiB`, `17 bytes`).
pub fn bytes_text(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["KiB", "MiB", "GiB", "TiB", "PiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut v = bytes as f64 / 1024.0;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    let digits = if v >= 100.0 {
        0
    } else if v >= 10.0 {
        1
    } else {
        2
    };
    format!("{v:.digits$} {}", UNITS[unit])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_split_bounded_and_binary_is_refused() {
        let mut r = std::io::Cursor::new(b"a b\r\nc\n\nlast".to_vec());
        let mut line = Vec::new();
        let mut got = Vec::new();
        while next_line(&mut r, &mut line).unwrap().unwrap() {
            got.push(String::from_utf8(line.clone()).unwrap());
        }
        assert_eq!(got, ["a b", "c", "", "last"]);

        let mut r = std::io::Cursor::new(b"v 1\0 2 3\n".to_vec());
        assert_eq!(
            next_line(&mut r, &mut line).unwrap(),
            Err(LineError::Binary)
        );

        let long = vec![b'x'; MAX_LINE_BYTES + 1];
        let mut r = std::io::BufReader::with_capacity(1 << 16, std::io::Cursor::new(long));
        assert_eq!(
            next_line(&mut r, &mut line).unwrap(),
            Err(LineError::TooLong)
        );
        assert!(line.capacity() <= MAX_LINE_BYTES + (1 << 16));
    }

    #[test]
    fn special_files_are_refused_by_kind() {
        let d = tempfile::tempdir().unwrap();
        let e = open(d.path(), "scene file", 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(e.contains("is a directory, not a scene file"), "{e}");
        let e = open(Path::new("/dev/zero"), "material library", 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(e.contains("is a device"), "{e}");
        let fifo = d.path().join("pipe");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = open(&fifo, "scene file", 1 << 20).unwrap_err().to_string();
        assert!(e.contains("FIFO"), "{e}");
        let e = open(&d.path().join("no.obj"), "scene file", 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(e.ends_with("scene file not found"), "{e}");
        let big = d.path().join("big");
        std::fs::write(&big, vec![b'x'; 2048]).unwrap();
        let e = read(&big, "probe file", 1024).unwrap_err().to_string();
        assert!(e.contains("2.00 KiB, over the limit of 1.00 KiB"), "{e}");
        assert_eq!(read(&big, "probe file", 4096).unwrap().len(), 2048);
    }

    #[test]
    fn sizes_read_in_binary_units() {
        assert_eq!(bytes_text(17), "17 bytes");
        assert_eq!(bytes_text(1536), "1.50 KiB");
        assert_eq!(bytes_text(3 << 30), "3.00 GiB");
        assert_eq!(bytes_text(200 << 20), "200 MiB");
    }
}
