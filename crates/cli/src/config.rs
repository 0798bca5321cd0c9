//! The scenario file (TOML): one scenario per file, strict (unknown keys and wrong types are
//! errors naming the key and line), every key documented in [`TEMPLATE`], which `clothcast
//! config` prints and which a test keeps equal to [`Config::default`].
//!
//! Section and key names are part of the interface: extend them, never rename them.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::path::{Path, PathBuf};

/// The commented default configuration printed by `clothcast config`.
pub const TEMPLATE: &str = include_str!("default_config.toml");

/// A whole scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Seed of every random choice (segmentation tracing order). Same seed, same outputs.
    pub seed: u64,
    /// Input mesh and its placement.
    pub mesh: MeshSection,
    /// Fabric material.
    pub material: MaterialSection,
    /// Liquid infill.
    pub infill: InfillSection,
    /// How the mold hangs.
    pub suspension: SuspensionSection,
    /// Rigid planes the fabric rests on.
    pub supports: Vec<Support>,
    /// Static equilibrium solver.
    pub solver: SolverSection,
    /// Cross field.
    pub field: FieldSection,
    /// Segmentation into patches.
    pub layout: LayoutSection,
    /// Flattening, orientation and sewing patterns.
    pub pattern: PatternSection,
    /// The check: the mold sewn from the patterns, of a woven fabric.
    pub validation: ValidationSection,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            seed: 1,
            mesh: MeshSection::default(),
            material: MaterialSection::default(),
            infill: InfillSection::default(),
            suspension: SuspensionSection::default(),
            supports: Vec::new(),
            solver: SolverSection::default(),
            field: FieldSection::default(),
            layout: LayoutSection::default(),
            pattern: PatternSection::default(),
            validation: ValidationSection::default(),
        }
    }
}

/// `[validation]`: the mold sewn from the cut patterns, of a woven fabric, filled as in the
/// simulation; how far the cast deviates from the target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ValidationSection {
    /// Run the check (`clothcast run`).
    pub enabled: bool,
    /// Tensile stiffness of a 1 m strip along the warp (N/m); absent: `[material]
    /// youngs_modulus`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warp_stiffness: Option<f64>,
    /// The same along the weft (N/m); absent: `[material] youngs_modulus`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weft_stiffness: Option<f64>,
    /// In-plane shear modulus over √(warp · weft stiffness).
    pub shear_ratio: f64,
    /// A measured fabric instead: the name of a built-in Wang et al. 2011 woven fabric
    /// ([`WOR11_FABRICS`]) or the path of a file in their JSON layout (relative to the scenario
    /// file).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fabric: Option<String>,
    /// Multiplies every stiffness of `fabric`; absent: the factor that gives its yarns' small-strain
    /// stiffnesses a geometric mean of `[material] youngs_modulus` (the garment fabrics of that
    /// database are some 12–290 times softer than the default 50 kN/m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fabric_scale: Option<f64>,
    /// Axial stiffness of a seam (N) beyond the fabric's; absent: its two seam allowances'
    /// fabric, 2 · `[pattern] seam_allowance_mm` · √(warp · weft stiffness); 0: seams no
    /// stiffer than the fabric.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seam_stiffness: Option<f64>,
}

/// The built-in woven fabrics of Wang et al. 2011 (`data/materials/wor11`), by name.
pub const WOR11_FABRICS: [(&str, &str); 5] = [
    ("11oz-black-denim", include_str!("../../../data/materials/wor11/11oz-black-denim.json")),
    ("pink-ribbon-brown", include_str!("../../../data/materials/wor11/pink-ribbon-brown.json")),
    ("royal-target", include_str!("../../../data/materials/wor11/royal-target.json")),
    ("tango-red-jet-set", include_str!("../../../data/materials/wor11/tango-red-jet-set.json")),
    ("white-dots-on-blk", include_str!("../../../data/materials/wor11/white-dots-on-blk.json")),
];

impl Default for ValidationSection {
    fn default() -> Self {
        Self {
            enabled: true,
            warp_stiffness: None,
            weft_stiffness: None,
            shear_ratio: 0.03,
            fabric: None,
            fabric_scale: None,
            seam_stiffness: None,
        }
    }
}

/// `[pattern]`: flattening, orientation on the fabric, and the sewing patterns.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PatternSection {
    /// "field" (warp/weft aligned with the cross field) or "longest-side" (the paper's
    /// heuristics).
    pub orientation: clothcast_flatten::Orientation,
    /// Which fibre runs along the field's major direction: "major" (the warp), "minor" (the
    /// weft) or "either" (whichever the orientation's turn gives).
    pub warp_along: clothcast_flatten::WarpAlong,
    /// Scale all pieces by one common factor so their total area equals the target's.
    pub match_area: bool,
    /// Sew line to cut line (mm).
    pub seam_allowance_mm: f64,
    /// Match marks every this many mm along a seam (and at its ends).
    pub notch_spacing_mm: f64,
    /// Length of a notch (mm).
    pub notch_length_mm: f64,
    /// Usable width of the fabric roll (mm).
    pub fabric_width_mm: f64,
    /// Allow pieces turned by 90° on the roll (warp and weft of similar stiffness).
    pub allow_weft_swap: bool,
    /// Spacing between nested pieces (mm).
    pub piece_gap_mm: f64,
    /// Label height (mm).
    pub text_height_mm: f64,
    /// A piece is badly distorted (warned about, split in a new layout) above this
    /// area-weighted mean quasi-conformal ratio.
    pub max_qc_mean: f64,
    /// … or when its largest per-face area ratio exceeds its smallest by more than this factor.
    pub max_area_spread: f64,
}

