//! The total potential Π = U_elastic − s·(W_hydrostatic + W_head) + s·Π_weight + Π_contact
//! (s the load factor), its gradient and its Hessian on the free degrees of freedom.
//!
//! Degrees of freedom are the free axes of each vertex's constraint frame
//! ([`crate::constraints::Constraints`]). The sparse pattern (3×3 blocks of vertices sharing a
//! face) is built once, with the value slot of every element-matrix entry precomputed, so
//! assembling a Hessian is a parallel per-face evaluation followed by a parallel gather (each
//! value slot sums its precomputed list of element entries in face order: deterministic, no
//! atomics). Per-face results go to reusable buffers.

use crate::constraints::Constraints;
use crate::element::{Bar, Element, Mat9, Vec9, add_bars, add_bars_corner, add_bars_energy};
use crate::hydrostatic::Hydrostatic;
use crate::loads::{Barrier, Plane, face_volume};
use crate::material::Material;
use crate::walls::Wall;
use clothcast_mesh::sparse::SymmetricPattern;
use clothcast_mesh::util::group_by_key;
use clothcast_mesh::{FaceId, Mesh, Vec3, VertexId};
use nalgebra::Matrix3;
use rayon::prelude::*;

/// External loads.
#[derive(Clone, Debug, Default)]
pub struct Loads {
    /// Liquid infill.
    pub hydrostatic: Option<Hydrostatic>,
    /// Uniform pressure (Pa) over the whole surface.
    pub head_pressure: f64,
    /// Fabric weight: (g · areal density) in N/m², and the up direction.
    pub self_weight: Option<(f64, Vec3)>,
}

const NO_SLOT: u32 = u32::MAX;
const CHUNK: usize = 2048;
/// Value slots per task of the parallel Hessian gather.
const GATHER_CHUNK: usize = 4096;
/// Entries of a face's 9×9 Hessian that reach the lower triangle of the global matrix: at
/// most 45 (the lower triangle of its 9 dofs, relabelled; fewer when some are constrained).
const PICKS: usize = 45;
/// Unused pick.
const NO_PICK: u8 = u8::MAX;
/// Below this many vertices AMD alone is as good as nested dissection (fertility, 4.5k
/// vertices: AMD's factor is the faster one), so the second ordering is not computed.
const ND_MIN_VERTICES: usize = 5000;

/// How many times AMD's factor entries nested dissection may have and still be chosen, where
/// its top split lets the factorization run on two threads (AMD's runs on one). Kitten's
/// 26.6k-face coarse level (AMD 314k vertex-graph entries, nested dissection 352k, 1.12×):
/// 42–52 → 33–38 ms per factorization, its solve 3.0–3.2 → 2.4–2.5 s (two alternating runs).
pub const SPLIT_FILL_ALLOWANCE: f64 = 1.25;

/// Whether nested dissection is chosen over AMD, by their vertex-graph factor entries, given
/// whether its top split can be used (see [`System::dof_ordering`]).
fn prefer_nested(amd_fill: usize, nd_fill: usize, splittable: bool) -> bool {
    nd_fill < amd_fill
        || (splittable && large_enough_to_split(nd_fill) && (nd_fill as f64) < SPLIT_FILL_ALLOWANCE * amd_fill as f64)
}

/// Whether a factor of this many vertex-graph entries pays for the two-thread split (with
/// three dofs per vertex the dofs' factor has about nine times its entries).
fn large_enough_to_split(nd_fill: usize) -> bool {
    9 * nd_fill >= crate::newton::SPLIT_MIN_FACTOR_LEN
}

/// Nested-dissection parts of at most this many vertices are ordered by AMD.
const ND_LEAF: usize = 64;

/// The dof ordering [`System::dof_ordering`] chose.
#[derive(Clone, Debug)]
pub struct DofOrdering {
    /// The free dofs in elimination order.
    pub dofs: Vec<usize>,
    /// Whether nested dissection was chosen (else AMD).
    pub nested: bool,
    /// With nested dissection, the dof counts of the two halves of its top split (eliminated
    /// first, before their separator), where the split factorization was asked for and the
    /// factor is large enough for it.
    pub split: Option<[usize; 2]>,
    /// Entries of the vertex graph's factor in AMD's order.
    pub amd_fill: usize,
    /// The same in nested dissection's order, when it was computed.
    pub nd_fill: Option<usize>,
    /// AMD's dof order, kept where nested dissection was chosen with the larger factor for
    /// its split: the order to fall back to if the split cannot be analysed.
    pub amd_dofs: Option<Vec<usize>>,
}

/// A face as the assembly's per-face loop reads it, in storage order.
#[derive(Clone, Copy)]
struct StoredFace {
    face: FaceId,
    vertices: [VertexId; 3],
    element: Element,
    /// The entries of its 9×9 Hessian (column-major index) kept in `hess`, the ones that
    /// land in the global lower triangle ([`NO_PICK`] where unused).
    pick: [u8; PICKS],
}

/// Per-face evaluation results (the Hessian's picked entries are in `System::hess`).
#[derive(Clone, Copy)]
struct FaceEval {
    energy: f64,
    magnitude: f64,
    grad: Vec9,
    ext_grad: Vec9,
}

