//! Laser images: σ per pixel of one aspect, and the range of the surface each pixel sees.
//!
//! The far-field view is an orthographic projection along the line of sight, so the image is
//! a depth buffer: every facet is rasterised onto a grid of samples (`supersample` ×
//! `supersample` per pixel, at their centres; a sample on an edge shared by two facets belongs
//! to exactly one), the nearest surface kept. A sample that sees a facet facing the receiver
//! and the source (and, bistatic, lit: the source's own depth buffer sees the same facet
//! there, or a surface within [`SHADOW_SLACK_SAMPLES`] samples' width of it) adds
//! `4 pi f_r cos(theta_i) dA` to its pixel, `dA` the sample's area in the image plane (a facet
//! of area `A` covers `A cos(theta_r)` of it, so summed over a facet this is its
//! `4 pi f_r cos(theta_i) cos(theta_r) A`). Visibility is thus by the part seen, not by the
//! centroid: the image's σ converges to the exact single-bounce σ as the samples shrink, with
//! an error bounded by the σ of the samples along the outlines, each of which decides for its
//! whole area whether the surface covers it, plus, along every edge between two facets, the
//! samples it crosses times the difference of their σ per area (each of those decides which
//! facet covers it; what [`LaserImage::sigma_bound`] reports).
//!
//! Memory: 16 bytes per sample (its depth, facet and side; 17 in a bistatic source's buffer,
//! with its doubt), at most [`MAX_SAMPLES`] a buffer, and 16 bytes per pixel; a sweep keeps a
//! receiver's (and, bistatic, a source's) buffer per thread, and per thread about 100 bytes
//! per facet (its terms, sample counts and queries) and 24 per vertex (48 bistatic), besides
//! the mesh's layout ([`RasterMesh`]).

use std::f64::consts::PI;

use crate::eval::eval_batch;
use crate::mesh::v3;
use crate::queries::{facing, QueryBatch};
use crate::scene::{Aspect, Mode, Scene};

/// Most pixels along an image's longer side.
pub const MAX_PIXELS: usize = 4096;

/// Most samples per pixel along each side.
pub const MAX_SUPERSAMPLE: usize = 16;

/// Most samples of one depth buffer (269 MB at 16 bytes each): [`MAX_PIXELS`] pixels and a
/// pixel of margin each side, one sample per pixel (with 2^24, 4,096 pixels were refused
/// whatever the supersampling).
pub const MAX_SAMPLES: usize = (MAX_PIXELS + 2) * (MAX_PIXELS + 2);

/// A bistatic sample counts as lit when the source's depth buffer at its place holds its own
/// facet, or a surface no nearer than this many of the source buffer's sample widths, plus
/// the tangent of the sample's facet's angle to the source, in front of it: the two buffers
/// sample the surface at points up to `step / sqrt 2` apart across the source's view, where a
/// plane at angle `theta` to it changes depth by `tan theta` per unit (a fixed slack let a
/// finely tessellated plate at 85° from the source shadow itself: σ 20–30% low).
pub const SHADOW_SLACK_SAMPLES: f64 = 2.0;

/// A sample lit only thanks to [`SHADOW_SLACK_SAMPLES`], under another facet nearer the
/// source, is taken as lit for certain when that facet's normal is within this cosine (30°)
/// of its own: the same surface, sampled at other points by the source. A facet turned
/// further (a wall on a plate) may really shadow the strip along its foot, so the sample
/// enters the bound.
pub const SLACK_SAME_SURFACE_COS: f64 = 0.866;

/// Where a facet seen from behind and one seen from the front lie at the same depth (the two
/// sides of a two-sided sheet), the front one holds the sample unless the other is nearer by
/// more than this many sample widths: rounding makes either nearer, and the sheet's back
/// side (which returns nothing) won at random.
pub const FRONT_TIE_SAMPLES: f64 = 1e-3;

/// Pixels of a laser image along its longer side unless given: a picture to look at.
pub const IMAGE_PIXELS: usize = 256;

/// Pixels along each aspect's longer side when a sweep's σ is summed by area
/// (`lrcs_by_area`) unless given: 512 samples a side at [`SUPERSAMPLE`]. Measured on the
/// 2-core machine (README, "At scale, by area"): a 1.3-million-facet sphere's 216 aspects
/// take 8.6 s with σ within 9.2e-6 of the closed form (stated bound 8.6% of σ), against 11.0 s
/// (3.7%) at [`IMAGE_PIXELS`]; the bundled target's 0.17 s, within 3.3% of a 1,022-pixel
/// sweep (stated bound 69%), against 0.57 s (1.4%, 33%). The time goal, 10 s for that sphere,
/// holds here and not at 256; the bound shrinks about as the pixel size, so a sweep that
/// needs a tighter bound asks for more pixels.
pub const SWEEP_PIXELS: usize = 128;

/// Samples per pixel along each side unless given: 16 samples a pixel, so that a pixel's σ
/// is an area fraction, not one sample's all-or-nothing.
pub const SUPERSAMPLE: usize = 4;

/// How to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageOptions {
    /// Pixels along the image's longer side (the target's extent across the line of sight).
    pub pixels: usize,
    /// Samples per pixel along each side.
    pub supersample: usize,
}

/// One aspect's image.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserImage {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// Pixel side, m.
    pub pixel_m: f64,
    /// The image's lower left corner on its right and up axes through the mesh origin, m
    /// (the axes run along the receiver's right and up; the mesh origin projects to 0, 0).
    pub origin_m: [f64; 2],
    /// σ per pixel, m², row by row from the top (up is the mesh's `z` seen from the sensor, or
    /// its `y` when looking along `z`).
    pub sigma: Vec<f64>,
    /// Range of the nearest surface each pixel sees (the mean over its samples that see one),
    /// m, as `brdf scene profile` measures it; NaN where none.
    pub range: Vec<f64>,
    /// σ of the samples on an outline (a neighbouring sample sees nothing, or a surface a
    /// depth jump away), m²: each decides for its whole area, and so may the empty sample
    /// beside it; plus, for every edge between two facets, the samples it crosses times the
    /// difference of their σ per area; plus, for every facet with an unshared edge that no
    /// sample saw (a part narrower than a sample), its projected area times the most a sample
    /// can be off by (its own σ per area, or that of what it may hide).
    pub outline_sigma: f64,
    /// σ of each material (scene order), m²: the pixels' sum split by the facet each sample
    /// sees.
    pub by_material: Vec<f64>,
    /// Facets that at least one sample sees lit.
    pub facets_seen: usize,
    /// Each material's share of σ from facets outside its fitted table's coverage, m² (0
    /// for materials without one), as [`crate::lrcs::AspectSigma::outside_coverage`].
    pub outside_coverage: Vec<f64>,
}

