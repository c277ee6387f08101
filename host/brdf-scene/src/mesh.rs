//! Target meshes: Wavefront OBJ (objects and groups name the parts) or STL, coordinates in
//! metres, facet normals from the winding (counter-clockwise seen from outside), checked
//! before use.
//!
//! Checks, each a [`MeshError`] naming the file and the line (OBJ) or facet number (STL):
//! non-finite coordinates; degenerate facets (zero area, or an angle so thin that the normal
//! is noise); polygons that no fan from one of their vertices triangulates (non-convex or non-planar);
//! inconsistent winding (two facets that run along a shared edge in the same direction, so
//! one of them faces the wrong way); and a closed shell whose facets all face inwards
//! (negative enclosed volume). Vertices at bit-identical positions are welded, so facets of
//! different OBJ objects that share positions are checked across the part boundary too.

use std::collections::HashMap;
use std::fmt;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use thiserror::Error;

/// Largest coordinate magnitude accepted, m: a thousand times the observable universe, and
/// far below where a facet's cross product overflows (about 1e154 m: a plate 2e77 m wide got
/// a zero normal and returned nothing, with no word).
pub const MAX_COORDINATE_M: f64 = 1e30;

/// Smallest accepted `2 A / L^2` of a facet (area `A`, longest edge `L`): about the sine of its
/// smallest angle. Below 1e-10 the cross product that gives the normal has lost all but a
/// few digits of f64 to cancellation, so the facet's normal (and whether a ray hits it) is
/// noise; a real surface has no such facet.
pub const DEGENERATE_SINE: f64 = 1e-10;

/// Two facets facing the same way lie in one plane when every vertex of the smaller is within
/// the pair's in-plane tolerance of the larger's plane: the sum of each facet's
/// `abs_m + rel * scale` ([`Precision`] of the mesh's coordinates; `scale` is the facet's
/// largest coordinate magnitude plus its longest edge), plus a few roundings of f64
/// ([`ARITHMETIC_REL`]) and [`COPLANAR_REL`] of the smaller facet's size. The precision is read from the file: what it writes is one step of
/// the format, and never looser than this (six decimals in metres: rounded by up to 5e-7 m,
/// so a decal on a tilted hull sits up to 1e-6 m off it) and [`COINCIDENT_REL`] (six
/// significant digits, `%g`: 5e-6 of the coordinate). Both are far below a modelled offset: a
/// decal lifted 1 mm off a hull 10 m from the origin is accepted (it then occludes the hull
/// under it).
pub const COINCIDENT_ABS_M: f64 = 1e-6;

/// Relative part of the loosest in-plane tolerance; see [`COINCIDENT_ABS_M`].
pub const COINCIDENT_REL: f64 = 1e-5;

/// Relative error of a distance from a facet's plane computed in f64 (16 roundings): added to
/// every [`Precision`]'s `rel`, and, divided by the facet's `2A/L^2` (about the sine of its
/// smallest angle, which its normal's error grows with), to its longest edge's share.
pub const ARITHMETIC_REL: f64 = 16.0 * f64::EPSILON;

/// How finely a mesh's coordinates are known: a coordinate `c` lies within `abs_m + rel * |c|`
/// (one step of the format it was written in) of where its writer meant it. It sets the
/// in-plane tolerance of the coincidence check ([`COINCIDENT_ABS_M`]).
///
/// A text mesh's is read from its digits ([`Precision::of_text`]): the most decimals and the
/// most significant digits any coordinate is written with, never looser than
/// [`Precision::WRITTEN`] (a file of round numbers keeps that) and never finer than one step
/// of f32 where every coordinate could have been written from an f32 (each lies within half
/// its last written digit of an f32: an f32's shortest decimals, all 17 digits of one widened
/// to f64, or one written to a fixed count of decimals). So survey coordinates written to six decimals, 5e6 m from the origin, are
/// compared within about 1e-5 m, not the 50 m that six significant digits would allow there (a
/// 0.5 m decal lying on a 1 m facet was accepted, and counted twice); written from an f32, they
/// are within about 1 m there, which is what an f32 resolves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Precision {
    /// Absolute part, m.
    pub abs_m: f64,
    /// Relative part (of the coordinate's magnitude).
    pub rel: f64,
}

impl Precision {
    /// The loosest assumed: six decimals in metres and six significant digits.
    pub const WRITTEN: Precision = Precision {
        abs_m: COINCIDENT_ABS_M,
        rel: COINCIDENT_REL,
    };
    /// Single precision (a binary STL): one step of an f32, 2^-23 of the coordinate.
    pub const SINGLE: Precision = Precision {
        abs_m: 0.0,
        rel: f32::EPSILON as f64,
    };
    /// Computed in double precision (a mesh built in memory): only [`ARITHMETIC_REL`].
    pub const DOUBLE: Precision = Precision { abs_m: 0.0, rel: 0.0 };

    /// The precision of coordinates written as `tokens` (decimal text, as an OBJ or ASCII STL
    /// writes them); [`Precision::WRITTEN`] when one is not a plain decimal number.
    pub fn of_text<'a>(tokens: impl IntoIterator<Item = &'a str>) -> Precision {
        let mut d = WrittenDigits::default();
        for t in tokens {
            d.add(t);
        }
        d.precision()
    }
}

/// The digits a text mesh's coordinates are written with, gathered while it is read
/// ([`Precision::of_text`]).
#[derive(Debug)]
struct WrittenDigits {
    /// Most significant digits of a coordinate (`5000000.125` has 10).
    sig: u32,
    /// Most decimals, less the exponent (`1.25e-3` has 5).
    dec: i32,
    /// Every coordinate could have been written from an f32.
    single: bool,
    /// Some coordinate was not a plain decimal (`inf`, hexadecimal, an exponent out of range).
    unread: bool,
    /// Some coordinate was read.
    seen: bool,
}

impl Default for WrittenDigits {
    fn default() -> Self {
        WrittenDigits {
            sig: 0,
            dec: i32::MIN,
            single: true,
            unread: false,
            seen: false,
        }
    }
}

impl WrittenDigits {
    fn add(&mut self, token: &str) {
        let Some((sig, dec)) = written_digits(token) else {
            self.unread = true;
            return;
        };
        self.seen = true;
        self.sig = self.sig.max(sig);
        self.dec = self.dec.max(dec);
        // What an f32 writer prints lies within half its last digit of an f32: its shortest
        // decimals, all 17 digits of it widened to f64, or a fixed count of decimals.
        if self.single {
            let half_step = 0.5 * 10f64.powi(-dec.clamp(-400, 400));
            // (Reading the decimal into f64 rounds it by half an f64 step: an f32 written
            // correctly rounded to a tie, 722.4296875 as `722.429688`, read back 5.0000006e-7
            // off, over half the last digit.)
            self.single = token.parse::<f64>().is_ok_and(|v| {
                (v - f64::from(v as f32)).abs() <= half_step * (1.0 + 1e-9) + 4.0 * f64::EPSILON * v.abs()
            });
        }
    }

    fn precision(&self) -> Precision {
        if self.unread || !self.seen {
            return Precision::WRITTEN;
        }
        let step = |digits: i32| 10f64.powi(digits.clamp(-400, 400));
        let digits_rel = step(1 - self.sig as i32);
        let rel = if self.single {
            digits_rel.max(Precision::SINGLE.rel)
        } else {
            digits_rel
        };
        Precision {
            abs_m: step(-self.dec).min(COINCIDENT_ABS_M),
            rel: rel.min(COINCIDENT_REL),
        }
    }
}

/// `(significant digits, decimals less the exponent)` of a decimal number as written:
/// `5000000.125` gives (10, 3), `-1.50e-3` (3, 5), `0.000000` (0, 6), `5e6` (1, -6); None for
/// what is not one (`inf`, `nan`, hexadecimal, an exponent that does not fit).
fn written_digits(token: &str) -> Option<(u32, i32)> {
    let t = token.strip_prefix(['+', '-']).unwrap_or(token);
    let (mantissa, exp) = match t.find(['e', 'E']) {
        Some(k) => (&t[..k], t[k + 1..].parse::<i32>().ok()?),
        None => (t, 0),
    };
    let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    let digits = || int.bytes().chain(frac.bytes());
    if int.len() + frac.len() == 0 || !digits().all(|b| b.is_ascii_digit()) || exp.abs() > 100_000 {
        return None;
    }
    let sig = digits().skip_while(|&b| b == b'0').count() as u32;
    Some((sig, frac.len() as i32 - exp))
}

/// Two coplanar facets overlap when they interpenetrate deeper than this fraction of the
/// smaller one's size (the square root of its area), and deeper than their in-plane
/// tolerance ([`COINCIDENT_ABS_M`]); wedges about a shared vertex, by this angle (radians).
/// Facets that merely touch along an edge or at a vertex interpenetrate by rounding alone:
/// 1e-16 of their size, the written precision where a vertex lies on a neighbour's edge, or
/// an f32's where the coordinates were computed in f32 and written with more digits than it
/// holds (4e-6 m on 1 m facets 3 km out: such T-junctions were refused). An overlap thinner
/// than this counts a strip of the smaller facet twice that is under 1e-3 of its size wide,
/// which changes its σ by about that fraction.
pub const OVERLAP_REL: f64 = 1e-3;

/// Two facets facing the same way lie in one plane when the smaller's vertices are within
/// this fraction of its size (the square root of its area) of the larger's plane, besides
/// the in-plane tolerance from the coordinates' precision ([`COINCIDENT_ABS_M`]): a few
/// steps of an f32 of the part's own size, which a decal computed in f32 in its part's frame
/// and written with more digits than f32 holds is off by, the digits not showing it. A
/// plate lifted by more (20 µm for one 20 m wide) is apart from the hull, and occludes it (at
/// 1e-4, a 1 mm thick 20 m plate's two sides were refused as lying on each other).
pub const COPLANAR_REL: f64 = 1e-6;

/// A vertex of at least this many facets is a hub (the centre of a fan), whose facets are
/// compared by their wedges around it instead of pairwise through the grid.
pub const HUB_DEGREE: u32 = 32;

/// A closed shell whose signed volume is within this fraction of its bounding box volume of
/// zero encloses nothing (a two-sided sheet, two facets back to back) and has no inside to
/// face; its orientation is not checked.
pub const FLAT_SHELL_VOLUME: f64 = 1e-9;

/// A shell with edges of one facet whose openings enclose, summed by size, within this
/// fraction of its area of nothing still encloses a volume: its openings are cracks of no width
/// (a T-junction, where a vertex lies on another facet's edge; a corner written twice a
/// rounding apart), and its orientation is checked as a closed shell's. An opening is a
/// connected run of such edges, its size the length of its vector area; a real opening's is
/// its projected size (the two ends of a pipe cancel in the sum of the facets' vector areas,
/// and a pipe wound inwards was refused as inside out). The rounding over ten million facets
/// is below 1e-9 of the area.
pub const CRACKED_SHELL_VECTOR_AREA: f64 = 1e-6;

/// The directions along which a group wound inside out has its farthest facets each way
/// tested, besides its first, for being inside the other groups (a cavity,
/// `Mesh::check_winding`): 7 points, each a pass over the groups around it.
pub const EXTREME_DIRECTIONS: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// An open shell whose openings (summed by their vector areas, `Mesh::openings`) are at
/// most this fraction of its own area, and whose volume is negative whatever closes them (by
/// a bound from their rim's length), is refused as inside out: a hull with a few facets
/// missing. Larger openings are a mouth (the inner surface of an exhaust or a bowl, facing
/// into it, is open and accepted).
pub const SMALL_OPENING: f64 = 1e-2;

/// Where a facet came from, for messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// 1-based line of an OBJ file.
    Line(u64),
    /// 1-based facet number (STL, or a mesh built in memory).
    Facet(usize),
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::Line(l) => write!(f, "line {l}"),
            Origin::Facet(k) => write!(f, "facet {k}"),
        }
    }
}

/// Why a mesh was refused.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Io {
        /// Mesh file.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Not a regular file (a device, a directory, a pipe), or larger than [`MAX_MESH_BYTES`].
    #[error("{file}: {why}")]
    NotAMeshFile {
        /// Mesh file.
        file: String,
        /// What it is instead.
        why: String,
    },
    /// Neither `.obj` nor `.stl`.
    #[error("{file}: unknown mesh format (expected .obj or .stl)")]
    Format {
        /// Mesh file.
        file: String,
    },
    /// The OBJ or STL reader refused the file, or a statement is not usable for a target.
    #[error("{file}: {at}: {message}")]
    Parse {
        /// Mesh file.
        file: String,
        /// Where.
        at: Origin,
        /// What is wrong.
        message: String,
    },
    /// The STL reader refused the file (it does not say where).
    #[error("{file}: not a readable STL file: {message}")]
    Stl {
        /// Mesh file.
        file: String,
        /// The reader's message.
        message: String,
    },
    /// No facets.
    #[error("{file}: no facets")]
    Empty {
        /// Mesh file.
        file: String,
    },
    /// A coordinate is NaN or infinite.
    #[error("{file}: {at}: a vertex coordinate is not finite")]
    NotFinite {
        /// Mesh file.
        file: String,
        /// Facet using the vertex.
        at: Origin,
    },
    /// A coordinate is beyond [`MAX_COORDINATE_M`].
    #[error("{file}: {at}: a vertex coordinate {value:e} is beyond {MAX_COORDINATE_M:e} m in magnitude (is the unit right?)")]
    TooFar {
        /// Mesh file.
        file: String,
        /// Facet using the vertex.
        at: Origin,
        /// The coordinate.
        value: f64,
    },
    /// A facet of (nearly) zero area.
    #[error(
        "{file}: {at}: degenerate facet (area {area:e} m^2, 2A/L^2 = {sine:e} below {DEGENERATE_SINE:e}): \
         its normal is undefined; remove it or merge its vertices"
    )]
    Degenerate {
        /// Mesh file.
        file: String,
        /// Where.
        at: Origin,
        /// Its area, m^2.
        area: f64,
        /// `2 A / L^2`.
        sine: f64,
    },
    /// A polygon whose fan triangles do not all face one way.
    #[error(
        "{file}: {at}: polygon of {vertices} vertices is not convex and planar (its fan triangles \
         face different ways, or a vertex lies off its plane): split it into triangles"
    )]
    Polygon {
        /// Mesh file.
        file: String,
        /// Where.
        at: Origin,
        /// Vertex count.
        vertices: usize,
    },
    /// Two facets run along a shared edge in the same direction.
    #[error(
        "{file}: inconsistent winding: {a} and {b} both run from {from:?} to {to:?} along their \
         shared edge, so one of them faces the wrong way (facets are counter-clockwise seen from \
         outside; or the mesh is not manifold there)"
    )]
    Winding {
        /// Mesh file.
        file: String,
        /// First facet.
        a: Origin,
        /// Second facet.
        b: Origin,
        /// Edge start, m.
        from: [f64; 3],
        /// Edge end, m.
        to: [f64; 3],
    },
    /// Two facets facing the same way on the same plane overlap: the surface there would be
    /// counted twice (a decal, or a part exported twice with another triangulation).
    #[error(
        "{file}: {a} and {b} lie on each other, facing the same way (in the same plane, \
         overlapping {depth:.3e} m deep): the surface there would be counted twice; remove one \
         (a decal on a hull must be cut out of it, or lifted off it)"
    )]
    Coincident {
        /// Mesh file.
        file: String,
        /// First facet.
        a: Origin,
        /// Second facet.
        b: Origin,
        /// How far they interpenetrate (the least overlap of their projections on their
        /// edges' normals), m.
        depth: f64,
    },
    /// A shell wound inside out: closed, or with openings too small to change the sign of
    /// its volume.
    #[error(
        "{file}: the shell containing {at} (part `{part}`) encloses a negative volume \
         ({volume:e} m^3, closed or with openings too small to change its sign): its facets \
         are clockwise seen from outside, so every normal points inwards; reverse the vertex \
         order of its facets"
    )]
    Inward {
        /// Mesh file.
        file: String,
        /// A facet of the shell.
        at: Origin,
        /// Its part.
        part: String,
        /// Signed volume, m^3.
        volume: f64,
    },
}

/// One triangle of the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facet {
    /// Vertex indices, counter-clockwise seen from outside.
    pub vertices: [u32; 3],
    /// Index into [`Mesh::parts`].
    pub part: u32,
    /// Outward unit normal (from the winding).
    pub normal: [f64; 3],
    /// Area, m^2.
    pub area: f64,
    /// Centroid, m.
    pub centroid: [f64; 3],
}

/// A checked triangle mesh.
#[derive(Clone)]
pub struct Mesh {
    /// Mesh file (or a label for meshes built in memory).
    pub file: PathBuf,
    /// Welded vertex positions, m.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles.
    pub facets: Vec<Facet>,
    /// Part names, in order of first appearance.
    pub parts: Vec<String>,
    /// Where each facet came from (OBJ line or facet number).
    pub origins: Vec<Origin>,
    /// Per facet: whether its shell is closed (each of its edges shared by exactly two
    /// facets), so the facet faces outwards and, seen from behind, always lies behind a front
    /// face of its own shell (a depth buffer may skip it then).
    pub closed: Vec<bool>,
    /// Per facet: the facet across each of its edges (vertex 0 to 1, 1 to 2, 2 to 0), or
    /// `u32::MAX` where no other facet, or more than one, shares that edge.
    pub neighbours: Vec<[u32; 3]>,
    /// How finely the coordinates are known (read from the file's digits).
    pub precision: Precision,
}