/// The discretized problem on a fixed mesh.
pub struct System<'a> {
    mesh: &'a Mesh,
    material: &'a dyn Material,
    loads: Loads,
    supports: Vec<Plane>,
    barrier: Option<Barrier>,
    volume_center: Vec3,
    vertex_mass_weight: Vec<f64>,
    /// Per vertex: frame (None = identity) and number of constrained leading axes.
    frames: Vec<(Option<Matrix3<f64>>, usize)>,
    /// Per vertex, per local axis: free dof index or u32::MAX.
    dof: Vec<[u32; 3]>,
    n_dofs: usize,
    pattern: SymmetricPattern,
    /// Per vertex: the slots of its 3×3 diagonal block (for contact).
    vertex_slots: Vec<[u32; 9]>,
    diag_slots: Vec<usize>,
    /// The faces in storage order (see `face_store`), with what the per-face evaluation reads.
    stored: Vec<StoredFace>,
    /// Gather map of the Hessian assembly: the picked entries summed into value slot `s` are
    /// `hess[gather_src[k]]` for `k` in `gather_start[s]..gather_start[s + 1]`, in face order.
    gather_start: Vec<usize>,
    gather_src: Vec<u32>,
    /// Per-face results, in storage order (see `face_store`).
    buf: Vec<FaceEval>,
    /// Picked Hessian entries, [`PICKS`] per face, in storage order (a compact array the
    /// gather reads; the full 9×9 matrices would be 81/45 = 1.8× the memory traffic).
    hess: Vec<f64>,
    /// A Hessian value buffer handed back by the caller ([`System::recycle_hessian`]), reused
    /// by the next assembly (kitten's is 13.6 MB: a fresh one each time costs page faults).
    spare_hessian: Option<Vec<f64>>,
    /// Per vertex, its corners `store · 3 + corner` in face order: `corners[corner_start[v]..
    /// corner_start[v + 1]]` (for the forces' reduction).
    corner_start: Vec<usize>,
    corners: Vec<u32>,
    /// Mean edge length of the mesh (m).
    mean_edge: f64,
    /// The residual's round-off floor ([`System::residual_floor`]).
    residual_floor: f64,
    /// Seam bars by face id ([`System::set_bars`]); empty: none.
    bars: Vec<[Bar; 3]>,
    /// Storage position of each face. Faces are stored sorted by their lowest-numbered vertex, so that
    /// the value slots of one vertex's rows, summed one after the other, read nearby entries
    /// of `hess` (kitten's gather was bound by the latency of those reads), and the per-face
    /// loop reads the positions in about vertex order. Any order gives the same sums: each
    /// slot still sums its entries in face order, and so does the gradient.
    face_store: Vec<u32>,
    /// The Hessian's geometric term taken exactly, not at the stress's positive part
    /// ([`System::set_exact_geometric`]).
    exact_geometric: bool,
}

/// One evaluation on free dofs.
pub struct Evaluation {
    /// Π.
    pub energy: f64,
    /// ∇Π on free dofs.
    pub gradient: Vec<f64>,
    /// External force (−∇ of the load potentials) on free dofs.
    pub external: Vec<f64>,
    /// Hessian values (pattern order), if requested.
    pub hessian: Option<Vec<f64>>,
    /// ∇Π per vertex in world coordinates (constrained components included).
    pub world_gradient: Vec<Vec3>,
    /// Σ of the magnitudes of the terms summed into Π: the scale of its round-off.
    pub energy_magnitude: f64,
    /// Norm of the internal (elastic and contact) forces over all vertices, constrained ones
    /// included (there they balance the reactions).
    pub internal_norm: f64,
}

impl<'a> System<'a> {
    /// Set up: elements (each target triangle its own rest shape), dofs, pattern and slots.
    pub fn new(
        mesh: &'a Mesh,
        material: &'a dyn Material,
        loads: Loads,
        constraints: &Constraints,
        supports: Vec<Plane>,
        barrier: Option<Barrier>,
    ) -> Self {
        Self::with_elements(mesh, Element::for_mesh(mesh), material, loads, constraints, supports, barrier)
    }

    /// Set up with given rest elements, one per face in face order (a sewn mold: each face's
    /// rest shape is its triangle on the cut pattern, [`Element::from_plane`]).
    pub fn with_elements(
        mesh: &'a Mesh,
        elements: Vec<Element>,
        material: &'a dyn Material,
        loads: Loads,
        constraints: &Constraints,
        supports: Vec<Plane>,
        barrier: Option<Barrier>,
    ) -> Self {
        assert_eq!(elements.len(), mesh.n_faces(), "one rest element per face");
        let nv = mesh.n_vertices();
        let residual_floor = residual_floor(mesh, &elements, material);
        let areas = mesh.vertex_areas();
        let vertex_mass_weight = match loads.self_weight {
            Some((w, _)) => areas.iter().map(|a| a * w).collect(),
            None => vec![0.0; nv],
        };
        let frames: Vec<_> = mesh.vertices().map(|v| constraints.frame(v)).collect();
        let mut dof = vec![[u32::MAX; 3]; nv];
        let mut n = 0u32;
        for v in 0..nv {
            for k in frames[v].1..3 {
                dof[v][k] = n;
                n += 1;
            }
        }
        let n_dofs = n as usize;
        // Pattern: all dof pairs of vertices sharing a face.
        let mut entries = Vec::with_capacity(mesh.n_faces() * 45);
        for f in mesh.face_ids() {
            let vs = mesh.face_vertices(f);
            for &a in &vs {
                for &b in &vs {
                    for &i in &dof[a.idx()] {
                        for &j in &dof[b.idx()] {
                            if i != u32::MAX && j != u32::MAX && i >= j {
                                entries.push((i as usize, j as usize));
                            }
                        }
                    }
                }
            }
        }
        let pattern = SymmetricPattern::from_entries(n_dofs, entries);
        // Per face, the picked entries and the value slot each one is summed into.
        let (face_pick, face_slots): (Vec<[u8; PICKS]>, Vec<[u32; PICKS]>) = (0..mesh.n_faces())
            .into_par_iter()
            .map(|fi| {
                let vs = mesh.face_vertices(FaceId::new(fi));
                let (mut pick, mut slot) = ([NO_PICK; PICKS], [NO_SLOT; PICKS]);
                let mut c = 0;
                for p in 0..9 {
                    for q in 0..9 {
                        let (i, j) = (dof[vs[p / 3].idx()][p % 3], dof[vs[q / 3].idx()][q % 3]);
                        if i != u32::MAX && j != u32::MAX && i >= j {
                            // Distinct corners (a `Mesh` never has a face with a repeated
                            // vertex) have distinct dofs: at most 45 pairs i ≥ j.
                            debug_assert!(c < PICKS, "a face with a repeated vertex");
                            pick[c] = (9 * q + p) as u8;
                            slot[c] = pattern.slot(i as usize, j as usize) as u32;
                            c += 1;
                        }
                    }
                }
                (pick, slot)
            })
            .unzip();
        let vertex_slots = (0..nv)
            .map(|v| {
                let mut s = [NO_SLOT; 9];
                for p in 0..3 {
                    for q in 0..3 {
                        let (i, j) = (dof[v][p], dof[v][q]);
                        if i != u32::MAX && j != u32::MAX && i >= j {
                            s[3 * p + q] = pattern.slot(i as usize, j as usize) as u32;
                        }
                    }
                }
                s
            })
            .collect();
        let diag_slots = pattern.diagonal_slots();
        let mut store_face: Vec<u32> = (0..u32::try_from(mesh.n_faces()).expect("fewer than 95M faces")).collect();
        store_face.sort_unstable_by_key(|&f| {
            let vs = mesh.face_vertices(FaceId::new(f as usize));
            (vs.iter().map(|v| v.idx()).min(), f)
        });
        let mut face_store = vec![0u32; mesh.n_faces()];
        for (p, &f) in store_face.iter().enumerate() {
            face_store[f as usize] = p as u32;
        }
        let (gather_start, gather_src) = gather_map(&face_slots, &face_store, pattern.nnz());
        let (corner_start, corners) = group_by_key(nv, || {
            mesh.face_ids().flat_map(|f| {
                let sp = face_store[f.idx()];
                mesh.face_vertices(f).into_iter().enumerate().map(move |(a, v)| (v.idx(), 3 * sp + a as u32))
            })
        });
        let stored = store_face
            .iter()
            .map(|&f| {
                let face = FaceId::new(f as usize);
                StoredFace {
                    face,
                    vertices: mesh.face_vertices(face),
                    element: elements[f as usize],
                    pick: face_pick[f as usize],
                }
            })
            .collect();
        let volume_center = mesh.bbox().center();
        let zero = FaceEval { energy: 0.0, magnitude: 0.0, grad: Vec9::zeros(), ext_grad: Vec9::zeros() };
        Self {
            mesh,
            material,
            loads,
            supports,
            barrier,
            volume_center,
            vertex_mass_weight,
            frames,
            dof,
            n_dofs,
            pattern,
            vertex_slots,
            diag_slots,
            stored,
            gather_start,
            gather_src,
            buf: vec![zero; mesh.n_faces()],
            hess: vec![0.0; mesh.n_faces() * PICKS],
            face_store,
            corner_start,
            corners,
            spare_hessian: None,
            mean_edge: mesh.mean_edge_length(),
            residual_floor,
            bars: Vec::new(),
            exact_geometric: false,
        }
    }

