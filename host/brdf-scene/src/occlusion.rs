//! Self-occlusion: does a ray from a facet's centroid towards the source (or receiver) hit
//! any other facet of the target? A bounding volume hierarchy over the facets (the `bvh`
//! crate's SAH build) keeps each ray at O(log n) facets.
//!
//! The traversal and the tests are conservative, so that no occluder is missed through
//! rounding: the boxes are padded by [`PAD`] of each facet's scale and at least
//! [`PAD_OF_DIAGONAL`] of the mesh size, a ray lying in the plane of a
//! box face counts as entering it (the crate's own slab test treats that case as a miss),
//! and a triangle is hit up to [`EDGE_SLACK`] beyond its edges, so a ray through the edge
//! shared by two occluding facets cannot slip between them. A hit counts only when the ray's
//! origin lies off the hit facet's plane by more than [`T_MIN`] of the origin facet's own
//! scale (its size plus its distance from the coordinate origin, what its rounding is relative
//! to): a hit nearer that plane is rounding in a plane through the origin (a coplanar
//! neighbour), never a facet in front of it.

use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::{BHShape, BoundingHierarchy};
use bvh::bvh::{Bvh, BvhNode};
use nalgebra::Point3;

use crate::mesh::{v3, Mesh};

/// Padding of each facet's box, as a fraction of the facet's scale (its size plus its
/// distance from the coordinate origin, what its coordinates' rounding is relative to): far
/// above f64 rounding (1e-16), far below the facet. A fraction of the whole mesh's size put
/// a 1 m pad on every facet of a 2 cm sphere beside a facet 1e9 m away: every ray met every
/// box (20,000 facets took 7.6 s, against 0.05 s without the far facet).
pub const PAD: f64 = 1e-9;

/// The least padding of a box, as a fraction of the mesh's bounding-box diagonal: a ray from
/// a facet across the mesh meets a box with a rounding of about 1e-16 of that distance, 45
/// times less.
pub const PAD_OF_DIAGONAL: f64 = 1e-14;

/// Barycentric slack of the ray-triangle test: a ray passing within 1e-12 (relative to the
/// triangle's size) outside an edge still hits, closing the cracks between neighbours.
pub const EDGE_SLACK: f64 = 1e-12;

/// Least distance of the ray's origin from the plane of a facet it hits, for the hit to
/// count, as a fraction of the origin facet's scale (its longest edge plus its largest
/// coordinate magnitude): about 4,500 times the rounding of coordinates of that size (2.2e-16
/// each), which is all that puts a coplanar neighbour's plane off the origin. Measured across
/// the hit facet's plane, not along the ray, so that grazing rays do not stretch it. Not of
/// the mesh diagonal: one facet 1e10 m away made it 10 m, and a plate 1 m behind another was
/// seen through it. At 6.4e6 m from the origin (geocentric coordinates) it is 6.4 µm: parts
/// closer together than that along their normal are not told apart.
pub const T_MIN: f64 = 1e-12;

struct Shape {
    index: usize,
    aabb: Aabb<f64, 3>,
    node: usize,
}

impl Bounded<f64, 3> for Shape {
    fn aabb(&self) -> Aabb<f64, 3> {
        self.aabb
    }
}

impl BHShape<f64, 3> for Shape {
    fn set_bh_node_index(&mut self, index: usize) {
        self.node = index;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// A triangle prepared for the Möller–Trumbore test.
#[derive(Clone, Copy)]
struct Tri {
    v0: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
    /// `|e1 x e2|`, twice the area.
    area2: f64,
}

/// The facets of a mesh with a BVH over them, for occlusion rays.
pub struct Occluder {
    nodes: Vec<BvhNode<f64, 3>>,
    shape_facet: Vec<usize>,
    tris: Vec<Tri>,
    /// Per facet, how far off a hit facet's plane a ray leaving it must start ([`T_MIN`]).
    t_min: Vec<f64>,
}

impl std::fmt::Debug for Occluder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Occluder")
            .field("facets", &self.tris.len())
            .field("nodes", &self.nodes.len())
            .finish()
    }
}