impl PatternSection {
    /// The roll's width less the seam allowance on both sides of a piece (metres).
    pub fn usable_width_m(&self) -> f64 {
        (self.fabric_width_mm - 2.0 * self.seam_allowance_mm) / 1000.0
    }
}

impl Default for PatternSection {
    fn default() -> Self {
        let p = clothcast_pattern::PatternOptions::default();
        Self {
            orientation: clothcast_flatten::FlattenOptions::default().orientation,
            warp_along: clothcast_flatten::FlattenOptions::default().warp_along,
            match_area: clothcast_flatten::FlattenOptions::default().match_area,
            seam_allowance_mm: p.seam_allowance_mm,
            notch_spacing_mm: p.notch_spacing_mm,
            notch_length_mm: p.notch_length_mm,
            fabric_width_mm: p.fabric_width_mm,
            allow_weft_swap: p.allow_weft_swap,
            piece_gap_mm: p.piece_gap_mm,
            text_height_mm: p.text_height_mm,
            max_qc_mean: clothcast_flatten::DistortionLimits::default().qc_mean,
            max_area_spread: clothcast_flatten::DistortionLimits::default().area_spread,
        }
    }
}

/// `[layout]`: the segmentation into patches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LayoutSection {
    /// D of the tracing cost ℓ (1 + D (φ/φmax)²).
    pub drift_penalty: f64,
    /// φmax: largest deviation (degrees) of a traced seam step from the field.
    pub max_deviation: f64,
    /// A separatrix this close (mean edge lengths) to another singularity ends there.
    pub capture_radius: f64,
    /// Straighten seams into geodesics and remesh along them.
    pub smooth_seams: bool,
    /// Pins along the traced seams every this many mean edge lengths (0: none).
    pub pin_spacing: f64,
    /// Move field-following seams onto streamlines of the field before straightening.
    pub follow_streamlines: bool,
    /// Merge adjacent patches when the union is a developable quad.
    pub merge: bool,
    /// Merges, corner splits and cusp repairs on the final, straightened seams.
    pub late_repairs: bool,
    /// `clothcast run`: where the flattening shrank a piece around a cone-like tip inside it
    /// (a triangle at under a tenth of its area), lay the patches out again with a dart to each
    /// such tip (or a cut through it where no dart can be made), kept when it shrinks the fabric
    /// less.
    pub cone_cuts: bool,
    /// Split patches whose developability score exceeds this (`inf`: never).
    pub max_developability: f64,
    /// Patches below this share of the area are merged into a neighbour.
    pub min_patch_fraction: f64,
    /// Remeshing: seam crossings this close to a vertex (share of the edge) snap to it.
    pub snap: f64,
    /// Most developability splits.
    pub max_splits: usize,
}

impl Default for LayoutSection {
    fn default() -> Self {
        let d = clothcast_layout::LayoutOptions::default();
        Self {
            drift_penalty: d.drift_penalty,
            max_deviation: d.max_deviation_deg,
            capture_radius: d.capture_radius,
            smooth_seams: d.smooth_seams,
            pin_spacing: d.pin_spacing,
            follow_streamlines: d.follow_streamlines,
            merge: d.merge,
            late_repairs: d.late_repairs,
            cone_cuts: true,
            max_developability: d.max_developability,
            min_patch_fraction: d.min_patch_fraction,
            snap: d.snap,
            max_splits: d.max_splits,
        }
    }
}

/// `[field]`: the cross field seams and fibres follow.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FieldSection {
    /// "strain" (the paper's method) or "curvature" (what garment tools use).
    pub source: clothcast_field::synthesis::FieldSource,
    /// A face is anisotropic when (e1 − e2)/(|e1| + |e2| + median) of its principal strains
    /// exceeds this.
    pub anisotropy_threshold: f64,
    /// Weight of the alignment to the raw field in the denoising pass (paper Eq. 7).
    pub alpha: f64,
    /// Singularities closer than this fraction of the bounding-box diagonal may be combined.
    pub relax_radius: f64,
    /// Largest rise of the field energy accepted for one merge or cancellation of singularities.
    pub relax_merge_energy: f64,
}

impl Default for FieldSection {
    fn default() -> Self {
        let d = clothcast_field::FieldOptions::default();
        Self {
            source: d.source,
            anisotropy_threshold: d.anisotropy_threshold,
            alpha: d.alpha,
            relax_radius: d.relax_radius,
            relax_merge_energy: d.relax_merge_energy,
        }
    }
}

/// `[mesh]`
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeshSection {
    /// Mesh file (relative paths are relative to the config file). None: the built-in example.
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "lossy_path")]
    pub path: Option<PathBuf>,
    /// Units of the file's coordinates.
    pub units: Units,
    /// Rescale so the extent along `up` is this many metres (overrides `units`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
    /// The suspension direction: up when the mold hangs.
    pub up: Up,
    /// Refine a coarse mesh (longest edges split at their midpoints, the shape unchanged) to
    /// `min_faces` faces and no edge longer than a tenth of the roll's usable width.
    pub refine: bool,
    /// With `refine`: the fewest faces the mesh is refined to.
    pub min_faces: usize,
}

/// Largest accepted `mesh.min_faces`.
pub const MAX_MIN_FACES: usize = 4_000_000;

impl Default for MeshSection {
    fn default() -> Self {
        Self { path: None, units: Units::M, height: None, up: Up::axis(2, 1.0), refine: true, min_faces: 1000 }
    }
}

/// Length units of an input file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// Metres.
    M,
    /// Centimetres.
    Cm,
    /// Millimetres.
    Mm,
}

