//! Rendering a camera path headless: PNG frames, per-frame statistics, a contact sheet, and (with
//! `compare`) the image error of the LOD against the full-resolution mesh frame by frame.

use super::RenderError;
use super::headless::{Gpu, OFFSCREEN_FORMAT, Offscreen};
use super::image_diff::{self, Comparison};
use super::renderer::{DrawOptions, Renderer};
use crate::camera_path::CameraPath;
use crate::refine::{
    CacheStats, Camera, FrameStats, Front, Hierarchy, Refiner, Settings, Streamed,
};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to render and where.
#[derive(Clone, Debug)]
pub struct RenderJob {
    pub size: [u32; 2],
    pub settings: Settings,
    pub draw: DrawOptions,
    /// Frames per second of path time.
    pub fps: f32,
    /// Write every k-th frame as PNG (statistics cover every frame).
    pub every: usize,
    /// Also render the full mesh each frame and measure the image error.
    pub compare: bool,
    /// Draw the full mesh instead of the level of detail (no refinement).
    pub full: bool,
    pub out_dir: PathBuf,
    /// When the user started it (the process's start, as near as the command knows): the summary's
    /// `first_frame_s` counts from here. `None`: from the call to [`render_path`].
    pub started: Option<Instant>,
}

/// One frame's line of `stats.csv`.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct FrameRecord {
    pub frame: usize,
    pub time_s: f32,
    pub triangles: u32,
    pub active_vertices: u32,
    pub splits: u32,
    pub unifies: u32,
    pub refine_ms: f64,
    pub upload_ms: f64,
    pub upload_bytes: u64,
    /// GPU time of the frame's pass (timestamp queries), when the adapter has them.
    pub gpu_ms: Option<f64>,
    /// Wall time of render + readback, for adapters without timestamps.
    pub frame_ms: f64,
    pub psnr_db: Option<f64>,
    pub differing: Option<f64>,
    /// With `compare`: the full mesh's GPU and wall time for the same frame.
    pub full_gpu_ms: Option<f64>,
    pub full_frame_ms: Option<f64>,
    /// The process's resident memory after the frame, MiB (Linux; `None` elsewhere).
    pub resident_mb: Option<f64>,
    /// A streamed tree's pages: read since the start, asked for and not arrived yet, and the
    /// bytes of those resident, MiB (`None` for a tree read whole).
    pub pages_loaded: Option<u64>,
    pub pages_pending: Option<u64>,
    pub cache_mb: Option<f64>,
}

impl FrameRecord {
    /// What the frame took on the CPU's clock: refinement, upload, drawing and readback.
    pub fn total_ms(&self) -> f64 {
        self.refine_ms + self.upload_ms + self.frame_ms
    }
}

#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Summary {
    pub frames: usize,
    pub adapter: String,
    pub triangles_mean: f64,
    pub triangles_max: u32,
    pub full_triangles: usize,
    pub refine_ms_median: f64,
    pub refine_ms_p95: f64,
    pub gpu_ms_median: Option<f64>,
    pub gpu_ms_p95: Option<f64>,
    pub frame_ms_median: f64,
    pub frame_ms_p95: f64,
    pub full_gpu_ms_median: Option<f64>,
    pub full_gpu_ms_p95: Option<f64>,
    pub full_frame_ms_median: Option<f64>,
    pub full_frame_ms_p95: Option<f64>,
    pub upload_bytes_mean: f64,
    pub psnr_db_mean: Option<f64>,
    pub psnr_db_min: Option<f64>,
    pub differing_mean: Option<f64>,
    pub differing_max: Option<f64>,
    pub worst_frame: Option<usize>,
    /// Seconds from [`RenderJob::started`] until the first frame was drawn and read back.
    pub first_frame_s: f64,
    /// The longest frame's [`FrameRecord::total_ms`].
    pub max_frame_ms: f64,
    /// The process's peak resident memory (`/usr/bin/time -v`'s maximum resident set size), MiB.
    pub peak_resident_mb: Option<f64>,
    /// A streamed tree's pages read, and the parts of it the runtime took in (`None` for a tree
    /// read whole).
    pub pages_loaded: Option<u64>,
    /// Pages of which only some nodes were kept, read whole again.
    pub pages_reread: Option<u64>,
    pub parts: Option<u64>,
    /// Pages that could not be read, each once: the front stayed coarse there.
    pub page_errors: Vec<String>,
    pub written: Vec<PathBuf>,
}