/// The grid the coincidence check compares facets in: cells in levels, each facet in the
/// lowest level where its box is at most two cells wide along each axis (so in at most 3^3
/// cells of it, mostly one or two). Level 0's cells are twice the median facet box along each
/// axis; level `l`'s are as wide as level 0's along each axis, or [`LEVEL_RATIO`]^l times
/// level 0's narrowest side where that is wider ([`Grid::side`]): they grow alike along every
/// axis, so that a wall among flat ground facets (whose median height is their padding, a
/// few mm) rises a few levels to cells about its own height, not to cells 4^l times the
/// ground's in width too (a city of 1.4 million facets took 48 s so, against 1.7 s). One facet far
/// larger than the rest (a ground plate beside a fine target, a facet 1e9 m away) sits in a
/// high level of its own, where cells as wide as it took the whole target into a few cells
/// (`mesh_check_speed`: a 327,680-facet sphere took 85.6 s beside a facet 1e9 m away, 19.6 s
/// above a 2 km ground plate). Level 0 as (cell, facet) pairs sorted by cell: 16 bytes per pair, each cell a key
/// of [`CELL_BITS`] bits per axis where it fits (a map of cells to lists took about 300 bytes
/// per facet), hashed otherwise; the levels above likewise, with a map from cell to its run.
/// Facets `left_out[k]` are not placed (copies of others). Built and sorted on all cores.
fn coincidence_grid(boxes: &[([f64; 3], [f64; 3])], left_out: &[bool]) -> Grid {
    // Twice the median along each axis: a facet then meets about two cells of level 0, not
    // eight. Per axis: cubes as wide as the longest side put a tube of full-length slivers in
    // one cell, and its check took k^2 / 2 pair tests (80,000 facets, 17 s).
    let cell = [0, 1, 2].map(|c| {
        let mut sides: Vec<f64> = boxes.par_iter().map(|(lo, hi)| hi[c] - lo[c]).collect();
        let mid = sides.len() / 2;
        let (_, median, _) = sides.select_nth_unstable_by(mid, f64::total_cmp);
        (2.0 * *median).max(f64::MIN_POSITIVE)
    });
    let mut grid = Grid {
        entries: Vec::new(),
        upper: Vec::new(),
        upper_runs: HashMap::new(),
        level: Vec::new(),
        levels: Vec::new(),
        origin: [0.0; 3],
        cell,
        packed: false,
    };
    grid.level = boxes
        .par_iter()
        .map(|(lo, hi)| {
            let mut l = 0u16;
            while (0..3).any(|c| hi[c] - lo[c] > 2.0 * grid.side(c, l)) {
                l += 1;
            }
            l
        })
        .collect();
    // The origin at level 0's least corner, so that its cells' indices are small enough to
    // pack where they can (the levels above are hashed).
    let (mut origin, mut top) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let ground = if grid.level.contains(&0) { 0 } else { u16::MAX };
    for (b, &l) in boxes.iter().zip(&grid.level) {
        if l == ground || ground == u16::MAX {
            for c in 0..3 {
                origin[c] = origin[c].min(b.0[c]);
                top[c] = top[c].max(b.1[c]);
            }
        }
    }
    grid.origin = origin;
    grid.packed = (0..3).all(|c| grid.index(top[c], c, 0) < 1 << CELL_BITS);
    let placed = |j: usize| left_out.get(j) != Some(&true);
    let cells = |j: usize, level: u16| grid.cells(&boxes[j], level).map(move |key| (key, j as u32));
    let mut entries: Vec<(u64, u32)> = (0..boxes.len())
        .into_par_iter()
        .filter(|&j| placed(j) && grid.level[j] == 0)
        .flat_map_iter(|j| cells(j, 0))
        .collect();
    entries.par_sort_unstable();
    let mut upper: Vec<(u64, u32)> = (0..boxes.len())
        .into_par_iter()
        .filter(|&j| placed(j) && grid.level[j] > 0)
        .flat_map_iter(|j| cells(j, grid.level[j]))
        .collect();
    upper.par_sort_unstable();
    let mut levels: Vec<(u16, [f64; 3], [f64; 3])> = Vec::new();
    for (j, b) in boxes.iter().enumerate() {
        let l = grid.level[j];
        if l == 0 || !placed(j) {
            continue;
        }
        let at = match levels.iter().position(|x| x.0 == l) {
            Some(at) => at,
            None => {
                levels.push((l, [f64::INFINITY; 3], [f64::NEG_INFINITY; 3]));
                levels.len() - 1
            }
        };
        for c in 0..3 {
            levels[at].1[c] = levels[at].1[c].min(b.0[c]);
            levels[at].2[c] = levels[at].2[c].max(b.1[c]);
        }
    }
    levels.sort_by_key(|x| x.0);
    // Each run of a cell sorted along the axis its facets are thinnest along, for the
    // facets below to find those whose boxes may meet theirs by bisection (a fine sphere
    // inside 5,000 stacked plates scanned every plate of its cell for each of its facets).
    let mut upper_runs = HashMap::new();
    let mut start = 0;
    for run in upper.chunk_by_mut(|x, y| x.0 == y.0) {
        let widest = |c: usize| {
            run.iter()
                .map(|&(_, j)| boxes[j as usize].1[c] - boxes[j as usize].0[c])
                .fold(0.0, f64::max)
        };
        let (axis, widest) = (0..3)
            .map(|c| (c, widest(c)))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .unwrap_or((0, 0.0));
        run.sort_unstable_by(|x, y| boxes[x.1 as usize].0[axis].total_cmp(&boxes[y.1 as usize].0[axis]));
        let run_of = UpperRun {
            from: start,
            to: start + run.len(),
            axis,
            widest,
        };
        upper_runs.insert(run[0].0, run_of);
        start += run.len();
    }
    grid.entries = entries;
    grid.upper = upper;
    grid.upper_runs = upper_runs;
    grid.levels = levels;
    grid
}

/// A cell's run of [`Grid::upper`]: its facets sorted by their boxes' least coordinate along
/// `axis`, the axis their boxes are thinnest along (at most `widest`).
struct UpperRun {
    from: usize,
    to: usize,
    axis: usize,
    widest: f64,
}

/// Each level of the coincidence grid's cells up to this many times as wide as the level's
/// below ([`coincidence_grid`], [`Grid::side`]).
const LEVEL_RATIO: f64 = 4.0;

/// The coincidence check's grid ([`coincidence_grid`]).
struct Grid {
    /// Level 0: (cell key, facet), sorted.
    entries: Vec<(u64, u32)>,
    /// The levels above: (cell key, facet), sorted.
    upper: Vec<(u64, u32)>,
    /// Each key's run of [`Grid::upper`].
    upper_runs: HashMap<u64, UpperRun>,
    /// Per facet, its level.
    level: Vec<u16>,
    /// The levels above 0 that hold facets, ascending, each with the box around its facets'
    /// boxes.
    levels: Vec<(u16, [f64; 3], [f64; 3])>,
    /// The boxes' least corner: cell `[i, j, k]` of level `l` begins at
    /// `origin + [i, j, k] * side(l)`.
    origin: [f64; 3],
    /// Level 0's cells' sides.
    cell: [f64; 3],
    /// Level 0's keys packed, not hashed ([`cell_key`]).
    packed: bool,
}

impl Grid {
    /// The side of level `level`'s cells along axis `c`: level 0's, or [`LEVEL_RATIO`]^level
    /// times level 0's narrowest, whichever is wider (the same at every axis from the level
    /// where that passes them all).
    fn side(&self, c: usize, level: u16) -> f64 {
        let narrowest = self.cell[0].min(self.cell[1]).min(self.cell[2]);
        self.cell[c].max(narrowest * LEVEL_RATIO.powi(i32::from(level)))
    }

    /// Index along axis `c` of level `level`'s cell holding coordinate `x`.
    fn index(&self, x: f64, c: usize, level: u16) -> i64 {
        cell_index(x, self.origin[c], self.side(c, level))
    }

    /// The key of level `level`'s cell of indices `i`.
    fn key(&self, i: [u64; 3], level: u16) -> u64 {
        if level == 0 {
            cell_key(i, self.packed)
        } else {
            cell_key([i[0] ^ (u64::from(level) << 48), i[1], i[2]], false)
        }
    }

    /// The key of level `level`'s cell holding point `p`.
    fn key_at(&self, p: [f64; 3], level: u16) -> u64 {
        self.key([0, 1, 2].map(|c| self.index(p[c], c, level) as u64), level)
    }

    /// The keys of level `level`'s cells that box `b` meets.
    fn cells(&self, b: &([f64; 3], [f64; 3]), level: u16) -> impl Iterator<Item = u64> + '_ {
        let range = |c: usize| self.index(b.0[c], c, level)..=self.index(b.1[c], c, level);
        let (ys, zs) = (range(1), range(2));
        range(0).flat_map(move |x| {
            let zs = zs.clone();
            ys.clone().flat_map(move |y| {
                zs.clone()
                    .map(move |z| self.key([x, y, z].map(|i| i as u64), level))
            })
        })
    }
}

/// Of two coincident pairs found (facets `a < b`, depth), the first in facet order.
fn first_pair(x: Option<(usize, usize, f64)>, y: Option<(usize, usize, f64)>) -> Option<(usize, usize, f64)> {
    match (x, y) {
        (Some(p), Some(q)) => Some(if (q.0, q.1) < (p.0, p.1) { q } else { p }),
        (p, q) => p.or(q),
    }
}

/// Bits of a coincidence-grid cell's index along each axis ([`cell_key`]).
const CELL_BITS: u32 = 21;

/// One key for the cell of indices `i`: packed when `packed` (each index below
/// 2^[`CELL_BITS`]), else a hash of the three (cells whose hashes collide share a key: their
/// pairs are tested, never missed, as a pair is tested only where its common box begins).
fn cell_key(i: [u64; 3], packed: bool) -> u64 {
    if packed {
        return (i[0] << (2 * CELL_BITS)) | (i[1] << CELL_BITS) | i[2];
    }
    // SplitMix64's finaliser, folding in one index at a time.
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    mix(mix(mix(i[0]) ^ i[1]) ^ i[2])
}

/// `floor((x - origin) / side)` as an integer, as `f64::floor` then `as i64` give it, without
/// the call to `floor` (which costs more than the rest of a pair's test in the grid).
fn cell_index(x: f64, origin: f64, side: f64) -> i64 {
    let v = (x - origin) / side;
    let t = v as i64;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

impl fmt::Debug for Mesh {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Mesh")
            .field("file", &self.file)
            .field("vertices", &self.vertices.len())
            .field("facets", &self.facets.len())
            .field("parts", &self.parts)
            .finish()
    }
}

/// Vector helpers (f64, 3-D).
pub(crate) mod v3 {
    pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    pub fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
    }
    pub fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
        [a[0] * s, a[1] * s, a[2] * s]
    }
    pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    pub fn norm(a: [f64; 3]) -> f64 {
        dot(a, a).sqrt()
    }
}