    /// Add seam bars: per face id, the bars along its three edges (corner k to k + 1; a bar
    /// of zero stiffness is none). Each seam edge belongs to one of its faces.
    pub fn set_bars(&mut self, bars: Vec<[Bar; 3]>) {
        assert_eq!(bars.len(), self.mesh.n_faces(), "bars for every face");
        self.bars = bars;
    }

    /// Mean edge length of the mesh (m).
    pub fn mean_edge_length(&self) -> f64 {
        self.mean_edge
    }

    /// The norm of ∇Π below which it cannot be told from round-off (N): positions are known
    /// to a relative ε of their size X, and an element turns a corner's error δx into forces
    /// of about A·K·|∇N_i|·Σ|∇N_j|·δx (A its rest area, ∇N its shape-function gradients, K
    /// the material's stiffness), summed over each vertex's faces, ×[`RESIDUAL_FLOOR_FACTOR`].
    /// On a sound mesh it is some 10⁻¹² of the load; sliver triangles (a height 10⁻⁷ of their
    /// length) raise it to 10⁻⁸ and more, where Newton's residual wanders instead of falling.
    pub fn residual_floor(&self) -> f64 {
        self.residual_floor
    }

    /// Hand back a Hessian value buffer from [`System::evaluate`] for the next assembly to reuse.
    pub fn recycle_hessian(&mut self, values: Vec<f64>) {
        self.spare_hessian = Some(values);
    }

