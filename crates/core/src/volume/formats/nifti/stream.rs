//! The bytes of a NIfTI-1 file, gzip-compressed or not (told by its first two bytes, not
//! its name), read with a bound: never more than vox_offset plus the voxel bytes the
//! checked header claims, and a file or stream shorter or longer than that is refused
//! with both numbers. A plain file's length is checked before any voxel is read; a gzip
//! stream's is known only as it is inflated, so it is inflated chunk by chunk, never into
//! a buffer of the claimed size.

use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

use flate2::bufread::MultiGzDecoder;

use super::header::{HEADER_BYTES, Layout};
use crate::error::{Error, Result};
use crate::util::open_regular;

/// Bytes decoded at a time: a multiple of every voxel size.
const CHUNK_BYTES: usize = 1 << 20;

/// The readable bytes of one file.
pub(super) struct Source {
    reader: Box<dyn Read>,
    /// A plain file's length on disk; `None` for a gzip stream.
    plain_length: Option<u64>,
    /// Bytes read so far (inflated ones for a gzip stream).
    position: u64,
}

/// How many bytes a file or stream turned out to hold.
enum Held {
    Exactly(u64),
    /// More than this many (a gzip stream's excess is counted only so far).
    MoreThan(u64),
}

impl Source {
    /// Opens `path` (a regular file: `what` says which) and tells gzip from plain.
    pub(super) fn open(path: &Path, what: &str) -> Result<Source> {
        let (file, length) = open_regular(path, what)?;
        let mut buffered = BufReader::with_capacity(1 << 16, file);
        let start = buffered.fill_buf().map_err(|e| Error::io(path, e))?;
        let (reader, plain_length): (Box<dyn Read>, _) = if start.starts_with(&[0x1f, 0x8b]) {
            (Box::new(MultiGzDecoder::new(buffered)), None)
        } else {
            (Box::new(buffered), Some(length))
        };
        Ok(Source {
            reader,
            plain_length,
            position: 0,
        })
    }

    /// The first 348 bytes.
    pub(super) fn read_header(&mut self, path: &Path) -> Result<[u8; HEADER_BYTES]> {
        let mut header = [0u8; HEADER_BYTES];
        let got = self.read_up_to(path, &mut header)?;
        if got < HEADER_BYTES {
            return Err(Error::format(
                path,
                format!(
                    "{} ends after {got} bytes, inside the {HEADER_BYTES}-byte NIfTI-1 header: truncated, or not a NIfTI-1 file",
                    self.noun()
                ),
            ));
        }
        Ok(header)
    }

    /// The voxels at `layout.offset`, as `f32` in file order; refuses a file or stream
    /// that does not end right after them.
    pub(super) fn read_voxels(mut self, path: &Path, layout: &Layout) -> Result<Vec<f32>> {
        if let Some(length) = self.plain_length
            && length != layout.offset.saturating_add(layout.data_bytes)
        {
            return Err(self.mismatch(path, Held::Exactly(length), layout));
        }
        self.skip_to(path, layout)?;
        let size = layout.datatype.bytes();
        let count = (layout.data_bytes / size as u64) as usize;
        // A plain file's length is checked: reserve it all. A stream's is not yet: grow as
        // it is inflated, so a false claim costs no more memory than the stream holds.
        let reserve = match self.plain_length {
            Some(_) => count,
            None => count.min(CHUNK_BYTES),
        };
        let mut values = Vec::with_capacity(reserve);
        let mut chunk = vec![0u8; CHUNK_BYTES.min(layout.data_bytes as usize)];
        let mut left = layout.data_bytes;
        while left > 0 {
            let want = left.min(chunk.len() as u64) as usize;
            let got = self.read_up_to(path, &mut chunk[..want])?;
            layout
                .datatype
                .decode(&chunk[..got - got % size], layout.byte_order, &mut values);
            if got < want {
                return Err(self.mismatch(path, Held::Exactly(self.position), layout));
            }
            left -= want as u64;
        }
        self.check_the_end(path, layout)?;
        Ok(values)
    }

    /// Skips to vox_offset (past extensions or padding), refusing a stream that ends first.
    fn skip_to(&mut self, path: &Path, layout: &Layout) -> Result<()> {
        let gap = layout.offset.saturating_sub(self.position);
        let skipped = io::copy(&mut (&mut self.reader).take(gap), &mut io::sink())
            .map_err(|e| self.failed(path, e))?;
        self.position += skipped;
        if skipped < gap {
            return Err(self.mismatch(path, Held::Exactly(self.position), layout));
        }
        Ok(())
    }

    /// Refuses bytes after the voxels: a stream's excess is counted up to as many bytes
    /// again as the header claims, so a long one costs bounded work.
    fn check_the_end(&mut self, path: &Path, layout: &Layout) -> Result<()> {
        let bound = self.position.max(1 << 20);
        let extra = io::copy(&mut (&mut self.reader).take(bound), &mut io::sink())
            .map_err(|e| self.failed(path, e))?;
        match extra {
            0 => Ok(()),
            n if n == bound => Err(self.mismatch(path, Held::MoreThan(self.position + n), layout)),
            n => Err(self.mismatch(path, Held::Exactly(self.position + n), layout)),
        }
    }

    /// Fills `buf` or reads to the end; returns the bytes read.
    fn read_up_to(&mut self, path: &Path, buf: &mut [u8]) -> Result<usize> {
        let mut filled = 0;
        while filled < buf.len() {
            match self.reader.read(&mut buf[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => {
                    self.position += filled as u64;
                    return Err(self.failed(path, e));
                }
            }
        }
        self.position += filled as u64;
        Ok(filled)
    }

    fn noun(&self) -> &'static str {
        match self.plain_length {
            Some(_) => "the file",
            None => "the decompressed (gzip) stream",
        }
    }

    fn failed(&self, path: &Path, e: io::Error) -> Error {
        match self.plain_length {
            Some(_) => Error::io(path, e),
            None => Error::format(
                path,
                format!(
                    "cannot decompress (gzip) past byte {}: {e}; the file is truncated or damaged",
                    self.position
                ),
            ),
        }
    }

    fn mismatch(&self, path: &Path, held: Held, layout: &Layout) -> Error {
        let (offset, data) = (layout.offset, layout.data_bytes);
        let total = offset.saturating_add(data);
        let (held_text, why) = match held {
            Held::Exactly(n) if n < offset => (format!("{n} bytes"), "vox_offset is past the end"),
            Held::Exactly(n) if n < total => (format!("{n} bytes"), "truncated, or a wrong header"),
            Held::Exactly(n) => (
                format!("{n} bytes"),
                "more than the header describes (wrong dims or datatype?)",
            ),
            Held::MoreThan(n) => (
                format!("more than {n} bytes"),
                "more than the header describes (wrong dims or datatype?)",
            ),
        };
        Error::format(
            path,
            format!(
                "{} holds {held_text}, but the header claims vox_offset {offset} + {data} = {total} bytes ({:?} voxels of {}): {why}",
                self.noun(),
                layout.dims,
                layout.datatype
            ),
        )
    }
}