impl Mesh {
    /// Reads and checks an OBJ or STL file (by extension).
    /// At most [`MAX_MESH_BYTES`] are read; anything but a regular file is refused unread.
    pub fn load(path: &Path) -> Result<Mesh, MeshError> {
        use std::io::Read;
        let file = path.display().to_string();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("obj" | "stl")) {
            return Err(MeshError::Format { file });
        }
        let io = |source| MeshError::Io {
            file: file.clone(),
            source,
        };
        let not_mesh = |why: String| MeshError::NotAMeshFile {
            file: file.clone(),
            why,
        };
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(not_mesh(
                "not a regular file (a device, directory or pipe)".into(),
            ));
        }
        let too_large = || {
            not_mesh(format!(
                "larger than {} MiB, the most a mesh may be (mesh::MAX_MESH_BYTES)",
                MAX_MESH_BYTES >> 20
            ))
        };
        // Refused unread when its size says so (a 5 GB file was read to 1 GiB first).
        if meta.len() > MAX_MESH_BYTES {
            return Err(too_large());
        }
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .map_err(io)?
            .take(MAX_MESH_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(io)?;
        if bytes.len() as u64 > MAX_MESH_BYTES {
            return Err(too_large()); // grew while being read
        }
        match ext.as_deref() {
            Some("obj") => Self::from_obj(path, without_bom(&bytes)),
            Some("stl") if without_bom(&bytes).starts_with(b"solid") => {
                Self::from_stl(path, without_bom(&bytes))
            }
            Some("stl") => Self::from_stl(path, &bytes),
            _ => Err(MeshError::Format { file }),
        }
    }

    /// Builds and checks a mesh from triangles: `(vertex indices, part index, origin)`, with
    /// coordinates known to `precision` ([`Precision::DOUBLE`] where they were computed).
    /// Vertices at bit-identical positions are welded first.
    pub fn from_triangles(
        file: PathBuf,
        vertices: Vec<[f64; 3]>,
        triangles: &[([u32; 3], u32, Origin)],
        parts: Vec<String>,
        precision: Precision,
    ) -> Result<Mesh, MeshError> {
        let name = file.display().to_string();
        if triangles.is_empty() {
            return Err(MeshError::Empty { file: name });
        }
        // Weld bit-identical positions, -0 and 0 as one (exporters write `-0.000000`: a
        // corner split in two opened a closed shell, and its winding went unchecked).
        // Sorted by position then index, each run's first index stands for the run; ids are
        // given in the order of first use (a hash map of a million positions cost seconds).
        let key = |v: &[f64; 3]| [v[0] + 0.0, v[1] + 0.0, v[2] + 0.0].map(f64::to_bits);
        let mut order: Vec<([u64; 3], u32)> = vertices
            .iter()
            .enumerate()
            .map(|(i, v)| (key(v), i as u32))
            .collect();
        order.par_sort_unstable();
        let mut first = vec![0u32; vertices.len()];
        for run in order.chunk_by(|x, y| x.0 == y.0) {
            for &(_, i) in run {
                first[i as usize] = run[0].1;
            }
        }
        drop(order);
        let mut welded: Vec<[f64; 3]> = Vec::new();
        let mut remap = vec![0u32; vertices.len()];
        for (i, v) in vertices.iter().enumerate() {
            let f = first[i] as usize;
            remap[i] = if f == i {
                welded.push(*v);
                (welded.len() - 1) as u32
            } else {
                remap[f]
            };
        }
        // Each facet on all cores; the first refused, in facet order, is named.
        let facets: Vec<Result<Facet, MeshError>> = triangles
            .par_iter()
            .map(|&(tri, part, at)| {
                let name = || name.clone();
                let ids = tri.map(|i| remap[i as usize]);
                let p = ids.map(|i| welded[i as usize]);
                if p.iter().flatten().any(|c| !c.is_finite()) {
                    return Err(MeshError::NotFinite { file: name(), at });
                }
                if let Some(&value) = p.iter().flatten().find(|c| c.abs() > MAX_COORDINATE_M) {
                    return Err(MeshError::TooFar {
                        file: name(),
                        at,
                        value,
                    });
                }
                let c = v3::cross(v3::sub(p[1], p[0]), v3::sub(p[2], p[0]));
                let twice_area = v3::norm(c);
                let longest = [v3::sub(p[1], p[0]), v3::sub(p[2], p[1]), v3::sub(p[0], p[2])]
                    .iter()
                    .map(|e| v3::dot(*e, *e))
                    .fold(0.0, f64::max);
                let sine = if longest > 0.0 { twice_area / longest } else { 0.0 };
                if !(twice_area > 0.0 && sine >= DEGENERATE_SINE)
                    || ids[0] == ids[1]
                    || ids[1] == ids[2]
                    || ids[0] == ids[2]
                {
                    return Err(MeshError::Degenerate {
                        file: name(),
                        at,
                        area: twice_area / 2.0,
                        sine,
                    });
                }
                Ok(Facet {
                    vertices: ids,
                    part,
                    normal: v3::scale(c, 1.0 / twice_area),
                    area: twice_area / 2.0,
                    centroid: v3::scale(v3::add(v3::add(p[0], p[1]), p[2]), 1.0 / 3.0),
                })
            })
            .collect();
        let facets = facets.into_iter().collect::<Result<Vec<Facet>, MeshError>>()?;
        let origins = triangles.iter().map(|t| t.2).collect();
        let mut mesh = Mesh {
            file,
            vertices: welded,
            facets,
            parts,
            origins,
            closed: Vec::new(),
            neighbours: Vec::new(),
            precision,
        };
        (mesh.closed, mesh.neighbours) = mesh.check_winding()?;
        mesh.check_coincident()?;
        Ok(mesh)
    }

    /// Smallest axis-aligned box around the vertices: (min, max), m.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        (lo, hi)
    }

    /// Length of the bounding box diagonal, m.
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        v3::norm(v3::sub(hi, lo))
    }

    /// No two facets facing the same way overlap in the same plane ([`COINCIDENT_ABS_M`],
    /// [`COINCIDENT_REL`], [`OVERLAP_REL`]). Facets are binned by their boxes (padded by their
    /// tolerance) in a grid of cells in levels, each facet in cells about its own size
    /// ([`coincidence_grid`]), and only pairs whose boxes meet in a cell are compared, each
    /// pair once. Planes are compared locally (each facet's vertices
    /// against the other's plane), never by their offsets from the coordinate origin, where a
    /// normal rounded by 1e-4 moves a plane 5 m from the origin by 0.5 mm.
    ///
    /// Cost: about linear in the facet count, whatever the spread of facet sizes (cells in
    /// levels, [`coincidence_grid`]); copies of a facet (the same three vertices, wound alike)
    /// are found by sorting, and the later ones left out; a fan of slivers around one vertex
    /// is compared by its wedges; pairs after the first found in facet order are not tried.
    fn check_coincident(&self) -> Result<(), MeshError> {
        let corners = |f: &Facet| f.vertices.map(|i| self.vertices[i as usize]);
        let tol: Vec<f64> = self
            .facets
            .par_iter()
            .map(|f| self.in_plane_tolerance(f))
            .collect();
        let boxes: Vec<([f64; 3], [f64; 3])> = self
            .facets
            .par_iter()
            .zip(&tol)
            .map(|(f, &t)| {
                let p = corners(f);
                let t = t + COPLANAR_REL * f.area.sqrt();
                let lo = [0, 1, 2].map(|c| p[0][c].min(p[1][c]).min(p[2][c]) - t);
                let hi = [0, 1, 2].map(|c| p[0][c].max(p[1][c]).max(p[2][c]) + t);
                (lo, hi)
            })
            .collect();
        // Copies: facets on the same three welded vertices in the same order (a part written
        // twice, stacked copies). Of each set the first two are compared, and the others are
        // left out of the grid: a pair with a later copy has the same outcome as the pair with
        // the first ([`Mesh::overlap`]), which comes no later in facet order (4,000 stacked copies of a box put
        // 48,000 facets around 8 hubs and in a few cells: 6.7 s to refuse).
        let mut copies: Vec<([u32; 3], u32)> = self
            .facets
            .par_iter()
            .enumerate()
            .map(|(k, f)| (f.vertices, k as u32))
            .collect();
        copies.par_sort_unstable();
        let mut left_out = vec![false; self.facets.len()];
        let mut first_copies = Vec::new();
        for run in copies.chunk_by(|x, y| x.0 == y.0).filter(|r| r.len() > 1) {
            first_copies.push((run[0].1 as usize, run[1].1 as usize));
            for &(_, k) in &run[1..] {
                left_out[k as usize] = true;
            }
        }
        drop(copies);
        let grid = coincidence_grid(&boxes, &left_out);
        // The first pair found so far in facet order, `a << 32 | b` (`u64::MAX`: none): pairs
        // after it are not tried.
        let best = std::sync::atomic::AtomicU64::new(u64::MAX);
        let order = |a: usize, b: usize| ((a.min(b) as u64) << 32) | a.max(b) as u64;
        let passed = |a: usize, b: usize| order(a, b) >= best.load(std::sync::atomic::Ordering::Relaxed);
        // The full test of a pair; the first pair in facet order is named, whatever order the
        // pairs are met in.
        let test = |a: usize, b: usize, found: &mut Option<(usize, usize, f64)>| {
            let (a, b) = (a.min(b), a.max(b));
            if passed(a, b) {
                return;
            }
            if let Some(depth) = self.overlap(a, b, tol[a] + tol[b]) {
                *found = first_pair(*found, Some((a, b, depth)));
                best.fetch_min(order(a, b), std::sync::atomic::Ordering::Relaxed);
            }
        };
        let mut found: Option<(usize, usize, f64)> = None;
        for &(a, b) in &first_copies {
            test(a, b, &mut found);
        }
        // Hubs: vertices of many facets (the centre of a fan). Their facets share one cell,
        // so pairs of them are found instead by sorting the facets' wedges at the hub by angle
        // (projected on the plane across the facets' mean normal; a facet more than 60
        // degrees off it keeps to the grid): only wedges that overlap there are tested.
        let mut degree = vec![0u32; self.vertices.len()];
        let mut mean = vec![[0.0; 3]; self.vertices.len()];
        for (_, f) in self.facets.iter().enumerate().filter(|&(k, _)| !left_out[k]) {
            for v in f.vertices {
                degree[v as usize] += 1;
                mean[v as usize] = v3::add(mean[v as usize], v3::scale(f.normal, f.area));
            }
        }
        let hub_of: Vec<u32> = self
            .facets
            .iter()
            .map(|f| {
                f.vertices
                    .into_iter()
                    .filter(|&v| {
                        let m = mean[v as usize];
                        degree[v as usize] >= HUB_DEGREE && v3::dot(m, f.normal) >= 0.5 * v3::norm(m)
                    })
                    .max_by_key(|&v| (degree[v as usize], std::cmp::Reverse(v)))
                    .unwrap_or(u32::MAX)
            })
            .collect();
        let mut at_hub: HashMap<u32, Vec<usize>> = HashMap::new();
        for (k, &h) in hub_of.iter().enumerate() {
            if h != u32::MAX && !left_out[k] {
                at_hub.entry(h).or_default().push(k);
            }
        }
        for (&h, members) in &at_hub {
            let m = mean[h as usize];
            let [u, w] = plane_frame(v3::scale(m, 1.0 / v3::norm(m)));
            let centre = self.vertices[h as usize];
            let angle = |k: u32| {
                let d = v3::sub(self.vertices[k as usize], centre);
                v3::dot(d, w).atan2(v3::dot(d, u))
            };
            // (start, width) of each wedge, counter-clockwise seen along the mean normal.
            let tau = std::f64::consts::TAU;
            let mut wedges: Vec<(f64, f64, usize)> = members
                .iter()
                .map(|&k| {
                    let v = self.facets[k].vertices;
                    let i = (0..3).position(|i| v[i] == h).unwrap_or(0);
                    let start = angle(v[(i + 1) % 3]).rem_euclid(tau);
                    let width = (angle(v[(i + 2) % 3]) - start).rem_euclid(tau);
                    (start, width, k)
                })
                .collect();
            wedges.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.2.cmp(&y.2)));
            let n = wedges.len();
            for i in 0..n {
                let (start, width, a) = wedges[i];
                // Wedges that begin inside this one (going round once): overlapping pairs.
                for step in 1..n {
                    let (s, _, b) = wedges[(i + step) % n];
                    let ahead = (s - start).rem_euclid(tau);
                    if ahead >= width - OVERLAP_REL {
                        break;
                    }
                    test(a, b, &mut found);
                }
            }
        }
        // The pairs of one cell's run of level 0's (key, facet) entries, each tested where
        // the pair's common box begins (each pair once).
        let in_run = |list: &mut Vec<(u32, usize)>, members: &[(u64, u32)]| {
            let mut found = None;
            let at = members[0].0;
            // Facets of one hub were compared above: each facet meets only those of other
            // hubs. Facets of no hub come last, in facet order.
            list.clear();
            list.extend(members.iter().map(|&(_, k)| (hub_of[k as usize], k as usize)));
            list.sort_unstable();
            let mut run_end = 0;
            for (i, &(ha, a)) in list.iter().enumerate() {
                if ha == u32::MAX && ((a as u64) << 32) >= best.load(std::sync::atomic::Ordering::Relaxed) {
                    break; // every pair left comes after the first found
                }
                if i >= run_end {
                    run_end = i + list[i..].iter().take_while(|e| e.0 == ha).count();
                }
                let from = if ha == u32::MAX { i + 1 } else { run_end };
                for &(_, b) in &list[from..] {
                    if passed(a, b) {
                        continue;
                    }
                    let (ba, bb) = (&boxes[a], &boxes[b]);
                    let start = [0, 1, 2].map(|c| ba.0[c].max(bb.0[c]));
                    // Boxes apart, or the pair is met again in the cell where their common
                    // box begins (tested there only).
                    if (0..3).any(|c| start[c] > ba.1[c].min(bb.1[c])) || grid.key_at(start, 0) != at {
                        continue;
                    }
                    test(a, b, &mut found);
                }
            }
            found
        };
        // A cell of the levels above: its facets sorted along the axis they are thinnest
        // along ([`UpperRun`]), each compared with those after it that begin before its end
        // there (a tube of 80,000 full-length slivers beside finer facets sits in a few such
        // cubes, and was compared all against all).
        let in_upper_run = |members: &[(u64, u32)]| {
            let mut found = None;
            let at = members[0].0;
            let axis = grid.upper_runs.get(&at).map_or(0, |r| r.axis);
            for (i, &(_, a)) in members.iter().enumerate() {
                let (a, ba) = (a as usize, &boxes[a as usize]);
                for &(_, b) in &members[i + 1..] {
                    let (b, bb) = (b as usize, &boxes[b as usize]);
                    if bb.0[axis] > ba.1[axis] {
                        break; // this one and those after begin beyond a's end
                    }
                    let (level, ha) = (grid.level[a], hub_of[a]);
                    if grid.level[b] != level || (hub_of[b] == ha && ha != u32::MAX) || passed(a, b) {
                        continue;
                    }
                    let start = [0, 1, 2].map(|c| ba.0[c].max(bb.0[c]));
                    if (0..3).any(|c| start[c] > ba.1[c].min(bb.1[c])) || grid.key_at(start, level) != at {
                        continue;
                    }
                    test(a, b, &mut found);
                }
            }
            found
        };
        // Cells in parallel, each keeping the first pair it finds in facet order.
        let in_cells = first_pair(
            grid.entries
                .par_chunk_by(|x, y| x.0 == y.0)
                .map_init(Vec::new, |list, members| in_run(list, members))
                .reduce(|| None, first_pair),
            grid.upper
                .par_chunk_by(|x, y| x.0 == y.0)
                .map(in_upper_run)
                .reduce(|| None, first_pair),
        );
        // Each facet against those of the levels above its own, in their cells it meets.
        let across = (0..self.facets.len())
            .into_par_iter()
            .filter(|&a| !left_out[a])
            .map(|a| {
                let mut found = None;
                let ba = &boxes[a];
                let meets =
                    |lo: &[f64; 3], hi: &[f64; 3]| (0..3).all(|c| ba.0[c] <= hi[c] && lo[c] <= ba.1[c]);
                for (level, lo, hi) in &grid.levels {
                    if *level <= grid.level[a] || !meets(lo, hi) {
                        continue;
                    }
                    for key in grid.cells(ba, *level) {
                        let Some(run) = grid.upper_runs.get(&key) else {
                            continue;
                        };
                        // Only boxes beginning between a's start less the widest and a's end
                        // along the run's axis may meet a's.
                        let members = &grid.upper[run.from..run.to];
                        let lo_of = |e: &(u64, u32)| boxes[e.1 as usize].0[run.axis];
                        // (Less a margin for rounding: leaving out fewer only costs tests.)
                        let margin = (ba.0[run.axis].abs() + run.widest) * 1e-12;
                        let first =
                            members.partition_point(|e| lo_of(e) < ba.0[run.axis] - run.widest - margin);
                        let near = members[first..].iter().take_while(|e| lo_of(e) <= ba.1[run.axis]);
                        for &(_, b) in near {
                            let b = b as usize;
                            let (ha, hb) = (hub_of[a], hub_of[b]);
                            if grid.level[b] != *level || (ha == hb && ha != u32::MAX) || passed(a, b) {
                                continue;
                            }
                            let bb = &boxes[b];
                            let start = [0, 1, 2].map(|c| ba.0[c].max(bb.0[c]));
                            if (0..3).any(|c| start[c] > ba.1[c].min(bb.1[c]))
                                || grid.key_at(start, *level) != key
                            {
                                continue;
                            }
                            test(a, b, &mut found);
                        }
                    }
                }
                found
            })
            .reduce(|| None, first_pair);
        let in_cells = first_pair(in_cells, across);
        match first_pair(found, in_cells) {
            Some((a, b, depth)) => Err(MeshError::Coincident {
                file: self.file.display().to_string(),
                a: self.origins[a],
                b: self.origins[b],
                depth,
            }),
            None => Ok(()),
        }
    }

    /// A facet's in-plane tolerance ([`COINCIDENT_ABS_M`], [`Precision`], [`ARITHMETIC_REL`]).
    fn in_plane_tolerance(&self, f: &Facet) -> f64 {
        let p = f.vertices.map(|i| self.vertices[i as usize]);
        let far = p.iter().flatten().fold(0.0_f64, |m, c| m.max(c.abs()));
        let edge = (0..3)
            .map(|k| v3::norm(v3::sub(p[(k + 1) % 3], p[k])))
            .fold(0.0, f64::max);
        let sine = 2.0 * f.area / (edge * edge);
        let Precision { abs_m, rel } = self.precision;
        abs_m + (rel + ARITHMETIC_REL) * (far + edge) + ARITHMETIC_REL * edge / sine
    }

    /// How deep facets `a` and `b` overlap when they lie on each other, facing the same way
    /// within `t` (their tolerances summed) of each other's plane ([`Mesh::check_coincident`]).
    fn overlap(&self, a: usize, b: usize, t: f64) -> Option<f64> {
        // Compared in the plane of the larger (then by its vertices), not of the first in
        // the file: the outcome is then the same for every copy of a facet, which the check
        // relies on to compare the first copy only.
        let key = |f: &Facet| (f.area, f.vertices);
        let (fa, fb) = (&self.facets[a], &self.facets[b]);
        let (fa, fb) = match key(fa).0.total_cmp(&key(fb).0).then(key(fa).1.cmp(&key(fb).1)) {
            std::cmp::Ordering::Less => (fb, fa),
            _ => (fa, fb),
        };
        if v3::dot(fa.normal, fb.normal) <= 0.0 {
            return None;
        }
        let corners = |f: &Facet| f.vertices.map(|i| self.vertices[i as usize]);
        let (pa, pb) = (corners(fa), corners(fb));
        // In one plane first (neighbours on a curved surface are not): the smaller's vertices
        // in the larger's plane, whose normal is the better known (the larger's vertices
        // against the smaller's plane, extrapolated, missed a 1 cm decal on a 100 m facet),
        // then apart at a shared vertex (the slivers of a fan), then the full test.
        let size = fa.area.min(fb.area).sqrt();
        let near = t + COPLANAR_REL * size;
        if !pb
            .iter()
            .all(|v| v3::dot(v3::sub(*v, pa[0]), fa.normal).abs() <= near)
        {
            return None;
        }
        let [u, w] = plane_frame(fa.normal);
        let flat = |v: [f64; 3]| {
            let d = v3::sub(v, pa[0]);
            [v3::dot(d, u), v3::dot(d, w)]
        };
        if apart_at_shared_vertex(fa.vertices, fb.vertices, |k| flat(self.vertices[k as usize])) {
            return None;
        }
        let depth = overlap_depth(&pa.map(flat), &pb.map(flat));
        (depth > (OVERLAP_REL * size).max(t)).then_some(depth)
    }

    /// Consistent winding across shared edges; closed shells face outwards. An edge shared by
    /// exactly two facets must be run in opposite directions by them; an edge of three or more
    /// facets (a sheet welded onto a body along an edge) is not manifold, and its shells are
    /// treated as open. Returns whether each facet's shell is closed.
    fn check_winding(&self) -> Result<(Vec<bool>, Vec<[u32; 3]>), MeshError> {
        let file = || self.file.display().to_string();
        let edges = |f: &Facet| {
            let v = f.vertices;
            [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])]
        };
        // Each facet's edge `e` is use `3k + e`. Sorted by undirected edge then use, each run
        // is one edge: how many facets use it, and its first use (first facet, its direction).
        let n = self.facets.len();
        let mut order: Vec<(u64, u32)> = Vec::with_capacity(3 * n);
        for (k, f) in self.facets.iter().enumerate() {
            for (e, (a, b)) in edges(f).into_iter().enumerate() {
                let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
                order.push((key, (3 * k + e) as u32));
            }
        }
        order.par_sort_unstable();
        let mut uses = vec![0u32; 3 * n];
        let mut first_use = vec![0u32; 3 * n];
        let mut neighbours = vec![[u32::MAX; 3]; n];
        for run in order.chunk_by(|x, y| x.0 == y.0) {
            for &(_, u) in run {
                uses[u as usize] = run.len() as u32;
                first_use[u as usize] = run[0].1;
            }
            if let [(_, u), (_, w)] = *run {
                neighbours[u as usize / 3][u as usize % 3] = w / 3;
                neighbours[w as usize / 3][w as usize % 3] = u / 3;
            }
        }
        let edge_of = |u: u32| edges(&self.facets[u as usize / 3])[u as usize % 3];
        for (k, f) in self.facets.iter().enumerate() {
            for (e, (a, b)) in edges(f).into_iter().enumerate() {
                let u = 3 * k + e;
                let (uses, first, dir) = (uses[u], first_use[u] as usize / 3, edge_of(first_use[u]));
                if uses == 2 && first != k && dir == (a, b) {
                    return Err(MeshError::Winding {
                        file: file(),
                        a: self.origins[first],
                        b: self.origins[k],
                        from: self.vertices[a as usize],
                        to: self.vertices[b as usize],
                    });
                }
            }
        }
        // Shells: facets connected through edges of two facets (union-find). An edge of three
        // or more (a flap welded onto a box along an edge, two boxes touching along one) joins
        // none: the box is a shell of its own, closed if it uses that edge twice itself (it
        // was one open shell with the flap, and went unchecked when wound inside out).
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for (k, across) in neighbours.iter().enumerate() {
            for &j in across.iter().filter(|&&j| j != u32::MAX) {
                let (ra, rb) = (root(&mut parent, k), root(&mut parent, j as usize));
                if ra != rb {
                    parent[ra] = rb;
                }
            }
        }
        let shell: Vec<usize> = (0..n).map(|k| root(&mut parent, k)).collect();
        // Uses of an edge of three or more facets that close their shell: the shell's own two
        // uses of it, which must run opposite ways.
        let mut closing = vec![false; 3 * n];
        for run in order.chunk_by(|x, y| x.0 == y.0).filter(|r| r.len() > 2) {
            let mut by_shell: Vec<(usize, u32)> =
                run.iter().map(|&(_, u)| (shell[u as usize / 3], u)).collect();
            by_shell.sort_unstable();
            for same in by_shell.chunk_by(|x, y| x.0 == y.0) {
                if let [(_, u), (_, w)] = *same {
                    if edge_of(u) == edge_of(w) {
                        let (a, b) = edge_of(w);
                        return Err(MeshError::Winding {
                            file: file(),
                            a: self.origins[(u as usize / 3).min(w as usize / 3)],
                            b: self.origins[(u as usize / 3).max(w as usize / 3)],
                            from: self.vertices[a as usize],
                            to: self.vertices[b as usize],
                        });
                    }
                    closing[u as usize] = true;
                    closing[w as usize] = true;
                }
            }
        }
        drop(order);
        let open_use = |u: usize| uses[u] != 2 && !closing[u];
        // Facets with an edge its shell does not close.
        let open_facet: Vec<bool> = (0..n).map(|k| (3 * k..3 * k + 3).any(open_use)).collect();
        let mut open = vec![false; n];
        for k in 0..n {
            open[shell[k]] |= open_facet[k];
        }
        // Pieces: facets connected through shared vertices. A shell cut apart by cracks (a
        // cube's top meeting its sides only at T-junctions) is two shells, neither enclosing
        // anything alone, but one piece that does.
        let mut piece_parent: Vec<usize> = (0..n).collect();
        let mut first_at = vec![usize::MAX; self.vertices.len()];
        for (k, f) in self.facets.iter().enumerate() {
            for v in f.vertices {
                let first = &mut first_at[v as usize];
                if *first == usize::MAX {
                    *first = k;
                } else {
                    let (ra, rb) = (root(&mut piece_parent, k), root(&mut piece_parent, *first));
                    if ra != rb {
                        piece_parent[ra] = rb;
                    }
                }
            }
        }
        let piece: Vec<usize> = (0..n).map(|k| root(&mut piece_parent, k)).collect();
        // The uses of edges their shell does not close: (facet, from, to).
        let boundary: Vec<(usize, u32, u32)> = (0..3 * n)
            .filter(|&u| open_use(u))
            .map(|u| {
                let (a, b) = edge_of(u as u32);
                (u / 3, a, b)
            })
            .collect();
        // Closed shells and cracked ones are checked; of the pieces, those with an opening.
        for (group, open_only) in [(&shell, false), (&piece, true)] {
            if let Some((first, volume)) = self.inward_group(group, &open_facet, &boundary, open_only) {
                return Err(MeshError::Inward {
                    file: file(),
                    at: self.origins[first],
                    part: self.parts[self.facets[first].part as usize].clone(),
                    volume,
                });
            }
        }
        let closed = (0..n).map(|k| !open[shell[k]]).collect();
        Ok((closed, neighbours))
    }

    /// The first group (facets `k` of group `group[k]`, the group's root) that encloses a
    /// negative volume and is no cavity: its first facet in file order and the volume. A group
    /// is checked when it is closed (no facet in `open_facet`), unless `open_only`, or when it
    /// has openings that are only cracks ([`CRACKED_SHELL_VECTOR_AREA`]) or too small to make
    /// its volume positive. A cavity (a hollow in a solid, its faces turned into the hollow)
    /// encloses a negative volume rightly: a group is one when the other enclosing groups (closed
    /// or nearly, facing out) wind about points of it ([`EXTREME_DIRECTIONS`]) at least once
    /// each ([`winding_number`]); only groups whose boxes hold its box are summed, so a solid
    /// with cavities costs up to 7 passes over its facets per cavity.
    fn inward_group(
        &self,
        group: &[usize],
        open_facet: &[bool],
        boundary: &[(usize, u32, u32)],
        open_only: bool,
    ) -> Option<(usize, f64)> {
        let n = self.facets.len();
        let mut open = vec![false; n];
        let mut volume = vec![0.0f64; n];
        // Per group: its facets' area, and the summed sizes of its openings.
        let mut area = vec![0.0f64; n];
        let openings = self.openings(group, boundary);
        // Per group: the length of its open edges.
        let mut rim = vec![0.0f64; n];
        for &(k, a, b) in boundary {
            rim[group[k]] += v3::norm(v3::sub(self.vertices[b as usize], self.vertices[a as usize]));
        }
        let mut lo = vec![[f64::INFINITY; 3]; n];
        let mut hi = vec![[f64::NEG_INFINITY; 3]; n];
        // The signed volume about a point of each group, not about the origin: at geocentric
        // coordinates (6.4e6 m) the terms about the origin cancel to rounding noise larger
        // than a small shell's volume (a 0.5 m cube read as -1.35 m^3, its inverse as
        // positive).
        let mut anchor: Vec<Option<[f64; 3]>> = vec![None; n];
        for (k, f) in self.facets.iter().enumerate() {
            let r = group[k];
            let p = f.vertices.map(|i| self.vertices[i as usize]);
            let o = *anchor[r].get_or_insert(p[0]);
            let q = p.map(|x| v3::sub(x, o));
            volume[r] += v3::dot(q[0], v3::cross(q[1], q[2])) / 6.0;
            area[r] += f.area;
            for q in p {
                for c in 0..3 {
                    lo[r][c] = lo[r][c].min(q[c]);
                    hi[r][c] = hi[r][c].max(q[c]);
                }
            }
            open[r] |= open_facet[k];
        }
        // Closed, cracked only, or with small openings and a positive volume (the outer wall
        // of a hollow with a port, its inner wall facing into the hollow a cavity of it).
        let encloses = |k: usize| {
            !open[k]
                || openings[k] <= CRACKED_SHELL_VECTOR_AREA * area[k]
                || (openings[k] <= SMALL_OPENING * area[k] && volume[k] > 0.0)
        };
        // Open, but inside out whatever closes it: any surface spanning open edges of length
        // `P` (a cone from one of their vertices) has an area below `P^2 / 4`, and changes the
        // volume about a point of the group by at most a third of that times the group's
        // diagonal. The bundled target wound inside out, with two facets taken out, was
        // accepted as an open sheet (sigma near 0 at every aspect).
        // Only where the openings are small beside the shell ([`SMALL_OPENING`], by their
        // vector areas): a cavity's inner surface, facing into it, is open at a mouth (an
        // exhaust seen alone).
        let inside_out_anyway = |k: usize| {
            let diagonal = v3::norm(v3::sub(hi[k], lo[k]));
            let cap = rim[k] * rim[k] / 4.0;
            openings[k] <= SMALL_OPENING * area[k] && -volume[k] > cap * diagonal / 3.0
        };
        // Each group's facets, in file order.
        let mut members_of: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (k, &g) in group.iter().enumerate() {
            members_of[g].push(k);
        }
        let roots: Vec<usize> = (0..n).filter(|&k| group[k] == k).collect();
        (0..n).find_map(|k| {
            let checked = if open[k] {
                encloses(k) || inside_out_anyway(k)
            } else {
                !open_only
            };
            if group[k] != k || !checked {
                return None;
            }
            let extent = v3::sub(hi[k], lo[k]);
            let box_volume = extent[0] * extent[1] * extent[2];
            if volume[k] >= -FLAT_SHELL_VOLUME * box_volume {
                return None;
            }
            // The first facet of the group in file order is named. A cavity lies inside the
            // other groups all over, not only at its first facet (a fin wound inside out and
            // pushed through a hull was taken for a cavity so).
            let members = &members_of[k];
            let first = members[0];
            // Its points: its first facet's, and its facets' farthest out each way along the
            // axes (a fin pushed through a hull, its top outside, had its first facet inside).
            let mut points = vec![first];
            for d in EXTREME_DIRECTIONS {
                let along = |j: &usize| v3::dot(self.facets[*j].centroid, d);
                points.extend(members.iter().max_by(|x, y| along(x).total_cmp(&along(y))));
                points.extend(members.iter().min_by(|x, y| along(x).total_cmp(&along(y))));
            }
            points.sort_unstable();
            points.dedup();
            // The groups around it hold its box.
            let holds = |r: usize| (0..3).all(|c| lo[r][c] <= lo[k][c] && hi[k][c] <= hi[r][c]);
            let around: Vec<usize> = roots
                .iter()
                .filter(|&&r| r != k && holds(r) && encloses(r))
                .flat_map(|&r| members_of[r].iter().copied())
                .collect();
            let cavity = !around.is_empty()
                && points
                    .iter()
                    .all(|&j| self.winding_number(&around, self.facets[j].centroid) >= 0.5);
            (!cavity).then_some((first, volume[k]))
        })
    }

    /// Per group (indexed by its root, as `group`), the summed sizes of its openings: the
    /// lengths of the vector areas of the connected runs of `boundary` edges (uses of edges not
    /// shared by exactly two facets: facet, from, to) that touch it, each about a point of its
    /// own.
    fn openings(&self, group: &[usize], boundary: &[(usize, u32, u32)]) -> Vec<f64> {
        let mut parent: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
        fn root(p: &mut std::collections::HashMap<u32, u32>, mut v: u32) -> u32 {
            loop {
                let u = *p.entry(v).or_insert(v);
                if u == v {
                    return v;
                }
                let w = *p.entry(u).or_insert(u);
                p.insert(v, w);
                v = w;
            }
        }
        for &(_, a, b) in boundary {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            if ra != rb {
                parent.insert(ra, rb);
            }
        }
        // Each run's vector area, about its root vertex.
        let mut run_area: std::collections::HashMap<u32, [f64; 3]> = std::collections::HashMap::new();
        let mut touches: Vec<(usize, u32)> = Vec::with_capacity(boundary.len());
        for &(k, a, b) in boundary {
            let r = root(&mut parent, a);
            let o = self.vertices[r as usize];
            let (pa, pb) = (
                v3::sub(self.vertices[a as usize], o),
                v3::sub(self.vertices[b as usize], o),
            );
            let s = run_area.entry(r).or_insert([0.0; 3]);
            *s = v3::add(*s, v3::scale(v3::cross(pa, pb), 0.5));
            touches.push((group[k], r));
        }
        touches.sort_unstable();
        touches.dedup();
        let mut out = vec![0.0; group.len()];
        for (g, r) in touches {
            out[g] += v3::norm(run_area[&r]);
        }
        out
    }

    /// How many times `facets` wind about `p`: the sum of the solid angles they subtend at it
    /// (Van Oosterom and Strackee's formula), over 4 pi. 1 inside a closed shell wound
    /// outwards, 0 outside, -1 inside one wound inwards; near those values for shells with
    /// cracks.
    fn winding_number(&self, facets: &[usize], p: [f64; 3]) -> f64 {
        let solid_angle = |&k: &usize| {
            let r = self.facets[k]
                .vertices
                .map(|i| v3::sub(self.vertices[i as usize], p));
            let l = r.map(v3::norm);
            let num = v3::dot(r[0], v3::cross(r[1], r[2]));
            let den = l[0] * l[1] * l[2]
                + v3::dot(r[0], r[1]) * l[2]
                + v3::dot(r[0], r[2]) * l[1]
                + v3::dot(r[1], r[2]) * l[0];
            2.0 * num.atan2(den)
        };
        // On all cores only where there is enough to share (20,000 cavities in a box asked
        // 600,000 times for 12 facets: 13 s of waking threads).
        let sum = if facets.len() < 4096 {
            facets.iter().map(solid_angle).sum::<f64>()
        } else {
            facets.par_iter().map(solid_angle).sum::<f64>()
        };
        sum / (4.0 * std::f64::consts::PI)
    }

    /// OBJ through `tobj`, with line numbers for every facet and every reader error.
    fn from_obj(path: &Path, bytes: &[u8]) -> Result<Mesh, MeshError> {
        let file = path.display().to_string();
        let options = tobj::LoadOptions {
            triangulate: false,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        };
        // The face lines are found while the OBJ reader reads (two passes over the bytes, on
        // two cores); the scan's refusals come first, as they would read alone.
        let (face_lines, models) = rayon::join(
            || scan_obj_faces(&file, bytes),
            || {
                let mut reader = LineCounter { data: bytes, pos: 0 };
                // Materials (`mtllib`) carry colours for renderers; the scene file gives the
                // BRDFs.
                tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default()))
                    .map(|(models, _)| models)
                    .map_err(|e| MeshError::Parse {
                        file: file.clone(),
                        at: Origin::Line(reader.line()),
                        message: format!("the OBJ reader refused it: {e}"),
                    })
            },
        );
        // Both refusing: the earlier line is named.
        if let (
            Err(MeshError::Parse {
                at: Origin::Line(a), ..
            }),
            Err(MeshError::Parse {
                at: Origin::Line(b), ..
            }),
        ) = (&face_lines, &models)
        {
            if b < a {
                return models.map(|_| unreachable!("an error"));
            }
        }
        let (face_lines, precision) = face_lines?;
        let models = models?;
        let mut vertices: Vec<[f64; 3]> = Vec::new();
        let mut triangles = Vec::new();
        let mut parts: Vec<String> = Vec::new();
        let total: usize = models
            .iter()
            .map(|m| {
                if m.mesh.face_arities.is_empty() {
                    m.mesh.indices.len() / 3
                } else {
                    m.mesh.face_arities.len()
                }
            })
            .sum();
        // Face statements map to faces one to one (checked); otherwise fall back to numbers.
        let lines_known = total == face_lines.len();
        let mut face_no = 0usize;
        for m in &models {
            let part = match parts.iter().position(|p| *p == m.name) {
                Some(i) => i,
                None => {
                    parts.push(m.name.clone());
                    parts.len() - 1
                }
            } as u32;
            let base = vertices.len() as u32;
            vertices.extend(m.mesh.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
            let arities: Vec<u32> = if m.mesh.face_arities.is_empty() {
                vec![3; m.mesh.indices.len() / 3]
            } else {
                m.mesh.face_arities.clone()
            };
            let mut at = 0usize;
            for &n in &arities {
                let n = n as usize;
                let idx: Vec<u32> = m.mesh.indices[at..at + n].iter().map(|i| base + i).collect();
                at += n;
                face_no += 1;
                let origin = if lines_known {
                    Origin::Line(face_lines[face_no - 1])
                } else {
                    Origin::Facet(face_no)
                };
                fan(&file, &vertices, &idx, part, origin, &mut triangles)?;
            }
        }
        Self::from_triangles(path.to_path_buf(), vertices, &triangles, parts, precision)
    }

    /// STL: one part, named after the file's stem. Binary through `stl_io` (f32, as stored);
    /// ASCII read here, in f64 ([`read_ascii_stl`]).
    fn from_stl(path: &Path, bytes: &[u8]) -> Result<Mesh, MeshError> {
        let file = path.display().to_string();
        let refuse = |at: Origin, message: String| MeshError::Parse {
            file: file.clone(),
            at,
            message,
        };
        // Binary: 80-byte header, facet count, 50 bytes per facet. Some exporters begin a
        // binary header with `solid` too: a file whose length matches its count is binary.
        let count = (bytes.len() >= 84)
            .then(|| u64::from(u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]])));
        let binary = count.is_some_and(|c| bytes.len() as u64 == 84 + 50 * c);
        if bytes.starts_with(b"solid") && !binary {
            // ASCII: the reader stops at the first `endsolid` and would drop any later solid.
            let text = String::from_utf8_lossy(bytes);
            let solids: Vec<usize> = text
                .lines()
                .enumerate()
                .filter(|(_, l)| l.split_whitespace().next() == Some("solid"))
                .map(|(k, _)| k + 1)
                .collect();
            if let Some(&second) = solids.get(1) {
                return Err(refuse(
                    Origin::Line(second as u64),
                    format!(
                        "a second `solid` ({} in all): one solid per STL file (split the file, \
                         or join its solids into one)",
                        solids.len()
                    ),
                ));
            }
            // Facets after the first `endsolid` (without a second `solid`) were dropped too.
            if let Some((k, _)) = text
                .lines()
                .enumerate()
                .skip_while(|(_, l)| l.split_whitespace().next() != Some("endsolid"))
                .skip(1)
                .find(|(_, l)| !l.trim().is_empty())
            {
                return Err(refuse(
                    Origin::Line(k as u64 + 1),
                    "text after `endsolid`: one solid per STL file, nothing after it".to_owned(),
                ));
            }
        } else if let (Some(count), false) = (count, binary) {
            // Text that is no ASCII STL the reader takes: say so, not that a binary count is
            // off (`SOLID`, or `solid` after blanks, read as a binary header).
            let head = String::from_utf8_lossy(&bytes[..bytes.len().min(80)]);
            let first = head.split_whitespace().next().unwrap_or("");
            if first.eq_ignore_ascii_case("solid") {
                return Err(refuse(
                    Origin::Facet(1),
                    format!(
                        "begins `{first}`{} like an ASCII STL, which must begin with `solid` at the \
                         very start of the file, its keywords in lower case (solid, facet normal, \
                         outer loop, vertex, endloop, endfacet, endsolid)",
                        if bytes[0].is_ascii_whitespace() {
                            " after blanks"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            // The reader trusts the count and would read a longer file short.
            return Err(refuse(
                Origin::Facet(1),
                format!(
                    "binary STL header counts {count} facets ({} bytes) but the file has {} bytes",
                    84 + 50 * count,
                    bytes.len()
                ),
            ));
        }
        // Three vertices per facet, and each facet's stored normal.
        let (vertices, normals, precision) = if bytes.starts_with(b"solid") && !binary {
            read_ascii_stl(&file, &String::from_utf8_lossy(bytes))?
        } else {
            let stl = stl_io::read_stl(&mut std::io::Cursor::new(bytes)).map_err(|e| MeshError::Stl {
                file: file.clone(),
                message: e.to_string(),
            })?;
            let at = |i: usize| [0, 1, 2].map(|c| f64::from(stl.vertices[i][c]));
            let vertices = stl.faces.iter().flat_map(|f| f.vertices.map(at)).collect();
            let normals = stl
                .faces
                .iter()
                .map(|f| [0, 1, 2].map(|c| f64::from(f.normal[c])))
                .collect();
            (vertices, normals, Precision::SINGLE)
        };
        let triangles: Vec<([u32; 3], u32, Origin)> = (0..normals.len() as u32)
            .map(|k| ([3 * k, 3 * k + 1, 3 * k + 2], 0, Origin::Facet(k as usize + 1)))
            .collect();
        let part = path
            .file_stem()
            .map_or_else(|| "stl".to_owned(), |s| s.to_string_lossy().into_owned());
        let mesh = Self::from_triangles(path.to_path_buf(), vertices, &triangles, vec![part], precision)?;
        // The winding decides which side faces out; an STL also stores a normal per facet. An
        // open shell wound inside out has no volume to give it away, and its stored normals
        // were the only sign (sigma was -0 at every aspect). Stored normals that are unit
        // vectors and point against the winding on most facets: refused.
        let stored: Vec<(usize, f64)> = normals
            .iter()
            .zip(&mesh.facets)
            .enumerate()
            .filter_map(|(k, (&n, facet))| {
                let len = v3::norm(n);
                ((0.9..=1.1).contains(&len)).then(|| (k, v3::dot(n, facet.normal) / len))
            })
            .collect();
        let against: Vec<usize> = stored.iter().filter(|(_, d)| *d < 0.0).map(|(k, _)| *k).collect();
        if !stored.is_empty() && 2 * against.len() > stored.len() {
            return Err(refuse(
                Origin::Facet(against[0] + 1),
                format!(
                    "the stored normals of {} of {} facets point against their winding (facets are \
                     counter-clockwise seen from outside): the surface is wound inside out, or its \
                     normals are wrong; reverse the facets' vertex order, or write the normals that \
                     match it",
                    against.len(),
                    stored.len()
                ),
            ));
        }
        Ok(mesh)
    }
}

/// An ASCII STL's vertices (three per facet, in f64), each facet's stored normal, and the
/// precision its digits give ([`Precision::of_text`]). The STL reader keeps f32: a plate
/// 6.4e6 m from the origin written to six decimals snapped 0.2 m wider, and sigma rose 15%.
/// Keywords in lower case, one statement per line, blank lines skipped; a line that is not the
/// statement due is named.
#[allow(clippy::type_complexity)]
fn read_ascii_stl(file: &str, text: &str) -> Result<(Vec<[f64; 3]>, Vec<[f64; 3]>, Precision), MeshError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(k, l)| (k as u64 + 1, l))
        .filter(|(_, l)| !l.trim().is_empty());
    let mut last = 1;
    let mut digits = WrittenDigits::default();
    // The next line: its number, which of the statements due it is, and its words after the
    // keyword (which may be two words); or the line and what was due.
    let mut statement = |due: &[&str]| -> Result<(u64, usize, Vec<&str>), MeshError> {
        let Some((n, line)) = lines.next() else {
            return Err(MeshError::Parse {
                file: file.to_owned(),
                at: Origin::Line(last),
                message: format!("the file ends where `{}` is due", due.join("` or `")),
            });
        };
        last = n;
        let words: Vec<&str> = line.split_whitespace().collect();
        match due.iter().position(|d| {
            let k: Vec<&str> = d.split(' ').collect();
            words.len() >= k.len() && words[..k.len()] == k[..]
        }) {
            Some(i) => Ok((n, i, words[due[i].split(' ').count()..].to_vec())),
            None => Err(MeshError::Parse {
                file: file.to_owned(),
                at: Origin::Line(n),
                message: format!(
                    "`{}` where `{}` is due (an ASCII STL: solid, then facet normal, outer loop, \
                     three vertex lines, endloop and endfacet per facet, then endsolid; keywords \
                     in lower case)",
                    line.trim(),
                    due.join("` or `")
                ),
            }),
        }
    };
    let three = |n: u64, words: &[&str], what: &str| -> Result<[f64; 3], MeshError> {
        let refuse = |message: String| MeshError::Parse {
            file: file.to_owned(),
            at: Origin::Line(n),
            message,
        };
        if words.len() != 3 {
            return Err(refuse(format!(
                "{what} needs 3 numbers, this one has {}",
                words.len()
            )));
        }
        let mut v = [0.0f64; 3];
        for (c, w) in v.iter_mut().zip(words) {
            *c = w
                .parse()
                .map_err(|_| refuse(format!("{what}: `{w}` is not a number")))?;
            if !c.is_finite() {
                return Err(refuse(format!("{what}: `{w}` is not finite")));
            }
        }
        Ok(v)
    };
    statement(&["solid"])?;
    let (mut vertices, mut normals) = (Vec::new(), Vec::new());
    loop {
        let (n, which, words) = statement(&["facet normal", "endsolid"])?;
        if which == 1 {
            break;
        }
        normals.push(three(n, &words, "facet normal")?);
        let (n, _, words) = statement(&["outer loop"])?;
        if !words.is_empty() {
            return Err(MeshError::Parse {
                file: file.to_owned(),
                at: Origin::Line(n),
                message: "`outer loop` takes no more words".into(),
            });
        }
        for _ in 0..3 {
            let (n, _, words) = statement(&["vertex"])?;
            for w in &words {
                digits.add(w);
            }
            vertices.push(three(n, &words, "vertex")?);
        }
        statement(&["endloop"])?;
        statement(&["endfacet"])?;
    }
    Ok((vertices, normals, digits.precision()))
}

/// Largest mesh file read, bytes: a binary STL of 20 million facets (50 bytes each), an OBJ
/// of several million; the file is held in memory while it is read, so this bounds that.
pub const MAX_MESH_BYTES: u64 = 1 << 30;

/// `bytes` without a leading UTF-8 byte-order mark (editors on Windows write one; the OBJ
/// reader took it for part of the first statement and the line numbers went wrong). Used for
/// text only: a binary STL's header may begin with any bytes.
fn without_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}