impl LaserImage {
    /// σ of the aspect: the sum over pixels.
    pub fn lrcs(&self) -> f64 {
        self.sigma.iter().fold(0.0, |s, v| s + v)
    }

    /// A bound on the image's error in σ from sampling: the σ of the samples on outlines
    /// (each, and the empty sample beside it, covered by at most half its area wrongly
    /// decided).
    pub fn sigma_bound(&self) -> f64 {
        self.outline_sigma
    }
}

/// Why an image cannot be drawn.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ImageError {
    /// Pixels or supersampling out of range, too many samples, or a scene an image cannot
    /// be made of.
    #[error("{0}")]
    Refused(String),
}

/// An orthographic view along `-d` (`d` towards the viewer): image axes `right`, `up`.
struct View {
    d: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
}

impl View {
    fn towards(d: [f64; 3]) -> View {
        // Up is z, or y when looking along z.
        let reference = if d[2].abs() > 0.999_999 {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        // Facing -d with `reference` up: right = (-d) x up.
        let r = v3::cross(v3::scale(d, -1.0), reference);
        let right = v3::scale(r, 1.0 / v3::norm(r));
        let up = v3::cross(right, v3::scale(d, -1.0));
        View { d, right, up }
    }

    /// Image-plane coordinates and range (`-(p . d)`) of `p`.
    fn project(&self, p: [f64; 3]) -> [f64; 3] {
        [v3::dot(p, self.right), v3::dot(p, self.up), -v3::dot(p, self.d)]
    }
}

/// A depth buffer of `nx` × `ny` samples of side `step` from `(x0, y0)` (the lower left).
#[derive(Default)]
struct Buffer {
    nx: usize,
    ny: usize,
    x0: f64,
    y0: f64,
    step: f64,
    samples: Vec<Sample>,
    /// Per sample, bistatic source buffers only: a facet no sample holds may lie across it
    /// in front of what it holds ([`Buffer::mark_unseen`]).
    doubt: Vec<bool>,
}

/// One sample of a [`Buffer`]: what a pass over the facets reads and writes together, in one
/// place (three arrays cost three cache misses per sample reached).
#[derive(Clone, Copy)]
struct Sample {
    /// Range of the nearest surface, m.
    depth: f64,
    /// Its facet, `u32::MAX` for none.
    facet: u32,
    /// Whether that facet faces the view (see [`FRONT_TIE_SAMPLES`]).
    front: bool,
}

impl Sample {
    const EMPTY: Sample = Sample {
        depth: f64::INFINITY,
        facet: u32::MAX,
        front: false,
    };
}

/// A mesh laid out for drawing, built once per scene ([`Scene::raster_mesh`]): its vertices
/// in the order the facets first use them, so that a pass over the facets reads them nearly
/// in sequence, and each facet's corners (in that numbering), normal, area, material and
/// shell closure in arrays of their own (the few bytes a view reads of each facet, where the
/// mesh's facets hold 72); and the facets cut into clusters, runs of at most
/// `CLUSTER_FACETS` consecutive facets whose normals lie within 30 degrees of the first's
/// (`CLUSTER_COS`): a view skips a cluster of a closed shell seen wholly from
/// behind without reading its facets, and the facing test one facing away from source or
/// receiver (about half the facets of a closed target whose file lists neighbouring facets
/// together, as exporters do; a file in random order makes clusters of a facet or two, and
/// costs what testing each facet costs). Memory: 24 bytes per vertex, 49 per facet and 48 per
/// cluster.
pub struct RasterMesh {
    vertices: Vec<[f64; 3]>,
    corners: Vec<[u32; 3]>,
    normal: Vec<[f64; 3]>,
    closed: Vec<bool>,
    area: Vec<f64>,
    /// Material (scene order).
    material: Vec<u32>,
    clusters: Vec<Cluster>,
    /// The facets with an edge no one other facet shares ([`seam_bound`]).
    open_edged: Vec<u32>,
}

/// Facets per [`RasterMesh`] cluster at most: small enough that a cluster along the outline
/// of a smooth body costs little, large enough that the clusters of 1.3 million facets take a
/// fraction of a millisecond to test.
const CLUSTER_FACETS: usize = 64;

/// The least cosine between the normals of a cluster's facets and its first facet's (30
/// degrees): a wider cone is seen wholly from behind from fewer directions.
const CLUSTER_COS: f64 = 0.866;

/// Added to the sine of a cluster's half angle before a cone test: a dot product of unit
/// vectors in f64 is off by a few 1e-16, and a cluster is skipped only when every facet's own
/// test would certainly fail.
const CONE_MARGIN: f64 = 1e-9;

/// Consecutive facets of a [`RasterMesh`] (`start..end`) and the cone holding their normals:
/// within `asin(reach - CONE_MARGIN)` of `axis`, `reach` infinite for a cone of 90 degrees or
/// more.
struct Cluster {
    start: u32,
    end: u32,
    axis: [f64; 3],
    reach: f64,
    /// Every facet's shell is closed.
    closed: bool,
}

impl Cluster {
    /// Whether every facet of the cluster has `n . d <= 0` (faces away from `d`, or edge-on):
    /// a normal within angle `alpha` of the axis makes at least `gamma - alpha` with `d`, at
    /// `gamma` from the axis, 90 degrees or more when `cos gamma <= -sin alpha`.
    fn all_away(&self, d: [f64; 3]) -> bool {
        v3::dot(self.axis, d) < -self.reach
    }

    /// The cluster of `normal[start..end]`.
    fn new(start: usize, end: usize, normal: &[[f64; 3]], closed: &[bool]) -> Cluster {
        let normals = &normal[start..end];
        let sum = normals.iter().fold([0.0; 3], |s, &n| v3::add(s, n));
        let length = v3::norm(sum);
        let (axis, reach) = if length > 0.0 && length.is_finite() {
            let axis = v3::scale(sum, 1.0 / length);
            let cos = normals.iter().map(|&n| v3::dot(n, axis)).fold(1.0, f64::min);
            if cos > CONE_MARGIN {
                (axis, (1.0 - cos * cos).max(0.0).sqrt() + CONE_MARGIN)
            } else {
                (axis, f64::INFINITY)
            }
        } else {
            ([0.0; 3], f64::INFINITY)
        };
        Cluster {
            start: start as u32,
            end: end as u32,
            axis,
            reach,
            closed: closed[start..end].iter().all(|&c| c),
        }
    }
}

impl std::fmt::Debug for RasterMesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RasterMesh")
            .field("vertices", &self.vertices.len())
            .field("facets", &self.corners.len())
            .field("clusters", &self.clusters.len())
            .finish()
    }
}

