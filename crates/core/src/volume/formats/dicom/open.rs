//! Opening one DICOM file safely: before dicom-rs parses a file (and allocates what its
//! element lengths claim), a walk over the element headers checks that every length fits
//! in the bytes that remain, so a damaged header is refused at once with the element and
//! the byte offset instead of allocating gigabytes. The walk also notices a data set
//! encoded in implicit VR under an explicit transfer syntax (pydicom reads such files; so
//! does volphot, parsing the data set as implicit VR).

use std::io::{Read, Seek, SeekFrom};

use dicom_core::dictionary::{DataDictionary, DataDictionaryEntry, VirtualVr};
use dicom_core::{Tag, VR};
use dicom_dictionary_std::{StandardDataDictionary, tags};
use dicom_object::{DefaultDicomObject, FileMetaTable, InMemDicomObject, OpenFileOptions};
use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};

/// The preamble and the `DICM` magic before the file meta group.
const PREAMBLE: u64 = 132;
/// Undefined length.
const UNDEFINED: u32 = u32::MAX;
/// Sequences nested deeper than this are damage (real files nest a few levels).
const MAX_DEPTH: usize = 32;
const ITEM: Tag = Tag(0xFFFE, 0xE000);
const ITEM_END: Tag = Tag(0xFFFE, 0xE00D);
const SEQUENCE_END: Tag = Tag(0xFFFE, 0xE0DD);

/// Why a file is not opened.
pub enum Refusal {
    /// No `DICM` magic at byte 128: not a DICOM file at all.
    NotDicom(String),
    /// A DICOM file whose header is damaged (why, with the element and byte).
    Damaged(String),
}

/// How far to parse.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Extent {
    /// The header only: stop before the pixel data.
    Header,
    /// The whole file.
    Everything,
}

/// How the data set after the meta group is encoded.
#[derive(Clone, Copy)]
struct Encoding {
    explicit: bool,
    big_endian: bool,
}

/// Opens a DICOM file from `reader` (`length` bytes), checked first ([module docs](self)).
pub fn open<R: Read + Seek>(
    mut reader: R,
    length: u64,
    extent: Extent,
) -> Result<DefaultDicomObject, Refusal> {
    let mut start = [0u8; PREAMBLE as usize];
    if length < PREAMBLE || reader.read_exact(&mut start).is_err() {
        return Err(Refusal::NotDicom(format!(
            "{length} bytes, too short for a DICOM file"
        )));
    }
    if &start[128..] != b"DICM" {
        return Err(Refusal::NotDicom(format!(
            "no DICM magic at byte 128 (found {})",
            escape(&start[128..])
        )));
    }
    let mut walk = Walk {
        reader: &mut reader,
        position: PREAMBLE,
        length,
    };
    let implicit_data_set = walk.file(extent).map_err(Refusal::Damaged)?;
    reader
        .seek(SeekFrom::Start(0))
        .map_err(|e| Refusal::Damaged(e.to_string()))?;
    let parsed = if implicit_data_set {
        open_implicit(reader)
    } else {
        let options = OpenFileOptions::new();
        let options = match extent {
            Extent::Header => options.read_until(tags::PIXEL_DATA),
            Extent::Everything => options,
        };
        options.from_reader(reader).map_err(|e| e.to_string())
    };
    parsed.map_err(|e| Refusal::Damaged(printable(&e)))
}

/// The meta group, then the data set parsed as implicit VR little endian.
fn open_implicit<R: Read>(mut reader: R) -> Result<DefaultDicomObject, String> {
    let mut preamble = [0u8; 128];
    reader
        .read_exact(&mut preamble)
        .map_err(|e| e.to_string())?;
    let meta = FileMetaTable::from_reader(&mut reader).map_err(|e| e.to_string())?;
    let implicit = TransferSyntaxRegistry
        .get("1.2.840.10008.1.2")
        .ok_or("implicit VR little endian is not registered")?;
    let data = InMemDicomObject::read_dataset_with_ts(std::io::BufReader::new(reader), implicit)
        .map_err(|e| e.to_string())?;
    Ok(data.with_exact_meta(meta))
}

/// The state of one walk over element headers.
struct Walk<'a, R> {
    reader: &'a mut R,
    position: u64,
    length: u64,
}

/// One element header.
struct Header {
    tag: Tag,
    vr: Option<VR>,
    length: u32,
    /// Where the header starts (for messages).
    at: u64,
}

