//! The partitioned build as separate steps, for any batch system (a Kubernetes Indexed Job, a
//! SLURM array) or Ray: a *plan* computes the mesh's shared data and writes each leaf cell's level
//! to a file in a shared folder; a *cell* step, run once per cell index on any machine, reads its
//! file, builds the cell and writes its remains and nodes; the *join* builds the levels above the
//! cells from those files and numbers the tree. The tree is the same, byte for byte, as
//! [`super::build_partitioned`] in one process: the cell step runs the very function the one
//! process runs on that cell, and the files carry its input and output exactly.
//!
//! Each file is `MAGIC`, its kind, the plan's identity (a CRC of the mesh at unit size, the options
//! and the cell size), its cell index, the payload, and a CRC-32 of all of that: the join refuses a
//! missing, truncated, corrupt or foreign cell with the file's name and what is wrong.

use super::partition::{self, LevelInput, LevelOutput, Live, Made, Params, Ref, Remains, Shared};
use super::{BuildError, BuildOptions, BuildStats, VertexTree};
use crate::mesh::Mesh;
use crate::simplify::metric::PairEnd;
use crate::vtree::{NONE, Node};
use bytemuck::Pod;
use glam::Vec3;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicUsize;
use std::time::Instant;

const MAGIC: &[u8; 8] = b"VUCELL\0\x01";
const INPUT: u32 = 1;
const OUTPUT: u32 = 2;
/// Magic, kind, plan, index.
const HEADER: usize = 8 + 4 + 4 + 4;

/// What a plan wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    /// Cell files written, `cell-0.in` … ; 0 when the mesh is built whole (it fits in one cell, or
    /// has colours, texture coordinates or materials): the join then builds it alone.
    pub cells: u32,
    /// The plan's identity, which every cell file carries.
    pub id: u32,
}

/// The file a cell step reads.
pub fn cell_input_path(dir: &Path, index: u32) -> PathBuf {
    dir.join(format!("cell-{index}.in"))
}

/// The file a cell step writes and the join reads.
pub fn cell_output_path(dir: &Path, index: u32) -> PathBuf {
    dir.join(format!("cell-{index}.out"))
}

/// The plan step: `mesh`'s shared data, and each leaf cell's level written to `dir`.
pub fn plan(
    mesh: &Mesh,
    options: &BuildOptions,
    cell_triangles: usize,
    dir: &Path,
) -> Result<Plan, BuildError> {
    let (unit, _) = super::at_unit_size(mesh)?;
    let id = plan_id(&unit, options, cell_triangles);
    if super::builds_whole(&unit, cell_triangles) {
        return Ok(Plan { cells: 0, id });
    }
    let shared = Shared::new(&unit, options, cell_triangles)?;
    let cells: Vec<u32> = shared.cells().collect();
    cells.par_iter().try_for_each(|&at| {
        let index = shared.cell_index(at);
        let mut out = Writer::new(INPUT, id, index);
        out.level_input(&shared.cell_input(at), shared.params());
        write(&cell_input_path(dir, index), &out.finish())
    })?;
    Ok(Plan {
        cells: cells.len() as u32,
        id,
    })
}

/// The cell step: reads `dir`'s cell `index`, builds it, writes its output.
pub fn build_cell(dir: &Path, index: u32) -> Result<(), BuildError> {
    let path = cell_input_path(dir, index);
    let bytes = read(&path, dir, index)?;
    let (mut r, id) = Reader::open(&bytes, &path, INPUT, None, index)?;
    let (input, params) = r.level_input()?;
    let out = partition::run_cell(input, &params, &AtomicUsize::new(0));
    let mut w = Writer::new(OUTPUT, id, index);
    w.level_output(&out);
    write(&cell_output_path(dir, index), &w.finish())
}