impl RasterMesh {
    /// The facets a view along `-d` draws, and whether each faces it: all but those of closed
    /// shells seen from behind (each lies behind a front face of its own shell), clusters of
    /// those skipped whole.
    fn drawn(&self, d: [f64; 3]) -> impl Iterator<Item = (usize, bool)> + '_ {
        self.clusters
            .iter()
            .filter(move |c| !(c.closed && c.all_away(d)))
            .flat_map(move |c| {
                (c.start as usize..c.end as usize).filter_map(move |k| {
                    let front = v3::dot(self.normal[k], d) > 0.0;
                    (front || !self.closed[k]).then_some((k, front))
                })
            })
    }

    /// The layout of `mesh`, whose facet `k` is of material `material[k]`.
    pub fn new(mesh: &crate::mesh::Mesh, material: &[u32]) -> RasterMesh {
        let mut number = vec![u32::MAX; mesh.vertices.len()];
        let mut vertices = Vec::with_capacity(mesh.vertices.len());
        let corners = mesh
            .facets
            .iter()
            .map(|f| {
                f.vertices.map(|v| {
                    let n = &mut number[v as usize];
                    if *n == u32::MAX {
                        *n = vertices.len() as u32;
                        vertices.push(mesh.vertices[v as usize]);
                    }
                    *n
                })
            })
            .collect();
        let normal: Vec<[f64; 3]> = mesh.facets.iter().map(|f| f.normal).collect();
        let mut clusters = Vec::new();
        let mut start = 0;
        while start < normal.len() {
            let first = normal[start];
            let end = (start + 1..normal.len())
                .take(CLUSTER_FACETS - 1)
                .find(|&k| v3::dot(normal[k], first) < CLUSTER_COS)
                .unwrap_or((start + CLUSTER_FACETS).min(normal.len()));
            clusters.push(Cluster::new(start, end, &normal, &mesh.closed));
            start = end;
        }
        RasterMesh {
            vertices,
            corners,
            area: mesh.facets.iter().map(|f| f.area).collect(),
            material: material.to_vec(),
            normal,
            closed: mesh.closed.clone(),
            clusters,
            open_edged: (0..mesh.facets.len() as u32)
                .filter(|&k| mesh.neighbours[k as usize].contains(&u32::MAX))
                .collect(),
        }
    }
}

