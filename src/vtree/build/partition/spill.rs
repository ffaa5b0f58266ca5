//! The nodes each level made, kept on disk from the moment the level is done until the tree is
//! numbered: held in memory they were a third of a partitioned build's peak (700 MB of 3 GB at
//! 14 M triangles), and they are only read again, once, in order.
//!
//! Each level's nodes go to one file in a temporary folder (removed when the build ends, however
//! it ends), as records in the order the level made them: the node, its two children as the cells
//! name them, and the input triangles that vanish at it. The numbering reads each level's files
//! side by side, one record of each at a time (see [`super::number`]).

use super::{Made, Ref};
use crate::vtree::Node;
use crate::vtree::build::BuildError;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// The folder the levels' files are in, removed with it.
pub(super) struct Spill {
    dir: tempfile::TempDir,
}

/// One level's nodes, on disk.
pub(super) struct Spilled {
    pub(super) cell: u32,
    pub(super) height: u32,
    pub(super) count: u32,
    path: PathBuf,
}

/// A node read back: the node, its children as the cells name them, the triangles that vanish at
/// it.
pub(super) struct Record {
    pub(super) node: Node,
    pub(super) children: [Ref; 2],
    pub(super) vanished: Vec<u32>,
}

fn failed(path: &Path, what: &str, e: std::io::Error) -> BuildError {
    BuildError::Spill {
        path: path.to_path_buf(),
        problem: format!("cannot {what} the build's temporary file: {e}"),
    }
}

impl Spill {
    /// A new folder inside `parent` (the output's folder, which has room for the output, where
    /// the system's temporary folder may be held in memory).
    pub(super) fn new(parent: &Path) -> Result<Spill, BuildError> {
        let dir = tempfile::Builder::new()
            .prefix(".vunify-build-")
            .tempdir_in(parent)
            .map_err(|e| failed(parent, "make a folder for", e))?;
        Ok(Spill { dir })
    }

    /// Writes `made` to its file and lets it go.
    pub(super) fn write(&self, made: Made) -> Result<Spilled, BuildError> {
        let path = self.dir.path().join(format!("level-{}.nodes", made.cell));
        let fail = |e| failed(&path, "write", e);
        let file = std::fs::File::create(&path).map_err(fail)?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        for (k, node) in made.nodes.iter().enumerate() {
            let gone = &made.vanished[made.offsets[k] as usize..made.offsets[k + 1] as usize];
            out.write_all(bytemuck::bytes_of(node)).map_err(fail)?;
            for c in made.children[k] {
                out.write_all(&c.0.to_le_bytes()).map_err(fail)?;
            }
            out.write_all(&(gone.len() as u32).to_le_bytes())
                .map_err(fail)?;
            out.write_all(bytemuck::cast_slice(gone)).map_err(fail)?;
        }
        out.flush().map_err(fail)?;
        Ok(Spilled {
            cell: made.cell,
            height: made.height,
            count: made.nodes.len() as u32,
            path,
        })
    }
}

/// Reads one level's records back, in order.
pub(super) struct Reader<'a> {
    input: BufReader<std::fs::File>,
    left: u32,
    path: &'a Path,
}

impl Spilled {
    pub(super) fn read(&self) -> Result<Reader<'_>, BuildError> {
        let file = std::fs::File::open(&self.path).map_err(|e| failed(&self.path, "open", e))?;
        Ok(Reader {
            input: BufReader::with_capacity(1 << 16, file),
            left: self.count,
            path: &self.path,
        })
    }
}

impl Reader<'_> {
    /// The next record, `None` after the last.
    pub(super) fn next(&mut self) -> Result<Option<Record>, BuildError> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left -= 1;
        let fail = |e| failed(self.path, "read", e);
        let mut node: Node = bytemuck::Zeroable::zeroed();
        self.input
            .read_exact(bytemuck::bytes_of_mut(&mut node))
            .map_err(fail)?;
        let mut word = [0u8; 8];
        let mut children = [Ref(0); 2];
        for c in &mut children {
            self.input.read_exact(&mut word).map_err(fail)?;
            *c = Ref(u64::from_le_bytes(word));
        }
        let mut count = [0u8; 4];
        self.input.read_exact(&mut count).map_err(fail)?;
        let mut vanished = vec![0u32; u32::from_le_bytes(count) as usize];
        self.input
            .read_exact(bytemuck::cast_slice_mut(&mut vanished))
            .map_err(fail)?;
        Ok(Some(Record {
            node,
            children,
            vanished,
        }))
    }
}