    /// The material.
    pub fn material(&self) -> &'a dyn Material {
        self.material
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.mesh.n_faces()
    }

    /// Number of free degrees of freedom.
    pub fn n_dofs(&self) -> usize {
        self.n_dofs
    }
    /// The Hessian pattern.
    pub fn pattern(&self) -> &SymmetricPattern {
        &self.pattern
    }
    /// The fill-reducing ordering of the free dofs the Newton solver factors with, chosen on
    /// the vertex graph (each vertex then expanded to its free dofs: cheaper than ordering
    /// the dof pattern, and as good): AMD, or, on systems of at least `ND_MIN_VERTICES`
    /// vertices, nested dissection by the rest positions ([`clothcast_mesh::ordering`]) when
    /// its vertex-graph factor has fewer entries, or, when `split` allows a factorization split
    /// over two threads and the factor is large enough for it
    /// ([`crate::newton::SPLIT_MIN_FACTOR_LEN`]), up to [`SPLIT_FILL_ALLOWANCE`] times as
    /// many. The two orderings are computed in parallel,
    /// and compared by a simplicial analysis of the vertex graph instead of the dof-level
    /// analysis of both (kitten's symbolic phase, with the split analysis: 0.62 → 0.33 s).
    pub fn dof_ordering(&self, split: bool) -> Result<DofOrdering, clothcast_mesh::sparse::SolveError> {
        use clothcast_mesh::ordering::nested_dissection_with_top;
        use clothcast_mesh::sparse::CholeskySolver;
        let n = self.mesh.n_vertices();
        let edges: Vec<(usize, usize)> = self.node_edges().collect();
        let amd = || -> Result<_, clothcast_mesh::sparse::SolveError> {
            let order = CholeskySolver::amd_order(n, edges.iter().copied())?;
            let fill = CholeskySolver::node_fill(n, edges.iter().copied(), &order)?;
            Ok((order, fill))
        };
        // Nested dissection, with the vertex counts of its top split's halves, and its fill.
        let nd = || {
            (n >= ND_MIN_VERTICES).then(|| {
                let (order, top) = nested_dissection_with_top(self.mesh.positions().as_slice(), &edges, ND_LEAF);
                // Optional: if its analysis fails, AMD stands.
                CholeskySolver::node_fill(n, edges.iter().copied(), &order).ok().map(|fill| (order, top, fill))
            })
        };
        let (amd, nd) = rayon::join(amd, nd);
        let (amd_order, amd_fill) = amd?;
        let nd = nd.flatten();
        let nd_fill = nd.as_ref().map(|d| d.2);
        Ok(match nd {
            Some((order, top, fill)) if prefer_nested(amd_fill, fill, split && top.is_some()) => {
                let free = |nodes: &[usize]| -> usize {
                    nodes.iter().map(|&v| self.dof[v].iter().filter(|&&i| i != u32::MAX).count()).sum()
                };
                let split = top
                    .filter(|_| split && large_enough_to_split(fill))
                    .map(|[a, b]| [free(&order[..a]), free(&order[a..a + b])]);
                let amd_dofs = (fill >= amd_fill).then(|| self.dofs_in_node_order(&amd_order));
                DofOrdering { dofs: self.dofs_in_node_order(&order), nested: true, split, amd_fill, nd_fill, amd_dofs }
            }
            _ => DofOrdering {
                dofs: self.dofs_in_node_order(&amd_order),
                nested: false,
                split: None,
                amd_fill,
                nd_fill,
                amd_dofs: None,
            },
        })
    }

    /// The mesh edges as vertex index pairs (the node graph of the dofs).
    fn node_edges(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.mesh.edges().map(|e| {
            let [a, b] = self.mesh.edge_vertices(e);
            (a.idx(), b.idx())
        })
    }

    /// The free dofs of the vertices in `order`, vertex by vertex.
    fn dofs_in_node_order(&self, order: &[usize]) -> Vec<usize> {
        order.iter().flat_map(|&v| self.dof[v].iter().filter(|&&i| i != u32::MAX).map(|&i| i as usize)).collect()
    }

    /// Slots of the diagonal entries.
    pub fn diagonal_slots(&self) -> &[usize] {
        &self.diag_slots
    }
    /// The rest element of face `f` (kept once, in the assembly's storage order).
    pub fn element(&self, f: FaceId) -> &Element {
        &self.stored[self.face_store[f.idx()] as usize].element
    }
    /// Supports.
    pub fn supports(&self) -> &[Plane] {
        &self.supports
    }
    /// Barrier, if supports exist.
    pub fn barrier(&self) -> Option<Barrier> {
        self.barrier
    }

    /// The rest shape's cotan Laplacian ⊗ I₃ on the free dofs, as values in the Hessian's
    /// pattern (a constrained axis acts as a Dirichlet boundary: its neighbours keep their
    /// diagonal term): the Hessian of ½ Σ_edges w_e ‖u_a − u_b‖² over displacements u, with
    /// w_e the edge's cotan weight (positive semi-definite for any weights, the Dirichlet
    /// energy of the displacement). [`crate::newton`]'s damping matrix.
    pub fn laplacian_values(&self) -> Vec<f64> {
        let w = self.mesh.cotan_weights();
        let mut vals = vec![0.0; self.pattern.nnz()];
        for e in self.mesh.edges() {
            let [a, b] = self.mesh.edge_vertices(e).map(|v| v.idx());
            let we = w[e];
            for (v, u) in [(a, b), (b, a)] {
                for k in 0..3 {
                    let i = self.dof[v][k];
                    if i == u32::MAX {
                        continue;
                    }
                    vals[self.diag_slots[i as usize]] += we;
                    // The coupling to the other end, once per pair (from the lower end).
                    if v > u {
                        continue;
                    }
                    for l in 0..3 {
                        let j = self.dof[u][l];
                        if j == u32::MAX {
                            continue;
                        }
                        let c = self.dof_direction(v, k).dot(&self.dof_direction(u, l));
                        if c != 0.0 {
                            vals[self.pattern.slot(i as usize, j as usize)] -= we * c;
                        }
                    }
                }
            }
        }
        vals
    }

    /// Free dof → (vertex, world direction).
    pub fn dof_direction(&self, v: usize, k: usize) -> Vec3 {
        match self.frames[v].0 {
            Some(r) => r.column(k).into_owned(),
            None => Vec3::ith(k, 1.0),
        }
    }

    /// x + Σ step_i · direction_i.
    pub fn apply_step(&self, x: &[Vec3], step: &[f64], alpha: f64, out: &mut [Vec3]) {
        out.copy_from_slice(x);
        for v in 0..x.len() {
            for k in 0..3 {
                let i = self.dof[v][k];
                if i != u32::MAX {
                    out[v] += self.dof_direction(v, k) * (alpha * step[i as usize]);
                }
            }
        }
    }

    fn face_corners(&self, x: &[Vec3], f: FaceId) -> [Vec3; 3] {
        self.mesh.face_vertices(f).map(|v| x[v.idx()])
    }

    /// Potential energy only; +∞ if a vertex reached or crossed a support.
    pub fn energy(&self, x: &[Vec3], s: f64) -> f64 {
        self.energy_faces(x, s, None)
    }

    /// Potential energy (what [`System::energy`] returns), and with `faces` every face's share
    /// of it (elastic energy minus the work of its pressures), by face id.
    pub fn energy_faces(&self, x: &[Vec3], s: f64, faces: Option<&mut Vec<f64>>) -> f64 {
        let mut local = Vec::new();
        let out = faces.unwrap_or(&mut local);
        out.resize(self.mesh.n_faces(), 0.0);
        // Each chunk of faces summed in face order, the chunks' sums in chunk order.
        let chunks: Vec<f64> = out
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, o)| {
                for (i, v) in o.iter_mut().enumerate() {
                    let f = FaceId::new(c * CHUNK + i);
                    *v = self.face_energy(self.element(f), f, &self.face_corners(x, f), s);
                }
                o.iter().sum::<f64>()
            })
            .collect();
        let mut e: f64 = chunks.iter().sum();
        e += s * self.weight_energy(x);
        e + self.contact_energy(x)
    }

    /// A face's share of Π (elastic energy minus the work of its pressures) at corners `p`.
    #[inline]
    fn face_energy(&self, element: &Element, f: FaceId, p: &[Vec3; 3], s: f64) -> f64 {
        let mut e = element.energy(self.material, f, p);
        if let Some(bars) = self.bars.get(f.idx()) {
            e = add_bars_energy(bars, p, e);
        }
        if let Some(h) = &self.loads.hydrostatic {
            e -= s * h.work(p);
        }
        if self.loads.head_pressure != 0.0 {
            e -= s * self.loads.head_pressure * self.volume_triple(p).1 / 6.0;
        }
        e
    }

    /// The corners relative to the volume centre, y, and six times the volume they enclose
    /// with it, y0·(y1 × y2): the head pressure's work is `s · p · y0·(y1 × y2) / 6` (in that
    /// order of operations, wherever a face's energy is summed).
    #[inline]
    fn volume_triple(&self, p: &[Vec3; 3]) -> ([Vec3; 3], f64) {
        let y = p.map(|q| q - self.volume_center);
        (y, y[0].dot(&y[1].cross(&y[2])))
    }

    /// Every face's share of Π at the point of the last [`System::evaluate`], by face id, into
    /// `out` (as [`System::energy_faces`] gives them, up to round-off).
    pub fn evaluated_face_energies(&self, out: &mut Vec<f64>) {
        out.clear();
        out.extend(self.face_store.iter().map(|&sp| self.buf[sp as usize].energy));
    }

    /// The free vertices of the faces whose share of Π rose most from `base` to `trial` (by
    /// face id, at two points): the faces are taken by decreasing rise until they hold
    /// `fraction` of the total rise. Sorted, without duplicates.
    pub fn overshooting_vertices(&self, base: &[f64], trial: &[f64], fraction: f64) -> Vec<usize> {
        let mut rise: Vec<(f64, u32)> = base
            .iter()
            .zip(trial)
            .enumerate()
            .filter(|(_, (b, t))| t > b)
            .map(|(i, (b, t))| (t - b, i as u32))
            .collect();
        rise.par_sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let total: f64 = rise.iter().map(|r| r.0).sum();
        let mut held = 0.0;
        let mut out = Vec::new();
        for &(r, i) in &rise {
            if held >= fraction * total {
                break;
            }
            held += r;
            let vs = self.mesh.face_vertices(FaceId::new(i as usize));
            out.extend(vs.iter().map(|v| v.idx()).filter(|&v| self.frames[v].1 < 3));
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The constraint frame of vertex `v` (None: the identity) and its number of constrained
    /// leading axes.
    pub(crate) fn frame(&self, v: usize) -> (Option<Matrix3<f64>>, usize) {
        self.frames[v]
    }

    /// The vertices that share a face with `v` (with repetitions).
    pub(crate) fn vertex_neighbours(&self, v: usize) -> impl Iterator<Item = usize> + '_ {
        self.corners[self.corner_start[v]..self.corner_start[v + 1]].iter().flat_map(move |&c| {
            let (sf, a) = (&self.stored[c as usize / 3], c as usize % 3);
            [sf.vertices[(a + 1) % 3].idx(), sf.vertices[(a + 2) % 3].idx()]
        })
    }

    /// The part of Π that depends on vertex `v` (its faces, its weight, its contacts) with `v`
    /// at `y` and every other vertex at `x`; with `derivatives`, also its gradient and its
    /// Hessian block with respect to `y` (the geometric terms of the elements and seam bars
    /// always projected to their positive parts: a relaxation needs a PSD block).
    /// The energy is the same to the bit either way (each face's share by
    /// [`System::face_energy`]'s formula), so one call with derivatives gives a relaxation
    /// both its step and the energy its trial points are compared with.
    pub(crate) fn vertex_terms(
        &self,
        x: &[Vec3],
        v: usize,
        y: &Vec3,
        s: f64,
        derivatives: bool,
    ) -> (f64, Vec3, Matrix3<f64>) {
        let (mut e, mut g, mut h) = (0.0, Vec3::zeros(), Matrix3::zeros());
        for &c in &self.corners[self.corner_start[v]..self.corner_start[v + 1]] {
            let (sf, a) = (&self.stored[c as usize / 3], c as usize % 3);
            let mut p = sf.vertices.map(|w| x[w.idx()]);
            p[a] = *y;
            if !derivatives {
                e += self.face_energy(&sf.element, sf.face, &p, s);
                continue;
            }
            // The face's share as `face_energy` sums it: elastic, minus the liquid's work
            // (`work_corner`'s value is `work`'s), minus the head pressure's.
            let (mut fe, fg, fh) = sf.element.corner(self.material, sf.face, &p, a);
            g += fg;
            h += fh;
            // Seam bars: the face's whole share of energy, corner a's derivatives.
            if let Some(bars) = self.bars.get(sf.face.idx()) {
                add_bars_corner(bars, &p, a, &mut fe, &mut g, &mut h);
            }
            if let Some((w, wg, wh)) = self.loads.hydrostatic.as_ref().and_then(|hy| hy.work_corner(&p, a)) {
                fe -= s * w;
                g -= wg * s;
                h -= wh * s;
            }
            let ph = self.loads.head_pressure;
            if ph != 0.0 {
                // The enclosed volume y0·(y1 × y2)/6 is linear in each corner: its corner block
                // of the Hessian is zero.
                let (y, triple) = self.volume_triple(&p);
                fe -= s * ph * triple / 6.0;
                g -= y[(a + 1) % 3].cross(&y[(a + 2) % 3]) * (s * ph / 6.0);
            }
            e += fe;
        }
        if let Some((_, up)) = self.loads.self_weight {
            let w = s * self.vertex_mass_weight[v];
            e += w * y.dot(&up);
            g += up * w;
        }
        if let Some(b) = self.barrier {
            for pl in &self.supports {
                let (be, d1, d2) = b.eval(pl.distance(y));
                if be != 0.0 {
                    e += be;
                    g += pl.normal * d1;
                    h += pl.normal * pl.normal.transpose() * d2;
                }
            }
        }
        (e, g, h)
    }

    fn weight_energy(&self, x: &[Vec3]) -> f64 {
        match self.loads.self_weight {
            Some((_, up)) => x.iter().zip(&self.vertex_mass_weight).map(|(p, m)| m * p.dot(&up)).sum(),
            None => 0.0,
        }
    }

    fn contact_energy(&self, x: &[Vec3]) -> f64 {
        let Some(b) = self.barrier else { return 0.0 };
        let mut e = 0.0;
        for pl in &self.supports {
            for p in x {
                e += b.eval(pl.distance(p)).0;
            }
        }
        e
    }

    /// Largest step fraction (≤ 1) that keeps every vertex at least 20% of its current
    /// distance away from every support.
    pub fn max_feasible_step(&self, x: &[Vec3], step: &[f64]) -> f64 {
        if self.supports.is_empty() {
            return 1.0;
        }
        let mut moved = vec![Vec3::zeros(); x.len()];
        self.apply_step(x, step, 1.0, &mut moved);
        let mut alpha: f64 = 1.0;
        for pl in &self.supports {
            for (p, q) in x.iter().zip(&moved) {
                let (d0, d1) = (pl.distance(p), pl.distance(q));
                if d1 < 0.2 * d0 {
                    alpha = alpha.min(0.8 * d0 / (d0 - d1));
                }
            }
        }
        alpha
    }

    /// Take the geometric term of the Hessian exactly from the next evaluation on (true), or at
    /// the stress's positive part (false, as set up): see [`Material::exact_geometric_below`].
    pub fn set_exact_geometric(&mut self, exact: bool) {
        self.exact_geometric = exact;
    }

    /// Energy, gradient, external force and (optionally) the Hessian, its elastic part's
    /// geometric term projected to PSD unless set exact ([`System::set_exact_geometric`]; see
    /// [`crate::element`]), seam bars included.
    pub fn evaluate(&mut self, x: &[Vec3], s: f64, hessian: bool) -> Evaluation {
        let mesh = self.mesh;
        let material = self.material;
        let project = !self.exact_geometric;
        let loads = &self.loads;
        let center = self.volume_center;
        let frames = &self.frames;
        let bars = &self.bars;
        self.buf.par_iter_mut().zip(self.hess.par_chunks_mut(PICKS)).zip(&self.stored).for_each(|((out, hout), sf)| {
            let f = sf.face;
            let p = sf.vertices.map(|v| x[v.idx()]);
            let (mut e, mut g, mut h) = sf.element.evaluate(material, f, &p, project);
            if let Some(b) = bars.get(f.idx()) {
                add_bars(b, &p, project, &mut e, &mut g, &mut h);
            }
            let mut ext = 0.0;
            let mut eg = Vec9::zeros();
            if let Some(hy) = &loads.hydrostatic
                && let Some((w, wg)) = hy.work_derivatives_into(&p, hessian.then_some((&mut h, s)))
            {
                ext += w;
                eg += wg;
            }
            if loads.head_pressure != 0.0 {
                let (v, vg, vh) = face_volume(&p, &center);
                let ph = loads.head_pressure;
                ext += ph * v;
                eg += vg * ph;
                if hessian {
                    h -= vh * (ph * s);
                }
            }
            let magnitude = e.abs() + (s * ext).abs();
            e -= s * ext;
            g -= eg * s;
            if hessian {
                if let Some(r) = rotate_block9(frames, &h, &sf.vertices) {
                    h = r;
                }
                let hs = h.as_slice();
                for (o, &k) in hout.iter_mut().zip(&sf.pick) {
                    *o = if k == NO_PICK { 0.0 } else { hs[k as usize] };
                }
            }
            *out = FaceEval { energy: e, magnitude, grad: g, ext_grad: eg };
        });
        // Deterministic reduction: the energy summed in face order; each vertex's forces
        // summed over its corners in face order, vertices in parallel.
        let nv = mesh.n_vertices();
        let mut energy = 0.0;
        let mut energy_magnitude = 0.0;
        for &sp in &self.face_store {
            let r = &self.buf[sp as usize];
            energy += r.energy;
            energy_magnitude += r.magnitude;
        }
        let mut grad = vec![Vec3::zeros(); nv];
        let mut extf = vec![Vec3::zeros(); nv];
        let (buf, start, corners) = (&self.buf, &self.corner_start, &self.corners);
        grad.par_iter_mut().zip(extf.par_iter_mut()).enumerate().with_min_len(CHUNK).for_each(|(v, (g, e))| {
            for &c in &corners[start[v]..start[v + 1]] {
                let (r, a) = (&buf[c as usize / 3], c as usize % 3);
                *g += r.grad.fixed_rows::<3>(3 * a);
                *e += r.ext_grad.fixed_rows::<3>(3 * a);
            }
        });
        if let Some((_, up)) = loads.self_weight {
            for v in 0..nv {
                let w = self.vertex_mass_weight[v];
                energy += s * w * x[v].dot(&up);
                grad[v] += up * (s * w);
                extf[v] -= up * w;
            }
        }
        // Contact: per-vertex barrier blocks.
        let mut contact_blocks: Vec<(usize, Matrix3<f64>)> = Vec::new();
        if let Some(b) = self.barrier {
            for pl in &self.supports {
                for v in 0..nv {
                    let (e, d1, d2) = b.eval(pl.distance(&x[v]));
                    if e != 0.0 {
                        energy += e;
                        grad[v] += pl.normal * d1;
                        contact_blocks.push((v, pl.normal * pl.normal.transpose() * d2));
                    }
                }
            }
        }
        let internal_norm = grad.iter().zip(&extf).map(|(g, f)| (g + f * s).norm_squared()).sum::<f64>().sqrt();
        let gradient = self.to_dofs(&grad);
        let external = self.to_dofs(&extf).iter().map(|v| v * s).collect();
        let hess = hessian.then(|| {
            // Parallel over value slots, each summed in face order: deterministic, and the
            // same sums as a sequential scatter.
            // Every slot is written by the gather below: a recycled buffer needs no clearing.
            let mut vals = match self.spare_hessian.take() {
                Some(v) if v.len() == self.pattern.nnz() => v,
                _ => vec![0.0; self.pattern.nnz()],
            };
            let (hess, start, src) = (&self.hess, &self.gather_start, &self.gather_src);
            vals.par_chunks_mut(GATHER_CHUNK).enumerate().for_each(|(c, out)| {
                for (i, v) in out.iter_mut().enumerate() {
                    let slot = c * GATHER_CHUNK + i;
                    let mut acc = 0.0;
                    for &k in &src[start[slot]..start[slot + 1]] {
                        acc += hess[k as usize];
                    }
                    *v = acc;
                }
            });
            for (v, blk) in contact_blocks {
                let blk = match self.frames[v].0 {
                    Some(r) => r.transpose() * blk * r,
                    None => blk,
                };
                for k in 0..9 {
                    let s = self.vertex_slots[v][k];
                    if s != NO_SLOT {
                        vals[s as usize] += blk[(k / 3, k % 3)];
                    }
                }
            }
            vals
        });
        Evaluation { energy, gradient, external, hessian: hess, world_gradient: grad, energy_magnitude, internal_norm }
    }

    /// The slack faces at `x` (largest principal Green strain e1 ≤ 0) as walls of Newton's step
    /// model ([`crate::walls`]), in face storage order; none when the material has no slack
    /// state.
    pub fn slack_walls(&self, x: &[Vec3]) -> Vec<Wall> {
        let Some(y) = self.material.slack_wall_stiffness() else { return Vec::new() };
        self.stored
            .par_iter()
            .filter_map(|sf| {
                let (e1, grad) = sf.element.largest_strain_gradient(&sf.vertices.map(|v| x[v.idx()]));
                if e1 > 0.0 {
                    return None;
                }
                let (mut dofs, mut coef) = ([u32::MAX; 9], [0.0; 9]);
                for (a, v) in sf.vertices.iter().enumerate() {
                    for k in 0..3 {
                        let i = self.dof[v.idx()][k];
                        if i != u32::MAX {
                            dofs[3 * a + k] = i;
                            coef[3 * a + k] = grad[a].dot(&self.dof_direction(v.idx(), k));
                        }
                    }
                }
                let face = u32::try_from(sf.face.idx()).expect("fewer than 95M faces");
                Some(Wall { face, e1, stiffness: sf.element.area * y, dofs, coef })
            })
            .collect()
    }

    /// World vectors per vertex → values on free dofs (projected on the free axes).
    pub fn to_dofs(&self, v: &[Vec3]) -> Vec<f64> {
        let mut out = vec![0.0; self.n_dofs];
        for (i, w) in v.iter().enumerate() {
            for k in 0..3 {
                let d = self.dof[i][k];
                if d != u32::MAX {
                    out[d as usize] = self.dof_direction(i, k).dot(w);
                }
            }
        }
        out
    }

    /// Total force the constraints exert on the fabric: at a constrained vertex equilibrium
    /// is −∇Π + R = 0, so R is the world gradient's component along the constrained axes
    /// (zero for a self-equilibrated load on a statically determinate support).
    pub fn reaction(&self, world_gradient: &[Vec3]) -> Vec3 {
        let mut total = Vec3::zeros();
        for (v, g) in world_gradient.iter().enumerate() {
            for a in 0..self.frames[v].1 {
                let dir = self.dof_direction(v, a);
                total += dir * dir.dot(g);
            }
        }
        total
    }

    /// The unbalanced force at vertex `v` (N): the world gradient's component along its free
    /// axes (zero at equilibrium; the constrained axes carry the reaction).
    pub fn residual_force(&self, v: usize, g: &Vec3) -> Vec3 {
        (self.frames[v].1..3)
            .map(|a| {
                let dir = self.dof_direction(v, a);
                dir * dir.dot(g)
            })
            .sum()
    }

    /// Contact force on each support (N): the barrier's push on the fabric.
    pub fn contact_forces(&self, x: &[Vec3]) -> Vec<Vec3> {
        let Some(b) = self.barrier else { return vec![Vec3::zeros(); self.supports.len()] };
        self.supports.iter().map(|pl| x.iter().map(|p| pl.normal * (-b.eval(pl.distance(p)).1)).sum()).collect()
    }
}

