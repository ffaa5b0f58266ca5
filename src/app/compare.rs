//! The comparison tool of Chen's report on quadric edge collapse: the same model in up to four viewports, one per merge metric, each a
//! build-order cut at the same triangle count, which can sweep down and up; any viewport's cut can be
//! exported as OBJ. Below them, on request, the simplifications within a distance at one ε —
//! `bounded` and Zou, Shen and Peng's three envelope methods — each at the triangle count it reached.

use super::model::{LoadMessage, Loaded, spawn_load, spawn_within};
use crate::mesh::{Mesh, Part};
use crate::refine::Front;
use crate::render::Renderer;
use crate::simplify::Metric;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::mpsc::Receiver;

/// Seconds for a sweep from all triangles down to 1 % and back.
pub const SWEEP_SECONDS: f32 = 8.0;

/// What a viewport shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shown {
    /// The tree built with this metric, cut at the view's target.
    Metric(Metric),
    /// A static simplification within a distance (`simplify --method NAME --epsilon E`).
    Within { method: &'static str, epsilon: f64 },
}

impl Shown {
    pub fn label(&self) -> String {
        match self {
            Shown::Metric(m) => m.name().to_string(),
            Shown::Within { method, epsilon } => format!("{method} ε {} %", 100.0 * epsilon),
        }
    }
}

/// The methods of `simplify` shown in the second row.
pub const WITHIN_METHODS: [&str; 4] = ["bounded", "offset-patch", "single-envelope", "cohen"];

pub struct Slot {
    pub shown: Shown,
    loading: Option<Receiver<LoadMessage>>,
    pub progress: f32,
    pub error: Option<String>,
    pub ready: Option<Ready>,
}

pub struct Ready {
    pub loaded: Loaded,
    pub front: Front,
    pub renderer: Renderer,
    /// Merges applied to the front (the root alone: all of them).
    merges: u32,
}

pub struct CompareView {
    pub slots: Vec<Slot>,
    pub target: u32,
    pub sweep: bool,
    sweep_time: f32,
    path: PathBuf,
    /// ε of the second row, when shown.
    pub within: Option<f64>,
}

impl CompareView {
    /// Starts building the model's tree with every metric (cached builds open at once).
    pub fn new(path: &Path, target: u32) -> CompareView {
        let slots = [
            Metric::EdgeLength,
            Metric::QemMidpoint,
            Metric::Qem,
            Metric::Hybrid,
        ]
        .into_iter()
        .map(|metric| Slot {
            shown: Shown::Metric(metric),
            loading: Some(spawn_load(path.to_path_buf(), metric)),
            progress: 0.0,
            error: None,
            ready: None,
        })
        .collect();
        CompareView {
            slots,
            target,
            sweep: false,
            sweep_time: 0.0,
            path: path.to_path_buf(),
            within: None,
        }
    }

    /// Adds the second row at `epsilon` (replacing one at another ε), or removes it (`None`).
    pub fn set_within(&mut self, epsilon: Option<f64>) {
        if self.within == epsilon {
            return;
        }
        self.within = epsilon;
        self.slots.retain(|s| matches!(s.shown, Shown::Metric(_)));
        let Some(epsilon) = epsilon else { return };
        for method in WITHIN_METHODS {
            self.slots.push(Slot {
                shown: Shown::Within { method, epsilon },
                loading: Some(spawn_within(self.path.clone(), method, epsilon)),
                progress: 0.0,
                error: None,
                ready: None,
            });
        }
    }

    /// Columns and rows of the viewport grid: 2 × 2 for the metrics, 4 × 2 with the second row.
    pub fn grid(&self) -> (u32, u32) {
        let columns = if self.slots.len() > 4 { 4 } else { 2 };
        (columns, (self.slots.len() as u32).div_ceil(columns))
    }

    /// The `i`-th viewport's corner and size within a `width × height` area.
    pub fn cell(&self, i: usize, width: u32, height: u32) -> ([u32; 2], [u32; 2]) {
        let (columns, rows) = self.grid();
        let (w, h) = (width / columns, height / rows.max(1));
        let i = i as u32;
        ([(i % columns) * w, (i / columns) * h], [w, h])
    }