/// Largest distance of a polygon's vertex from its mean plane (through the vertices' mean,
/// normal to the Newell normal), relative to the polygon's largest vertex-to-vertex distance.
/// Coordinates printed with 6 significant digits are off their plane by about 1e-6 of the
/// polygon's size; a square folded by 0.05 degrees along its diagonal has its vertices 1.5e-4
/// of its diagonal off the mean plane (and σ depends on how it is split).
pub const POLYGON_PLANAR_REL: f64 = 1e-4;

/// Triangulates one polygon as a fan from its first vertex, refusing a polygon whose fan
/// triangles do not all face the way of its Newell normal (non-convex or non-planar).
fn fan(
    file: &str,
    vertices: &[[f64; 3]],
    idx: &[u32],
    part: u32,
    origin: Origin,
    out: &mut Vec<([u32; 3], u32, Origin)>,
) -> Result<(), MeshError> {
    if idx.len() == 3 {
        out.push(([idx[0], idx[1], idx[2]], part, origin));
        return Ok(());
    }
    let p = |i: u32| vertices[i as usize];
    let mean = idx
        .iter()
        .fold([0.0; 3], |m, &i| v3::add(m, p(i)))
        .map(|c| c / idx.len() as f64);
    // About the polygon's mean: about the coordinate origin, the terms of a polygon 1e8 m out
    // cancel to rounding larger than its own normal, and planar quads were refused.
    let mut newell = [0.0; 3];
    for (k, &i) in idx.iter().enumerate() {
        let (a, b) = (v3::sub(p(i), mean), v3::sub(p(idx[(k + 1) % idx.len()]), mean));
        newell = v3::add(newell, v3::cross(a, b));
    }
    let refuse = || MeshError::Polygon {
        file: file.to_owned(),
        at: origin,
        vertices: idx.len(),
    };
    let unit = v3::norm(newell);
    let size = idx
        .iter()
        .flat_map(|&i| idx.iter().map(move |&j| (i, j)))
        .map(|(i, j)| v3::norm(v3::sub(p(i), p(j))))
        .fold(0.0, f64::max);
    let off_plane = idx
        .iter()
        .map(|&i| (v3::dot(v3::sub(p(i), mean), newell) / unit).abs())
        .fold(0.0, f64::max);
    if !(unit > 0.0 && off_plane <= POLYGON_PLANAR_REL * size) {
        return Err(refuse());
    }
    // The fan from the first vertex whose fan triangles all face the Newell normal: from the
    // polygon's first vertex when it can (the triangles it always had), else from another, so
    // that a convex polygon with a vertex on a straight edge (an exporter's way to mend a
    // T-junction) is not refused for a flat fan triangle that another start avoids.
    let n = idx.len();
    let fans = |start: usize| {
        (1..n - 1).all(|k| {
            let (a, b, c) = (
                p(idx[start]),
                p(idx[(start + k) % n]),
                p(idx[(start + k + 1) % n]),
            );
            v3::dot(v3::cross(v3::sub(b, a), v3::sub(c, a)), newell) > 0.0
        })
    };
    let start = (0..n).find(|&s| fans(s)).ok_or_else(refuse)?;
    for k in 1..n - 1 {
        out.push((
            [idx[start], idx[(start + k) % n], idx[(start + k + 1) % n]],
            part,
            origin,
        ));
    }
    Ok(())
}