impl Units {
    /// Metres per unit.
    pub fn to_metres(self) -> f64 {
        match self {
            Units::M => 1.0,
            Units::Cm => 0.01,
            Units::Mm => 0.001,
        }
    }
}

/// A direction: an axis name ("+z", "-y", ...) or an explicit vector [x, y, z].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Up(pub [f64; 3]);

impl Up {
    fn axis(i: usize, s: f64) -> Self {
        let mut v = [0.0; 3];
        v[i] = s;
        Up(v)
    }
    /// Unit vector.
    pub fn unit(&self) -> [f64; 3] {
        let n = (self.0[0].powi(2) + self.0[1].powi(2) + self.0[2].powi(2)).sqrt();
        self.0.map(|c| c / n)
    }
    /// An explicit vector, refused where its length is not a finite, non-zero number.
    pub fn vector(v: [f64; 3]) -> Result<Self, String> {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 0.0 && n.is_finite() { Ok(Up(v)) } else { Err("its length must be a finite, non-zero number".into()) }
    }
    /// Parse "+x" / "-z" / "x" style names, or a vector "[x, y, z]" (finite, not zero).
    pub fn parse(s: &str) -> Result<Self, String> {
        let t = s.trim();
        if let Some(inner) = t.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            let c: Result<Vec<f64>, _> = inner.split(',').map(|x| x.trim().parse::<f64>()).collect();
            return match c.as_deref() {
                Ok(&[x, y, z]) => Up::vector([x, y, z]).map_err(|e| format!("invalid direction {s:?}: {e}")),
                _ => Err(format!("invalid direction {s:?}: a vector [x, y, z] needs three numbers")),
            };
        }
        let (sign, name) = match t.as_bytes().first() {
            Some(b'+') => (1.0, &t[1..]),
            Some(b'-') => (-1.0, &t[1..]),
            _ => (1.0, t),
        };
        let i = match name {
            "x" | "X" => 0,
            "y" | "Y" => 1,
            "z" | "Z" => 2,
            _ => return Err(format!("invalid direction {s:?}: use +x, -x, +y, -y, +z, -z or [x, y, z]")),
        };
        Ok(Up::axis(i, sign))
    }
}

impl Serialize for Up {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let v = self.0;
        let nz: Vec<usize> = (0..3).filter(|&i| v[i] != 0.0).collect();
        if nz.len() == 1 && v[nz[0]].abs() == 1.0 {
            let sign = if v[nz[0]] > 0.0 { '+' } else { '-' };
            s.serialize_str(&format!("{sign}{}", ["x", "y", "z"][nz[0]]))
        } else {
            v.serialize(s)
        }
    }
}

impl<'de> Deserialize<'de> for Up {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Name(String),
            Vector([f64; 3]),
        }
        match Raw::deserialize(d)
            .map_err(|_| serde::de::Error::custom("expected an axis such as \"+z\" or a vector [x, y, z]"))?
        {
            Raw::Name(s) => Up::parse(&s).map_err(serde::de::Error::custom),
            Raw::Vector(v) => Up::vector(v).map_err(|e| serde::de::Error::custom(format!("the up vector: {e}"))),
        }
    }
}

/// `[material]`: the isotropic fabric (project convention: thickness-integrated Young's
/// modulus Y in N/m and Poisson ratio ν; shear modulus G = Y / (2(1 + ν))).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MaterialSection {
    /// Membrane model.
    pub model: MaterialModel,
    /// Y (N/m).
    pub youngs_modulus: f64,
    /// ν.
    pub poisson_ratio: f64,
    /// Fabric mass per area (kg/m²).
    pub areal_density: f64,
    /// Include the fabric's own weight in the load.
    pub self_weight: bool,
}

impl Default for MaterialSection {
    fn default() -> Self {
        Self {
            model: MaterialModel::TensionField,
            youngs_modulus: 50_000.0,
            poisson_ratio: 0.3,
            areal_density: 0.25,
            self_weight: false,
        }
    }
}

/// The membrane model of the simulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MaterialModel {
    /// St. Venant–Kirchhoff with the tension-field (wrinkling) relaxation: fabric carries no
    /// compression.
    TensionField,
    /// Plain St. Venant–Kirchhoff (carries compression; slow or stalling where fabric would
    /// wrinkle).
    Stvk,
}

/// `[infill]`: the liquid cast.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InfillSection {
    /// Density (kg/m³); 1460 is liquid plaster as in the paper.
    pub density: f64,
    /// "top" or the fill height in metres above the mold's lowest point, along `up`.
    pub fill_level: FillLevel,
    /// Extra uniform pressure (Pa), e.g. from a pressure head above the mold.
    pub head_pressure: f64,
}

impl Default for InfillSection {
    fn default() -> Self {
        Self { density: 1460.0, fill_level: FillLevel::Top, head_pressure: 0.0 }
    }
}

/// Fill level of the liquid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FillLevel {
    /// Full to the top of the mold.
    Top,
    /// Metres above the lowest point, along `up`.
    Height(f64),
}

impl Serialize for FillLevel {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            FillLevel::Top => s.serialize_str("top"),
            FillLevel::Height(h) => s.serialize_f64(*h),
        }
    }
}

impl<'de> Deserialize<'de> for FillLevel {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Name(String),
            Float(f64),
            Int(i64),
        }
        match Raw::deserialize(d).map_err(|_| serde::de::Error::custom("expected \"top\" or a height in metres"))? {
            Raw::Name(s) if s == "top" => Ok(FillLevel::Top),
            Raw::Name(s) => {
                Err(serde::de::Error::custom(format!("expected \"top\" or a height in metres, found {s:?}")))
            }
            Raw::Float(h) => Ok(FillLevel::Height(h)),
            Raw::Int(h) => Ok(FillLevel::Height(h as f64)),
        }
    }
}