impl Occluder {
    /// Builds the hierarchy (in parallel on all cores).
    pub fn new(mesh: &Mesh) -> Occluder {
        let least = PAD_OF_DIAGONAL * mesh.diagonal();
        let tris: Vec<Tri> = mesh
            .facets
            .iter()
            .map(|f| {
                let p = f.vertices.map(|i| mesh.vertices[i as usize]);
                let (e1, e2) = (v3::sub(p[1], p[0]), v3::sub(p[2], p[0]));
                Tri {
                    v0: p[0],
                    e1,
                    e2,
                    area2: v3::norm(v3::cross(e1, e2)),
                }
            })
            .collect();
        let mut shapes: Vec<Shape> = mesh
            .facets
            .iter()
            .enumerate()
            .map(|(index, f)| {
                let p = f.vertices.map(|i| mesh.vertices[i as usize]);
                let lo = [0, 1, 2].map(|k| p[0][k].min(p[1][k]).min(p[2][k]));
                let hi = [0, 1, 2].map(|k| p[0][k].max(p[1][k]).max(p[2][k]));
                let far = p.iter().flatten().fold(0.0_f64, |m, c| m.max(c.abs()));
                let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
                let pad = (PAD * (far + size)).max(least);
                let lo = lo.map(|c| c - pad);
                let hi = hi.map(|c| c + pad);
                Shape {
                    index,
                    aabb: Aabb::with_bounds(Point3::from(lo), Point3::from(hi)),
                    node: 0,
                }
            })
            .collect();
        let bvh = Bvh::build_par(&mut shapes);
        Occluder {
            nodes: bvh.nodes,
            shape_facet: shapes.iter().map(|s| s.index).collect(),
            tris,
            t_min: mesh
                .facets
                .iter()
                .map(|f| {
                    let p = f.vertices.map(|i| mesh.vertices[i as usize]);
                    let edge = (0..3)
                        .map(|k| v3::norm(v3::sub(p[(k + 1) % 3], p[k])))
                        .fold(0.0, f64::max);
                    let far = p.iter().flatten().fold(0.0_f64, |m, c| m.max(c.abs()));
                    T_MIN * (edge + far)
                })
                .collect(),
        }
    }

    /// True when the ray from `origin` along the unit vector `dir` hits a facet other than
    /// `skip` (the facet the ray leaves). `stack` is scratch space, reused between calls.
    pub fn blocked(&self, origin: [f64; 3], dir: [f64; 3], skip: usize, stack: &mut Vec<usize>) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inv = dir.map(|d| 1.0 / d);
        stack.clear();
        stack.push(0);
        while let Some(n) = stack.pop() {
            match &self.nodes[n] {
                BvhNode::Leaf { shape_index, .. } => {
                    let f = self.shape_facet[*shape_index];
                    if f != skip && hits(&self.tris[f], origin, dir, self.t_min[skip]) {
                        return true;
                    }
                }
                BvhNode::Node {
                    child_l_index,
                    child_l_aabb,
                    child_r_index,
                    child_r_aabb,
                    ..
                } => {
                    if enters(child_l_aabb, origin, dir, inv) {
                        stack.push(*child_l_index);
                    }
                    if enters(child_r_aabb, origin, dir, inv) {
                        stack.push(*child_r_index);
                    }
                }
            }
        }
        false
    }
}

/// Slab test of a ray (t >= 0) against a box; a direction component of 0 keeps the ray in
/// that slab if the origin is inside it (no 0 * inf).
#[inline]
fn enters(b: &Aabb<f64, 3>, o: [f64; 3], d: [f64; 3], inv: [f64; 3]) -> bool {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        let (lo, hi) = (b.min[k], b.max[k]);
        if d[k] == 0.0 {
            if o[k] < lo || o[k] > hi {
                return false;
            }
        } else {
            let a = (lo - o[k]) * inv[k];
            let c = (hi - o[k]) * inv[k];
            t0 = t0.max(a.min(c));
            t1 = t1.min(a.max(c));
        }
    }
    t0 <= t1
}

/// Möller–Trumbore: does the ray hit the triangle ahead of its origin, with the origin more
/// than `t_min` from the triangle's plane? A ray in the triangle's plane (edge-on) does not:
/// the triangle has no projected area along it.
#[inline]
fn hits(t: &Tri, o: [f64; 3], d: [f64; 3], t_min: f64) -> bool {
    let p = v3::cross(d, t.e2);
    let det = v3::dot(t.e1, p);
    let scale = v3::norm(t.e1) * v3::norm(t.e2);
    if det.abs() <= 1e-14 * scale {
        return false;
    }
    let inv = 1.0 / det;
    let s = v3::sub(o, t.v0);
    let u = v3::dot(s, p) * inv;
    if !(-EDGE_SLACK..=1.0 + EDGE_SLACK).contains(&u) {
        return false;
    }
    let q = v3::cross(s, t.e1);
    let v = v3::dot(d, q) * inv;
    if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return false;
    }
    // The origin's distance from the hit facet's plane is `t |n . d|`, with
    // `|n . d| = |det| / |e1 x e2|`.
    let t_hit = v3::dot(t.e2, q) * inv;
    t_hit > 0.0 && t_hit * det.abs() > t_min * t.area2
}