/// Near and far planes for a model of this diagonal: close enough to fly into it, far enough to see
/// it whole from any generated path.
pub fn clip_planes(diagonal: f32) -> (f32, f32) {
    let d = diagonal.max(f32::MIN_POSITIVE);
    (d * 1e-3, d * 100.0)
}

pub fn camera_at(path: &CameraPath, t: f32, size: [u32; 2], diagonal: f32) -> Camera {
    let (near, far) = clip_planes(diagonal);
    path.camera(t, size, near, far)
}

/// The most frames one render makes: a day of path at 30 fps would be 2.6 million PNG-less frames of
/// statistics, and no user means that; a typo in a path's times does happen.
pub const MAX_FRAMES: usize = 1_000_000;

/// Frames in a path of `seconds` at `fps`, the first and last included; `None` past [`MAX_FRAMES`]
/// (or for a duration or rate that is not a positive finite number).
pub fn frame_count(seconds: f32, fps: f32) -> Option<usize> {
    let frames = (seconds as f64 * fps as f64).floor() + 1.0;
    (frames.is_finite() && frames >= 1.0 && frames <= MAX_FRAMES as f64).then_some(frames as usize)
}

/// Renders `path` over the model; writes frames, `stats.csv`, `contact_sheet.png` (and with
/// `compare`, `worst_side_by_side.png`) into `job.out_dir`.
pub fn render_path(
    gpu: &Gpu,
    h: &Hierarchy,
    path: &CameraPath,
    job: &RenderJob,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Summary, JobError> {
    let mut whole = Whole {
        h,
        refiner: Refiner::new(h, job.settings),
    };
    render_frames(gpu, &mut whole, path, job, progress)
}

/// [`render_path`] over a tree streamed from its file: each frame draws the front over the
/// pages read so far (see [`Streamed`]). The full mesh is not at hand, so neither `compare` nor
/// `full` can be asked for.
pub fn render_streamed(
    gpu: &Gpu,
    streamed: &mut Streamed,
    path: &CameraPath,
    job: &RenderJob,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Summary, JobError> {
    if job.compare || job.full {
        return Err(JobError::NeedsWhole);
    }
    // The first frame waits a little for what it asks for, rather than show the root's pages.
    let size = [job.size[0].max(1), job.size[1].max(1)];
    streamed.prepare(
        &camera_at(path, 0.0, size, streamed.hierarchy().diagonal),
        FIRST_FRAME_WAIT,
    );
    let mut summary = render_frames(gpu, streamed, path, job, progress)?;
    summary.pages_loaded = Some(streamed.cache_stats().loaded);
    summary.pages_reread = Some(streamed.cache_stats().rereads);
    summary.parts = Some(streamed.parts);
    Ok(summary)
}

/// How long a streamed render's first frame may wait for the pages it asks for.
const FIRST_FRAME_WAIT: std::time::Duration = std::time::Duration::from_millis(1000);

/// What a render draws: a front over a hierarchy, adapted each frame.
trait Source {
    fn hierarchy(&self) -> &Hierarchy;
    /// Adapts the front to `camera`; also says whether the hierarchy is new.
    fn update(&mut self, camera: &Camera) -> (FrameStats, bool);
    fn output(&mut self) -> (&Hierarchy, &mut Front, &[(u32, glam::Vec3)]);
    /// A streamed tree's cache, and the pages that could not be read since the last call.
    fn cache(&mut self) -> Option<(CacheStats, Vec<String>)>;
}

/// A tree read whole.
struct Whole<'a> {
    h: &'a Hierarchy,
    refiner: Refiner,
}

impl Source for Whole<'_> {
    fn hierarchy(&self) -> &Hierarchy {
        self.h
    }
    fn update(&mut self, camera: &Camera) -> (FrameStats, bool) {
        (self.refiner.update(self.h, camera), false)
    }
    fn output(&mut self) -> (&Hierarchy, &mut Front, &[(u32, glam::Vec3)]) {
        let (front, moved) = self.refiner.output();
        (self.h, front, moved)
    }
    fn cache(&mut self) -> Option<(CacheStats, Vec<String>)> {
        None
    }
}