/// The vertices of `scene` in `view` ([`View::project`]) into `out` (in [`RasterMesh`]
/// order), and their extent in the image plane.
fn project_all(scene: &Scene, view: &View, out: &mut Vec<[f64; 3]>) -> ([f64; 2], [f64; 2]) {
    out.clear();
    out.extend(scene.raster_mesh().vertices.iter().map(|&p| view.project(p)));
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for q in out.iter() {
        for k in 0..2 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    (lo, hi)
}

/// `bounds` widened by `margin` each side.
fn widen((lo, hi): ([f64; 2], [f64; 2]), margin: f64) -> ([f64; 2], [f64; 2]) {
    ([lo[0] - margin, lo[1] - margin], [hi[0] + margin, hi[1] + margin])
}

/// The smallest index `i >= 0` with `i >= v` (`v` finite or infinite; a call to `ceil` costs
/// more than the rest of a small triangle).
fn ceil_index(v: f64) -> usize {
    // Without branches: whether a facet's box begins on a sample is a coin toss.
    let t = v.max(0.0) as usize;
    t + usize::from((t as f64) < v)
}

impl Buffer {
    /// Every facet of `scene` rasterised in `view` over `bounds`, reusing this buffer's
    /// memory; `projected` holds the vertices in `view` ([`project_all`]) and is turned into
    /// sample coordinates.
    fn draw(
        &mut self,
        scene: &Scene,
        view: &View,
        step: f64,
        bounds: ([f64; 2], [f64; 2]),
        projected: &mut [[f64; 3]],
    ) {
        let ([x0, y0], [x1, y1]) = bounds;
        let nx = (((x1 - x0) / step).ceil() as usize).max(1);
        let ny = (((y1 - y0) / step).ceil() as usize).max(1);
        (self.nx, self.ny, self.x0, self.y0, self.step) = (nx, ny, x0, y0, step);
        self.samples.clear();
        self.samples.resize(nx * ny, Sample::EMPTY);
        // Sample coordinates: centre of sample (i, j) at (i + 0.5, j + 0.5); once per vertex,
        // not once per facet using it; snapped to [`SNAP`] (see [`Edge`]).
        for p in projected.iter_mut() {
            *p = [snap((p[0] - x0) / step), snap((p[1] - y0) / step), p[2]];
        }
        let mesh = scene.raster_mesh();
        for (k, front) in mesh.drawn(view.d) {
            let [a, bb, c] = mesh.corners[k].map(|i| projected[i as usize]);
            self.triangle(k as u32, front, a, bb, c);
        }
    }

    /// Marks the samples a facet no sample holds may cover in front of what they hold
    /// ([`Buffer::doubt`]): such a facet (narrower than a sample, or a rod's walls when the
    /// source buffer is coarser than the receiver's) casts a shadow no sample saw (a comb of
    /// thin walls behind a long rod lost its whole shadow: σ 1.0e-4 against 5.7e-5, outside
    /// its bound). Every point of a triangle holding no sample centre lies within a sample
    /// (along each axis) of its edges, so the samples around points half a sample apart
    /// along its edges cover it. Facets hidden behind what the samples hold cast no shadow
    /// beyond it and mark nothing. `projected` holds the vertices in sample coordinates
    /// ([`Buffer::draw`]); `seen` is scratch space, all false before and after.
    fn mark_unseen(&mut self, scene: &Scene, view: &View, projected: &[[f64; 3]], seen: &mut Vec<bool>) {
        let mesh = scene.raster_mesh();
        seen.resize(mesh.corners.len(), false);
        for s in &self.samples {
            if s.facet != u32::MAX {
                seen[s.facet as usize] = true;
            }
        }
        self.doubt.clear();
        self.doubt.resize(self.samples.len(), false);
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        for (k, _) in mesh.drawn(view.d).filter(|&(k, _)| !seen[k]) {
            let p = mesh.corners[k].map(|i| projected[i as usize]);
            let near = p[0][2].min(p[1][2]).min(p[2][2]);
            for e in 0..3 {
                let (a, b) = (p[e], p[(e + 1) % 3]);
                let steps = (2.0 * (b[0] - a[0]).abs().max((b[1] - a[1]).abs()))
                    .ceil()
                    .min(1e7) as usize;
                for m in 0..=steps {
                    let f = if steps == 0 { 0.0 } else { m as f64 / steps as f64 };
                    let (x, y) = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
                    let (ci, cj) = (x.floor() as i64, y.floor() as i64);
                    for j in (cj - 1).max(0)..=(cj + 1).min(ny - 1) {
                        for i in (ci - 1).max(0)..=(ci + 1).min(nx - 1) {
                            let t = (j * nx + i) as usize;
                            if self.samples[t].depth > near {
                                self.doubt[t] = true;
                            }
                        }
                    }
                }
            }
        }
        for s in &self.samples {
            if s.facet != u32::MAX {
                seen[s.facet as usize] = false;
            }
        }
    }

    /// Rasterises one triangle given in sample coordinates: every sample centre inside it
    /// (edges by the top-left rule: a centre on an edge shared by two triangles belongs to
    /// one) at its interpolated depth, where nearer than what the sample holds.
    fn triangle(&mut self, id: u32, front: bool, a: [f64; 3], b: [f64; 3], c: [f64; 3]) {
        // Depths compared with a facet seen from behind set back (see [`FRONT_TIE_SAMPLES`]).
        let tie = FRONT_TIE_SAMPLES * self.step;
        let behind = |z: f64, front: bool| if front { z } else { z + tie };
        let (mut a, mut b, c) = (a, b, c);
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area == 0.0 || !area.is_finite() {
            return; // seen edge-on: no projected area
        }
        if area < 0.0 {
            std::mem::swap(&mut a, &mut b);
        }
        let per_area = 1.0 / area.abs();
        // The sample centres in the triangle's box: `i + 0.5` from its least to its greatest
        // `x`. Subtracting 0.5 and truncating are monotone, so no centre in the box is left
        // out (at most one more each side is tried; the exact test decides); most facets of
        // a fine mesh hold no centre at all and end here.
        let (min_x, max_x) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
        let (min_y, max_y) = (a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]));
        if !(max_x >= 0.5 && max_y >= 0.5) {
            return;
        }
        let lo_x = ceil_index(min_x - 0.5);
        let hi_x = ((max_x - 0.5) as usize).saturating_add(1).min(self.nx);
        let lo_y = ceil_index(min_y - 0.5);
        let hi_y = ((max_y - 0.5) as usize).saturating_add(1).min(self.ny);
        if lo_x >= hi_x || lo_y >= hi_y {
            return;
        }
        let (ea, eb, ec) = (Edge::new(b, c), Edge::new(c, a), Edge::new(a, b));
        for j in lo_y..hi_y {
            let y = j as f64 + 0.5;
            // A wide box: this row's span, where the row's centre line crosses the edges, a
            // sample wider each side (the exact test below decides); not the whole box, which
            // a long thin facet across the image makes thousands of times larger.
            let (from, to) = if hi_x - lo_x <= NARROW_BOX_SAMPLES {
                (lo_x, hi_x)
            } else {
                let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for (p, q) in [(a, b), (b, c), (c, a)] {
                    if (p[1] - y) * (q[1] - y) <= 0.0 {
                        let (x0, x1) = if q[1] == p[1] {
                            (p[0], q[0])
                        } else {
                            let x = p[0] + (y - p[1]) * (q[0] - p[0]) / (q[1] - p[1]);
                            (x, x)
                        };
                        x_lo = x_lo.min(x0.min(x1));
                        x_hi = x_hi.max(x0.max(x1));
                    }
                }
                if x_lo > x_hi {
                    continue;
                }
                let from = (x_lo - 1.5).max(lo_x as f64) as usize;
                let to = ((x_hi + 1.5).max(0.0) as usize + 1).min(hi_x);
                (from, to)
            };
            // Along the row each edge function changes by `-dy` a sample, exactly (see
            // [`Edge`]).
            let x = from as f64 + 0.5;
            let (mut wa, mut wb, mut wc) = (ea.at(x, y), eb.at(x, y), ec.at(x, y));
            let row = &mut self.samples[j * self.nx..(j + 1) * self.nx];
            for held in &mut row[from..to] {
                // The sample is read whether or not the centre is inside: the read then
                // starts before the test decides (most centres tried are outside, at random).
                let was = *held;
                let inside = ea.inside(wa) & eb.inside(wb) & ec.inside(wc);
                let (za, zb, zc) = (wa, wb, wc);
                wa -= ea.dy;
                wb -= eb.dy;
                wc -= ec.dy;
                if !inside {
                    continue;
                }
                let z = (za * a[2] + zb * b[2] + zc * c[2]) * per_area;
                if behind(z, front) < behind(was.depth, was.front) {
                    *held = Sample {
                        depth: z,
                        facet: id,
                        front,
                    };
                }
            }
        }
    }

    /// The sample holding image-plane point `(x, y)`, if inside.
    fn at(&self, x: f64, y: f64) -> Option<usize> {
        let (i, j) = ((x - self.x0) / self.step, (y - self.y0) / self.step);
        (i >= 0.0 && j >= 0.0 && (i as usize) < self.nx && (j as usize) < self.ny)
            .then(|| j as usize * self.nx + i as usize)
    }
}

/// A triangle's box at most this many samples wide is tried whole, row by row, without
/// working out where each row crosses its edges (which costs more than trying them).
const NARROW_BOX_SAMPLES: usize = 4;

/// Vertices in sample coordinates are snapped to multiples of `1 / SNAP` of a sample (a
/// shift of less than 0.4% of a sample, far inside the sampling bound): coordinates below
/// [`MAX_SIDE`] samples then have at most 24 significant bits, so an edge function (a
/// difference of two products of such differences) is exact in f64, and so is each step
/// along a row.
const SNAP: f64 = 256.0;

/// Most samples along a depth buffer's side (a receiver's has at most 4,098 + margin; a
/// bistatic source's is made coarser until within it).
const MAX_SIDE: f64 = 65_536.0;

/// `v` (sample coordinates, at least 0) snapped down to a multiple of `1 / SNAP`.
fn snap(v: f64) -> f64 {
    ((v * SNAP) as i64) as f64 / SNAP
}

/// One edge `p -> q` of a counter-clockwise triangle, for its edge function: positive inside.
/// With snapped vertices ([`SNAP`]) the function is exact, so the two triangles sharing an
/// edge get the same value with opposite signs, and a centre on it is never rejected by both
/// through rounding (it is also evaluated from the edge's lower endpoint, x then y, whichever
/// way it is traversed, which keeps that so for unsnapped input); the top-left rule gives such
/// a centre to one of them (an edge owns it when it is a top edge, horizontal with the
/// triangle below it, or a left edge, going down).
struct Edge {
    ox: f64,
    oy: f64,
    dx: f64,
    dy: f64,
    owns: bool,
}