/// `[suspension]`
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SuspensionSection {
    /// How the mold is held.
    pub mode: SuspensionMode,
    /// For `top-band`: clamp every vertex within this many metres of the top (along `up`).
    pub band: f64,
    /// For `vertices`: the clamped vertices (0-based ids of the input file).
    pub vertices: Vec<u32>,
}

impl Default for SuspensionSection {
    fn default() -> Self {
        Self { mode: SuspensionMode::TopBand, band: 0.05, vertices: Vec::new() }
    }
}

/// How the mold is held.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SuspensionMode {
    /// Clamp the vertices within `band` of the top.
    TopBand,
    /// Clamp the listed vertices.
    Vertices,
    /// Clamp every boundary loop (open molds).
    Boundary,
    /// Nothing clamped (self-equilibrated loads only; rigid motions are removed).
    None,
}

/// `[[supports]]`: a rigid plane the fabric cannot pass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Support {
    /// A point on the plane (metres, mesh frame after scaling).
    #[serde(deserialize_with = "exactly_three")]
    pub point: [f64; 3],
    /// Normal pointing to the side where the fabric is.
    #[serde(deserialize_with = "exactly_three")]
    pub normal: [f64; 3],
}

/// A 3-vector that must be given with exactly three numbers: serde's `[f64; 3]` reads the first
/// three elements of a TOML array and ignores the rest, which would drop a mistyped fourth.
fn exactly_three<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v = Vec::<f64>::deserialize(d)?;
    <[f64; 3]>::try_from(v.as_slice()).map_err(|_| serde::de::Error::invalid_length(v.len(), &"an array of 3 numbers"))
}

/// `[solver]`
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSection {
    /// Converged when the residual force is below this fraction of the load.
    pub tolerance: f64,
    /// Newton iterations allowed (over all load steps): a number, or "auto" (the default) for
    /// a limit that scales with the mesh ([`MaxIterations`]).
    pub max_iterations: MaxIterations,
    /// Continue after a non-converged solve (marked in the summary).
    pub allow_unconverged: bool,
    /// Precision of the sparse factorization of every Newton step.
    pub factor_precision: FactorPrecision,
    /// Start large solves from the equilibrium of a simplified mold.
    pub coarse_start: bool,
    /// Meshes with at least this many faces get the coarse start.
    pub coarse_start_min_faces: usize,
    /// The simplified mold has this many times fewer faces.
    pub coarse_start_ratio: usize,
    /// Sweeps of local relaxation of the vertices a rejected Newton step sent too far, before
    /// the step is shortened (0: plain backtracking).
    pub relax_sweeps: usize,
    /// The damping matrix of the Newton steps.
    pub damping: DampingMatrix,
}

impl Default for SolverSection {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: MaxIterations::Auto,
            allow_unconverged: false,
            factor_precision: FactorPrecision::Auto,
            coarse_start: true,
            coarse_start_min_faces: clothcast_sim::coarse::CoarseOptions::default().min_faces,
            coarse_start_ratio: clothcast_sim::coarse::CoarseOptions::default().ratio,
            relax_sweeps: clothcast_sim::newton::NewtonOptions::default().relax_sweeps,
            damping: DampingMatrix::Laplacian,
        }
    }
}

/// `[solver] damping`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DampingMatrix {
    /// The rest shape's cotan Laplacian: damps a vertex's motion relative to its neighbours.
    Laplacian,
    /// The rest Hessian's diagonal (the former default).
    Diagonal,
}

/// `[solver] max_iterations`: a number of Newton iterations, or `"auto"`, the default: as many
/// as [`clothcast_sim::newton::AUTO_ITERATION_BUDGET`] over three dofs per vertex, at least
/// [`clothcast_sim::newton::DEFAULT_MAX_ITERATIONS`] (1000, meshes of 20k vertices and more)
/// and at most [`clothcast_sim::newton::AUTO_MAX_ITERATIONS_CAP`] (20000): a solve that does
/// not converge on a small mesh runs one to two and a half minutes on the development machine
/// before it says so (filled to a fifth: spot 72 s; torus, bunny, fertility 120 / 155 / 141 s
/// on a day the machine ran 1.4–2.5× slow; it stopped after 1000 iterations, seconds, before),
/// where molds filled low converge in thousands; on large meshes 1000 (kitten filled to a
/// fifth: 214 s, measured before its coarse levels got 1000 iterations).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaxIterations {
    /// Scaled with the mesh.
    Auto,
    /// This many (at least one: the type holds no zero, so no solve is allowed none).
    Fixed(std::num::NonZeroUsize),
}

impl MaxIterations {
    /// The limit for a mesh of `vertices` vertices (three dofs each; the clamped ones' few
    /// count too: a budget, not an exact cost).
    pub fn resolve(self, vertices: usize) -> usize {
        match self {
            Self::Auto => clothcast_sim::newton::auto_max_iterations(3 * vertices),
            Self::Fixed(n) => n.get(),
        }
    }
}

/// Written back (the summary's `scenario`) as it is read: a number or "auto".
impl Serialize for MaxIterations {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Auto => s.serialize_str("auto"),
            Self::Fixed(n) => s.serialize_u64(n.get() as u64),
        }
    }
}

/// What [`MaxIterations`] accepts, for its parse errors.
const MAX_ITERATIONS_EXPECTED: &str = "a whole number of iterations (at least 1) or \"auto\"";