impl<R: Read + Seek> Walk<'_, R> {
    /// Walks the file after the magic; whether its data set is implicit VR under an explicit syntax.
    fn file(&mut self, extent: Extent) -> Result<bool, String> {
        let syntax = self.meta_group()?;
        let mut encoding = match syntax.as_str() {
            "1.2.840.10008.1.2" => Encoding {
                explicit: false,
                big_endian: false,
            },
            "1.2.840.10008.1.2.2" => Encoding {
                explicit: true,
                big_endian: true,
            },
            // Deflated: the data set is compressed; dicom-rs inflates it.
            "1.2.840.10008.1.2.1.99" | "1.2.840.10008.1.2.8.1" => return Ok(false),
            _ => Encoding {
                explicit: true,
                big_endian: false,
            },
        };
        let implicit = encoding.explicit && !self.next_vr_is_valid()?;
        if implicit {
            encoding = Encoding {
                explicit: false,
                big_endian: false,
            };
        }
        self.data_set(encoding, None, 0, extent == Extent::Header)?;
        Ok(implicit)
    }

    /// The file meta group (explicit VR little endian, group 0002): its transfer syntax.
    fn meta_group(&mut self) -> Result<String, String> {
        let encoding = Encoding {
            explicit: true,
            big_endian: false,
        };
        let mut syntax = String::new();
        while self.position + 8 <= self.length {
            let start = self.position;
            let group = self.peek_group(encoding)?;
            if group != 0x0002 {
                break;
            }
            let h = self.header(encoding)?;
            self.check_fits(&h)?;
            if h.tag == tags::TRANSFER_SYNTAX_UID && h.length <= 64 {
                let mut uid = vec![0u8; h.length as usize];
                self.read(&mut uid)?;
                syntax = String::from_utf8_lossy(&uid)
                    .trim_end_matches(['\0', ' '])
                    .to_string();
            } else {
                self.skip(u64::from(h.length))?;
            }
            debug_assert!(self.position > start);
        }
        Ok(syntax)
    }

    /// Elements until `end` (a defined length), an item delimiter (`None`) or the end of
    /// the file (top level, `None`); at the top level stops at the pixel data if asked.
    fn data_set(
        &mut self,
        e: Encoding,
        end: Option<u64>,
        depth: usize,
        stop_at_pixels: bool,
    ) -> Result<(), String> {
        loop {
            let done = match end {
                Some(end) => self.position >= end,
                None => self.position >= self.length,
            };
            if done {
                return Ok(());
            }
            let h = self.header(e)?;
            if h.tag == ITEM_END && depth > 0 {
                return Ok(());
            }
            if depth == 0 && stop_at_pixels && h.tag >= tags::PIXEL_DATA {
                return Ok(());
            }
            self.element(e, &h, depth)?;
        }
    }

    /// The value of one element: a sequence walked, anything else checked and skipped.
    fn element(&mut self, e: Encoding, h: &Header, depth: usize) -> Result<(), String> {
        let vr = h.vr.unwrap_or_else(|| dictionary_vr(h.tag));
        let pixels = h.tag == tags::PIXEL_DATA;
        if h.length == UNDEFINED {
            // Undefined length: a sequence or encapsulated pixel data. dicom-rs reads a UN
            // element of undefined length as a sequence in the data set's own encoding,
            // where PS3.5 §6.2.2 has implicit VR; walked as dicom-rs will parse it, such
            // a sequence would be read with item tags for lengths (gigabytes).
            let walked = self.sequence(e, None, depth + 1, pixels);
            if vr == VR::UN && e.explicit {
                return walked.map_err(|why| {
                    format!(
                        "element {} at byte {} has VR UN and an undefined length: a sequence in implicit VR \
                         (PS3.5 §6.2.2), which this reader parses as explicit VR and cannot read ({why})",
                        show(h.tag),
                        h.at
                    )
                });
            }
            return walked;
        }
        self.check_fits(h)?;
        if vr == VR::SQ {
            let end = self.position + u64::from(h.length);
            return self.sequence(e, Some(end), depth + 1, false);
        }
        self.skip(u64::from(h.length))
    }

    /// The items of a sequence (or the fragments of encapsulated pixel data).
    fn sequence(
        &mut self,
        e: Encoding,
        end: Option<u64>,
        depth: usize,
        fragments: bool,
    ) -> Result<(), String> {
        if depth > MAX_DEPTH {
            return Err(format!(
                "sequences nested more than {MAX_DEPTH} deep at byte {}",
                self.position
            ));
        }
        loop {
            if end.is_some_and(|end| self.position >= end) {
                return Ok(());
            }
            let at = self.position;
            let tag = self.tag(e)?;
            let length = self.u32(e)?;
            let h = Header {
                tag,
                vr: None,
                length,
                at,
            };
            match tag {
                SEQUENCE_END => return Ok(()),
                ITEM if length == UNDEFINED && !fragments => {
                    self.data_set(e, None, depth, false)?;
                }
                ITEM => {
                    self.check_fits(&h)?;
                    let item_end = self.position + u64::from(length);
                    if fragments {
                        self.skip(u64::from(length))?;
                    } else {
                        self.data_set(e, Some(item_end), depth, false)?;
                    }
                }
                _ => {
                    return Err(format!(
                        "expected a sequence item at byte {at}, found element {}",
                        show(tag)
                    ));
                }
            }
        }
    }

    /// Whether the next two bytes after the next tag are a VR (explicit VR data set).
    fn next_vr_is_valid(&mut self) -> Result<bool, String> {
        if self.position + 6 > self.length {
            return Ok(true);
        }
        let mut bytes = [0u8; 6];
        self.read(&mut bytes)?;
        self.reader
            .seek(SeekFrom::Current(-6))
            .map_err(|e| e.to_string())?;
        self.position -= 6;
        Ok(VR::from_binary([bytes[4], bytes[5]]).is_some())
    }

    fn peek_group(&mut self, e: Encoding) -> Result<u16, String> {
        let group = self.u16(e)?;
        self.reader
            .seek(SeekFrom::Current(-2))
            .map_err(|e| e.to_string())?;
        self.position -= 2;
        Ok(group)
    }

    /// One element header: tag, VR (explicit) and length.
    fn header(&mut self, e: Encoding) -> Result<Header, String> {
        let at = self.position;
        let tag = self.tag(e)?;
        if tag.0 == 0xFFFE || !e.explicit {
            let length = self.u32(e)?;
            return Ok(Header {
                tag,
                vr: None,
                length,
                at,
            });
        }
        let mut code = [0u8; 2];
        self.read(&mut code)?;
        let vr = VR::from_binary(code).ok_or_else(|| {
            format!(
                "element {} at byte {at} has no valid VR (found {})",
                show(tag),
                escape(&code)
            )
        })?;
        let long = matches!(
            vr,
            VR::OB
                | VR::OD
                | VR::OF
                | VR::OL
                | VR::OV
                | VR::OW
                | VR::SQ
                | VR::SV
                | VR::UC
                | VR::UN
                | VR::UR
                | VR::UT
                | VR::UV
        );
        let length = if long {
            self.skip(2)?;
            self.u32(e)?
        } else {
            u32::from(self.u16(e)?)
        };
        Ok(Header {
            tag,
            vr: Some(vr),
            length,
            at,
        })
    }

    /// A defined length must fit in the bytes left in the file.
    fn check_fits(&self, h: &Header) -> Result<(), String> {
        let left = self.length.saturating_sub(self.position);
        if h.length == UNDEFINED || u64::from(h.length) <= left {
            return Ok(());
        }
        Err(format!(
            "element {} at byte {} claims {} bytes, but the file has only {left} bytes after it \
             (a damaged header, or a data set encoded other than its transfer syntax says)",
            show(h.tag),
            h.at,
            h.length
        ))
    }

    fn tag(&mut self, e: Encoding) -> Result<Tag, String> {
        Ok(Tag(self.u16(e)?, self.u16(e)?))
    }

    fn u16(&mut self, e: Encoding) -> Result<u16, String> {
        let mut b = [0u8; 2];
        self.read(&mut b)?;
        Ok(if e.big_endian {
            u16::from_be_bytes(b)
        } else {
            u16::from_le_bytes(b)
        })
    }

    fn u32(&mut self, e: Encoding) -> Result<u32, String> {
        let mut b = [0u8; 4];
        self.read(&mut b)?;
        Ok(if e.big_endian {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<(), String> {
        self.reader.read_exact(buf).map_err(|_| {
            format!(
                "the file ends at byte {} inside an element header (truncated)",
                self.length
            )
        })?;
        self.position += buf.len() as u64;
        Ok(())
    }

    fn skip(&mut self, n: u64) -> Result<(), String> {
        if self.position + n > self.length {
            return Err(format!(
                "the file ends at byte {} inside an element value (truncated)",
                self.length
            ));
        }
        let n = i64::try_from(n).map_err(|e| e.to_string())?;
        self.reader
            .seek(SeekFrom::Current(n))
            .map_err(|e| e.to_string())?;
        self.position += n as u64;
        Ok(())
    }
}

/// The VR the data dictionary gives `tag` (UN when unknown or context-dependent).
pub fn dictionary_vr(tag: Tag) -> VR {
    match StandardDataDictionary.by_tag(tag).map(|e| e.vr()) {
        Some(VirtualVr::Exact(vr)) => vr,
        _ => VR::UN,
    }
}

fn show(tag: Tag) -> String {
    format!("({:04X},{:04X})", tag.0, tag.1)
}

/// A few bytes for a message, escaped.
fn escape(bytes: &[u8]) -> String {
    format!("\"{}\"", bytes.escape_ascii())
}

/// A parser's message for an error: control characters escaped, at most 300 characters.
pub fn printable(message: &str) -> String {
    message
        .chars()
        .take(300)
        .flat_map(|c| {
            if c.is_control() {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}