impl Edge {
    fn new(p: [f64; 3], q: [f64; 3]) -> Edge {
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        let o = if (p[0], p[1]) <= (q[0], q[1]) { p } else { q };
        Edge {
            ox: o[0],
            oy: o[1],
            dx,
            dy,
            owns: (dy == 0.0 && dx < 0.0) || dy < 0.0,
        }
    }

    fn at(&self, x: f64, y: f64) -> f64 {
        self.dx * (y - self.oy) - self.dy * (x - self.ox)
    }

    /// Whether a centre where the edge function is `w` lies on the inner side (without
    /// branches: samples fall either side at random).
    fn inside(&self, w: f64) -> bool {
        (w > 0.0) | ((w == 0.0) & self.owns)
    }
}

/// One facet's terms at one aspect (zero for facets not facing source and receiver).
#[derive(Clone, Copy, Debug, Default)]
struct FacetTerms {
    /// 4 pi f_r cos(theta_i): σ per unit area in the image plane.
    g: f64,
    /// Its area projected on the image plane, cos(theta_r) A, m².
    projected: f64,
    /// The tangent of its angle to the source (see [`SHADOW_SLACK_SAMPLES`]).
    slope: f64,
    /// Its material (scene order).
    material: u32,
    /// Outside its material's fitted-table coverage.
    outside: bool,
    /// Some sample sees it lit.
    seen: bool,
}

/// Memory one image needs, kept between the images of a sweep (one per thread): the projected
/// vertices, the depth buffers and the per-facet terms (each aspect resets only the entries
/// it wrote).
#[derive(Default)]
pub(crate) struct Scratch {
    projected: Vec<[f64; 3]>,
    /// The vertices in the source's view (bistatic).
    projected_source: Vec<[f64; 3]>,
    receiver: Buffer,
    source: Buffer,
    /// Per facet: what a sample that sees it needs (one place in memory, as samples reach
    /// facets in no particular order).
    terms: Vec<FacetTerms>,
    /// The facets whose entries above the last image wrote.
    touched: Vec<u32>,
    values: Vec<f64>,
    queries: Vec<QueryBatch>,
    /// Pixel column of each sample column (`usize::MAX` beyond the image).
    column: Vec<usize>,
    /// Per facet: lit, outline and doubtful samples ([`sigma_by_area`]).
    counts: Vec<[u32; 3]>,
    /// Per facet: held by a sample of the source buffer ([`Buffer::mark_unseen`]).
    seen: Vec<bool>,
    /// Per facet: its term `g` if it faces source and receiver, else [`NOT_FACING`] (what
    /// [`seam_bound`] reads of a neighbour: 8 bytes, where the terms take 32).
    g: Vec<f64>,
}

/// [`Scratch::g`] of a facet not facing both.
const NOT_FACING: f64 = -1.0;

impl Scratch {
    /// Per-facet entries for `n` facets, all zero.
    fn reset(&mut self, n: usize) {
        if self.terms.len() != n {
            self.terms = vec![FacetTerms::default(); n];
            self.g = vec![NOT_FACING; n];
        }
        for &k in &self.touched {
            self.terms[k as usize] = FacetTerms::default();
            self.g[k as usize] = NOT_FACING;
        }
        self.touched.clear();
    }
}

/// The laser image of `scene` at `aspect`, each material's exact model (f64).
pub fn image(scene: &Scene, aspect: &Aspect, options: &ImageOptions) -> Result<LaserImage, ImageError> {
    image_with(scene, aspect, options, &mut Scratch::default())
}

/// One aspect drawn into a [`Scratch`]: its receiver buffer (and, bistatic, the source's),
/// and the per-facet terms of the facets facing both.
struct Drawn {
    view: View,
    source_view: View,
    /// Towards the source.
    s: [f64; 3],
    bistatic: bool,
    width: usize,
    height: usize,
    pixel: f64,
    step: f64,
    /// Samples per pixel along each side.
    k: usize,
}

/// The facets of `mesh` facing source `s` and receiver `v` ([`facing`]) into `out`, one
/// batch per material (mesh order within clusters); clusters
/// facing away from either are skipped whole.
fn facing_positions(
    mesh: &RasterMesh,
    v: [f64; 3],
    s: [f64; 3],
    mono: bool,
    out: &mut Vec<QueryBatch>,
    materials: usize,
) {
    QueryBatch::empty_per_material(out, materials);
    for cluster in &mesh.clusters {
        if cluster.all_away(v) || cluster.all_away(s) {
            continue;
        }
        for k in cluster.start as usize..cluster.end as usize {
            if let Some([mu_i, mu_r, cos_phi]) = facing(mesh.normal[k], s, v, mono) {
                let b = &mut out[mesh.material[k] as usize];
                b.cos_theta_i.push(mu_i);
                b.cos_theta_r.push(mu_r);
                b.cos_phi.push(cos_phi);
                b.weight.push(4.0 * PI * mu_i * mu_r * mesh.area[k]);
                b.facet.push(k as u32);
            }
        }
    }
}