impl<'de> Deserialize<'de> for MaxIterations {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl serde::de::Visitor<'_> for Visit {
            type Value = MaxIterations;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(MAX_ITERATIONS_EXPECTED)
            }
            fn visit_u64<E: serde::de::Error>(self, n: u64) -> Result<MaxIterations, E> {
                let n = usize::try_from(n).map_err(|_| E::custom(format!("{n} is too large")))?;
                std::num::NonZeroUsize::new(n)
                    .map(MaxIterations::Fixed)
                    .ok_or_else(|| E::custom(format!("expected {MAX_ITERATIONS_EXPECTED}, found 0")))
            }
            fn visit_i64<E: serde::de::Error>(self, n: i64) -> Result<MaxIterations, E> {
                match u64::try_from(n) {
                    Ok(n) => self.visit_u64(n),
                    Err(_) => Err(E::custom(format!("expected {MAX_ITERATIONS_EXPECTED}, found {n}"))),
                }
            }
            fn visit_str<E: serde::de::Error>(self, w: &str) -> Result<MaxIterations, E> {
                match w {
                    "auto" => Ok(MaxIterations::Auto),
                    _ => Err(E::custom(format!("expected {MAX_ITERATIONS_EXPECTED}, found \"{w}\""))),
                }
            }
        }
        d.deserialize_any(Visit)
    }
}

/// `[solver] factor_precision`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FactorPrecision {
    /// Single precision for large factors, double for small ones.
    Auto,
    /// Double precision: every step one direct solve.
    Double,
    /// A single-precision factor preconditions a double-precision iterative solve.
    Single,
}

/// A configuration error naming the key and, when known, the line.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// Could not read the file.
    #[error("cannot read config {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// OS error.
        source: std::io::Error,
    },
    /// TOML syntax, unknown key, wrong type.
    #[error("config {path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// toml's message (with line and column).
        message: String,
    },
    /// A value out of its range.
    #[error("config {path}{}: `{key}` = {value}: {reason}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Value {
        /// The file.
        path: String,
        /// 1-based line, when found.
        line: Option<usize>,
        /// Dotted key.
        key: String,
        /// The value as written.
        value: String,
        /// What is wrong.
        reason: String,
    },
}

impl Config {
    /// Parse and check a configuration text.
    pub fn from_toml(text: &str, path: &str) -> Result<Self, ConfigError> {
        let cfg: Config = toml::from_str(text)
            .map_err(|e| ConfigError::Parse { path: path.into(), message: e.to_string().trim_end().to_string() })?;
        cfg.check(Some(text), path)?;
        Ok(cfg)
    }

