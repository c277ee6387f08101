//! Meshes the project makes itself: spheres, plates, boxes, and the bundled target (a
//! cylinder with end caps and a fin), for the tests, the benchmark and `data/scenes/`.
//! Every facet is counter-clockwise seen from outside.

use std::collections::HashMap;
use std::io::Write;
use std::path::PathBuf;

use crate::mesh::{Mesh, MeshError, Origin, Precision};

/// Collects vertices and triangles by part, then checks them into a [`Mesh`] or writes OBJ.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    vertices: Vec<[f64; 3]>,
    triangles: Vec<([u32; 3], u32)>,
    parts: Vec<String>,
}

impl MeshBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// The index of part `name`, added if new.
    pub fn part(&mut self, name: &str) -> u32 {
        match self.parts.iter().position(|p| p == name) {
            Some(i) => i as u32,
            None => {
                self.parts.push(name.to_owned());
                (self.parts.len() - 1) as u32
            }
        }
    }

    /// Adds a vertex, m.
    pub fn vertex(&mut self, p: [f64; 3]) -> u32 {
        self.vertices.push(p);
        (self.vertices.len() - 1) as u32
    }

    /// Adds a triangle (counter-clockwise seen from outside).
    pub fn triangle(&mut self, v: [u32; 3], part: u32) {
        self.triangles.push((v, part));
    }

    /// Adds the quadrilateral `a b c d` (counter-clockwise) as two triangles.
    pub fn quad(&mut self, [a, b, c, d]: [u32; 4], part: u32) {
        self.triangle([a, b, c], part);
        self.triangle([a, c, d], part);
    }

    /// Triangles so far.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// No triangles yet.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Checks the triangles into a mesh labelled `label` (facets numbered from 1).
    pub fn build(&self, label: &str) -> Result<Mesh, MeshError> {
        let tris: Vec<([u32; 3], u32, Origin)> = self
            .triangles
            .iter()
            .enumerate()
            .map(|(k, &(v, p))| (v, p, Origin::Facet(k + 1)))
            .collect();
        Mesh::from_triangles(
            PathBuf::from(label),
            self.vertices.clone(),
            &tris,
            self.parts.clone(),
            Precision::DOUBLE,
        )
    }

    /// Writes Wavefront OBJ: the vertices (shortest round-trip decimals, so a reader gets the
    /// same bits), then one `o` block per part.
    pub fn write_obj<W: Write>(&self, mut w: W, header: &str) -> std::io::Result<()> {
        for line in header.lines() {
            writeln!(w, "# {line}")?;
        }
        for v in &self.vertices {
            writeln!(w, "v {} {} {}", v[0], v[1], v[2])?;
        }
        for (p, name) in self.parts.iter().enumerate() {
            writeln!(w, "o {name}")?;
            for (t, _) in self.triangles.iter().filter(|t| t.1 as usize == p) {
                writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
            }
        }
        Ok(())
    }

    /// An icosphere of `radius` about the origin: the icosahedron with each triangle split
    /// into `4^level` and every vertex pushed out to the sphere (all vertices on it).
    pub fn icosphere(&mut self, radius: f64, level: u32, part: &str) {
        let part = self.part(part);
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut pts: Vec<[f64; 3]> = vec![
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ];
        let unit = |p: [f64; 3]| {
            let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            [p[0] / n, p[1] / n, p[2] / n]
        };
        for p in &mut pts {
            *p = unit(*p);
        }
        let mut faces: Vec<[usize; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..level {
            let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
            let mut next = Vec::with_capacity(faces.len() * 4);
            let mut midpoint = |a: usize, b: usize, pts: &mut Vec<[f64; 3]>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (p, q) = (pts[a], pts[b]);
                    pts.push(unit([p[0] + q[0], p[1] + q[1], p[2] + q[2]]));
                    pts.len() - 1
                })
            };
            for [a, b, c] in faces {
                let ab = midpoint(a, b, &mut pts);
                let bc = midpoint(b, c, &mut pts);
                let ca = midpoint(c, a, &mut pts);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            faces = next;
        }
        let base = self.vertices.len() as u32;
        self.vertices
            .extend(pts.iter().map(|p| [p[0] * radius, p[1] * radius, p[2] * radius]));
        for f in faces {
            self.triangle(f.map(|i| base + i as u32), part);
        }
    }

    /// A rectangle `corner + s u + t v` (`s, t` in [0, 1]) split into `nu x nv` cells, facing
    /// `u x v`.
    pub fn plate(
        &mut self,
        corner: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        (nu, nv): (usize, usize),
        part: &str,
    ) {
        let part = self.part(part);
        let mut id = vec![vec![0u32; nv + 1]; nu + 1];
        for (i, row) in id.iter_mut().enumerate() {
            for (j, slot) in row.iter_mut().enumerate() {
                let (s, t) = (i as f64 / nu as f64, j as f64 / nv as f64);
                *slot = self.vertex([0, 1, 2].map(|k| corner[k] + s * u[k] + t * v[k]));
            }
        }
        for i in 0..nu {
            for j in 0..nv {
                self.quad([id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]], part);
            }
        }
    }

    /// The closed box `[lo, hi]`, each face split into cells of `cells[k]` per edge along
    /// axis `k`.
    pub fn cuboid(&mut self, lo: [f64; 3], hi: [f64; 3], cells: [usize; 3], part: &str) {
        let part = self.part(part);
        // Grid coordinate `i` of axis `k`, computed the same way for every face, so shared
        // edges get bit-identical vertices (welded by the mesh).
        let at = |k: usize, i: usize| lo[k] + (hi[k] - lo[k]) * (i as f64 / cells[k] as f64);
        // (normal axis, side, u axis, w axis) with e_u x e_w pointing outwards.
        let faces = [
            (0, true, 1, 2),
            (0, false, 2, 1),
            (1, true, 2, 0),
            (1, false, 0, 2),
            (2, true, 0, 1),
            (2, false, 1, 0),
        ];
        for (k, high, u, w) in faces {
            let fixed = if high { cells[k] } else { 0 };
            let mut id = vec![vec![0u32; cells[w] + 1]; cells[u] + 1];
            for (i, row) in id.iter_mut().enumerate() {
                for (j, slot) in row.iter_mut().enumerate() {
                    let mut p = [0.0; 3];
                    p[k] = at(k, fixed);
                    p[u] = at(u, i);
                    p[w] = at(w, j);
                    *slot = self.vertex(p);
                }
            }
            for i in 0..cells[u] {
                for j in 0..cells[w] {
                    self.quad([id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]], part);
                }
            }
        }
    }

    /// A closed cylinder along `x` from `x0` to `x1` of `radius`: `segments` around, `rings`
    /// along; the side is part `side`, the two end caps (fans about the axis) part `caps`.
    pub fn cylinder(
        &mut self,
        (x0, x1): (f64, f64),
        radius: f64,
        (segments, rings): (usize, usize),
        side: &str,
        caps: &str,
    ) {
        let (side, caps) = (self.part(side), self.part(caps));
        let mut id = vec![vec![0u32; segments]; rings + 1];
        for (j, row) in id.iter_mut().enumerate() {
            let x = x0 + (x1 - x0) * (j as f64 / rings as f64);
            for (i, slot) in row.iter_mut().enumerate() {
                let a = std::f64::consts::TAU * i as f64 / segments as f64;
                *slot = self.vertex([x, radius * a.cos(), radius * a.sin()]);
            }
        }
        for j in 0..rings {
            for i in 0..segments {
                let n = (i + 1) % segments;
                self.quad([id[j][i], id[j][n], id[j + 1][n], id[j + 1][i]], side);
            }
        }
        let (c0, c1) = (self.vertex([x0, 0.0, 0.0]), self.vertex([x1, 0.0, 0.0]));
        for i in 0..segments {
            let n = (i + 1) % segments;
            self.triangle([c0, id[0][n], id[0][i]], caps);
            self.triangle([c1, id[rings][i], id[rings][n]], caps);
        }
    }
}