/// The statements of the OBJ format (geometry, grouping, display and free-form ones), which
/// the reader takes or skips knowingly; any other word beginning a line is an error.
const OBJ_STATEMENTS: [&str; 36] = [
    "v",
    "vt",
    "vn",
    "vp",
    "f",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "call",
];

/// Lines of the face statements the OBJ reader will turn into faces, in order; refuses face
/// statements that cannot be a facet (fewer than three vertices, a polyline of three or more
/// vertices, which the reader would take for a face), vertex weights other than 1 and words
/// that are not OBJ statements, with their line.
fn scan_obj_faces(file: &str, bytes: &[u8]) -> Result<(Vec<u64>, Precision), MeshError> {
    // A carriage return not followed by a line feed ends no line for the reader: a file with
    // classic Mac line ends was one line, refused for having "no facets".
    if let Some(at) = (0..bytes.len()).find(|&i| bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n')) {
        return Err(MeshError::Parse {
            file: file.to_owned(),
            at: Origin::Line(bytes[..at].iter().filter(|&&b| b == b'\n').count() as u64 + 1),
            message: "a carriage return without a line feed (lines ended by CR alone): end the \
                      lines with LF or CR LF"
                .into(),
        });
    }
    let text = String::from_utf8_lossy(bytes);
    let mut out = Vec::new();
    // Vertex indices are checked here, where the line is known (the reader refused an index
    // past the last vertex at the file's last line): vertices so far, and faces reaching
    // further ahead (the reader takes those if the vertex comes later).
    let mut vertices = 0i64;
    let mut ahead: Vec<(u64, i64)> = Vec::new();
    let mut digits = WrittenDigits::default();
    let parse_error = |at: Origin, message: String| MeshError::Parse {
        file: file.to_owned(),
        at,
        message,
    };
    for (k, line) in text.lines().enumerate() {
        let line_no = k as u64 + 1;
        let mut words = line.split_whitespace();
        let at = Origin::Line(line_no);
        // The reader does not join a line ending in `\` with the next (the OBJ format's
        // continuation): the next line's words were read as a statement of their own.
        if line.trim_end().ends_with('\\') && !line.trim_start().starts_with('#') {
            return Err(MeshError::Parse {
                file: file.to_owned(),
                at,
                message: "a line continuation (`\\` at the end of the line) is not read: join \
                          the statement onto one line"
                    .into(),
            });
        }
        match words.next() {
            Some("f") => {
                let refs: Vec<&str> = words.collect();
                let n = refs.len();
                if n < 3 {
                    return Err(MeshError::Parse {
                        file: file.to_owned(),
                        at,
                        message: format!("a face needs at least 3 vertices, this one has {n}"),
                    });
                }
                for r in refs {
                    // `v`, `v/t`, `v//n` or `v/t/n`; what is not a number the reader refuses.
                    let Ok(i) = r.split('/').next().unwrap_or("").parse::<i64>() else {
                        continue;
                    };
                    if i == 0 || i < -vertices {
                        return Err(parse_error(
                            at,
                            format!(
                                "vertex index {i}: indices count from 1 (or back from -1), and {vertices} vertices \
                                 come before this line"
                            ),
                        ));
                    }
                    if i > vertices {
                        ahead.push((line_no, i));
                    }
                }
                out.push(line_no);
            }
            Some("l") if words.count() >= 3 => {
                return Err(MeshError::Parse {
                    file: file.to_owned(),
                    at,
                    message: "a polyline (`l`) of 3 or more vertices has no surface and cannot \
                              be part of a target"
                        .into(),
                })
            }
            // A fourth vertex coordinate is a homogeneous weight the reader divides by (w = 2
            // halved the target, w = -1 mirrored it): only 1 is taken.
            Some("v") => {
                vertices += 1;
                let w: Vec<&str> = line.split_whitespace().skip(1).collect();
                if let Some(c) = w
                    .iter()
                    .take(3)
                    .find(|c| c.parse::<f64>().is_ok_and(|c| !c.is_finite()))
                {
                    return Err(parse_error(at, format!("vertex coordinate `{c}` is not finite")));
                }
                for c in w.iter().take(3) {
                    digits.add(c);
                }
                if w.len() == 4 && w[3].parse::<f64>() != Ok(1.0) {
                    return Err(MeshError::Parse {
                        file: file.to_owned(),
                        at,
                        message: format!(
                            "vertex weight w = {} (a fourth coordinate): positions are x y z, or \
                             x y z 1",
                            w[3]
                        ),
                    });
                }
            }
            // Free-form geometry (a curve or surface patch) is a surface the reader does not
            // tessellate: a `surf` lid was dropped with no word and σ lost it.
            Some(word @ ("surf" | "curv" | "curv2")) => {
                return Err(MeshError::Parse {
                    file: file.to_owned(),
                    at,
                    message: format!(
                        "free-form geometry (`{word}`) is not read: export the target as polygons \
                         (triangles or convex planar faces)"
                    ),
                })
            }
            // A statement the reader does not know is skipped by it: a misspelt `v0 1 0` shifted
            // every later vertex index. Only the statements of the OBJ format are taken.
            Some(word) if !word.starts_with('#') && !OBJ_STATEMENTS.contains(&word) => {
                return Err(MeshError::Parse {
                    file: file.to_owned(),
                    at,
                    message: format!("`{word}` is not an OBJ statement (v, f, o, g, ...)"),
                })
            }
            _ => {}
        }
    }
    if let Some(&(line, i)) = ahead.iter().find(|&&(_, i)| i > vertices) {
        return Err(parse_error(
            Origin::Line(line),
            format!("vertex index {i}: the file has {vertices} vertices"),
        ));
    }
    Ok((out, digits.precision()))
}

/// A `BufRead` over bytes that knows which line the reader last took, so that an error of
/// the OBJ reader can name its line.
struct LineCounter<'a> {
    data: &'a [u8],
    pos: usize,
}

impl LineCounter<'_> {
    /// 1-based line of the last byte consumed (the line being parsed).
    fn line(&self) -> u64 {
        let upto = self.pos.saturating_sub(1);
        self.data[..upto].iter().filter(|&&b| b == b'\n').count() as u64 + 1
    }
}

impl Read for LineCounter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = buf.len().min(self.data.len() - self.pos);
        buf[..n].copy_from_slice(&self.data[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl BufRead for LineCounter<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.data[self.pos..])
    }
    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.data.len());
    }
}

/// True when two triangles (vertex ids, counter-clockwise in the plane `at` maps them into)
/// that share a vertex lie in wedges at it that do not overlap, so the triangles cannot:
/// each lies in its wedge (its two edges from the shared vertex). Wedges are convex, so they
/// are apart exactly when the line along one of their four edges has one on each side. A
/// shared edge run both ways (consistent winding) puts the two on its two sides. Without a
/// shared vertex, or with wedges that overlap, false: the full test decides. This keeps a
/// fan of slivers around one vertex (a cylinder's cap) to one cheap test per pair.
fn apart_at_shared_vertex(a: [u32; 3], b: [u32; 3], at: impl Fn(u32) -> [f64; 2]) -> bool {
    let Some(i) = (0..3).find(|&i| b.contains(&a[i])) else {
        return false;
    };
    let j = (0..3).position(|j| b[j] == a[i]).unwrap_or(0);
    let v = at(a[i]);
    let dir = |k: u32| {
        let p = at(k);
        [p[0] - v[0], p[1] - v[1]]
    };
    // Each wedge from its first edge counter-clockwise to its second.
    let (a1, a2) = (dir(a[(i + 1) % 3]), dir(a[(i + 2) % 3]));
    let (b1, b2) = (dir(b[(j + 1) % 3]), dir(b[(j + 2) % 3]));
    // Sine of the angle from p to q, so that rounding at the shared edge reads as zero.
    let unit = |p: [f64; 2]| {
        let l = (p[0] * p[0] + p[1] * p[1]).sqrt();
        [p[0] / l, p[1] / l]
    };
    let (a1, a2, b1, b2) = (unit(a1), unit(a2), unit(b1), unit(b2));
    let turn = |p: [f64; 2], q: [f64; 2]| p[0] * q[1] - p[1] * q[0];
    let eps = OVERLAP_REL;
    (turn(a1, b1) <= eps && turn(a1, b2) <= eps)
        || (turn(a2, b1) >= -eps && turn(a2, b2) >= -eps)
        || (turn(b1, a1) <= eps && turn(b1, a2) <= eps)
        || (turn(b2, a1) >= -eps && turn(b2, a2) >= -eps)
}

/// Two axes across a unit normal, for comparisons in a plane.
fn plane_frame(n: [f64; 3]) -> [[f64; 3]; 2] {
    let helper = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = v3::cross(n, helper);
    let u = v3::scale(u, 1.0 / v3::norm(u));
    [u, v3::cross(n, u)]
}