/// A face's 9×9 matrix in its vertices' constraint frames (None when no vertex has one: unchanged).
fn rotate_block9(frames: &[(Option<Matrix3<f64>>, usize)], h: &Mat9, vs: &[VertexId; 3]) -> Option<Mat9> {
    if vs.iter().all(|v| frames[v.idx()].0.is_none()) {
        return None;
    }
    let mut r = Mat9::identity();
    for (a, v) in vs.iter().enumerate() {
        if let Some(m) = frames[v.idx()].0 {
            r.fixed_view_mut::<3, 3>(3 * a, 3 * a).copy_from(&m);
        }
    }
    Some(r.transpose() * h * r)
}

/// The assembly's gather map (see [`System`]): for every value slot, the picked entries
/// summed into it (index `store · PICKS + c`, `store` the face's storage position and `c` the
/// pick's position in its list), in face order.
///
/// # Panics
/// With 95M faces or more (the indices are `u32`; such a mesh would not fit in memory anyway).
fn gather_map(face_slots: &[[u32; PICKS]], face_store: &[u32], nnz: usize) -> (Vec<usize>, Vec<u32>) {
    group_by_key(nnz, || {
        face_slots.iter().zip(face_store).flat_map(|(slots, &sp)| {
            slots
                .iter()
                .enumerate()
                .filter(|&(_, &s)| s != NO_SLOT)
                .map(move |(c, &s)| (s as usize, u32::try_from(sp as usize * PICKS + c).expect("fewer than 95M faces")))
        })
    })
}