/// Checks the resolution, draws the receiver's (and, bistatic, the source's) depth buffer
/// into `scratch`, writes the terms of every facet facing both and each sample column's pixel
/// column (`Scratch::column`).
fn draw_aspect(
    scene: &Scene,
    aspect: &Aspect,
    options: &ImageOptions,
    scratch: &mut Scratch,
) -> Result<Drawn, ImageError> {
    scene.one_wavelength("an image").map_err(ImageError::Refused)?;
    let (n, k) = (options.pixels, options.supersample);
    if !(1..=MAX_PIXELS).contains(&n) {
        return Err(ImageError::Refused(format!(
            "--pixels {n}: give 1 to {MAX_PIXELS}"
        )));
    }
    if !(1..=MAX_SUPERSAMPLE).contains(&k) {
        return Err(ImageError::Refused(format!(
            "--supersample {k}: give 1 to {MAX_SUPERSAMPLE}"
        )));
    }
    let samples = (n * k + 2 * k) * (n * k + 2 * k);
    if samples > MAX_SAMPLES {
        // (n k + 2 k)^2 <= MAX_SAMPLES, a pixel of margin each side.
        let most = (MAX_PIXELS + 2) / k - 2;
        return Err(ImageError::Refused(format!(
            "{n} pixels x {k} samples each way: {samples} samples with the margin, more than \
             {MAX_SAMPLES}; with --supersample {k} give at most {most} pixels"
        )));
    }
    scratch.reset(scene.mesh.facets.len());
    let v = aspect.receiver();
    let s = aspect.source(scene.sensor.mode);
    let view = View::towards(v);
    let extent = project_all(scene, &view, &mut scratch.projected);
    let (lo, hi) = extent;
    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f64::MIN_POSITIVE);
    let pixel = size / n as f64;
    // One pixel of margin each side, so outlines lie inside the image.
    let (lo, hi) = widen(extent, pixel);
    let width = (((hi[0] - lo[0]) / pixel).round() as usize).max(1);
    let height = (((hi[1] - lo[1]) / pixel).round() as usize).max(1);
    let step = pixel / k as f64;
    let hi = [lo[0] + width as f64 * pixel, lo[1] + height as f64 * pixel];
    scratch
        .receiver
        .draw(scene, &view, step, (lo, hi), &mut scratch.projected);
    let bistatic = matches!(scene.sensor.mode, Mode::Bistatic { .. });
    let Scratch {
        terms,
        touched,
        values,
        queries,
        g,
        ..
    } = scratch;
    let mesh = scene.raster_mesh();
    facing_positions(
        mesh,
        v,
        s,
        scene.sensor.mode == Mode::Monostatic,
        queries,
        scene.materials.len(),
    );
    for (batch, m) in queries.iter().zip(&scene.materials) {
        values.clear();
        values.resize(batch.len(), 0.0);
        let e = m.evaluator();
        eval_batch(&e, &batch.cos_theta_i, &batch.cos_theta_r, &batch.cos_phi, values);
        let table = e.fitted_table();
        for j in 0..batch.len() {
            let k = batch.facet[j] as usize;
            touched.push(batch.facet[j]);
            let t = &mut terms[k];
            t.g = 4.0 * PI * values[j] * batch.cos_theta_i[j];
            t.projected = batch.cos_theta_r[j] * mesh.area[k];
            g[k] = t.g;
            if bistatic {
                let ci = batch.cos_theta_i[j];
                t.slope = (1.0 - ci * ci).max(0.0).sqrt() / ci;
            }
            t.material = mesh.material[k];
            if let Some(table) = &table {
                let g = brdf_core::Geometry::from_cosines(
                    batch.cos_theta_i[j],
                    batch.cos_theta_r[j],
                    batch.cos_phi[j],
                );
                t.outside = !table.covers(&g);
            }
        }
    }
    let source_view = View::towards(s);
    if bistatic {
        let b = widen(
            project_all(scene, &source_view, &mut scratch.projected_source),
            pixel,
        );
        // The receiver's sample size, or coarser where the source sees the target wider than
        // MAX_SAMPLES of them (a rod seen end-on by the receiver and broadside by the source
        // failed the sweep): the shadow's doubtful samples enter the bound either way, and so
        // do the samples of facets too thin for any source sample to hold
        // ([`Buffer::mark_unseen`]).
        let mut source_step = step;
        // Each side also below 2^16 samples, where edge functions are exact ([`SNAP`]).
        let fits = |w: f64| {
            let (sx, sy) = (((b.1[0] - b.0[0]) / w).ceil(), ((b.1[1] - b.0[1]) / w).ceil());
            sx * sy <= MAX_SAMPLES as f64 && sx.max(sy) <= MAX_SIDE
        };
        while !fits(source_step) {
            source_step *= 1.25;
        }
        scratch
            .source
            .draw(scene, &source_view, source_step, b, &mut scratch.projected_source);
        scratch
            .source
            .mark_unseen(scene, &source_view, &scratch.projected_source, &mut scratch.seen);
    }
    let drawn = Drawn {
        view,
        source_view,
        s,
        bistatic,
        width,
        height,
        pixel,
        step,
        k,
    };
    drawn.columns(scratch.receiver.nx, &mut scratch.column);
    Ok(drawn)
}

impl Drawn {
    /// The surface point receiver sample `at` sees.
    fn point(&self, buffer: &Buffer, at: usize) -> [f64; 3] {
        let (i, j) = (at % buffer.nx, at / buffer.nx);
        let x = buffer.x0 + (i as f64 + 0.5) * self.step;
        let y = buffer.y0 + (j as f64 + 0.5) * self.step;
        v3::add(
            v3::add(v3::scale(self.view.right, x), v3::scale(self.view.up, y)),
            v3::scale(self.view.d, -buffer.samples[at].depth),
        )
    }

    /// Whether receiver sample `at`, seeing facet `id` (whose slope to the source is `slope`),
    /// is lit: always monostatic; bistatic, where the source's buffer at its point holds the
    /// same facet or a surface no nearer than the slack. And whether that is in doubt: a
    /// source sample beside that one decides otherwise (a shadow's edge passes by, and the
    /// receiver sample's area may lie on either side of it), or it is lit only by the slack
    /// under a facet turned more than [`SLACK_SAME_SURFACE_COS`] from its own (the foot of a
    /// wall standing on a plate: the shadow's strip along it read as lit).
    fn lit(&self, scratch: &Scratch, mesh: &RasterMesh, at: usize, id: u32, slope: f64) -> (bool, bool) {
        if !self.bistatic {
            return (true, false);
        }
        let sb = &scratch.source;
        // Where the source sees the sample's point.
        let q = self.source_view.project(self.point(&scratch.receiver, at));
        let slack = (SHADOW_SLACK_SAMPLES + slope) * sb.step;
        let lit_at = |t: usize| sb.samples[t].facet == id || sb.samples[t].depth >= q[2] - slack;
        match sb.at(q[0], q[1]) {
            Some(t) => {
                let lit = lit_at(t);
                if sb.doubt[t] {
                    return (lit, true);
                }
                let other = sb.samples[t].facet;
                if lit
                    && other != id
                    && other != u32::MAX
                    && sb.samples[t].depth < q[2]
                    && v3::dot(mesh.normal[id as usize], mesh.normal[other as usize]) < SLACK_SAME_SURFACE_COS
                {
                    return (true, true);
                }
                let (i, j) = (t % sb.nx, t / sb.nx);
                let beside = [
                    (i > 0).then(|| t - 1),
                    (i + 1 < sb.nx).then(|| t + 1),
                    (j > 0).then(|| t - sb.nx),
                    (j + 1 < sb.ny).then(|| t + sb.nx),
                ];
                (lit, beside.into_iter().flatten().any(|u| lit_at(u) != lit))
            }
            None => (true, false),
        }
    }

    /// Whether receiver sample `(si, sj)` lies on an outline: a neighbouring sample sees
    /// nothing, or a surface that does not continue this one (another facet whose depth
    /// jumps by more than a sample).
    fn outline(&self, buffer: &Buffer, si: usize, sj: usize) -> bool {
        let at = sj * buffer.nx + si;
        let depth = buffer.samples[at].depth;
        let near = |t: usize| {
            let s = buffer.samples[t];
            s.facet != u32::MAX && (s.depth - depth).abs() <= 4.0 * self.step
        };
        (si == 0 || !near(at - 1))
            || (si + 1 == buffer.nx || !near(at + 1))
            || (sj == 0 || !near(at - buffer.nx))
            || (sj + 1 == buffer.ny || !near(at + buffer.nx))
    }

