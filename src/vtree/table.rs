//! The header and section table of a `.vtree` (docs/FORMAT.md), checked for both readers: the
//! whole file's ([`super::read_bytes`]) and the page-by-page one ([`super::PagedFile`]), which
//! reads the table first and then only the sections it needs.

use super::format::{
    Cursor, FORMAT_VERSION, FormatError, FormatErrorKind, HEADER, MAGIC, MAX_SECTIONS,
    OLDEST_FORMAT_VERSION, TABLE_ENTRY, crc,
};
use std::path::Path;

/// Builds the errors of one file.
pub(super) struct Fail<'a> {
    pub(super) path: &'a Path,
}

impl Fail<'_> {
    pub(super) fn at(
        &self,
        offset: Option<u64>,
        kind: FormatErrorKind,
        message: String,
    ) -> FormatError {
        FormatError {
            path: self.path.to_path_buf(),
            offset,
            kind,
            message,
        }
    }

    pub(super) fn invalid(&self, message: String) -> FormatError {
        self.at(None, FormatErrorKind::Invalid, message)
    }
}

/// A section: its tag, where its body starts in the file, and the body.
pub(super) type Section<'b> = ([u8; 4], u64, &'b [u8]);

/// A section as the table lists it: its tag, offset, length and CRC-32.
pub(super) type TableEntry = ([u8; 4], u64, u64, u32);

/// The header, the section table and the sections, each checked (magic, version, checksums, one
/// section after another to the end of the file, no tag twice); returns the version and the
/// sections in file order.
pub(super) fn sections<'b>(
    bytes: &'b [u8],
    fail: &Fail,
) -> Result<(u32, Vec<Section<'b>>), FormatError> {
    let (version, table) = table(bytes, bytes.len() as u64, fail)?;
    let mut found: Vec<Section> = Vec::with_capacity(table.len());
    for (tag, offset, length, sum) in table {
        let body = &bytes[offset as usize..(offset + length) as usize];
        check_body(&tag, offset, body, sum, fail)?;
        found.push((tag, offset, body));
    }
    Ok((version, found))
}

/// Checks a section's body against its CRC-32 from the table.
pub(super) fn check_body(
    tag: &[u8; 4],
    offset: u64,
    body: &[u8],
    sum: u32,
    fail: &Fail,
) -> Result<(), FormatError> {
    if crc(body) != sum {
        return Err(fail.at(
            Some(offset),
            FormatErrorKind::Checksum,
            format!(
                "section {} is corrupt (checksum mismatch)",
                String::from_utf8_lossy(tag)
            ),
        ));
    }
    Ok(())
}

/// The header and the section table of a file of `len` bytes, from its first bytes (`head`: at
/// least the header and the table, or the whole file), checked (magic, version, the table's
/// checksum, one section after another to the end of the file, no tag twice) but not the sections'
/// bodies; returns the version and the table in file order.
pub(super) fn table(
    head: &[u8],
    len: u64,
    fail: &Fail,
) -> Result<(u32, Vec<TableEntry>), FormatError> {
    if head.len() < HEADER || head[..8] != MAGIC {
        return Err(fail.at(
            Some(0),
            FormatErrorKind::NotAVtree,
            "not a .vtree file (bad magic)".into(),
        ));
    }
    let c = Cursor { bytes: head };
    let version = c.u32(8);
    if !(OLDEST_FORMAT_VERSION..=FORMAT_VERSION).contains(&version) {
        let advice = if version > FORMAT_VERSION {
            "it was written by a newer vunify: update vunify, or rebuild it with this one's `vunify build`"
        } else {
            "rebuild it with `vunify build`"
        };
        return Err(fail.at(
            Some(8),
            FormatErrorKind::WrongVersion { found: version },
            format!(
                "format version {version}; this build reads versions {OLDEST_FORMAT_VERSION} to {FORMAT_VERSION}: {advice}"
            ),
        ));
    }
    let count = c.u32(12);
    if count > MAX_SECTIONS {
        return Err(fail.at(
            Some(12),
            FormatErrorKind::Invalid,
            format!("{count} sections; at most {MAX_SECTIONS} are allowed"),
        ));
    }
    let table_end = table_len(count);
    if head.len() < table_end {
        return Err(fail.at(
            Some(len),
            FormatErrorKind::Truncated,
            format!(
                "the file ends inside its section table ({} bytes needed)",
                table_end - 4
            ),
        ));
    }
    if crc(&head[..table_end - 4]) != c.u32(table_end - 4) {
        return Err(fail.at(
            Some(table_end as u64 - 4),
            FormatErrorKind::Checksum,
            "the header or section table is corrupt (checksum mismatch)".into(),
        ));
    }
    let mut expected = table_end as u64;
    let mut found: Vec<TableEntry> = Vec::with_capacity(count as usize);
    for i in 0..count as usize {
        let at = HEADER + i * TABLE_ENTRY;
        let tag: [u8; 4] = head[at..at + 4].try_into().expect("4 bytes");
        let (offset, length, sum) = (c.u64(at + 8), c.u64(at + 16), c.u32(at + 24));
        let name = String::from_utf8_lossy(&tag).into_owned();
        if offset != expected {
            return Err(fail.at(
                Some(at as u64),
                FormatErrorKind::Invalid,
                format!(
                    "section {name} starts at {offset}, expected {expected}: sections must follow each other"
                ),
            ));
        }
        let end = offset.checked_add(length).filter(|&e| e <= len).ok_or_else(|| {
            fail.at(Some(len), FormatErrorKind::Truncated, format!("section {name} ({length} bytes at {offset}) runs past the end of the {len}-byte file"))
        })?;
        if found.iter().any(|(t, ..)| *t == tag) {
            return Err(fail.at(
                Some(at as u64),
                FormatErrorKind::Invalid,
                format!("section {name} appears twice"),
            ));
        }
        found.push((tag, offset, length, sum));
        expected = end;
    }
    if expected != len {
        return Err(fail.at(
            Some(expected),
            FormatErrorKind::Invalid,
            format!("{} bytes after the last section", len - expected),
        ));
    }
    Ok((version, found))
}

/// The bytes of the header and a table of `count` sections, with the table's checksum.
const fn table_len(count: u32) -> usize {
    HEADER + TABLE_ENTRY * count as usize + 4
}

/// The most bytes a header and its table take: what a reader that streams reads before it knows
/// where the sections are.
pub(super) const HEAD_BYTES: usize = table_len(MAX_SECTIONS);