/// The bundled target's dimensions and resolution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetSpec {
    /// Hull length along x, m.
    pub length: f64,
    /// Hull radius, m.
    pub radius: f64,
    /// Facets around the hull.
    pub segments: usize,
    /// Rings along the hull.
    pub rings: usize,
    /// Fin cells per metre along each edge.
    pub fin_cells_per_m: f64,
}

impl TargetSpec {
    /// The target in `data/scenes/`: a 4 m hull of 0.5 m radius, 48 x 16 facets, fin cells
    /// of 0.1 m (2,188 facets).
    pub const BUNDLED: TargetSpec = TargetSpec {
        length: 4.0,
        radius: 0.5,
        segments: 48,
        rings: 16,
        fin_cells_per_m: 10.0,
    };

    /// The bundled target refined evenly (hull rings and segments, fin cells) to the first
    /// resolution with at least `facets` facets, for timing.
    pub fn with_facets(facets: usize) -> TargetSpec {
        let b = Self::BUNDLED;
        let mut k = 1.0f64;
        loop {
            let s = TargetSpec {
                segments: (b.segments as f64 * k).round() as usize,
                rings: (b.rings as f64 * k).round() as usize,
                fin_cells_per_m: b.fin_cells_per_m * k,
                ..b
            };
            if s.facets() >= facets {
                return s;
            }
            k *= 1.01;
        }
    }