    /// Read a configuration file; a relative `[mesh] path` is made relative to the file.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io { path: path.into(), source })?;
        let mut cfg = Self::from_toml(&text, &path.display().to_string())?;
        if let Some(p) = &cfg.mesh.path
            && p.is_relative()
        {
            cfg.mesh.path = Some(path.parent().unwrap_or(Path::new(".")).join(p));
        }
        // A fabric file (not a built-in name) relative to the scenario file.
        if let Some(f) = &cfg.validation.fabric
            && !WOR11_FABRICS.iter().any(|(n, _)| n == f)
            && Path::new(f).is_relative()
        {
            let joined = path.parent().unwrap_or(Path::new(".")).join(f);
            cfg.validation.fabric = Some(joined.display().to_string());
        }
        Ok(cfg)
    }

    /// Range checks; `source` (the TOML text) lets errors name the line.
    pub fn check(&self, source: Option<&str>, path: &str) -> Result<(), ConfigError> {
        let err = |section: &str, key: &str, value: String, reason: &str| ConfigError::Value {
            path: path.into(),
            line: source.and_then(|s| locate_key(s, section, key)),
            key: if section.is_empty() { key.into() } else { format!("{section}.{key}") },
            value,
            reason: reason.into(),
        };
        let positive = |section: &str, key: &str, v: f64| {
            if v > 0.0 && v.is_finite() { Ok(()) } else { Err(err(section, key, show(v), "must be a positive number")) }
        };
        let non_negative = |section: &str, key: &str, v: f64| {
            if v >= 0.0 && v.is_finite() { Ok(()) } else { Err(err(section, key, show(v), "must be zero or positive")) }
        };
        // Upper bounds far beyond any fabric formwork, which keep the arithmetic finite (a value
        // of 1e300 turned the solve's residual into NaN, a piece gap of 1e15 mm asked the nesting
        // for petabytes).
        let at_most = |section: &str, key: &str, v: f64, max: f64, what: &str| {
            if v <= max {
                Ok(())
            } else {
                Err(err(section, key, show(v), &format!("must be at most {} ({what})", show(max))))
            }
        };
        let within = |section: &str, key: &str, v: f64, (lo, hi): (f64, f64), unit: &str| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(err(section, key, show(v), &format!("must lie in [{}, {}]{unit}", show(lo), show(hi))))
            }
        };
        if let Some(h) = self.mesh.height {
            positive("mesh", "height", h)?;
            at_most("mesh", "height", h, 1e4, "m: a mold at most 10 km tall")?;
        }
        if self.mesh.min_faces > MAX_MIN_FACES {
            return Err(err("mesh", "min_faces", self.mesh.min_faces.to_string(), "must be at most 4000000"));
        }
        positive("material", "youngs_modulus", self.material.youngs_modulus)?;
        within(
            "material",
            "youngs_modulus",
            self.material.youngs_modulus,
            MODULUS_RANGE,
            " N/m (woven formwork fabrics: 10⁴–10⁶ N/m)",
        )?;
        let nu = self.material.poisson_ratio;
        if !(nu > -1.0 && nu < 1.0) {
            return Err(err("material", "poisson_ratio", show(nu), "must lie in (-1, 1) for a plane-stress membrane"));
        }
        non_negative("material", "areal_density", self.material.areal_density)?;
        at_most("material", "areal_density", self.material.areal_density, 100.0, "kg/m²: fabrics weigh 0.1–1")?;
        non_negative("infill", "density", self.infill.density)?;
        at_most("infill", "density", self.infill.density, 1e5, "kg/m³: the densest metals are about 22000")?;
        if let FillLevel::Height(h) = self.infill.fill_level {
            non_negative("infill", "fill_level", h)?;
            at_most("infill", "fill_level", h, 1e4, "m")?;
        }
        let hp = self.infill.head_pressure;
        if !(hp.is_finite() && hp.abs() <= 1e8) {
            return Err(err("infill", "head_pressure", show(hp), "must be finite, at most 1e8 Pa either way"));
        }
        if hp < 0.0 && self.infill.density == 0.0 {
            return Err(err(
                "infill",
                "head_pressure",
                show(hp),
                "is a suction with no liquid ([infill] density = 0): a fabric cannot hold it, the mold would collapse; give a positive pressure or a liquid",
            ));
        }
        positive("suspension", "band", self.suspension.band)?;
        if self.suspension.mode == SuspensionMode::Vertices && self.suspension.vertices.is_empty() {
            return Err(err("suspension", "vertices", "[]".into(), "mode = \"vertices\" needs at least one vertex"));
        }
        if self.suspension.mode != SuspensionMode::Vertices && !self.suspension.vertices.is_empty() {
            let mode = match self.suspension.mode {
                SuspensionMode::TopBand => "top-band",
                SuspensionMode::Boundary => "boundary",
                SuspensionMode::None => "none",
                SuspensionMode::Vertices => "vertices",
            };
            return Err(err(
                "suspension",
                "vertices",
                format!("{} vertices", self.suspension.vertices.len()),
                &format!("are given but mode = \"{mode}\" does not use them; set mode = \"vertices\" to clamp them"),
            ));
        }
        for (i, s) in self.supports.iter().enumerate() {
            if s.point.iter().any(|c| !c.is_finite()) {
                return Err(err("supports", "point", format!("{:?} (support {i})", s.point), "must be finite"));
            }
            let n = s.normal.iter().map(|c| c * c).sum::<f64>().sqrt();
            if !(n > 0.0 && n.is_finite()) {
                return Err(err(
                    "supports",
                    "normal",
                    format!("{:?} (support {i})", s.normal),
                    "must be finite with a finite, non-zero length",
                ));
            }
        }
        if !(self.solver.tolerance >= MIN_TOLERANCE && self.solver.tolerance < 1.0) {
            return Err(err(
                "solver",
                "tolerance",
                show(self.solver.tolerance),
                "must lie in [1e-12, 1): below 1e-12 the residual is round-off (the built-in example stops at \
                 1.0e-12 at 0.5 m, 1.8e-12 at 0.3 m)",
            ));
        }
        if self.solver.coarse_start_ratio < 2 {
            return Err(err(
                "solver",
                "coarse_start_ratio",
                self.solver.coarse_start_ratio.to_string(),
                "must be at least 2",
            ));
        }
        let f = &self.field;
        if !(0.0..=1.0).contains(&f.anisotropy_threshold) {
            return Err(err("field", "anisotropy_threshold", show(f.anisotropy_threshold), "must lie in [0, 1]"));
        }
        non_negative("field", "alpha", f.alpha)?;
        if !(0.0..=1.0).contains(&f.relax_radius) {
            return Err(err(
                "field",
                "relax_radius",
                show(f.relax_radius),
                "must lie in [0, 1] (a fraction of the bounding-box diagonal)",
            ));
        }
        non_negative("field", "relax_merge_energy", f.relax_merge_energy)?;
        let l = &self.layout;
        non_negative("layout", "drift_penalty", l.drift_penalty)?;
        if !(l.max_deviation >= 0.1 && l.max_deviation <= 90.0) {
            return Err(err("layout", "max_deviation", show(l.max_deviation), "must lie in [0.1, 90] degrees"));
        }
        non_negative("layout", "capture_radius", l.capture_radius)?;
        non_negative("layout", "pin_spacing", l.pin_spacing)?;
        if !(l.max_developability > 0.0) {
            return Err(err(
                "layout",
                "max_developability",
                show(l.max_developability),
                "must be positive (inf: never split)",
            ));
        }
        if !(0.0..0.5).contains(&l.min_patch_fraction) {
            return Err(err("layout", "min_patch_fraction", show(l.min_patch_fraction), "must lie in [0, 0.5)"));
        }
        if !(0.0..=0.5).contains(&l.snap) {
            return Err(err("layout", "snap", show(l.snap), "must lie in [0, 0.5]"));
        }
        let p = &self.pattern;
        non_negative("pattern", "seam_allowance_mm", p.seam_allowance_mm)?;
        positive("pattern", "notch_spacing_mm", p.notch_spacing_mm)?;
        non_negative("pattern", "notch_length_mm", p.notch_length_mm)?;
        positive("pattern", "fabric_width_mm", p.fabric_width_mm)?;
        at_most("pattern", "fabric_width_mm", p.fabric_width_mm, 1e5, "mm: a 100 m roll")?;
        at_most(
            "pattern",
            "seam_allowance_mm",
            p.seam_allowance_mm,
            (0.25 * p.fabric_width_mm).min(100.0),
            &format!(
                "mm: at most 100, and a quarter of fabric_width_mm = {}, so that pieces fit between their allowances",
                show(p.fabric_width_mm)
            ),
        )?;
        non_negative("pattern", "piece_gap_mm", p.piece_gap_mm)?;
        at_most("pattern", "piece_gap_mm", p.piece_gap_mm, p.fabric_width_mm, "mm: the roll's width")?;
        positive("pattern", "text_height_mm", p.text_height_mm)?;
        if !(p.max_qc_mean >= 1.0) {
            return Err(err("pattern", "max_qc_mean", show(p.max_qc_mean), "must be at least 1 (inf: no limit)"));
        }
        if !(p.max_area_spread >= 1.0) {
            return Err(err(
                "pattern",
                "max_area_spread",
                show(p.max_area_spread),
                "must be at least 1 (inf: no limit)",
            ));
        }
        let v = &self.validation;
        if let Some(k) = v.warp_stiffness {
            positive("validation", "warp_stiffness", k)?;
        }
        if let Some(k) = v.weft_stiffness {
            positive("validation", "weft_stiffness", k)?;
        }
        for (key, k) in [("warp_stiffness", v.warp_stiffness), ("weft_stiffness", v.weft_stiffness)] {
            if let Some(k) = k {
                within("validation", key, k, MODULUS_RANGE, " N/m")?;
            }
        }
        positive("validation", "shear_ratio", v.shear_ratio)?;
        at_most("validation", "shear_ratio", v.shear_ratio, 10.0, "the shear modulus over the yarns' mean stiffness")?;
        if let Some(k) = v.fabric_scale {
            positive("validation", "fabric_scale", k)?;
            within("validation", "fabric_scale", k, (1e-6, 1e6), "")?;
            if v.fabric.is_none() {
                return Err(err("validation", "fabric_scale", show(k), "scales a measured fabric: set fabric too"));
            }
        }
        if let Some(k) = v.seam_stiffness {
            non_negative("validation", "seam_stiffness", k)?;
            at_most("validation", "seam_stiffness", k, MODULUS_RANGE.1, "N")?;
        }
        if v.fabric.is_some() && (v.warp_stiffness.is_some() || v.weft_stiffness.is_some()) {
            let key = if v.warp_stiffness.is_some() { "warp_stiffness" } else { "weft_stiffness" };
            return Err(err(
                "validation",
                key,
                format!("{:?}", v.warp_stiffness.or(v.weft_stiffness).unwrap_or_default()),
                "give either a measured fabric or the stiffnesses, not both",
            ));
        }
        Ok(())
    }
}