/// The join: the levels above the cells whose outputs are in `dir`, and the tree. `mesh`,
/// `options` and `cell_triangles` must be the plan's (the cells' files say whether they are).
pub fn join(
    mesh: &Mesh,
    options: &BuildOptions,
    cell_triangles: usize,
    dir: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(VertexTree, BuildStats), BuildError> {
    let start = Instant::now();
    super::build_scaled(mesh, progress, &mut |unit, progress| {
        if super::builds_whole(unit, cell_triangles) {
            return super::build_unit(unit, options, progress);
        }
        let id = plan_id(unit, options, cell_triangles);
        let shared = Shared::new(unit, options, cell_triangles)?;
        let leaf = |shared: &Shared, at: u32| {
            let index = shared.cell_index(at);
            let path = cell_output_path(dir, index);
            let bytes = read(&path, dir, index)?;
            let (mut r, _) = Reader::open(&bytes, &path, OUTPUT, Some(id), index)?;
            let out = r.level_output(at, unit)?;
            shared.count_merges(out.made.nodes.len());
            Ok(out)
        };
        shared.finish(&leaf, dir, start, progress)
    })
}

/// A CRC of what decides the tree: the mesh at unit size, the options, the cell size.
fn plan_id(mesh: &Mesh, options: &BuildOptions, cell_triangles: usize) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(bytemuck::cast_slice(&mesh.positions));
    h.update(bytemuck::cast_slice(&mesh.triangles));
    h.update(format!("{options:?} {cell_triangles}").as_bytes());
    h.finalize()
}

fn cell_error(path: &Path, problem: impl Into<String>) -> BuildError {
    BuildError::Cell {
        path: path.to_path_buf(),
        problem: problem.into(),
    }
}

/// Reads cell `index`'s file at `path` in `dir`.
fn read(path: &Path, dir: &Path, index: u32) -> Result<Vec<u8>, BuildError> {
    std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => cell_error(
            path,
            format!(
                "missing: the plan was not made here, or this cell's step has not run or failed \
                 (`vunify cell {} --index {index}`)",
                dir.display()
            ),
        ),
        _ => cell_error(path, format!("cannot read: {e}")),
    })
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), BuildError> {
    crate::export::write_atomic(path, bytes)
        .map_err(|e| cell_error(path, format!("cannot write: {e}")))
}

/// A cell file being written.
struct Writer(Vec<u8>);

impl Writer {
    fn new(kind: u32, id: u32, index: u32) -> Writer {
        let mut w = Writer(MAGIC.to_vec());
        for v in [kind, id, index] {
            w.u32(v);
        }
        w
    }

    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }

    fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }

    fn slice<T: Pod>(&mut self, items: &[T]) {
        self.0
            .extend_from_slice(&(items.len() as u64).to_le_bytes());
        self.0.extend_from_slice(bytemuck::cast_slice(items));
    }

    fn remains(&mut self, r: &Remains) {
        let slots = &r.slots;
        self.slice(&slots.iter().map(|s| s.node.0).collect::<Vec<u64>>());
        self.slice(&slots.iter().map(|s| s.current).collect::<Vec<Node>>());
        self.slice(
            &slots
                .iter()
                .map(|s| end_to_floats(&s.end))
                .collect::<Vec<_>>(),
        );
        self.slice(&slots.iter().map(|s| s.mass).collect::<Vec<f32>>());
        self.slice(&slots.iter().map(|s| s.samples).collect::<Vec<_>>());
        let triangles: Vec<[u32; 4]> = r
            .triangles
            .iter()
            .map(|&(f, [a, b, c])| [f, a, b, c])
            .collect();
        self.slice(&triangles);
        self.slice(&r.pairs.iter().map(|&(a, b)| [a, b]).collect::<Vec<_>>());
    }

    fn level_input(&mut self, input: &LevelInput, params: &Params) {
        for v in [input.at, input.height, input.target, u32::from(input.root)] {
            self.u32(v);
        }
        self.remains(&input.remains);
        self.slice(
            &input
                .locked
                .iter()
                .map(|&l| u8::from(l))
                .collect::<Vec<u8>>(),
        );
        let options = serde_json::to_vec(&params.options).unwrap_or_default();
        self.slice(&options);
        self.f32(params.mean_edge_length);
        self.f32(params.radius);
    }

    fn level_output(&mut self, out: &LevelOutput) {
        self.remains(&out.remains);
        let m = &out.made;
        self.u32(m.cell);
        self.u32(m.height);
        self.slice(&m.nodes);
        self.slice(
            &m.children
                .iter()
                .map(|c| c.map(|r| r.0))
                .collect::<Vec<_>>(),
        );
        self.slice(&m.vanished);
        self.slice(&m.offsets);
        let s = &out.stats;
        self.slice(&[
            s.flip_deferrals as u64,
            s.widenings as u64,
            s.rounds,
            s.pricings,
        ]);
        self.slice(&[s.phases.pricing, s.phases.merging, s.phases.repricing]);
    }

    /// The bytes, with their CRC at the end.
    fn finish(mut self) -> Vec<u8> {
        let crc = crc32fast::hash(&self.0);
        self.u32(crc);
        self.0
    }
}