    /// Facets of [`target`] at this resolution.
    pub fn facets(&self) -> usize {
        let (lo, hi) = fin_box(self);
        let c = fin_cells(self, lo, hi);
        2 * self.segments * self.rings + 2 * self.segments + 4 * (c[0] * c[1] + c[1] * c[2] + c[0] * c[2])
    }
}

/// The fin's box: 1.2 m long (x from -1.8 to -0.6), 0.08 m thick, 0.8 m above the hull's
/// top, its base inside the hull.
fn fin_box(spec: &TargetSpec) -> ([f64; 3], [f64; 3]) {
    let r = spec.radius;
    let base = r * (std::f64::consts::PI / spec.segments as f64).cos() * 0.9;
    ([-1.8, -0.04, base], [-0.6, 0.04, r + 0.8])
}

fn fin_cells(spec: &TargetSpec, lo: [f64; 3], hi: [f64; 3]) -> [usize; 3] {
    [0, 1, 2].map(|k| (((hi[k] - lo[k]) * spec.fin_cells_per_m).ceil() as usize).max(1))
}

/// The bundled target: a cylindrical hull along `x` (part `hull`), flat end caps (`caps`)
/// and a thin fin on top towards the rear (`fin`, a closed box whose base sits inside the
/// hull). The fin shadows the hull and the hull the fin, so occlusion matters at most aspects.
pub fn target(spec: TargetSpec) -> MeshBuilder {
    let mut b = MeshBuilder::new();
    let l = spec.length;
    b.cylinder(
        (-l / 2.0, l / 2.0),
        spec.radius,
        (spec.segments, spec.rings),
        "hull",
        "caps",
    );
    let (lo, hi) = fin_box(&spec);
    let cells = fin_cells(&spec, lo, hi);
    b.cuboid(lo, hi, cells, "fin");
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_facet_count_formula_matches_the_built_target() {
        for spec in [TargetSpec::BUNDLED, TargetSpec::with_facets(5_000)] {
            let m = target(spec).build("target").unwrap();
            assert_eq!(m.facets.len(), spec.facets(), "{spec:?}");
        }
        assert_eq!(TargetSpec::BUNDLED.facets(), 2188);
        assert!(TargetSpec::with_facets(100_000).facets() >= 100_000);
        assert!(TargetSpec::with_facets(100_000).facets() < 103_000);
    }
}