/// The smallest overlap of two 2-D triangles' projections over the six edge normals (the
/// separating axes of two triangles), in length units: 0 or less when they are disjoint or
/// only touch. The normals are unit, so the overlap is a distance.
fn overlap_depth(a: &[[f64; 2]; 3], b: &[[f64; 2]; 3]) -> f64 {
    let mut depth = f64::INFINITY;
    for t in [a, b] {
        for e in 0..3 {
            let (p, q) = (t[e], t[(e + 1) % 3]);
            let (nx, ny) = (q[1] - p[1], p[0] - q[0]);
            let len = nx.hypot(ny);
            if len == 0.0 {
                continue;
            }
            let proj = |s: &[[f64; 2]; 3]| {
                let v = s.map(|r| (r[0] * nx + r[1] * ny) / len);
                (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]))
            };
            let ((a0, a1), (b0, b1)) = (proj(a), proj(b));
            depth = depth.min(a1.min(b1) - a0.max(b0));
        }
    }
    depth
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj(text: &str) -> Result<Mesh, MeshError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.obj");
        std::fs::write(&p, text).unwrap();
        Mesh::load(&p)
    }

    const TETRA: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\no body\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";

    /// A square pipe open at both ends, its faces turned inwards (a duct's inner surface):
    /// its two openings cancel in the sum of the facets' vector areas, and it was taken for a
    /// cracked closed shell and refused as inside out. Its openings have a size: an open
    /// shell, taken either way round.
    #[test]
    fn a_pipe_open_at_both_ends_is_an_open_shell_either_way_round() {
        let v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
        let sides = ["1 2 6 5", "2 3 7 6", "3 4 8 7", "4 1 5 8"];
        for inward in [false, true] {
            let faces: String = sides
                .iter()
                .map(|f| {
                    let mut ids: Vec<&str> = f.split(' ').collect();
                    if inward {
                        ids.reverse();
                    }
                    format!("f {}\n", ids.join(" "))
                })
                .collect();
            let m = obj(&format!("{v}{faces}")).unwrap_or_else(|e| panic!("inward {inward}: {e}"));
            assert!(m.closed.iter().all(|&c| !c), "inward {inward}");
        }
    }

    /// A bad vertex index or a vertex that is not finite is named at its own line (the reader
    /// named the file's last line, or the first face using the vertex); of two refusals, the
    /// earlier line. An index to a vertex written later is taken, as the reader takes it.
    #[test]
    fn bad_indices_and_vertices_are_named_at_their_lines() {
        let faces = "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
        let line = |text: &str| obj(text).unwrap_err().to_string();
        let tail = "#\n#\n";
        for (text, at, says) in [
            (
                format!("{TETRA}f 1 2 9\n{tail}"),
                10,
                "vertex index 9: the file has 4",
            ),
            (format!("{TETRA}f 0 1 2\n{tail}"), 10, "vertex index 0"),
            (format!("{TETRA}f -5 1 2\n{tail}"), 10, "vertex index -5"),
            (
                format!("v 0 0 0\nv nan 0 0\nv 0 1 0\nv 0 0 1\n{faces}"),
                2,
                "`nan` is not finite",
            ),
            (
                format!("v 0 0 0\nv 1e999 0 0\nv 0 1 0\nv 0 0 1\n{faces}"),
                2,
                "`1e999` is not finite",
            ),
            (
                format!("v 0 0 0\nv 1 x 0\nv 0 1 0\nv 0 0 1\n{faces}f 1 2\n"),
                2,
                "OBJ reader",
            ),
        ] {
            let e = line(&text);
            assert!(e.contains(&format!("line {at}:")) && e.contains(says), "{e}");
        }
        let ahead = "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
        assert_eq!(obj(ahead).unwrap().facets.len(), 4);
    }

    #[test]
    fn a_tetrahedron_loads_with_outward_normals_and_lines() {
        let m = obj(TETRA).unwrap();
        assert_eq!(m.facets.len(), 4);
        assert_eq!(m.parts, vec!["body"]);
        assert_eq!(m.origins[0], Origin::Line(6));
        // Facet 1 3 2 lies in z = 0 and faces -z.
        assert_eq!(m.facets[0].normal, [0.0, 0.0, -1.0]);
        assert!((m.facets[0].area - 0.5).abs() < 1e-15);
    }

    /// Files the readers misread were refused with misleading messages: an OBJ with lines
    /// ended by CR alone ("no facets"), an ASCII STL beginning `SOLID` or blanks before `solid`
    /// ("binary STL header counts 1347374924 facets"). Each now says what it is.
    #[test]
    fn an_ascii_stl_is_read_in_double_precision_and_its_statements_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.stl");
        // A 1.3 m square plate facing +x, 6.4e6 m out, written to six decimals: read as f32,
        // its width snapped to 1.5 m (sigma 15% high).
        let y0 = 6.4e6 + 0.123;
        let v = |y: f64, z: f64| format!("vertex 0 {:.6} {:.6}\n", y0 + y, z);
        let tri = |a: String, b: String, c: String| {
            format!("facet normal 1 0 0\nouter loop\n{a}{b}{c}endloop\nendfacet\n")
        };
        let plate = tri(v(0.0, 0.0), v(1.3, 0.0), v(1.3, 1.3)) + &tri(v(0.0, 0.0), v(1.3, 1.3), v(0.0, 1.3));
        for head in ["solid plate\n", "solid\tplate\n", "solid\n"] {
            std::fs::write(&p, format!("{head}{plate}endsolid\n")).unwrap();
            let mesh = Mesh::load(&p).unwrap();
            let area: f64 = mesh.facets.iter().map(|f| f.area).sum();
            assert!((area - 1.69).abs() < 1e-9, "{head:?}: area {area}");
            assert!(mesh.precision.rel < 1e-11, "{:?}", mesh.precision);
        }
        // A statement out of place, or a vertex short of a number, is named at its line.
        let cases = [
            (
                plate.replacen("endloop\n", "", 1),
                "line 7",
                "`endfacet` where `endloop` is due",
            ),
            (
                plate.replacen(" 0.000000\n", "\n", 1),
                "line 4",
                "vertex needs 3 numbers",
            ),
            (
                plate.replacen("normal 1 0 0", "normal 1 0 x", 1),
                "line 2",
                "`x` is not a number",
            ),
            (
                plate.replacen("normal 1 0 0", "normal nan 0 0", 1),
                "line 2",
                "`nan` is not finite",
            ),
            (
                plate.replacen("outer loop", "outer loop 3", 1),
                "line 3",
                "takes no more words",
            ),
        ];
        for (body, line, says) in cases {
            std::fs::write(&p, format!("solid t\n{body}endsolid t\n")).unwrap();
            let e = Mesh::load(&p).unwrap_err().to_string();
            assert!(e.contains(line) && e.contains(says), "{e}");
        }
        std::fs::write(&p, format!("solid t\n{plate}")).unwrap();
        let e = Mesh::load(&p).unwrap_err().to_string();
        assert!(
            e.contains("ends where `facet normal` or `endsolid` is due"),
            "{e}"
        );
    }

    #[test]
    fn line_ends_and_stl_keywords_the_readers_cannot_take_are_named() {
        let e = obj("o p\rv 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1") && e.contains("carriage return"), "{e}");
        let e = obj("o p\nv 0 0 0\nv 1 0 0\r\nv 0 1 0\rf 1 2 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("carriage return"), "{e}");
        assert!(obj("o p\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n").is_ok());
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.stl");
        let body = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        for (head, says) in [("SOLID t\n", "begins `SOLID`"), ("  solid t\n", "after blanks")] {
            std::fs::write(&p, format!("{head}{body}").repeat(3)).unwrap();
            let e = Mesh::load(&p).unwrap_err().to_string();
            assert!(e.contains(says) && e.contains("lower case"), "{e}");
        }
    }

    /// A convex pentagon with a vertex on the straight edge between two others (how exporters
    /// mend a T-junction) was refused when that edge met the first vertex (its fan from there
    /// has a flat triangle) and accepted written from another vertex; now both, with the same
    /// area. A polygon no fan from any of its vertices triangulates is still refused.
    #[test]
    fn a_vertex_on_a_straight_edge_does_not_refuse_a_convex_polygon() {
        let v = "o p\nv 0 0 0\nv 0.5 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
        for f in ["f 1 2 3 4 5", "f 2 3 4 5 1", "f 5 1 2 3 4"] {
            let m = obj(&format!("{v}{f}\n")).unwrap();
            let area: f64 = m.facets.iter().map(|x| x.area).sum();
            assert!((area - 1.0).abs() < 1e-15, "{f}: {area}");
            assert!(m.facets.iter().all(|x| x.normal == [0.0, 0.0, 1.0]), "{f}");
        }
        // A comb with two notches: no start fans it.
        let comb = "o p\nv 0 0 0\nv 4 0 0\nv 4 2 0\nv 3 1 0\nv 2 2 0\nv 1 1 0\nv 0 2 0\nf 1 2 3 4 5 6 7\n";
        assert!(obj(comb).unwrap_err().to_string().contains("not convex"));
    }

    /// The grid's cell index is `floor` exactly, below zero, at integers and beyond.
    #[test]
    fn cell_indices_are_floors() {
        for x in [
            -3.0,
            -2.5,
            -1e-300,
            -0.0,
            0.0,
            0.5,
            1.0,
            2.999_999_999,
            1e18,
            -1e18,
            1e300,
            f64::NAN,
        ] {
            assert_eq!(cell_index(x, 0.0, 1.0), x.floor() as i64, "{x}");
            assert_eq!(cell_index(x, 0.25, 0.1), ((x - 0.25) / 0.1).floor() as i64, "{x}");
        }
    }

    /// A tube of full-length slivers (each 10 m long, a few mm across): cells as wide as a
    /// facet's longest side put every facet in one cell (80,000 facets took 17 s to check);
    /// cells sized per axis spread them, a few in each.
    #[test]
    fn slivers_spread_over_the_coincidence_grid() {
        let k = 2000;
        let boxes: Vec<([f64; 3], [f64; 3])> = (0..k)
            .map(|i| {
                let (a, b) = [i, i + 1]
                    .map(|j| std::f64::consts::TAU * j as f64 / k as f64)
                    .into();
                let (y, z) = ([0.5 * a.cos(), 0.5 * b.cos()], [0.5 * a.sin(), 0.5 * b.sin()]);
                (
                    [-5.0, y[0].min(y[1]), z[0].min(z[1])],
                    [5.0, y[0].max(y[1]), z[0].max(z[1])],
                )
            })
            .collect();
        let grid = coincidence_grid(&boxes, &[]).entries;
        let fullest = grid.chunk_by(|x, y| x.0 == y.0).map(<[_]>::len).max().unwrap();
        assert!(fullest <= 32, "{fullest} of {k} facets in one cell");
    }

    /// One box far larger than the rest (a 2 km ground plate beside 10,000 facets 1 cm wide)
    /// sits in a level of its own: cells as wide as it put all the small ones in one cell
    /// (a 327,680-facet sphere beside a facet 1e9 m away took 85.6 s to check).
    #[test]
    fn a_facet_far_larger_than_the_rest_sits_in_a_level_of_its_own() {
        let mut boxes: Vec<([f64; 3], [f64; 3])> = (0..10_000)
            .map(|k| {
                let (x, y) = ((k % 100) as f64 * 0.01, (k / 100) as f64 * 0.01);
                ([x, y, 1.0], [x + 0.01, y + 0.01, 1.0 + 1e-6])
            })
            .collect();
        boxes.push(([-1000.0, -1000.0, 0.0], [1000.0, 1000.0, 1e-6]));
        let grid = coincidence_grid(&boxes, &[]);
        assert!(grid.level[10_000] > 0 && grid.level[..10_000].iter().all(|&l| l == 0));
        let fullest = grid
            .entries
            .chunk_by(|x, y| x.0 == y.0)
            .map(<[_]>::len)
            .max()
            .unwrap();
        assert!(fullest <= 32, "{fullest} of 10,000 facets in one cell");
        // Across levels, pairs are found all the same, and the first in file order is named:
        // a 0.5 m decal lying on the ground plate (lines 15 and 18; the plate's in-plane
        // tolerance is 4 cm), before two small facets lying on each other (lines 19 and 20);
        // lifted 10 cm off it, the decal is accepted, and so are the small ones apart.
        let ground = "v -1000 -1000 0\nv 1000 -1000 0\nv 1000 1000 0\nv -1000 1000 0\n";
        let decal = |z: f64| format!("v 0 0 {z}\nv 0.5 0 {z}\nv 0 0.5 {z}\n");
        let pair = "v 5 5 1\nv 5.01 5 1\nv 5 5.01 1\nv 5.001 5.001 1\nv 5.011 5.001 1\nv 5.001 5.011 1\n";
        let faces = "o ground\nf 1 2 3\nf 1 3 4\no small\nf 5 6 7\nf 8 9 10\nf 11 12 13\n";
        let text = |z: f64| format!("{ground}{}{pair}{faces}", decal(z));
        let e = obj(&text(0.0)).unwrap_err().to_string();
        assert!(
            e.contains("line 15 and line 18") && e.contains("lie on each other"),
            "{e}"
        );
        let e = obj(&text(0.1)).unwrap_err().to_string();
        assert!(e.contains("line 19 and line 20"), "{e}");
        let apart = text(0.1).replace(
            "v 5.001 5.001 1\nv 5.011 5.001 1\nv 5.001 5.011 1",
            "v 5 5 2\nv 5.01 5 2\nv 5 5.01 2",
        );
        assert!(obj(&apart).is_ok());
    }

    /// Random soups of facets whose sizes span five decades, in planes at random tilts, facing
    /// either way, some with a fan of slivers about a hub (one turn, or a turn and a quarter,
    /// which lies on itself) and some with a facet written four times: the pair the grid names,
    /// or none, is the first in facet order that comparing every pair finds.
    #[test]
    fn the_grid_names_the_pair_that_comparing_every_pair_finds() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut refused, mut accepted) = (0, 0);
        for trial in 0..60 {
            let planes = 1 + (trial * 37) % 600;
            let frames: Vec<([f64; 3], [[f64; 3]; 2])> = (0..planes)
                .map(|k| {
                    let (a, b) = (0.3 * next(), std::f64::consts::TAU * next());
                    let n = [a.sin() * b.cos(), a.sin() * b.sin(), a.cos()];
                    ([0.0, 0.0, 3.0 * k as f64], plane_frame(n))
                })
                .collect();
            let mut vertices: Vec<[f64; 3]> = Vec::new();
            let mut triangles: Vec<[u32; 3]> = Vec::new();
            let at = |k: usize, x: f64, y: f64| {
                let (o, [u, w]) = frames[k];
                v3::add(o, v3::add(v3::scale(u, x), v3::scale(w, y)))
            };
            for _ in 0..150 {
                let k = (next() * planes as f64) as usize % planes;
                let size = 10f64.powf(-3.0 + 5.0 * next());
                let (cx, cy, turn) = (1000.0 * next() - 500.0, 1000.0 * next() - 500.0, next());
                let base = vertices.len() as u32;
                for i in 0..3 {
                    let angle = std::f64::consts::TAU * (turn + i as f64 / 3.0 + 0.1 * next());
                    vertices.push(at(k, cx + size * angle.cos(), cy + size * angle.sin()));
                }
                triangles.push(if next() < 0.5 {
                    [base, base + 1, base + 2]
                } else {
                    [base, base + 2, base + 1]
                });
            }
            if trial % 3 == 0 {
                let (k, turns, slivers) = (trial % planes, if trial % 2 == 0 { 1.0 } else { 1.25 }, 61);
                let centre = vertices.len() as u32;
                vertices.push(at(k, 20.0, 20.0));
                for i in 0..=slivers {
                    let angle = std::f64::consts::TAU * turns * i as f64 / slivers as f64;
                    vertices.push(at(k, 20.0 + angle.cos(), 20.0 + angle.sin()));
                }
                triangles.extend((0..slivers).map(|i| [centre, centre + 1 + i, centre + 2 + i]));
            }
            if trial % 5 == 0 {
                let copy = triangles[(next() * 150.0) as usize % 150];
                triangles.extend([copy; 3]);
            }
            let facets = triangles
                .iter()
                .map(|&ids| {
                    let p = ids.map(|i| vertices[i as usize]);
                    let c = v3::cross(v3::sub(p[1], p[0]), v3::sub(p[2], p[0]));
                    Facet {
                        vertices: ids,
                        part: 0,
                        normal: v3::scale(c, 1.0 / v3::norm(c)),
                        area: v3::norm(c) / 2.0,
                        centroid: v3::scale(v3::add(v3::add(p[0], p[1]), p[2]), 1.0 / 3.0),
                    }
                })
                .collect::<Vec<_>>();
            let mesh = Mesh {
                file: "soup".into(),
                vertices,
                origins: (1..=facets.len()).map(Origin::Facet).collect(),
                facets,
                parts: vec!["soup".into()],
                closed: Vec::new(),
                neighbours: Vec::new(),
                precision: Precision::WRITTEN,
            };
            let tol: Vec<f64> = mesh.facets.iter().map(|f| mesh.in_plane_tolerance(f)).collect();
            let n = mesh.facets.len();
            let every = (0..n)
                .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
                .find(|&(a, b)| mesh.overlap(a, b, tol[a] + tol[b]).is_some());
            let named = match mesh.check_coincident() {
                Ok(()) => None,
                Err(MeshError::Coincident {
                    a: Origin::Facet(a),
                    b: Origin::Facet(b),
                    ..
                }) => Some((a - 1, b - 1)),
                Err(e) => panic!("trial {trial}: {e}"),
            };
            assert_eq!(named, every, "trial {trial}");
            if named.is_some() {
                refused += 1;
            } else {
                accepted += 1;
            }
        }
        assert!(
            refused >= 10 && accepted >= 10,
            "{refused} refused, {accepted} accepted"
        );
    }

    /// Walls among flat ground facets (whose median height is their padding, 4 µm) sit in
    /// cells about their own size: cells of higher levels grow alike along every axis from
    /// level 0's narrowest side (grown from each axis's own, a 2.5 m wall's cells were 2,000
    /// km wide, and a city of 1.4 million facets took 48 s to check against 1.7 s).
    #[test]
    fn walls_on_flat_ground_sit_in_cells_of_their_own_size() {
        let mut boxes: Vec<([f64; 3], [f64; 3])> = (0..10_000)
            .map(|k| {
                let (x, y) = ((k % 100) as f64, (k / 100) as f64);
                ([x, y, -1e-6], [x + 1.0, y + 1.0, 1e-6])
            })
            .collect();
        boxes.extend((0..100).map(|k| ([k as f64, 50.0, 0.0], [k as f64 + 1.0, 50.0 + 2e-6, 2.5])));
        let grid = coincidence_grid(&boxes, &[]);
        let wall = grid.level[10_000];
        assert!(wall > 0 && grid.level[10_000..].iter().all(|&l| l == wall));
        let sides = [0, 1, 2].map(|c| grid.side(c, wall));
        assert!(sides.iter().all(|&w| (1.25..=8.0).contains(&w)), "{sides:?}");
    }

    /// Copies of a facet (the same three vertices in the same order) are compared by the first two
    /// and left out of the grid: 4,000 stacked copies of a box are refused at once (6.7 s
    /// before, every pair of 48,000 facets around 8 hubs tried), naming the first copy of the
    /// first face; a pair earlier in file order than any copies is named first; copies wound
    /// the other way (a two-sided plate) are no copies.
    #[test]
    fn copies_of_a_facet_are_named_by_the_first_pair_in_file_order() {
        let mut text = String::new();
        for k in 0..4000 {
            text += "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n";
            let b = 8 * k;
            for q in [
                [1, 3, 4, 2],
                [5, 6, 8, 7],
                [1, 2, 6, 5],
                [3, 7, 8, 4],
                [1, 5, 7, 3],
                [2, 4, 8, 6],
            ] {
                let q = q.map(|i| i + b);
                text += &format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]);
            }
        }
        let t = std::time::Instant::now();
        let e = obj(&text).unwrap_err().to_string();
        println!("4,000 stacked copies of a box refused in {:?}", t.elapsed());
        assert!(e.contains("line 9 and line 23"), "{e}");
        // Facets: C, A, B (lying on A), C, C (three copies: two alone are refused by their
        // winding, one edge run the same way twice): the copies (lines 10 and 13) first.
        let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.1 0.1 0\nv 1.1 0.1 0\nv 0.1 1.1 0\n";
        let c = "v 5 5 5\nv 6 5 5\nv 5 6 5\n";
        let e = obj(&format!("{v}{c}f 7 8 9\nf 1 2 3\nf 4 5 6\nf 7 8 9\nf 7 8 9\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 10 and line 13") && e.contains("lie on each other"),
            "{e}"
        );
        // X (apart), A, B, C, C, C: A and B first, though the copies, compared before the
        // grid, were found first.
        let x = "v 9 9 9\nv 10 9 9\nv 9 10 9\n";
        let e = obj(&format!(
            "{v}{c}{x}f 10 11 12\nf 1 2 3\nf 4 5 6\nf 7 8 9\nf 7 8 9\nf 7 8 9\n"
        ))
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("line 14 and line 15") && e.contains("lie on each other"),
            "{e}"
        );
        // C and C wound the other way, twice each: two-sided, and copies of each side.
        let e = obj(&format!("{c}f 1 2 3\nf 1 3 2\nf 1 2 3\nf 1 3 2\nf 1 2 3\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 4 and line 6") && e.contains("lie on each other"),
            "{e}"
        );
    }

    /// Cells hashed when the grid is wider than 2^CELL_BITS cells a side: a coincident pair
    /// beside a facet 1e9 m away is still found and named (cells doubled until they fitted
    /// before), and a mesh without one passes.
    #[test]
    fn a_coincident_pair_is_found_in_a_grid_too_wide_to_pack() {
        let far = "v 1e9 0 0\nv 1e9 0.001 0\nv 1e9 0 0.001\nf 1 2 3\n";
        let pair = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.1 0.1 0\nv 1.1 0.1 0\nv 0.1 1.1 0\nf 4 5 6\nf 7 8 9\n";
        let e = obj(&format!("{far}{pair}")).unwrap_err().to_string();
        assert!(e.contains("line 11") && e.contains("line 12"), "{e}");
        let apart = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 5\nv 1 0 5\nv 0 1 5\nf 4 5 6\nf 7 8 9\n";
        assert!(obj(&format!("{far}{apart}")).is_ok());
        let boxes = [
            ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
            ([1e9, 0.0, 0.0], [1e9 + 1e-3, 1e-3, 1e-3]),
        ];
        assert!(!coincidence_grid(&boxes, &[]).packed);
    }

    /// A cube whose top is split at a vertex on the edge it shares with a side (a T-junction:
    /// that edge has one facet on each side, split on one only) has edges of one facet, but
    /// encloses its volume all the same: wound inside out, it was taken as an open shell and
    /// returned σ 0 with no word. Now refused as a closed shell is; wound outwards, accepted;
    /// a cube with a real opening (its top missing) is still an open shell.
    #[test]
    fn a_shell_cracked_by_a_t_junction_is_checked_for_its_winding() {
        let cube =
            "o cube\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\nv 1 0.5 1\n";
        let sides = ["1 3 4 2", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6"];
        let top = ["5 6 9", "5 9 8 7"];
        let write = |faces: &[&str], inside_out: bool| {
            let mut text = cube.to_owned();
            for f in faces {
                let mut v: Vec<&str> = f.split(' ').collect();
                if inside_out {
                    v.reverse();
                }
                text += &format!("f {}\n", v.join(" "));
            }
            text
        };
        let all: Vec<&str> = sides.iter().chain(&top).copied().collect();
        let m = obj(&write(&all, false)).unwrap();
        assert!(
            m.closed.iter().all(|c| !c),
            "the T-junction leaves edges of one facet"
        );
        let e = obj(&write(&all, true)).unwrap_err().to_string();
        assert!(e.contains("negative volume"), "{e}");
        // A real opening: no top at all, wound either way, is an open surface.
        assert!(obj(&write(&sides, true)).is_ok());
        assert!(obj(&write(&sides, false)).is_ok());
        // A top fanned through a vertex on each of its edges meets the sides only at
        // T-junctions: a shell of its own, apart from theirs, neither cracked alone; the
        // piece they form (sharing the corners) is, and wound inside out it is refused.
        let cube = format!("{cube}v 0.5 0 1\nv 1 0.5 1\nv 0.5 1 1\nv 0 0.5 1\nv 0.5 0.5 1\n");
        let ring = [5, 10, 6, 11, 8, 12, 7, 13, 5];
        let fan: Vec<String> = ring.windows(2).map(|w| format!("14 {} {}", w[0], w[1])).collect();
        let faces: Vec<&str> = sides
            .iter()
            .copied()
            .chain(fan.iter().map(String::as_str))
            .collect();
        let with = |inside_out: bool| {
            let mut text = cube.clone();
            for f in &faces {
                let mut v: Vec<&str> = f.split(' ').collect();
                if inside_out {
                    v.reverse();
                }
                text += &format!("f {}\n", v.join(" "));
            }
            obj(&text)
        };
        assert!(with(false).is_ok());
        let e = with(true).unwrap_err().to_string();
        assert!(e.contains("negative volume"), "{e}");
    }

    #[test]
    fn inside_out_shells_flipped_facets_and_degenerates_are_named() {
        let inward = TETRA
            .replace("f 1 3 2", "f 1 2 3")
            .replace("f 1 2 4", "f 1 4 2")
            .replace("f 2 3 4", "f 2 4 3")
            .replace("f 1 4 3", "f 1 3 4");
        let e = obj(&inward).unwrap_err().to_string();
        assert!(
            e.contains("t.obj") && e.contains("line 6") && e.contains("negative volume"),
            "{e}"
        );
        let flipped = TETRA.replace("f 2 3 4", "f 2 4 3");
        let e = obj(&flipped).unwrap_err().to_string();
        assert!(e.contains("inconsistent winding") && e.contains("line 8"), "{e}");
        let e = obj(&format!("{TETRA}v 2 0 0\nf 1 2 5\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 11") && e.contains("degenerate"), "{e}");
        let e = obj("v 0 0 0\nv 1 0 0\nf 1 2\n").unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("at least 3"), "{e}");
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("refused"), "{e}");
        // A dart (one reflex corner) is fanned from that corner, which triangulates it.
        let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.2 0.2 0\nf 2 4 3 1\n").unwrap();
        let area: f64 = m.facets.iter().map(|f| f.area).sum();
        assert!((area - 0.2).abs() < 1e-15, "{area}");
        let e = obj("v 0 0 0\nv 4 0 0\nv 4 2 0\nv 3 1 0\nv 2 2 0\nv 1 1 0\nv 0 2 0\nf 1 2 3 4 5 6 7\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 8") && e.contains("not convex"), "{e}");
    }

    #[test]
    fn a_sheet_welded_onto_a_body_along_an_edge_is_accepted() {
        // A fin (both sides) standing on the tetrahedron's edge 1-2.
        let fin = format!("{TETRA}v 0.5 -0.5 -0.5\no fin\nf 1 2 5\nf 1 5 2\n");
        let m = obj(&fin).unwrap();
        assert_eq!(m.parts, vec!["body", "fin"]);
        // The body is then open at that edge, so its orientation is not checked: a flipped
        // body facet elsewhere is still found.
        let e = obj(&fin.replace("f 2 3 4", "f 2 4 3")).unwrap_err().to_string();
        assert!(e.contains("inconsistent winding"), "{e}");
    }

    #[test]
    fn an_open_sheet_and_a_two_sided_plate_are_accepted() {
        let sheet = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\ng plate\nf 1 2 3 4\n";
        let m = obj(sheet).unwrap();
        assert_eq!(m.facets.len(), 2);
        assert_eq!(m.origins, vec![Origin::Line(6), Origin::Line(6)]);
        let two = format!("{sheet}f 4 3 2 1\n");
        assert_eq!(obj(&two).unwrap().facets.len(), 4);
    }

    /// A quad folded out of its plane is refused whichever vertex it starts at (accepted, its σ
    /// depended on the start vertex); one off its plane by print rounding is accepted.
    #[test]
    fn a_folded_quad_is_refused_and_a_rounded_one_accepted() {
        // The unit square with corner 3 lifted by tan(40 deg) and by 1e-6.
        let quad = |z: &str, order: &str| format!("v 0 0 0\nv 1 0 0\nv 1 1 {z}\nv 0 1 0\nf {order}\n");
        for order in ["1 2 3 4", "2 3 4 1"] {
            let e = obj(&quad("0.8391", order)).unwrap_err().to_string();
            assert!(
                e.contains("line 5") && e.contains("not convex and planar"),
                "{order}: {e}"
            );
            // A fold of 0.1 degrees is still a fold.
            let e = obj(&quad("0.001745", order)).unwrap_err().to_string();
            assert!(e.contains("off its plane"), "{order}: {e}");
            assert_eq!(obj(&quad("0.000001", order)).unwrap().facets.len(), 2);
        }
    }

    /// A binary STL whose header counts other than the facets it holds, and an ASCII STL of
    /// two solids, are refused (the first was read short, the second lost its second solid).
    #[test]
    fn a_line_continuation_is_refused_and_a_bare_solid_read() {
        // A continued vertex (`v 0 1 \` then `0`) was blamed on the next line's `0`.
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 \\\n 0\nf 1 2 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("line continuation"), "{e}");
        // A comment ending in a backslash is a comment.
        obj("# C:\\meshes\\\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        // An ASCII STL whose `solid` has no name (the format allows it) failed with "failed
        // to fill whole buffer".
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.stl");
        let body = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n";
        for head in ["solid\n", "solid\r\n", "solid name\n"] {
            std::fs::write(&p, format!("{head}{body}")).unwrap();
            let m = Mesh::load(&p).unwrap_or_else(|e| panic!("{head:?}: {e}"));
            assert_eq!(m.facets.len(), 1);
        }
    }

    /// An open surface wound inside out with its stored normals pointing out gave sigma -0 at
    /// every aspect with no word: the normals are compared with the winding.
    #[test]
    fn stl_normals_against_the_winding_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.stl");
        // Two triangles of a plate, wound clockwise seen from +z (facing -z).
        let write = |normals: [[f32; 3]; 2]| {
            let tris = [
                [[0., 0., 0.], [0., 1., 0.], [1., 0., 0.]],
                [[1., 0., 0.], [0., 1., 0.], [1., 1., 0.]],
            ];
            let mut text = String::from("solid t\n");
            for (t, n) in tris.iter().zip(normals) {
                text.push_str(&format!("facet normal {} {} {}\nouter loop\n", n[0], n[1], n[2]));
                for v in t {
                    text.push_str(&format!("vertex {} {} {}\n", v[0], v[1], v[2]));
                }
                text.push_str("endloop\nendfacet\n");
            }
            text.push_str("endsolid t\n");
            std::fs::write(&p, text).unwrap();
            Mesh::load(&p)
        };
        let e = write([[0., 0., 1.], [0., 0., 1.]]).unwrap_err().to_string();
        assert!(
            e.contains("facet 1") && e.contains("2 of 2 facets point against their winding"),
            "{e}"
        );
        // Normals that agree, zero normals (left to the reader), or one of two against: read.
        assert_eq!(
            write([[0., 0., -1.], [0., 0., -1.]]).unwrap().facets[0].normal,
            [0., 0., -1.]
        );
        write([[0., 0., 0.], [0., 0., 0.]]).unwrap();
        write([[0., 0., 1.], [0., 0., -1.]]).unwrap();
    }

    #[test]
    fn stl_facet_counts_and_solids_are_checked() {
        let dir = tempfile::tempdir().unwrap();
        let facet = |v: [[f32; 3]; 3]| -> Vec<u8> {
            let mut b: Vec<u8> = [0f32, 0.0, 1.0].iter().flat_map(|x| x.to_le_bytes()).collect();
            b.extend(v.iter().flatten().flat_map(|x| x.to_le_bytes()));
            b.extend([0, 0]);
            b
        };
        let t1 = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]];
        let t2 = [[2., 0., 0.], [3., 0., 0.], [2., 1., 0.]];
        let binary = |count: u32, n: usize| {
            let mut b = vec![b'x'; 80];
            b.extend(count.to_le_bytes());
            for t in [t1, t2].iter().take(n) {
                b.extend(facet(*t));
            }
            b
        };
        let p = dir.path().join("b.stl");
        for (count, n) in [(1, 2), (3, 2)] {
            std::fs::write(&p, binary(count, n)).unwrap();
            let e = Mesh::load(&p).unwrap_err().to_string();
            assert!(e.contains(&format!("header counts {count} facets")), "{e}");
        }
        std::fs::write(&p, binary(2, 2)).unwrap();
        assert_eq!(Mesh::load(&p).unwrap().facets.len(), 2);
        // A binary header that begins with `solid` (some exporters write one) is still binary.
        let mut solid_header = binary(2, 2);
        solid_header[..6].copy_from_slice(b"solid ");
        std::fs::write(&p, &solid_header).unwrap();
        assert_eq!(Mesh::load(&p).unwrap().facets.len(), 2);
        let a = "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n\
                 endloop\nendfacet\nendsolid a\n";
        let b = a.replace("solid a", "solid b").replace("vertex 0 ", "vertex 5 ");
        std::fs::write(&p, format!("{a}{b}")).unwrap();
        let e = Mesh::load(&p).unwrap_err().to_string();
        assert!(e.contains("line 10") && e.contains("second `solid`"), "{e}");
        // Facets after the first `endsolid`, with no second `solid`, were dropped in silence.
        let tail = b.replace("solid b\n", "").replace("endsolid b\n", "");
        std::fs::write(&p, format!("{a}{tail}")).unwrap();
        let e = Mesh::load(&p).unwrap_err().to_string();
        assert!(e.contains("line 10") && e.contains("after `endsolid`"), "{e}");
        std::fs::write(&p, format!("{a}\n  \n")).unwrap();
        assert_eq!(
            Mesh::load(&p).unwrap().facets.len(),
            1,
            "blank lines after it are fine"
        );
    }

    /// A vertex weight was divided by (w = 2 halved the target) and an unknown statement was
    /// skipped (a misspelt `v0` shifted every later vertex index): both are refused by line.
    #[test]
    fn vertex_weights_and_unknown_statements_are_refused() {
        let e = obj(&TETRA.replace("v 1 0 0", "v 1 0 0 2"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("vertex weight w = 2"), "{e}");
        assert!(obj(&TETRA.replace("v 1 0 0", "v 1 0 0 1")).is_ok());
        let e = obj(&TETRA.replace("v 1 0 0", "v0 1 0 0"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2") && e.contains("`v0` is not an OBJ statement"),
            "{e}"
        );
        assert!(obj(&format!("# c\nmtllib a.mtl\nusemtl x\ns off\n{TETRA}")).is_ok());
    }

    /// Free-form geometry was skipped (a `surf` lid lost with no word); coordinates beyond
    /// 1.2e77 m gave zero normals (the cross product overflowed) and σ 0; planar quads 1e8 m
    /// from the origin were refused as not planar (the Newell normal about the origin).
    #[test]
    fn free_form_geometry_huge_coordinates_and_far_quads() {
        let lid = format!("{TETRA}v 0 0 2\nv 1 0 2\nv 1 1 2\nv 0 1 2\no lid\ncstype bspline\ndeg 1 1\nsurf 0 1 0 1 5 6 7 8\nparm u 0 0 1 1\nparm v 0 0 1 1\nend\n");
        let e = obj(&lid).unwrap_err().to_string();
        assert!(
            e.contains("line 17") && e.contains("free-form geometry (`surf`)"),
            "{e}"
        );
        for s in [2e77, 1e31] {
            let big = TETRA.replace("v 1 0 0", &format!("v {s:e} 0 0"));
            let e = obj(&big).unwrap_err().to_string();
            assert!(e.contains("beyond 1e30 m"), "{s}: {e}");
        }
        let scaled = TETRA
            .replace("v 1 0 0", "v 1e29 0 0")
            .replace("v 0 1 0", "v 0 1e29 0")
            .replace("v 0 0 1", "v 0 0 1e29");
        let m = obj(&scaled).unwrap();
        assert!(m.facets.iter().all(|f| f.area > 1e57 && f.area.is_finite()));
        for o in [1e8, 6.4e6, 1e12] {
            let quads = format!(
                "v {o} {o} {o}\nv {a} {o} {o}\nv {a} {a} {o}\nv {o} {a} {o}\no plate\nf 1 2 3 4\n",
                a = o + 1.0
            );
            let m = obj(&quads).unwrap_or_else(|e| panic!("{o}: {e}"));
            assert_eq!(m.facets.len(), 2, "{o}");
            assert!((m.facets[0].area + m.facets[1].area - 1.0).abs() < 1e-6, "{o}");
        }
    }

    /// An inside-out cube written with one corner as `-0` was welded as an open shell (its
    /// winding unchecked); one at geocentric coordinates had a signed volume of rounding noise
    /// (the right winding refused, the inverse accepted). Both are checked now.
    #[test]
    fn an_inside_out_shell_is_found_whatever_its_zeros_and_its_offset() {
        let cube = |o: [f64; 3], h: f64, inside_out: bool, neg_zero: bool| -> String {
            let mut t = String::new();
            for k in 0..8 {
                let c = [k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|b| b as f64 * h);
                let p: Vec<String> = (0..3)
                    .map(|i| {
                        let v = o[i] + c[i];
                        if neg_zero && k == 0 && i == 0 && v == 0.0 {
                            "-0".to_owned()
                        } else {
                            format!("{v}")
                        }
                    })
                    .collect();
                t += &format!("v {}\n", p.join(" "));
            }
            // Outward (counter-clockwise from outside) faces of the unit cube.
            for f in ["1 3 4 2", "5 6 8 7", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6"] {
                let mut ids: Vec<&str> = f.split(' ').collect();
                if inside_out {
                    ids.reverse();
                }
                t += &format!("f {}\n", ids.join(" "));
            }
            t
        };
        assert!(obj(&cube([0.0; 3], 1.0, false, true)).is_ok());
        let e = obj(&cube([0.0; 3], 1.0, true, true)).unwrap_err().to_string();
        assert!(e.contains("negative volume"), "{e}");
        let far = [6.4e6, 1.0e5, 3.0e5];
        assert!(
            obj(&cube(far, 0.5, false, false)).is_ok(),
            "an outward cube far from the origin"
        );
        let e = obj(&cube(far, 0.5, true, false)).unwrap_err().to_string();
        assert!(e.contains("negative volume"), "{e}");
    }

    /// A hollow solid: an outward cube holding a cube wound inwards (a cavity, its faces
    /// turned into the hollow) encloses a negative volume rightly and was refused as inside
    /// out. Accepted now; an inward cube beside the outward one, or inside a cavity, or
    /// holding an outward one, is still refused, as is an inward cube alone.
    /// An OBJ of boxes `(lo, hi, wound inwards)`, each its own part (`b0`, `b1`, ...), its
    /// faces as quads, followed by `extra` (statements that may use the boxes' vertices).
    fn boxes(list: &[([f64; 3], [f64; 3], bool)], extra: &str) -> String {
        let mut text = String::new();
        for (k, &(lo, hi, inward)) in list.iter().enumerate() {
            text += &format!("o b{k}\n");
            for c in 0..8 {
                let p = [0, 1, 2].map(|a| if (c >> a) & 1 == 1 { hi[a] } else { lo[a] });
                text += &format!("v {} {} {}\n", p[0], p[1], p[2]);
            }
            for face in [
                [1, 3, 4, 2],
                [5, 6, 8, 7],
                [1, 2, 6, 5],
                [3, 7, 8, 4],
                [1, 5, 7, 3],
                [2, 4, 8, 6],
            ] {
                let mut ids = face.map(|i| i + 8 * k);
                if inward {
                    ids.reverse();
                }
                text += &format!("f {} {} {} {}\n", ids[0], ids[1], ids[2], ids[3]);
            }
        }
        text + extra
    }

    #[test]
    fn a_shell_inside_out_is_found_beside_flaps_touching_shells_and_small_holes() {
        let inside_out = |text: &str, part: &str| {
            let e = obj(text).expect_err(part).to_string();
            assert!(
                e.contains("negative volume") && e.contains(&format!("part `{part}`")),
                "{e}"
            );
        };
        let unit = ([0.0, 0.0, 0.0], [2.0, 2.0, 1.0]);
        // A flap welded onto an edge of a box: the box was one open shell with it, unchecked.
        let flap = "o flap\nv 2.5 1 1\nf 7 8 9\n";
        let flap_inward = "o flap\nv 2.5 1 1\nf 8 7 9\n";
        inside_out(&boxes(&[(unit.0, unit.1, true)], flap_inward), "b0");
        obj(&boxes(&[(unit.0, unit.1, false)], flap)).unwrap();
        // Two boxes touching along an edge, one inside out.
        let touching = |inward: bool| {
            boxes(
                &[
                    (unit.0, unit.1, false),
                    ([2.0, 2.0, 0.0], [3.0, 3.0, 1.0], inward),
                ],
                "",
            )
        };
        inside_out(&touching(true), "b1");
        obj(&touching(false)).unwrap();
        // A box wound inside out and pushed through another's top, listed with a face inside
        // the other first: taken for a cavity, as only that face's centre was tested.
        let hull = ([-2.0, -0.5, -0.5], [2.0, 0.5, 0.5]);
        let fin = |inward: bool| {
            boxes(
                &[
                    (hull.0, hull.1, false),
                    ([-0.5, -0.05, 0.3], [0.5, 0.05, 1.3], inward),
                ],
                "",
            )
        };
        inside_out(&fin(true), "b1");
        obj(&fin(false)).unwrap();
        // A sphere of 320 facets, inside out, with one or two facets taken out: its openings
        // are far too small to make its volume positive. With a third of it taken out, or
        // wound outwards, accepted.
        let mut sphere = crate::shapes::MeshBuilder::new();
        sphere.icosphere(1.0, 2, "ball");
        let mut written = Vec::new();
        sphere.write_obj(&mut written, "").unwrap();
        let written = String::from_utf8(written).unwrap();
        let sphere_obj = |inward: bool, drop: &dyn Fn(usize) -> bool| {
            let mut k = 0;
            let mut text = String::new();
            for line in written.lines() {
                if let Some(ids) = line.strip_prefix("f ") {
                    k += 1;
                    if drop(k - 1) {
                        continue;
                    }
                    let mut ids: Vec<&str> = ids.split(' ').collect();
                    if inward {
                        ids.reverse();
                    }
                    text += &format!("f {}\n", ids.join(" "));
                } else {
                    text += &format!("{line}\n");
                }
            }
            assert_eq!(k, 320);
            text
        };
        inside_out(&sphere_obj(true, &|k| k == 17), "ball");
        inside_out(&sphere_obj(true, &|k| k == 17 || k == 200), "ball");
        obj(&sphere_obj(false, &|k| k == 17)).unwrap();
        obj(&sphere_obj(true, &|k| k % 3 == 0)).unwrap();
    }

    #[test]
    fn a_mouth_is_no_small_opening_and_a_fin_out_of_a_concave_hull_no_cavity() {
        // The inner surface of a ball with a cap cut off (an exhaust's or a bowl's inside,
        // facing into it): open at a mouth, accepted; a few facets missing, refused.
        let mut ball = crate::shapes::MeshBuilder::new();
        ball.icosphere(1.0, 3, "inside");
        let mut written = Vec::new();
        ball.write_obj(&mut written, "").unwrap();
        let written = String::from_utf8(written).unwrap();
        let z: Vec<f64> = written
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|c| c.split(' ').nth(2).unwrap().parse().unwrap())
            .collect();
        let inward_without = |cut: &dyn Fn(f64) -> bool| -> String {
            written
                .lines()
                .filter_map(|l| match l.strip_prefix("f ") {
                    None => Some(format!("{l}\n")),
                    Some(ids) => {
                        let ids: Vec<usize> = ids.split(' ').map(|i| i.parse().unwrap()).collect();
                        let centre = ids.iter().map(|&i| z[i - 1]).sum::<f64>() / 3.0;
                        (!cut(centre)).then(|| format!("f {} {} {}\n", ids[2], ids[1], ids[0]))
                    }
                })
                .collect()
        };
        obj(&inward_without(&|z| z > 0.8)).unwrap();
        // The inside of a convergent nozzle: radius 1 at its closed face, 0.5 at its mouth 2
        // further on, facing into it. Its volume is negative whatever closes the mouth, but
        // the mouth is 6% of its area: a mouth, accepted.
        let nozzle = |inward: bool| {
            let n = 32;
            let mut text = String::from("o nozzle\nv 0 0 0\n");
            for (x, r) in [(0.0, 1.0), (2.0, 0.5)] {
                for k in 0..n {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    text += &format!("v {x} {} {}\n", r * a.cos(), r * a.sin());
                }
            }
            let face = |ids: [usize; 3]| {
                let [a, b, c] = if inward { [ids[0], ids[2], ids[1]] } else { ids };
                format!("f {a} {b} {c}\n")
            };
            for k in 0..n {
                let (i, j) = (2 + k, 2 + (k + 1) % n);
                // Outward: the face looks along -x, the wall away from the axis.
                text += &face([1, j, i]);
                text += &face([i, j, j + n]);
                text += &face([i, j + n, i + n]);
            }
            text
        };
        obj(&nozzle(true)).unwrap();
        obj(&nozzle(false)).unwrap();
        // A hollow ball with a 10 degree port, its walls not joined at the port: the inner
        // wall, facing into the hollow, is a cavity of the outer; alone, it is refused.
        let shell = |r: f64, inward: bool| -> String {
            let mut b = crate::shapes::MeshBuilder::new();
            b.icosphere(r, 3, if inward { "inner" } else { "outer" });
            let mut w = Vec::new();
            b.write_obj(&mut w, "").unwrap();
            let w = String::from_utf8(w).unwrap();
            let v: Vec<[f64; 3]> = w
                .lines()
                .filter_map(|l| l.strip_prefix("v "))
                .map(|c| {
                    let c: Vec<f64> = c.split(' ').map(|x| x.parse().unwrap()).collect();
                    [c[0], c[1], c[2]]
                })
                .collect();
            w.lines()
                .filter_map(|l| match l.strip_prefix("f ") {
                    None => Some(format!("{l}\n")),
                    Some(ids) => {
                        let ids: Vec<usize> = ids.split(' ').map(|i| i.parse().unwrap()).collect();
                        let z = ids.iter().map(|&i| v[i - 1][2]).sum::<f64>() / 3.0;
                        (z < r * 10f64.to_radians().cos()).then(|| {
                            if inward {
                                format!("f {} {} {}\n", ids[2], ids[1], ids[0])
                            } else {
                                format!("f {} {} {}\n", ids[0], ids[1], ids[2])
                            }
                        })
                    }
                })
                .collect()
        };
        let inner = shell(0.98, true);
        let shifted: String = inner
            .lines()
            .map(|l| match l.strip_prefix("f ") {
                Some(ids) => {
                    let ids: Vec<usize> = ids
                        .split(' ')
                        .map(|i| i.parse::<usize>().unwrap() + 642)
                        .collect();
                    format!("f {} {} {}\n", ids[0], ids[1], ids[2])
                }
                None => format!("{l}\n"),
            })
            .collect();
        obj(&format!("{}{shifted}", shell(1.0, false))).expect("a hollow ball with a port");
        let e = obj(&inner).unwrap_err().to_string();
        assert!(e.contains("negative volume") && e.contains("part `inner`"), "{e}");
        let e = obj(&inward_without(&|z| z > 0.99)).unwrap_err().to_string();
        assert!(e.contains("negative volume"), "{e}");
        // An L-shaped solid (its cap a six-sided face) holding a fin wound inside out in its
        // lower arm, whose top sticks out of the arm into the notch, within the L's box: the
        // fin's first facet lies inside the arm; its highest facet does not.
        let l_shape = "o hull\nv 0 0 0\nv 4 0 0\nv 4 0 1\nv 1 0 1\nv 1 0 4\nv 0 0 4\n\
                       v 0 1 0\nv 4 1 0\nv 4 1 1\nv 1 1 1\nv 1 1 4\nv 0 1 4\n\
                       f 1 2 3 4 5 6\nf 12 11 10 9 8 7\nf 1 7 8 2\nf 2 8 9 3\nf 3 9 10 4\n\
                       f 4 10 11 5\nf 5 11 12 6\nf 6 12 7 1\n";
        let with_fin = |top: f64| {
            let mut fin = crate::shapes::MeshBuilder::new();
            fin.cuboid([2.0, 0.2, 0.2], [3.0, 0.8, top], [1, 1, 40], "fin");
            let mut written = Vec::new();
            fin.write_obj(&mut written, "").unwrap();
            let mut text = l_shape.to_owned();
            for line in String::from_utf8(written).unwrap().lines() {
                text += &match line.strip_prefix("f ") {
                    Some(ids) => {
                        let ids: Vec<usize> =
                            ids.split(' ').map(|i| i.parse::<usize>().unwrap() + 12).collect();
                        format!("f {} {} {}\n", ids[2], ids[1], ids[0])
                    }
                    None => format!("{line}\n"),
                };
            }
            text
        };
        let e = obj(&with_fin(1.03)).unwrap_err().to_string();
        assert!(e.contains("negative volume") && e.contains("part `fin`"), "{e}");
        obj(&with_fin(0.9)).expect("a cavity in the arm");
    }

    #[test]
    fn a_vertex_off_a_seam_by_f32_rounding_is_no_overlap() {
        // Two coplanar plates 3 km out, written with 17 digits, meeting along a seam; the
        // middle of the seam is a vertex of one side only, off the seam by `off` (f32 rounding
        // of coordinates computed in f32 and shifted in f64: 4e-6 m). Refused as an overlap
        // at 4e-6 m deep; 5 cm deep is one.
        let text = |off: f64| {
            let (x0, y0) = (3000.123456789, -2000.987654321);
            let v = |x: f64, y: f64| format!("v {:?} {:?} 7.25\n", x + x0, y + y0);
            [
                v(0.0, 0.0),
                v(2.0, 0.0),
                v(0.0, 2.0),
                v(2.0, 2.0),
                v(1.0 - off, 1.0 - off),
            ]
            .concat()
                + "f 1 2 3\nf 2 4 5\nf 5 4 3\n"
        };
        obj(&text(4e-6)).unwrap();
        let e = obj(&text(0.05)).unwrap_err().to_string();
        assert!(e.contains("lie on each other"), "{e}");
    }

    #[test]
    fn a_cavity_in_a_solid_is_not_inside_out() {
        let cube = |o: f64, h: f64, inward: bool, first: usize| -> (String, String) {
            let mut v = String::new();
            for k in 0..8 {
                let c = [k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|b| o + b as f64 * h);
                v += &format!("v {} {} {}\n", c[0], c[1], c[2]);
            }
            let mut f = String::new();
            for face in ["1 3 4 2", "5 6 8 7", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6"] {
                let mut ids: Vec<usize> = face
                    .split(' ')
                    .map(|i| i.parse::<usize>().unwrap() + first)
                    .collect();
                if inward {
                    ids.reverse();
                }
                f += &format!("f {} {} {} {}\n", ids[0], ids[1], ids[2], ids[3]);
            }
            (v, f)
        };
        let mesh = |cubes: &[(f64, f64, bool)]| {
            let (mut v, mut f) = (String::new(), String::new());
            for (k, &(o, h, inward)) in cubes.iter().enumerate() {
                let (cv, cf) = cube(o, h, inward, 8 * k);
                v += &cv;
                f += &cf;
            }
            obj(&format!("o solid\n{v}{f}"))
        };
        let hollow = mesh(&[(0.0, 3.0, false), (1.0, 1.0, true)]).expect("a hollow cube");
        assert!(hollow.closed.iter().all(|&c| c));
        // The cavity listed first.
        assert!(mesh(&[(1.0, 1.0, true), (0.0, 3.0, false)]).is_ok());
        for (what, cubes) in [
            ("alone", vec![(1.0, 1.0, true)]),
            ("beside a solid", vec![(0.0, 3.0, false), (5.0, 1.0, true)]),
            (
                "in a cavity",
                vec![(0.0, 9.0, false), (1.0, 7.0, true), (3.0, 1.0, true)],
            ),
            ("holding a solid", vec![(0.0, 3.0, true), (1.0, 1.0, false)]),
        ] {
            let e = mesh(&cubes).expect_err(what).to_string();
            assert!(e.contains("negative volume"), "{what}: {e}");
        }
    }

    /// A device is refused unread, whatever its name says (`/dev/zero` was read until memory
    /// ran out), and so is a directory.
    #[test]
    fn a_device_or_directory_is_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("zero.stl");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let e = Mesh::load(&link).unwrap_err().to_string();
        assert!(e.contains("zero.stl: not a regular file"), "{e}");
        let sub = dir.path().join("d.obj");
        std::fs::create_dir(&sub).unwrap();
        let e = Mesh::load(&sub).unwrap_err().to_string();
        assert!(e.contains("d.obj: not a regular file"), "{e}");
        let e = Mesh::load(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(e.contains("unknown mesh format"), "{e}");
    }

    /// A UTF-8 byte-order mark before the first statement is not part of it (the first line
    /// was lost and a later one blamed).
    #[test]
    fn a_byte_order_mark_is_skipped() {
        let m = obj(&format!("\u{feff}{TETRA}")).unwrap();
        assert_eq!(m.facets.len(), 4);
        assert_eq!(m.origins[0], Origin::Line(6));
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.stl");
        let stl = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n\
                   endloop\nendfacet\nendsolid t\n";
        std::fs::write(&p, format!("\u{feff}{stl}")).unwrap();
        assert_eq!(Mesh::load(&p).unwrap().facets.len(), 1);
    }
}