    /// The pixel column of each sample column (`usize::MAX` beyond the image) into `out`: a
    /// division per sample costs more than its work.
    fn columns(&self, nx: usize, out: &mut Vec<usize>) {
        out.clear();
        out.extend((0..nx).map(|si| {
            if si / self.k < self.width {
                si / self.k
            } else {
                usize::MAX
            }
        }));
    }
}

/// [`image`] in `scratch`'s memory.
pub(crate) fn image_with(
    scene: &Scene,
    aspect: &Aspect,
    options: &ImageOptions,
    scratch: &mut Scratch,
) -> Result<LaserImage, ImageError> {
    let d = draw_aspect(scene, aspect, options, scratch)?;
    let mesh = scene.raster_mesh();
    let (width, height, step) = (d.width, d.height, d.step);
    let column = std::mem::take(&mut scratch.column);
    let buffer = &scratch.receiver;
    let area = step * step;
    let mut sigma = vec![0.0; width * height];
    let mut range_sum = vec![0.0; width * height];
    let mut range_n = vec![0u32; width * height];
    let mut outline_sigma = 0.0;
    let mut by_material = vec![0.0; scene.materials.len()];
    let mut outside_coverage = vec![0.0; scene.materials.len()];
    let mut facets_seen = 0;
    for sj in 0..buffer.ny {
        // Pixel row, from the top.
        let py = sj / d.k;
        if py >= height {
            continue;
        }
        let row = (height - 1 - py) * width;
        for si in 0..buffer.nx {
            let at = sj * buffer.nx + si;
            let id = buffer.samples[at].facet;
            if id == u32::MAX {
                continue;
            }
            let px = column[si];
            if px == usize::MAX {
                continue;
            }
            let pix = row + px;
            // Range as `brdf scene profile` measures it: bistatic, half the extra path.
            range_sum[pix] += if d.bistatic {
                0.5 * (buffer.samples[at].depth - v3::dot(d.point(buffer, at), d.s))
            } else {
                buffer.samples[at].depth
            };
            range_n[pix] += 1;
            let t = scratch.terms[id as usize];
            if t.g == 0.0 {
                continue;
            }
            let g = t.g;
            let (lit, doubt) = d.lit(scratch, mesh, at, id, t.slope);
            if !lit {
                if doubt {
                    outline_sigma += g * area;
                }
                continue;
            }
            sigma[pix] += g * area;
            let m = t.material as usize;
            by_material[m] += g * area;
            if t.outside {
                outside_coverage[m] += g * area;
            }
            if !t.seen {
                scratch.terms[id as usize].seen = true;
                facets_seen += 1;
            }
            if doubt || d.outline(buffer, si, sj) {
                outline_sigma += g * area;
            }
        }
    }
    outline_sigma += seam_bound(scene, scratch, d.view.d, area);
    scratch.column = column;
    let range = range_sum
        .iter()
        .zip(&range_n)
        .map(|(s, &c)| if c == 0 { f64::NAN } else { s / f64::from(c) })
        .collect();
    Ok(LaserImage {
        width,
        height,
        pixel_m: d.pixel,
        origin_m: [scratch.receiver.x0, scratch.receiver.y0],
        sigma,
        range,
        outline_sigma,
        by_material,
        facets_seen,
        outside_coverage,
    })
}

/// The sampling error inside the surface: a sample decides for its whole area which facet
/// covers it, so where an edge between two facets crosses a sample, the sample may be wrong
/// by its area times the difference of the two facets' terms (σ per unit area; zero for a
/// facet not facing both); an edge `lx` by `ly` samples long crosses at most `lx + ly + 2`
/// samples. Summed over every edge of every facet facing both, each once. A facet no sample
/// sees contains no whole sample, so it lies in the samples its edges cross and is counted
/// there; one with an edge no other facet shares (a loose or thin part that may slip between
/// samples) adds besides its projected area times the most a sample can be off by: its own σ,
/// or that of what it hides (128 dark strips above a bright plate, each between two sample
/// centres, hid 18% of it under a stated bound ten times too small when only their own σ
/// counted). Where the other side is unknown (an edge no other
/// single facet shares, or a silhouette: the neighbour faces away from `receiver`), a crossed
/// sample may be off by the larger of its facet's term and the largest term less it. Hidden
/// facets are counted as if seen (the bound only errs high there). Without the edges, facets
/// narrower than a sample lined up with the samples were sampled at one phase: a corrugated
/// sheet 10% off under a stated 1% bound. Needs the receiver's sample coordinates in
/// `scratch.projected`.
fn seam_bound(scene: &Scene, scratch: &Scratch, receiver: [f64; 3], area: f64) -> f64 {
    let mesh = scene.raster_mesh();
    let projected = &scratch.projected;
    // The largest term of a facet facing both (the most any sample can be off by).
    let largest = scratch
        .touched
        .iter()
        .map(|&f| scratch.terms[f as usize].g)
        .fold(0.0, f64::max);
    // The samples edge `e` of facet `f` crosses (`lx + ly + 2` for an edge `lx` by `ly`).
    let crossed = |f: usize, e: usize| {
        let c = mesh.corners[f];
        let (p, q) = (projected[c[e] as usize], projected[c[(e + 1) % 3] as usize]);
        (p[0] - q[0]).abs() + (p[1] - q[1]).abs() + 2.0
    };
    let mut bound = 0.0;
    for &f in &scratch.touched {
        let tf = &scratch.terms[f as usize];
        if !tf.seen && scene.mesh.neighbours[f as usize].contains(&u32::MAX) {
            bound += tf.projected * tf.g.max(largest - tf.g);
        }
        for (e, &h) in scene.mesh.neighbours[f as usize].iter().enumerate() {
            if h == u32::MAX {
                // An edge no one other facet shares: an outline, a T-junction, a decal's or a
                // sliver's border, a seam of three facets. What lies beside it is unknown (the
                // samples may all miss it: decals a sample apart hid their plate), so each
                // sample it crosses may be off by as much as its facet's term differs from
                // any other's, at most the larger of `g` and `largest - g`.
                if tf.seen {
                    bound += crossed(f as usize, e) * area * tf.g.max(largest - tf.g);
                }
                continue;
            }
            let gh = scratch.g[h as usize];
            let h_facing = gh != NOT_FACING;
            // Each seam once: from its lower-numbered facet when both face both.
            if h_facing && h < f {
                continue;
            }
            // A neighbour facing away from the receiver makes this edge a silhouette: what lies
            // beyond is unknown, as beyond an edge of one facet (thin dark boxes 1 mm above a
            // bright plate, less than an outline's depth jump in front of it, hid it unbounded).
            let dg = if !h_facing && v3::dot(mesh.normal[h as usize], receiver) <= 0.0 {
                tf.g.max(largest - tf.g)
            } else {
                (tf.g - gh.max(0.0)).abs()
            };
            if dg == 0.0 {
                continue;
            }
            bound += crossed(f as usize, e) * area * dg;
        }
    }
    // Facets of open shells facing away from the receiver are drawn, hiding what lies behind
    // them, with no σ of their own: along their edges no other facet shares, a sample may be
    // off by the largest term, and one no sample holds may hide that much over its projected
    // area (thin one-sided strips seen from behind, between the samples, above a bright
    // plate: 5 times outside the bound).
    let away: Vec<u32> = mesh
        .open_edged
        .iter()
        .copied()
        .filter(|&f| v3::dot(mesh.normal[f as usize], receiver) <= 0.0)
        .collect();
    if away.is_empty() || largest == 0.0 {
        return bound;
    }
    let mut held = vec![false; mesh.corners.len()];
    for s in &scratch.receiver.samples {
        if s.facet != u32::MAX {
            held[s.facet as usize] = true;
        }
    }
    for f in away {
        let k = f as usize;
        if !held[k] {
            bound += -v3::dot(mesh.normal[k], receiver) * mesh.area[k] * largest;
        }
        for e in (0..3).filter(|&e| scene.mesh.neighbours[k][e] == u32::MAX) {
            bound += crossed(k, e) * area * largest;
        }
    }
    bound
}