/// The smallest `[solver] tolerance` accepted: below it the relative residual is the
/// assembly's round-off, which a solve cannot get under.
const MIN_TOLERANCE: f64 = 1e-12;

/// A number as a user reads it: plain, or in exponent form when very large or small (1e300
/// rather than its 301 digits).
fn show(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e7).contains(&v.abs()) { format!("{v:e}") } else { v.to_string() }
}

/// A path as text, its bytes that are not UTF-8 replaced (a file name of any bytes still gets
/// its summary).
fn lossy_path<S: serde::Serializer>(path: &Option<PathBuf>, s: S) -> Result<S::Ok, S::Error> {
    match path {
        Some(p) => s.serialize_some(&p.to_string_lossy()),
        None => s.serialize_none(),
    }
}

/// The thickness-integrated Young's moduli accepted (N/m): from a film far softer than any
/// fabric to a steel sheet a few millimetres thick.
pub(crate) const MODULUS_RANGE: (f64, f64) = (1.0, 1e9);

/// 1-based line of `key = ...` inside `[section]` (or `[[section]]`) of a TOML text.
fn locate_key(text: &str, section: &str, key: &str) -> Option<usize> {
    let mut current = String::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(h) = t.strip_prefix('[') {
            current = h.trim_start_matches('[').split(']').next().unwrap_or("").trim().to_string();
            continue;
        }
        if current == section
            && let Some(rest) = t.strip_prefix(key)
            && rest.trim_start().starts_with('=')
        {
            return Some(i + 1);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn template_is_the_default() {
        let cfg = Config::from_toml(TEMPLATE, "template").unwrap();
        assert_eq!(cfg, Config::default());
    }

    #[test]
    fn unknown_key_names_key_and_line() {
        let e = Config::from_toml("[material]\nyoungs_modulu = 5\n", "c.toml").unwrap_err().to_string();
        assert!(e.contains("youngs_modulu") && e.contains("line 2"), "{e}");
        let e = Config::from_toml("[infill]\ndensity = \"heavy\"\n", "c.toml").unwrap_err().to_string();
        assert!(e.contains("density") && e.contains("line 2"), "{e}");
    }

    #[test]
    fn range_errors_name_key_and_line() {
        let e =
            Config::from_toml("seed = 3\n[material]\n# c\npoisson_ratio = 1.5\n", "c.toml").unwrap_err().to_string();
        assert!(e.contains("c.toml:4") && e.contains("material.poisson_ratio"), "{e}");
        for (key, value) in [("max_qc_mean", "0.9"), ("max_area_spread", "nan"), ("max_area_spread", "0.5")] {
            let e = Config::from_toml(&format!("[pattern]\n{key} = {value}\n"), "p.toml").unwrap_err().to_string();
            assert!(e.contains("p.toml:2") && e.contains(&format!("pattern.{key}")) && e.contains("at least 1"), "{e}");
        }
        let c = Config::from_toml("[pattern]\nmax_qc_mean = inf\nmax_area_spread = 8\n", "p").unwrap();
        assert_eq!((c.pattern.max_qc_mean, c.pattern.max_area_spread), (f64::INFINITY, 8.0));
    }

    #[test]
    fn fuzzed_scenarios_are_refused_by_name() {
        let e = Config::from_toml("[[supports]]\npoint = [0, 0, -1, 7]\nnormal = [0, 0, 1]\n", "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("invalid length 4"), "{e}");
        assert!(Config::from_toml("[[supports]]\npoint = [0, 0, -1]\nnormal = [0, 0, 1]\n", "s").is_ok());
        let e = Config::from_toml("[suspension]\nvertices = [1, 2]\n", "v.toml").unwrap_err().to_string();
        assert!(e.contains("suspension.vertices") && e.contains("top-band"), "{e}");
        let e = Config::from_toml("[infill]\ndensity = 0\nhead_pressure = -1000\n", "h.toml").unwrap_err().to_string();
        assert!(e.contains("infill.head_pressure") && e.contains("suction"), "{e}");
        assert!(Config::from_toml("[infill]\nhead_pressure = -1000\n", "h").is_ok());
    }

    #[test]
    fn max_iterations_is_a_number_or_auto() {
        assert_eq!(Config::default().solver.max_iterations, MaxIterations::Auto);
        let c = Config::from_toml("[solver]\nmax_iterations = 250\n", "c").unwrap();
        assert_eq!(c.solver.max_iterations, MaxIterations::Fixed(std::num::NonZeroUsize::new(250).unwrap()));
        assert_eq!(c.solver.max_iterations.resolve(1_000_000), 250);
        let c = Config::from_toml("[solver]\nmax_iterations = \"auto\"\n", "c").unwrap();
        assert_eq!(c.solver.max_iterations, MaxIterations::Auto);
        // 60 million over 3 dofs per vertex, between 1000 and 20000.
        assert_eq!(c.solver.max_iterations.resolve(2304), 8680);
        assert_eq!(c.solver.max_iterations.resolve(51_000), 1000);
        assert_eq!(c.solver.max_iterations.resolve(4), 20_000);
        // Refused with what is expected (the key and line come with every config error).
        for (bad, says) in [
            ("\"many\"", "or \"auto\", found \"many\""),
            ("\"AUTO\"", "found \"AUTO\""),
            ("-5", "found -5"),
            ("2.5", "(at least 1) or \"auto\""),
            ("true", "(at least 1) or \"auto\""),
            ("[3]", "(at least 1) or \"auto\""),
            ("0", "(at least 1) or \"auto\", found 0"),
        ] {
            let e =
                Config::from_toml(&format!("[solver]\nmax_iterations = {bad}\n"), "c.toml").unwrap_err().to_string();
            assert!(e.contains(says) && (e.contains("line 2") || e.contains("c.toml:2")), "{bad}: {e}");
        }
        // Written back as it was read (the summary's scenario).
        let echo = toml::to_string(&Config::default().solver).unwrap();
        assert!(echo.contains("max_iterations = \"auto\""), "{echo}");
        let echo = toml::to_string(&Config::from_toml("[solver]\nmax_iterations = 77\n", "c").unwrap().solver).unwrap();
        assert!(echo.contains("max_iterations = 77"), "{echo}");
    }

    #[test]
    fn up_and_fill_level_forms() {
        let c = Config::from_toml("[mesh]\nup = \"-y\"\n[infill]\nfill_level = 0.3\n", "c").unwrap();
        assert_eq!(c.mesh.up, Up([0.0, -1.0, 0.0]));
        assert_eq!(c.infill.fill_level, FillLevel::Height(0.3));
        let c = Config::from_toml("[mesh]\nup = [0, 1, 1]\n[infill]\nfill_level = 1\n", "c").unwrap();
        assert_eq!(c.mesh.up, Up([0.0, 1.0, 1.0]));
        assert_eq!(c.infill.fill_level, FillLevel::Height(1.0));
        assert!(Config::from_toml("[mesh]\nup = \"sideways\"\n", "c").is_err());
        assert!(Config::from_toml("[infill]\nfill_level = \"half\"\n", "c").is_err());
        let c = Config::from_toml("[solver]\nfactor_precision = \"single\"\n", "c").unwrap();
        assert_eq!(c.solver.factor_precision, FactorPrecision::Single);
        let e = Config::from_toml("[solver]\n\nfactor_precision = \"half\"\n", "c").unwrap_err().to_string();
        assert!(e.contains("factor_precision") && e.contains("line 3"), "{e}");
        let e = Config::from_toml("[solver]\ncoarse_start_ratio = 1\n", "c").unwrap_err().to_string();
        assert!(e.contains("solver.coarse_start_ratio") && e.contains("at least 2"), "{e}");
        let c2 = Config::from_toml("[solver]\ncoarse_start = false\ncoarse_start_min_faces = 7\n", "c").unwrap();
        assert!(!c2.solver.coarse_start && c2.solver.coarse_start_min_faces == 7);
        assert_eq!(Config::default().solver.relax_sweeps, 10);
        assert_eq!(Config::from_toml("[solver]\nrelax_sweeps = 0\n", "c").unwrap().solver.relax_sweeps, 0);
        let e = Config::from_toml("[solver]\nrelax_sweeps = -1\n", "c").unwrap_err().to_string();
        assert!(e.contains("relax_sweeps"), "{e}");
        assert_eq!(Config::default().solver.damping, DampingMatrix::Laplacian);
        let c3 = Config::from_toml("[solver]\ndamping = \"diagonal\"\n", "c").unwrap();
        assert_eq!(c3.solver.damping, DampingMatrix::Diagonal);
        let e = Config::from_toml("[solver]\ndamping = \"identity\"\n", "c").unwrap_err().to_string();
        assert!(e.contains("damping"), "{e}");
        // Round trip through TOML.
        let text = toml::to_string(&c).unwrap();
        assert_eq!(Config::from_toml(&text, "rt").unwrap(), c);
    }
}