/// The factor of [`System::residual_floor`]: the sum above bounds the worst case, which the
/// rounding errors, random in sign and direction, do not reach. Calibrated on four meshes with
/// slivers (a sphere, two tori and spot_low_resolution with edges pulled to 10⁻² or 10⁻¹ of
/// their length next to a neighbour, smallest angles down to 2·10⁻⁵ degrees): over their last
/// 100+ of 200 Newton iterations the residual wandered at 2.5–5% of the unscaled bound, so a
/// tenth of it lies 2–4 times above where they wander.
pub const RESIDUAL_FLOOR_FACTOR: f64 = 0.1;

/// [`System::residual_floor`] of a mesh, its rest elements and material.
fn residual_floor(mesh: &Mesh, elements: &[Element], material: &dyn Material) -> f64 {
    let size = mesh.positions().iter().map(|p| p.amax()).fold(0.0, f64::max);
    let k = material.reference_stiffness();
    let mut per_vertex = vec![0.0f64; mesh.n_vertices()];
    for (f, el) in elements.iter().enumerate() {
        let spread: f64 = el.grad_n.iter().map(|g| g.norm()).sum();
        for (c, v) in mesh.face_vertices(FaceId::new(f)).iter().enumerate() {
            per_vertex[v.idx()] += el.area * k * spread * el.grad_n[c].norm();
        }
    }
    let norm = (3.0 * per_vertex.iter().map(|a| a * a).sum::<f64>()).sqrt();
    RESIDUAL_FLOOR_FACTOR * f64::EPSILON * size * norm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::WrinklingStVenantKirchhoff;

    /// The assembly as first written (a full 9×9 matrix per face, scattered in face order):
    /// energy, world gradient and Hessian values.
    fn reference(sys: &System<'_>, x: &[Vec3], s: f64) -> (f64, Vec<Vec3>, Vec<f64>) {
        let mesh = sys.mesh;
        let mut energy = 0.0;
        let mut grad = vec![Vec3::zeros(); mesh.n_vertices()];
        let mut vals = vec![0.0; sys.pattern.nnz()];
        for f in mesh.face_ids() {
            let vs = mesh.face_vertices(f);
            let p = vs.map(|v| x[v.idx()]);
            let (mut e, mut g, mut h) = sys.element(f).evaluate(sys.material, f, &p, !sys.exact_geometric);
            let mut ext = 0.0;
            let mut eg = Vec9::zeros();
            if let Some(hy) = &sys.loads.hydrostatic
                && let Some((w, wg, wh)) = hy.work_derivatives(&p)
            {
                ext += w;
                eg += wg;
                h -= wh * s;
            }
            let ph = sys.loads.head_pressure;
            if ph != 0.0 {
                let (v, vg, vh) = face_volume(&p, &sys.volume_center);
                ext += ph * v;
                eg += vg * ph;
                h -= vh * (ph * s);
            }
            e -= s * ext;
            g -= eg * s;
            energy += e;
            let h = rotate_block9(&sys.frames, &h, &vs).unwrap_or(h);
            for a in 0..3 {
                grad[vs[a].idx()] += g.fixed_rows::<3>(3 * a);
            }
            for pp in 0..9 {
                for q in 0..9 {
                    let (i, j) = (sys.dof[vs[pp / 3].idx()][pp % 3], sys.dof[vs[q / 3].idx()][q % 3]);
                    if i != u32::MAX && j != u32::MAX && i >= j {
                        vals[sys.pattern.slot(i as usize, j as usize)] += h[(pp, q)];
                    }
                }
            }
        }
        (energy, grad, vals)
    }

    /// Nested dissection is chosen with the smaller factor, or with one up to 25% larger than
    /// AMD's when it can be split over two threads and is large enough for that (the numbers
    /// of kitten's 26.6k-face coarse level: AMD 313 694 entries, nested dissection 352 104).
    #[test]
    fn nested_dissection_is_preferred_where_it_splits() {
        assert!(prefer_nested(100, 99, false));
        assert!(!prefer_nested(313_694, 352_104, false));
        assert!(prefer_nested(313_694, 352_104, true));
        // Beyond the allowance, or too small a factor to split.
        assert!(!prefer_nested(313_694, 400_000, true));
        assert!(!prefer_nested(150_000, 177_031, true));
    }

    /// The compact, reordered, parallel assembly sums exactly what the plain one did, in the
    /// same order (so the same values, to the bit), with rotated frames and fixed dofs (faces
    /// with fewer than 45 picks), and on a recycled buffer that held garbage.
    #[test]
    fn assembly_equals_the_plain_face_order_scatter() {
        let mesh = clothcast_mesh::shapes::icosphere(2, 0.3);
        let mat = WrinklingStVenantKirchhoff::from_young_poisson(2e4, 0.3);
        let up = Vec3::new(0.1, 0.0, 1.0).normalize();
        let loads = Loads {
            hydrostatic: Some(Hydrostatic { rho_g: 14000.0, up, fill_height: 0.05 }),
            head_pressure: 300.0,
            self_weight: None,
        };
        let mut c = Constraints::free(mesh.n_vertices());
        c.fix_vertex(VertexId(0));
        c.fix_vertex(VertexId(11));
        c.fix_direction(VertexId(5), Vec3::new(1.0, 2.0, 0.5));
        c.fix_direction(VertexId(7), Vec3::new(0.0, 1.0, 1.0));
        c.fix_direction(VertexId(7), Vec3::new(1.0, 0.0, 0.0));
        let mut sys = System::new(&mesh, &mat, loads, &c, vec![], None);
        // Scrambled storage order must not matter either: it is sorted by lowest vertex, which
        // on an icosphere differs from the face order.
        assert!(sys.face_store.windows(2).any(|w| w[0] > w[1]));
        let x: Vec<Vec3> =
            mesh.positions().iter().map(|p| Vec3::new(p.x * 1.1, p.y * 0.9 + 0.03 * p.z, p.z * 1.05)).collect();
        let (e, g, h) = reference(&sys, &x, 0.8);
        sys.recycle_hessian(vec![f64::NAN; sys.pattern.nnz()]);
        for _ in 0..2 {
            let ev = sys.evaluate(&x, 0.8, true);
            assert!(ev.energy == e, "{} vs {e}", ev.energy);
            assert!(ev.world_gradient.iter().zip(&g).all(|(a, b)| a == b));
            let vals = ev.hessian.expect("requested");
            assert!(vals.iter().zip(&h).all(|(a, b)| a == b), "Hessian values differ");
            sys.recycle_hessian(vals);
        }
    }
}