#[cfg(test)]
mod coincident_tests {
    use super::*;

    fn obj(text: &str) -> Result<Mesh, MeshError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.obj");
        std::fs::write(&p, text).unwrap();
        Mesh::load(&p)
    }

    /// A 2 x 2 plate (two triangles) facing +z, and a 1 x 1 decal on it at height `z`,
    /// triangulated along its other diagonal, as its own part.
    fn plate_and_decal(z: f64, decal_faces_up: bool) -> String {
        let decal = if decal_faces_up {
            "f 5 6 7\nf 5 7 8\n"
        } else {
            "f 5 7 6\nf 5 8 7\n"
        };
        format!(
            "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nv 0.5 0.5 {z}\nv 1.5 0.5 {z}\nv 1.5 1.5 {z}\nv 0.5 1.5 {z}\n\
             o plate\nf 1 2 3\nf 1 3 4\no decal\n{decal}"
        )
    }

    #[test]
    fn a_decal_on_a_hull_is_refused_naming_both_facets() {
        // The decal lying on the plate was counted twice (sigma doubled there).
        let e = obj(&plate_and_decal(0.0, true)).unwrap_err().to_string();
        assert!(e.contains("lie on each other") && e.contains("line 1"), "{e}");
        // Lifted 1 mm, it occludes the plate instead: accepted. Facing the other way (a
        // two-sided sheet), accepted.
        obj(&plate_and_decal(1e-3, true)).unwrap();
        obj(&plate_and_decal(0.0, false)).unwrap();
        // The same plate split into four triangles that only share edges: accepted.
        obj("v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nv 1 1 0\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n").unwrap();
        // A second copy of the plate triangulated along the other diagonal.
        let twice =
            "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nf 1 2 3\nf 1 3 4\nv 0 0 0.0\nv 2 0 0\nv 2 2 0\nv 0 2 0\n";
        let e = obj(&format!("{twice}o copy\nf 2 3 4\nf 2 4 1\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("lie on each other") || e.contains("inconsistent winding"),
            "{e}"
        );
    }

    /// `plate_and_decal` turned 37 degrees about x and 23 about y, moved 5 to 9 m from the
    /// origin and written to six decimals, as exporters do.
    fn tilted_six_decimals(z: f64, scale: f64) -> String {
        let (a, b) = (37f64.to_radians(), 23f64.to_radians());
        let place = |p: [f64; 3]| {
            let p = p.map(|c| c * scale);
            let (y, z) = (p[1] * a.cos() - p[2] * a.sin(), p[1] * a.sin() + p[2] * a.cos());
            let (x, z) = (p[0] * b.cos() + z * b.sin(), -p[0] * b.sin() + z * b.cos());
            format!("v {:.6} {:.6} {:.6}\n", x + 5.0, y - 3.0, z + 7.0)
        };
        let corners = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]];
        let decal = [[0.5, 0.5, z], [1.5, 0.5, z], [1.5, 1.5, z], [0.5, 1.5, z]];
        let mut text: String = corners.iter().chain(&decal).map(|p| place(*p)).collect();
        text.push_str("o plate\nf 1 2 3\nf 1 3 4\no decal\nf 5 6 7\nf 5 7 8\n");
        text
    }

    #[test]
    fn a_decal_on_a_tilted_hull_far_from_the_origin_is_refused_at_six_decimals() {
        // Rounded to 1e-6 m, the decal's plane and the hull's were 1e-6 m apart and their
        // normals 1e-6 apart: compared by offsets from the origin against 1e-9 of the
        // diagonal, they were two planes, and the decal was counted twice.
        for scale in [1.0, 0.01, 30.0] {
            let e = obj(&tilted_six_decimals(0.0, scale)).unwrap_err().to_string();
            assert!(e.contains("lie on each other"), "scale {scale}: {e}");
        }
        // Lifted 1 mm (2 m plate) or 1 cm (60 m plate): accepted.
        obj(&tilted_six_decimals(1e-3, 1.0)).unwrap();
        obj(&tilted_six_decimals(1e-3 / 3.0, 30.0)).unwrap();
    }

    #[test]
    fn a_tilted_plate_with_a_vertex_on_a_neighbours_edge_is_accepted_at_six_decimals() {
        // Three triangles: the midpoint of the long edge is a vertex of two of them but not
        // of the third (a T-junction). Rounded, the third and its neighbours interpenetrate
        // by the rounding (5e-7 m), which is not an overlap.
        let (a, b) = (29f64.to_radians(), 41f64.to_radians());
        let place = |p: [f64; 2]| {
            let (y, z) = (p[1] * a.cos(), p[1] * a.sin());
            let (x, z) = (p[0] * b.cos() + z * b.sin(), -p[0] * b.sin() + z * b.cos());
            format!("v {:.6} {:.6} {:.6}\n", x + 3.0, y, z - 2.0)
        };
        let pts = [
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0 / 3.0, 1.0],
            [2.0 / 3.0, 0.5],
            [1.0, 1.0],
        ];
        let mut text: String = pts.iter().map(|p| place(*p)).collect();
        text.push_str("f 1 2 4\nf 1 4 3\nf 2 5 3\n");
        obj(&text).unwrap();
    }

    #[test]
    fn the_same_pair_is_named_on_every_load() {
        let text = plate_and_decal(0.0, true);
        let named = || {
            let e = obj(&text).unwrap_err().to_string();
            e[e.find("t.obj:").unwrap()..].to_string()
        };
        let first = named();
        for _ in 0..5 {
            assert_eq!(named(), first);
        }
    }

    /// A fan of `k` slivers around the origin covering `turns` turns (rim rounded to six
    /// decimals, the apex `apex` above the rim's plane), optionally written twice.
    fn fan(k: usize, turns: f64, apex: f64, twice: bool) -> String {
        let mut text = format!("v 0 0 {apex}\n");
        for i in 0..k {
            let t = turns * std::f64::consts::TAU * i as f64 / k as f64;
            text.push_str(&format!("v {:.6} {:.6} 0\n", t.cos(), t.sin()));
        }
        let last = if turns >= 1.0 && turns.fract() == 0.0 {
            k
        } else {
            k - 1
        };
        for copy in 0..1 + twice as usize {
            text.push_str(&format!("o copy{copy}\n"));
            for i in 0..last {
                text.push_str(&format!("f 1 {} {}\n", i + 2, (i + 1) % k + 2));
            }
        }
        text
    }

    #[test]
    fn written_digits_and_the_precision_they_give() {
        assert_eq!(written_digits("5000000.125"), Some((10, 3)));
        assert_eq!(written_digits("-1.50e-3"), Some((3, 5)));
        assert_eq!(written_digits("+0.000000"), Some((0, 6)));
        assert_eq!(written_digits("5e+06"), Some((1, -6)));
        assert_eq!(written_digits(".5"), Some((1, 1)));
        for not in ["inf", "nan", "0x1p3", "1e", ".", "-", "1e999999", "1.2.3"] {
            assert_eq!(written_digits(not), None, "{not}");
        }
        let p = |t: &[&str]| Precision::of_text(t.iter().copied());
        // Six decimals at survey coordinates: the decimals, and the 13 digits, hold.
        let survey = p(&["5000000.125000", "-3.500000", "0.000000"]);
        assert_eq!(survey.abs_m, 1e-6);
        assert!((survey.rel - 1e-12).abs() < 1e-24, "{survey:?}");
        // `%g`: six significant digits.
        let g = p(&["5.12346e+06", "0.123457", "1.5e-07"]);
        assert!((g.rel - 1e-5).abs() < 1e-17 && g.abs_m < 1e-6, "{g:?}");
        // Round numbers, or a word the digits cannot be read from: the loosest.
        assert_eq!(p(&["0", "1", "-3", "2.5"]), Precision::WRITTEN);
        assert_eq!(p(&["5000000.125000", "inf"]), Precision::WRITTEN);
        assert_eq!(p(&[]), Precision::WRITTEN);
        // Shortest decimals of f64 values, and of f32 values widened to f64 (17 digits, but
        // each exactly an f32): double, single.
        let double = p(&["5000000.123456789", "0.1"]);
        assert!(double.rel < 1e-14 && double.abs_m <= 1e-9, "{double:?}");
        let widened = p(&["0.10000000149011612", "5000000.5"]);
        assert_eq!(widened.rel, Precision::SINGLE.rel, "{widened:?}");
        // An f32's shortest decimals, or an f32 at six decimals: single at best; a digit that
        // no f32 is within half of is double.
        assert_eq!(p(&["0.12345679", "12.5"]).rel, Precision::SINGLE.rel);
        assert_eq!(p(&["1000.123413", "-0.5"]).rel, Precision::SINGLE.rel);
        // An f32 written correctly rounded at a tie (722.4296875), read back over half the
        // last digit off by f64's own rounding: still single.
        assert_eq!(p(&["722.429688", "0.5"]).rel, Precision::SINGLE.rel);
        assert!(p(&["0.123456789", "12.5"]).rel < Precision::SINGLE.rel);
    }

    /// `plate_and_decal` moved to `(x0, y0, z0)` and written to six decimals.
    fn survey_plate_and_decal(x0: f64, y0: f64, z0: f64, z: f64) -> String {
        let shift = |l: &str| {
            let c: Vec<f64> = l[2..].split(' ').map(|c| c.parse().unwrap()).collect();
            format!("v {:.6} {:.6} {:.6}", c[0] + x0, c[1] + y0, c[2] + z0)
        };
        plate_and_decal(z, true)
            .lines()
            .map(|l| {
                if l.starts_with("v ") {
                    shift(l)
                } else {
                    l.to_owned()
                }
            })
            .map(|l| l + "\n")
            .collect()
    }

    #[test]
    fn a_decal_at_survey_coordinates_is_refused_at_six_decimals() {
        // At 5e6 m the tolerance was 1e-5 of the coordinates, 50 m: the decal was within it
        // of the plate but overlapped it by less, and was counted twice.
        // (Offsets that are not round: a file whose every coordinate is also an f32's value
        // reads as single precision, compared within about 1 m there.)
        let offsets = [
            (5e6 + 0.123457, 4.2e6 + 0.654321, 0.0),
            (0.0, 0.0, 6.4e6 + 0.318529),
            (-3.1e6 - 0.271828, 2.2e6 + 0.141421, 4.9e6 + 0.577215),
        ];
        for (x0, y0, z0) in offsets {
            let e = obj(&survey_plate_and_decal(x0, y0, z0, 0.0))
                .unwrap_err()
                .to_string();
            assert!(e.contains("lie on each other"), "{e}");
            // Lifted 1 mm: accepted.
            obj(&survey_plate_and_decal(x0, y0, z0, 1e-3)).unwrap();
        }
        // Tilted there, written to six decimals: the decal is refused, and a vertex on a
        // neighbour's edge is no overlap.
        let far = |text: String| {
            text.lines()
                .map(|l| match l.strip_prefix("v ") {
                    Some(c) => {
                        let c: Vec<f64> = c.split(' ').map(|c| c.parse().unwrap()).collect();
                        format!(
                            "v {:.6} {:.6} {:.6}\n",
                            c[0] + 4.7e6,
                            c[1] - 2.3e6 + 0.1,
                            c[2] + 3.9e6
                        )
                    }
                    None => format!("{l}\n"),
                })
                .collect::<String>()
        };
        let e = obj(&far(tilted_six_decimals(0.0, 1.0))).unwrap_err().to_string();
        assert!(e.contains("lie on each other"), "{e}");
        obj(&far(tilted_six_decimals(1e-3, 1.0))).unwrap();
        let mesh = obj(&far(tilted_six_decimals(1e-3, 1.0))).unwrap();
        assert!(
            mesh.precision.abs_m == 1e-6 && mesh.precision.rel < 1e-11,
            "{:?}",
            mesh.precision
        );
    }

    #[test]
    fn a_large_panel_a_millimetre_proud_is_apart() {
        // An 18 m panel 1 mm above a 20 m plate: 6e-5 of its size, apart (it occludes the
        // plate); lying on it, refused.
        let text = |z: f64| {
            format!(
                "v 0 0 0\nv 20 0 0\nv 20 20 0\nv 0 20 0\nv 1 1 {z}\nv 19 1 {z}\nv 19 19 {z}\nv 1 19 {z}\n\
                 o plate\nf 1 2 3\nf 1 3 4\no panel\nf 5 6 7\nf 5 7 8\n"
            )
        };
        obj(&text(1e-3)).unwrap();
        let e = obj(&text(0.0)).unwrap_err().to_string();
        assert!(e.contains("lie on each other"), "{e}");
    }

    #[test]
    fn a_small_decal_on_a_large_tilted_facet_is_refused() {
        // A 1 cm decal on a 100 m plate: the plate's vertices against the decal's plane, 100 m
        // out, were off by the decal's rounding times 1e4, and the pair was not compared.
        let e = obj(&tilted_six_decimals_decal(0.0)).unwrap_err().to_string();
        assert!(e.contains("lie on each other"), "{e}");
        obj(&tilted_six_decimals_decal(1e-3)).unwrap();
    }

    /// A 100 m plate turned 37 degrees about x and 23 about y, with a 1 cm decal at height `z`
    /// near its middle, written to six decimals.
    fn tilted_six_decimals_decal(z: f64) -> String {
        let (a, b) = (37f64.to_radians(), 23f64.to_radians());
        let place = |p: [f64; 3]| {
            let (y, z) = (p[1] * a.cos() - p[2] * a.sin(), p[1] * a.sin() + p[2] * a.cos());
            let (x, z) = (p[0] * b.cos() + z * b.sin(), -p[0] * b.sin() + z * b.cos());
            format!("v {:.6} {:.6} {:.6}\n", x + 5.0, y - 3.0, z + 7.0)
        };
        let corners = [
            [0.0, 0.0, 0.0],
            [100.0, 0.0, 0.0],
            [100.0, 100.0, 0.0],
            [0.0, 100.0, 0.0],
        ];
        let d = 0.01;
        let decal = [
            [50.0, 30.0, z],
            [50.0 + d, 30.0, z],
            [50.0 + d, 30.0 + d, z],
            [50.0, 30.0 + d, z],
        ];
        let mut text: String = corners.iter().chain(&decal).map(|p| place(*p)).collect();
        text.push_str("o plate\nf 1 2 3\nf 1 3 4\no decal\nf 5 6 7\nf 5 7 8\n");
        text
    }

    #[test]
    fn fans_are_checked_by_their_wedges_in_about_linear_time() {
        // 20,000 slivers around one vertex took 50 s compared pairwise in one cell.
        let t = std::time::Instant::now();
        assert_eq!(obj(&fan(20_000, 1.0, 0.0, false)).unwrap().facets.len(), 20_000);
        println!("a fan of 20,000 facets checked in {:?}", t.elapsed());
        // A cone's apex (every facet in its own plane), a part of a turn: accepted.
        obj(&fan(500, 1.0, 0.3, false)).unwrap();
        obj(&fan(500, 0.5, 0.0, false)).unwrap();
        // A fan winding one and a half turns lies on itself; a fan written twice (two
        // parts) too.
        // (601 slivers, so that no rim vertex of the second turn falls on one of the first.)
        for text in [
            fan(601, 1.5, 0.0, false),
            fan(500, 1.0, 0.0, true),
            fan(40, 1.0, 0.0, true),
        ] {
            let e = obj(&text).unwrap_err().to_string();
            assert!(
                e.contains("lie on each other") || e.contains("inconsistent winding"),
                "{e}"
            );
        }
        // The first overlapping pair in file order is named: sliver 0, from 0 to 1.5/601 of
        // a turn, and sliver 400, from 0.9983 to 1.0008 turns (lines 604 and 1004).
        let e = obj(&fan(601, 1.5, 0.0, false)).unwrap_err().to_string();
        assert!(e.contains("line 604 and line 1004"), "{e}");
    }

    #[test]
    fn the_bundled_target_and_a_large_flat_plate_pass_quickly() {
        let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/target.obj");
        Mesh::load(&target).unwrap();
        // 200 x 200 quads in one plane: 80,000 coplanar triangles, compared through the grid.
        let n = 200;
        let mut text = String::new();
        for j in 0..=n {
            for i in 0..=n {
                text.push_str(&format!("v {i} {j} 0\n"));
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i + 1;
                text.push_str(&format!(
                    "f {a} {} {}\nf {a} {} {}\n",
                    a + 1,
                    a + n + 2,
                    a + n + 2,
                    a + n + 1
                ));
            }
        }
        let t = std::time::Instant::now();
        let m = obj(&text).unwrap();
        assert_eq!(m.facets.len(), 2 * n * n);
        println!("{} coplanar facets checked in {:?}", m.facets.len(), t.elapsed());
    }
}