/// A pair end as the 15 floats a file holds: its quadric, position and weight.
fn end_to_floats(end: &PairEnd) -> [f32; 15] {
    let mut out = [0.0; 15];
    out[..11].copy_from_slice(bytemuck::cast_slice(std::slice::from_ref(&end.quadric)));
    out[11..14].copy_from_slice(&end.position.to_array());
    out[14] = end.weight;
    out
}

fn end_from_floats(f: &[f32; 15]) -> PairEnd {
    PairEnd {
        quadric: bytemuck::pod_read_unaligned(bytemuck::cast_slice(&f[..11])),
        position: Vec3::from_slice(&f[11..14]),
        weight: f[14],
    }
}

/// A cell file being read, every length and index checked.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl<'a> Reader<'a> {
    /// Checks the header and CRC: a `kind` file of cell `index`, and of plan `id` when given.
    fn open(
        bytes: &'a [u8],
        path: &'a Path,
        kind: u32,
        id: Option<u32>,
        index: u32,
    ) -> Result<(Reader<'a>, u32), BuildError> {
        if bytes.len() < HEADER + 4 || &bytes[..8] != MAGIC {
            return Err(cell_error(path, "not a vunify cell file"));
        }
        let (body, crc) = bytes.split_at(bytes.len() - 4);
        if crc32fast::hash(body).to_le_bytes() != crc {
            return Err(cell_error(
                path,
                format!(
                    "corrupt or truncated ({} bytes; the checksum does not match)",
                    bytes.len()
                ),
            ));
        }
        let mut r = Reader {
            bytes: body,
            at: 8,
            path,
        };
        let (k, plan, i) = (r.u32()?, r.u32()?, r.u32()?);
        if k != kind {
            return Err(r.error(format!(
                "a cell {} file where its {} was expected",
                if k == INPUT { "input" } else { "output" },
                if kind == INPUT { "input" } else { "output" }
            )));
        }
        if i != index {
            return Err(r.error(format!("holds cell {i}, not cell {index}")));
        }
        if id.is_some_and(|id| id != plan) {
            return Err(r.error(
                "belongs to another plan (another mesh, options or cell size): plan again and \
                 rerun the cells",
            ));
        }
        Ok((r, plan))
    }

    fn error(&self, problem: impl Into<String>) -> BuildError {
        cell_error(self.path, problem)
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], BuildError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(self.error(format!("truncated at byte {}", self.at)));
        };
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }

    fn u32(&mut self) -> Result<u32, BuildError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or_default(),
        ))
    }

    fn f32(&mut self) -> Result<f32, BuildError> {
        Ok(f32::from_bits(self.u32()?))
    }

    fn vec<T: Pod>(&mut self) -> Result<Vec<T>, BuildError> {
        let len = u64::from_le_bytes(self.take(8)?.try_into().unwrap_or_default());
        let size = usize::try_from(len)
            .ok()
            .and_then(|l| l.checked_mul(size_of::<T>()));
        let Some(size) = size else {
            return Err(self.error(format!("an array of {len} items at byte {}", self.at)));
        };
        Ok(bytemuck::pod_collect_to_vec(self.take(size)?))
    }

    /// A vector of `len` items.
    fn vec_of<T: Pod>(&mut self, len: usize, what: &str) -> Result<Vec<T>, BuildError> {
        let v = self.vec::<T>()?;
        if v.len() != len {
            return Err(self.error(format!("{} {what} for {len} slots", v.len())));
        }
        Ok(v)
    }

    fn remains(&mut self) -> Result<Remains, BuildError> {
        let refs: Vec<u64> = self.vec()?;
        let n = refs.len();
        let nodes: Vec<Node> = self.vec_of(n, "nodes")?;
        let ends: Vec<[f32; 15]> = self.vec_of(n, "quadrics")?;
        let mass: Vec<f32> = self.vec_of(n, "masses")?;
        let samples: Vec<[u32; 4]> = self.vec_of(n, "sample lists")?;
        let triangles: Vec<[u32; 4]> = self.vec()?;
        let pairs: Vec<[u32; 2]> = self.vec()?;
        let in_range = |s: &u32| (*s as usize) < n;
        if !triangles.iter().all(|t| t[1..].iter().all(in_range))
            || !pairs.iter().all(|p| p.iter().all(in_range))
        {
            return Err(self.error("a triangle or pair names a slot that is not there"));
        }
        let slots = (0..n)
            .map(|i| Live {
                node: Ref(refs[i]),
                current: nodes[i],
                end: end_from_floats(&ends[i]),
                mass: mass[i],
                samples: samples[i],
            })
            .collect();
        Ok(Remains {
            slots,
            triangles: triangles
                .iter()
                .map(|t| (t[0], [t[1], t[2], t[3]]))
                .collect(),
            pairs: pairs.iter().map(|p| (p[0], p[1])).collect(),
        })
    }

    fn level_input(&mut self) -> Result<(LevelInput, Params), BuildError> {
        let (at, height, target, root) = (self.u32()?, self.u32()?, self.u32()?, self.u32()?);
        let remains = self.remains()?;
        let locked: Vec<u8> = self.vec_of(remains.slots.len(), "lock flags")?;
        let options: Vec<u8> = self.vec()?;
        let options = serde_json::from_slice(&options)
            .map_err(|e| self.error(format!("its build options: {e}")))?;
        let params = Params {
            options,
            mean_edge_length: self.f32()?,
            radius: self.f32()?,
        };
        if remains.slots.iter().any(|s| s.node.as_leaf().is_none()) {
            return Err(self.error("a cell's input holds a vertex that is not a leaf"));
        }
        let input = LevelInput {
            at,
            height,
            target: target.min(remains.slots.len() as u32).max(1),
            root: root != 0,
            remains,
            locked: locked.iter().map(|&l| l != 0).collect(),
        };
        Ok((input, params))
    }

    /// Cell output of leaf kd-tree node `at`, checked against `mesh`: every leaf it names is a
    /// vertex, every node it names its own, every triangle an input triangle.
    fn level_output(&mut self, at: u32, mesh: &Mesh) -> Result<LevelOutput, BuildError> {
        let remains = self.remains()?;
        let (cell, height) = (self.u32()?, self.u32()?);
        let nodes: Vec<Node> = self.vec()?;
        let children: Vec<[u64; 2]> = self.vec_of(nodes.len(), "child pairs")?;
        let vanished: Vec<u32> = self.vec()?;
        let offsets: Vec<u32> = self.vec_of(nodes.len() + 1, "vanishing offsets")?;
        let counts: Vec<u64> = self.vec_of(4, "counters")?;
        let phases: Vec<f64> = self.vec_of(3, "phase times")?;
        let leaves = mesh.positions.len() as u32;
        let names_ok = |r: Ref| match r.as_leaf() {
            Some(v) => v < leaves,
            None => {
                let (c, k) = r.cell_and_index();
                c == at && (k as usize) < nodes.len()
            }
        };
        let samples_ok = |s: &Live| s.samples.iter().all(|&q| q == NONE || q < leaves);
        if cell != at
            || !remains
                .slots
                .iter()
                .all(|s| names_ok(s.node) && samples_ok(s))
            || !children.iter().flatten().all(|&c| names_ok(Ref(c)))
            || !offsets.windows(2).all(|w| w[0] <= w[1])
            || offsets.first() != Some(&0)
            || offsets.last().map(|&l| l as usize) != Some(vanished.len())
            || !vanished
                .iter()
                .all(|&f| (f as usize) < mesh.triangles.len())
            || !remains
                .triangles
                .iter()
                .all(|t| (t.0 as usize) < mesh.triangles.len())
        {
            return Err(
                self.error("its nodes do not fit the plan's mesh (a cell of another build?)")
            );
        }
        let mut stats = BuildStats {
            flip_deferrals: counts[0] as u32,
            widenings: counts[1] as u32,
            rounds: counts[2],
            pricings: counts[3],
            ..Default::default()
        };
        stats.phases.pricing = phases[0];
        stats.phases.merging = phases[1];
        stats.phases.repricing = phases[2];
        Ok(LevelOutput {
            remains,
            made: Made {
                cell,
                height,
                nodes,
                children: children.iter().map(|c| c.map(Ref)).collect(),
                vanished,
                offsets,
            },
            stats,
        })
    }
}