/// One aspect's σ by area without its pixels (what a sweep needs), as [`image`] would sum it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct AreaSigma {
    /// As [`LaserImage::by_material`].
    pub by_material: Vec<f64>,
    /// As [`LaserImage::sigma_bound`].
    pub bound: f64,
    /// As [`LaserImage::facets_seen`].
    pub facets_seen: usize,
    /// As [`LaserImage::outside_coverage`].
    pub outside_coverage: Vec<f64>,
}

/// [`image`]'s σ, bound and counts, in `scratch`'s memory, without the pixels: the samples
/// are counted per facet (a 4-byte count a facet, where the image reads each facet's terms
/// at every sample: a cache miss per facet on a large mesh) and each facet's σ is its count
/// times its term, so the sums agree with the image's to rounding.
pub(crate) fn sigma_by_area(
    scene: &Scene,
    aspect: &Aspect,
    options: &ImageOptions,
    scratch: &mut Scratch,
) -> Result<AreaSigma, ImageError> {
    let d = draw_aspect(scene, aspect, options, scratch)?;
    let mesh = scene.raster_mesh();
    let column = std::mem::take(&mut scratch.column);
    // Per facet: samples that see it lit, those of them on an outline or in doubt, and the
    // unlit ones in doubt (a shadow's edge); at most MAX_SAMPLES each.
    let mut counts = std::mem::take(&mut scratch.counts);
    counts.clear();
    counts.resize(scene.mesh.facets.len(), [0; 3]);
    let buffer = &scratch.receiver;
    for sj in 0..buffer.ny {
        if sj / d.k >= d.height {
            continue;
        }
        for si in 0..buffer.nx {
            let at = sj * buffer.nx + si;
            let id = buffer.samples[at].facet;
            if id == u32::MAX || column[si] == usize::MAX {
                continue;
            }
            let (lit, doubt) = if d.bistatic {
                d.lit(scratch, mesh, at, id, scratch.terms[id as usize].slope)
            } else {
                (true, false)
            };
            let c = &mut counts[id as usize];
            if lit {
                c[0] += 1;
                c[1] += u32::from(doubt || d.outline(buffer, si, sj));
            } else {
                c[2] += u32::from(doubt);
            }
        }
    }
    let area = d.step * d.step;
    let mut bound = 0.0;
    let mut by_material = vec![0.0; scene.materials.len()];
    let mut outside_coverage = vec![0.0; scene.materials.len()];
    let mut facets_seen = 0;
    for &id in &scratch.touched {
        let t = &mut scratch.terms[id as usize];
        let [lit, outline, doubt] = counts[id as usize].map(f64::from);
        if t.g == 0.0 {
            continue;
        }
        bound += t.g * area * doubt;
        if lit == 0.0 {
            continue;
        }
        facets_seen += 1;
        t.seen = true;
        let sigma = t.g * area * lit;
        by_material[t.material as usize] += sigma;
        if t.outside {
            outside_coverage[t.material as usize] += sigma;
        }
        bound += t.g * area * outline;
    }
    bound += seam_bound(scene, scratch, d.view.d, area);
    scratch.column = column;
    scratch.counts = counts;
    Ok(AreaSigma {
        by_material,
        bound,
        facets_seen,
        outside_coverage,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cluster is skipped only when every facet in it faces away: for clusters of normals
    /// spread over cones of 0 to 60 degrees (and one of opposite normals, which no direction
    /// may skip), every direction `all_away` accepts has `n . d <= 0` for each normal, and
    /// directions well behind a narrow cluster are accepted (the test is not vacuous).
    #[test]
    fn a_cluster_is_skipped_only_when_all_its_facets_face_away() {
        let mut seed = 12345u64;
        let mut uniform = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut unit = || loop {
            let v = [0, 1, 2].map(|_| 2.0 * uniform() - 1.0);
            let n = v3::norm(v);
            if n > 0.1 && n <= 1.0 {
                break v3::scale(v, 1.0 / n);
            }
        };
        let mut skipped = 0;
        for spread in [0.0, 0.01, 0.1, 0.5, 1.0, 5.0] {
            for _ in 0..20 {
                let centre = unit();
                let mut normals: Vec<[f64; 3]> = (0..CLUSTER_FACETS)
                    .map(|_| {
                        let n = v3::add(centre, v3::scale(unit(), spread * 0.2));
                        v3::scale(n, 1.0 / v3::norm(n))
                    })
                    .collect();
                if spread == 5.0 {
                    normals[1] = v3::scale(normals[0], -1.0);
                }
                let closed = vec![true; normals.len()];
                let cluster = Cluster::new(0, normals.len(), &normals, &closed);
                for _ in 0..500 {
                    let d = unit();
                    if cluster.all_away(d) {
                        skipped += 1;
                        for n in &normals {
                            assert!(
                                v3::dot(*n, d) <= 0.0,
                                "spread {spread}: a facet facing {d:?} skipped"
                            );
                        }
                    }
                }
                if spread == 0.0 {
                    assert!(cluster.all_away(v3::scale(centre, -1.0)));
                }
                if spread == 5.0 {
                    assert!(cluster.reach.is_infinite());
                }
            }
        }
        assert!(skipped > 10_000, "{skipped} skipped");
    }
}