impl Source for Streamed {
    fn hierarchy(&self) -> &Hierarchy {
        Streamed::hierarchy(self)
    }
    fn update(&mut self, camera: &Camera) -> (FrameStats, bool) {
        let frame = Streamed::update(self, camera);
        (frame.stats, frame.new_part)
    }
    fn output(&mut self) -> (&Hierarchy, &mut Front, &[(u32, glam::Vec3)]) {
        Streamed::output(self)
    }
    fn cache(&mut self) -> Option<(CacheStats, Vec<String>)> {
        let errors = self.take_failures();
        Some((
            self.cache_stats(),
            errors.iter().map(|(_, e)| e.to_string()).collect(),
        ))
    }
}

fn render_frames(
    gpu: &Gpu,
    source: &mut dyn Source,
    path: &CameraPath,
    job: &RenderJob,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Summary, JobError> {
    let h = source.hierarchy();
    let started = job.started.unwrap_or_else(Instant::now);
    let frames = frame_count(path.duration(), job.fps).ok_or(JobError::TooManyFrames {
        seconds: path.duration(),
        fps: job.fps,
    })?;
    std::fs::create_dir_all(&job.out_dir).map_err(|e| JobError::io(&job.out_dir, e))?;
    let (device, queue) = (&gpu.device, &gpu.queue);
    let target = Offscreen::new(device, job.size);
    let mut lod = Renderer::new(device, OFFSCREEN_FORMAT);
    lod.set_hierarchy(device, queue, h);
    let mut full = job.compare.then(|| {
        let mut r = Renderer::new(device, OFFSCREEN_FORMAT);
        r.set_hierarchy(device, queue, h);
        draw_every_leaf(gpu, &mut r, h);
        r
    });
    let full_triangles = full.as_ref().map_or(0, |r| r.triangles() as usize);
    // With `full`, every leaf is drawn and nothing refines.
    let fixed = job.full.then(|| draw_every_leaf(gpu, &mut lod, h));
    let diagonal = h.diagonal;
    let mut records = Vec::with_capacity(frames);
    let mut kept = Vec::new();
    let mut worst: Option<(f64, usize, [image::RgbaImage; 2])> = None;
    let mut summary = Summary {
        adapter: gpu.adapter_name(),
        full_triangles,
        ..Default::default()
    };
    let sheet_every = (frames / 16).max(1);
    for i in 0..frames {
        let t = i as f32 / job.fps;
        let camera = camera_at(path, t, target.size, diagonal);
        let (stats, upload_bytes, upload_ms) = match fixed {
            Some(stats) => (stats, 0, 0.0),
            None => {
                let (stats, new) = source.update(&camera);
                let t0 = Instant::now();
                let (h, front, moved) = source.output();
                if new {
                    lod.set_hierarchy(device, queue, h);
                }
                let upload = lod.upload(device, queue, h, front, moved);
                (stats, upload.bytes, t0.elapsed().as_secs_f64() * 1e3)
            }
        };
        let cache = source.cache();
        let t0 = Instant::now();
        let (image, gpu_ms) = frame(gpu, &mut lod, &target, &camera, &job.draw)?;
        let frame_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut record = FrameRecord {
            frame: i,
            time_s: t,
            triangles: stats.triangles,
            active_vertices: stats.active_vertices,
            splits: stats.splits,
            unifies: stats.unifies,
            refine_ms: stats.refine_secs * 1e3,
            upload_ms,
            upload_bytes,
            gpu_ms,
            frame_ms,
            resident_mb: crate::memory::resident_bytes().map(|b| b as f64 / MIB),
            ..Default::default()
        };
        if let Some((c, errors)) = cache {
            record.pages_loaded = Some(c.loaded);
            record.pages_pending = Some(c.pending as u64);
            record.cache_mb = Some(c.resident_bytes as f64 / MIB);
            summary.page_errors.extend(errors);
        }
        if i == 0 {
            summary.first_frame_s = started.elapsed().as_secs_f64();
        }
        if let Some(full) = full.as_mut() {
            let t0 = Instant::now();
            let (reference, full_gpu_ms) = frame(gpu, full, &target, &camera, &job.draw)?;
            record.full_frame_ms = Some(t0.elapsed().as_secs_f64() * 1e3);
            record.full_gpu_ms = full_gpu_ms;
            let Comparison {
                psnr_db, differing, ..
            } = image_diff::compare(&image, &reference);
            record.psnr_db = Some(psnr_db);
            record.differing = Some(differing);
            if worst.as_ref().is_none_or(|w| psnr_db < w.0) {
                worst = Some((psnr_db, i, [image.clone(), reference]));
            }
        }
        if i % job.every.max(1) == 0 {
            let file = job.out_dir.join(format!("frame_{i:05}.png"));
            save(&image, &file)?;
            summary.written.push(file);
        }
        if i % sheet_every == 0 && kept.len() < 16 {
            kept.push(image);
        }
        records.push(record);
        progress(i + 1, frames);
    }

    let csv = job.out_dir.join("stats.csv");
    write_csv(&records, &csv).map_err(|e| JobError::io(&csv, e))?;
    summary.written.push(csv);
    let sheet = job.out_dir.join("contact_sheet.png");
    save(&image_diff::contact_sheet(&kept, 4, 320), &sheet)?;
    summary.written.push(sheet);
    if let Some((_, i, [a, b])) = &worst {
        let file = job.out_dir.join("worst_side_by_side.png");
        let diff = image_diff::difference(a, b);
        save(&image_diff::side_by_side(&[a, b, &diff]), &file)?;
        summary.written.push(file);
        summary.worst_frame = Some(*i);
    }
    summarise(&mut summary, &records);
    summary.peak_resident_mb = crate::memory::peak_resident_bytes().map(|b| b as f64 / MIB);
    Ok(summary)
}

const MIB: f64 = 1024.0 * 1024.0;

/// Has `renderer` draw the full mesh: every leaf of `h`, every triangle.
fn draw_every_leaf(gpu: &Gpu, renderer: &mut Renderer, h: &Hierarchy) -> FrameStats {
    let mut all = Front::new(h);
    all.refine_all(h);
    renderer.set_triangles(&gpu.device, &gpu.queue, &all.all_vertices(h));
    FrameStats {
        triangles: all.triangle_count() as u32,
        active_vertices: h.leaf_count,
        ..Default::default()
    }
}

/// Renders one frame into `target` and reads it back, with the GPU time where there are timestamps.
pub fn frame(
    gpu: &Gpu,
    renderer: &mut Renderer,
    target: &Offscreen,
    camera: &Camera,
    draw: &DrawOptions,
) -> Result<(image::RgbaImage, Option<f64>), RenderError> {
    let mut encoder = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
    renderer.draw(
        &gpu.device,
        &gpu.queue,
        &mut encoder,
        super::Target {
            color: &target.color_view,
            depth: &target.depth_view,
        },
        camera,
        draw,
    );
    renderer.resolve_timing(&mut encoder);
    target.copy_out(&mut encoder);
    gpu.queue.submit([encoder.finish()]);
    let image = target.read(&gpu.device)?;
    let gpu_ms = renderer.read_gpu_ms(&gpu.device, &gpu.queue);
    Ok((image, gpu_ms))
}

fn summarise(s: &mut Summary, records: &[FrameRecord]) {
    s.frames = records.len();
    if records.is_empty() {
        return;
    }
    let n = records.len() as f64;
    s.triangles_mean = records.iter().map(|r| r.triangles as f64).sum::<f64>() / n;
    s.triangles_max = records.iter().map(|r| r.triangles).max().unwrap_or(0);
    let mut refine: Vec<f64> = records.iter().map(|r| r.refine_ms).collect();
    refine.sort_by(f64::total_cmp);
    s.refine_ms_median = percentile(&refine, 0.5);
    s.refine_ms_p95 = percentile(&refine, 0.95);
    s.max_frame_ms = records
        .iter()
        .map(FrameRecord::total_ms)
        .fold(0.0, f64::max);
    let sorted = |f: &dyn Fn(&FrameRecord) -> Option<f64>| {
        let mut v: Vec<f64> = records.iter().filter_map(f).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let median_p95 = |v: &[f64]| (!v.is_empty()).then(|| (percentile(v, 0.5), percentile(v, 0.95)));
    let gpu = sorted(&|r| r.gpu_ms);
    (s.gpu_ms_median, s.gpu_ms_p95) = median_p95(&gpu).unzip();
    let wall = sorted(&|r| Some(r.frame_ms));
    (s.frame_ms_median, s.frame_ms_p95) = median_p95(&wall).unwrap_or_default();
    (s.full_gpu_ms_median, s.full_gpu_ms_p95) = median_p95(&sorted(&|r| r.full_gpu_ms)).unzip();
    (s.full_frame_ms_median, s.full_frame_ms_p95) =
        median_p95(&sorted(&|r| r.full_frame_ms)).unzip();
    s.upload_bytes_mean = records.iter().map(|r| r.upload_bytes as f64).sum::<f64>() / n;
    let psnr: Vec<f64> = records.iter().filter_map(|r| r.psnr_db).collect();
    if !psnr.is_empty() {
        // Identical frames have infinite PSNR; cap them at 100 dB for the mean.
        s.psnr_db_mean = Some(psnr.iter().map(|p| p.min(100.0)).sum::<f64>() / psnr.len() as f64);
        s.psnr_db_min = psnr.iter().copied().reduce(f64::min);
        let diff: Vec<f64> = records.iter().filter_map(|r| r.differing).collect();
        s.differing_mean = Some(diff.iter().sum::<f64>() / diff.len() as f64);
        s.differing_max = diff.iter().copied().reduce(f64::max);
    }
}

pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn write_csv(records: &[FrameRecord], file: &Path) -> std::io::Result<()> {
    let mut out = Vec::new();
    writeln!(
        out,
        "frame,time_s,triangles,active_vertices,splits,unifies,refine_ms,upload_ms,upload_bytes,gpu_ms,frame_ms,psnr_db,differing_share,full_gpu_ms,full_frame_ms,resident_mb,pages_loaded,pages_pending,cache_mb"
    )?;
    let count = |x: Option<u64>| x.map_or(String::new(), |v| v.to_string());
    let opt = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v:.4}"));
    for r in records {
        writeln!(
            out,
            "{},{:.4},{},{},{},{},{:.4},{:.4},{},{},{:.3},{},{},{},{},{},{},{},{}",
            r.frame,
            r.time_s,
            r.triangles,
            r.active_vertices,
            r.splits,
            r.unifies,
            r.refine_ms,
            r.upload_ms,
            r.upload_bytes,
            opt(r.gpu_ms),
            r.frame_ms,
            opt(r.psnr_db),
            opt(r.differing),
            opt(r.full_gpu_ms),
            opt(r.full_frame_ms),
            opt(r.resident_mb),
            count(r.pages_loaded),
            count(r.pages_pending),
            opt(r.cache_mb),
        )?;
    }
    crate::export::write_atomic(file, &out)
}

/// Writes a PNG atomically.
pub fn save(image: &image::RgbaImage, file: &Path) -> Result<(), JobError> {
    let mut bytes = Vec::new();
    image
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| JobError::Image(file.into(), e.to_string()))?;
    crate::export::write_atomic(file, &bytes).map_err(|e| JobError::io(file, e))
}

#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("{0}: {1}")]
    Io(PathBuf, std::io::Error),
    #[error(
        "the path lasts {seconds} s: at {fps} frames a second that is more than the {MAX_FRAMES} frames a render makes; shorten the path or lower --fps"
    )]
    TooManyFrames { seconds: f32, fps: f32 },
    #[error(
        "--compare and --full draw the full mesh, which a streamed tree does not hold: leave out --cache to read the tree whole"
    )]
    NeedsWhole,
    #[error("{0}: cannot encode the image: {1}")]
    Image(PathBuf, String),
}

impl JobError {
    fn io(path: &Path, e: std::io::Error) -> JobError {
        JobError::Io(path.into(), e)
    }
}