    /// Receives finished builds; moves every ready front to the target triangle count.
    pub fn update(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        format: wgpu::TextureFormat,
        dt: f32,
    ) {
        for slot in &mut self.slots {
            let Some(rx) = &slot.loading else { continue };
            while let Ok(message) = rx.try_recv() {
                match message {
                    LoadMessage::Progress(share, _) => slot.progress = share,
                    LoadMessage::Done(Ok(loaded)) => {
                        let mut renderer = Renderer::new(device, format);
                        renderer.set_hierarchy(device, queue, &loaded.hierarchy);
                        let merges = loaded.tree.build_order.len() as u32;
                        slot.ready = Some(Ready {
                            front: Front::new(&loaded.hierarchy),
                            loaded,
                            renderer,
                            merges,
                        });
                    }
                    LoadMessage::Done(Err(e)) => slot.error = Some(e),
                }
            }
            if slot.ready.is_some() || slot.error.is_some() {
                slot.loading = None;
            }
        }
        let total = self
            .slots
            .iter()
            .filter(|s| matches!(s.shown, Shown::Metric(_)))
            .filter_map(|s| s.ready.as_ref())
            .map(|r| r.loaded.tree.triangles as u32)
            .max()
            .unwrap_or(0);
        if self.sweep && total > 0 {
            // Down to 1 % and back, geometrically, so that every level gets its share of time.
            self.sweep_time = (self.sweep_time + dt) % SWEEP_SECONDS;
            let phase = self.sweep_time / SWEEP_SECONDS;
            let x = 1.0 - (2.0 * phase - 1.0).abs();
            self.target = ((total as f32) * 0.01f32.powf(x)).round().max(1.0) as u32;
        }
        for slot in &mut self.slots {
            let target = match slot.shown {
                Shown::Metric(_) => self.target,
                // A static result: all of it.
                Shown::Within { .. } => u32::MAX,
            };
            if let Some(ready) = &mut slot.ready {
                ready.set_triangles(target);
                ready.renderer.upload(
                    device,
                    queue,
                    &ready.loaded.hierarchy,
                    &mut ready.front,
                    &[],
                );
            }
        }
    }
}

impl Ready {
    /// The build-order cut with at most `target` triangles (the one with the fewest merges).
    fn set_triangles(&mut self, target: u32) {
        let tree = &self.loaded.tree;
        let total = tree.triangles as u32;
        let offsets = &tree.vanish_offsets;
        // Triangles left after m merges: total − offsets[m]; the fewest merges that reach the target.
        let m = offsets
            .partition_point(|&gone| total - gone > target)
            .min(self.loaded.tree.build_order.len()) as u32;
        let h = &self.loaded.hierarchy;
        while self.merges > m {
            self.merges -= 1;
            self.front
                .split(h, self.loaded.tree.build_order[self.merges as usize]);
        }
        while self.merges < m {
            self.front
                .unify(h, self.loaded.tree.build_order[self.merges as usize]);
            self.merges += 1;
        }
    }

    /// Writes the current cut as OBJ into `dir`, named after the model, `label` and its triangle
    /// count; returns the file.
    pub fn export(&self, dir: &Path, label: &str) -> Result<PathBuf, String> {
        let h = &self.loaded.hierarchy;
        let mut index = std::collections::HashMap::new();
        let mut positions: Vec<Vec3> = Vec::new();
        let mut triangles = Vec::new();
        for t in self.front.indices() {
            triangles.push(t.map(|u| {
                *index.entry(u).or_insert_with(|| {
                    positions.push(h.position[u as usize]);
                    positions.len() as u32 - 1
                })
            }));
        }
        let mut mesh = Mesh::from_triangles(positions, triangles);
        let label: String = label
            .chars()
            .map(|c| {
                if c.is_alphanumeric() || c == '.' {
                    c
                } else {
                    '-'
                }
            })
            .collect();
        mesh.parts = vec![Part {
            name: format!("{label}-{}", self.front.triangle_count()),
            triangles: 0..mesh.triangles.len() as u32,
        }];
        let stem = self
            .loaded
            .path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "model".into());
        let file = dir.join(format!(
            "{stem}-{label}-{}.obj",
            self.front.triangle_count()
        ));
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        crate::export::write_obj(&mesh, &file).map_err(|e| format!("{}: {e}", file.display()))?;
        Ok(file)
    }
}
