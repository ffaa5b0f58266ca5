//! A section of a `.vtree` file as it is written: bytes in memory, or the coded pages of a paged
//! file, which may wait on disk (see [`super::paged::Pages`]).

/// A section's bytes: pieces in memory, or the coded pages.
pub(super) enum Body<'a> {
    Pieces(Vec<&'a [u8]>),
    Pages(&'a super::paged::Pages),
}

impl<'a> Body<'a> {
    pub(super) fn one(bytes: &'a [u8]) -> Body<'a> {
        Body::Pieces(vec![bytes])
    }

    pub(super) fn len(&self) -> u64 {
        match self {
            Body::Pieces(pieces) => pieces.iter().map(|p| p.len() as u64).sum(),
            Body::Pages(pages) => pages.bytes(),
        }
    }

    pub(super) fn crc(&self) -> u32 {
        match self {
            Body::Pieces(pieces) => {
                let mut hasher = crc32fast::Hasher::new();
                pieces.iter().for_each(|p| hasher.update(p));
                hasher.finalize()
            }
            Body::Pages(pages) => pages.crc(),
        }
    }

    pub(super) fn write_to(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        match self {
            Body::Pieces(pieces) => pieces.iter().try_for_each(|p| out.write_all(p)),
            Body::Pages(pages) => pages.write_to(out),
        }
    }
}
