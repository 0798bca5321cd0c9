//! Stage 1: the filled mold's equilibrium (`deformed.ply`, summary `simulation`).

use crate::config::{self, Config, MaterialModel, SuspensionMode};
use crate::failure::{Blame, Failure};
use crate::input::Input;
use crate::progress::Progress;
use anyhow::{Context, anyhow};
use clothcast_mesh::io::{Attribute, PlyFormat, write_atomic, write_ply};
use clothcast_mesh::{Vec3, VertexId};
use clothcast_sim::loads::Plane;
use clothcast_sim::material::{Material, StVenantKirchhoff, WrinklingStVenantKirchhoff};
use clothcast_sim::newton::{FactorPrecision, NewtonOptions};
use clothcast_sim::{FillLevel, Scenario, SimResult, Suspension, simulate};
use std::path::Path;

/// The library scenario of a configuration, for a solve on a mesh of `vertices` vertices (the
/// target's, or the sewn mold's: they set the `"auto"` iteration limit).
pub fn scenario(cfg: &Config, input: &Input, vertices: usize) -> Result<Scenario, Failure> {
    let suspension = match cfg.suspension.mode {
        SuspensionMode::TopBand => Suspension::TopBand { band: cfg.suspension.band },
        SuspensionMode::Boundary => Suspension::Boundary,
        SuspensionMode::None => Suspension::None,
        SuspensionMode::Vertices => {
            // Ids are those of the input file; map them through any repair.
            let mut of_input = vec![None; input.vertex_to_input.iter().map(|&v| v as usize + 1).max().unwrap_or(0)];
            for (i, &v) in input.vertex_to_input.iter().enumerate() {
                of_input[v as usize].get_or_insert(VertexId::new(i));
            }
            let mut vs = Vec::new();
            for &v in &cfg.suspension.vertices {
                match of_input.get(v as usize).copied().flatten() {
                    Some(m) => vs.push(m),
                    None => {
                        return Err(Failure::Input(anyhow!(
                            "suspension.vertices: vertex {v} is not in the (repaired) mesh, which has {} vertices",
                            input.vertex_to_input.len()
                        )));
                    }
                }
            }
            Suspension::Vertices(vs)
        }
    };
    Ok(Scenario {
        up: input.up,
        infill_density: cfg.infill.density,
        fill_level: match cfg.infill.fill_level {
            config::FillLevel::Top => FillLevel::Top,
            config::FillLevel::Height(h) => FillLevel::Height(h),
        },
        head_pressure: cfg.infill.head_pressure,
        self_weight: cfg.material.self_weight.then_some(cfg.material.areal_density),
        suspension,
        supports: cfg.supports.iter().map(|s| Plane::new(Vec3::from(s.point), Vec3::from(s.normal))).collect(),
        gravity: clothcast_sim::scenario::GRAVITY,
        newton: NewtonOptions {
            tolerance: cfg.solver.tolerance,
            max_iterations: cfg.solver.max_iterations.resolve(vertices),
            factor_precision: match cfg.solver.factor_precision {
                config::FactorPrecision::Auto => FactorPrecision::Auto,
                config::FactorPrecision::Double => FactorPrecision::Double,
                config::FactorPrecision::Single => FactorPrecision::Single,
            },
            relax_sweeps: cfg.solver.relax_sweeps,
            damping: match cfg.solver.damping {
                config::DampingMatrix::Laplacian => clothcast_sim::newton::Damping::Laplacian,
                config::DampingMatrix::Diagonal => clothcast_sim::newton::Damping::Diagonal,
            },
            ..Default::default()
        },
        coarse: cfg.solver.coarse_start.then_some(clothcast_sim::coarse::CoarseOptions {
            min_faces: cfg.solver.coarse_start_min_faces,
            ratio: cfg.solver.coarse_start_ratio,
        }),
    })
}

/// Where a solve that did not converge left its largest unbalanced force, and what that
/// usually means, for its message ("" when there is nothing to say).
fn residual_site(s: &clothcast_sim::SimStats, input: &Input, self_weight: bool) -> String {
    let Some(site) = &s.largest_residual else { return String::new() };
    // The input file's vertex, as in the other messages (summary.json keeps deformed.ply's).
    let vertex = input.input_vertex(VertexId::new(site.vertex)).idx();
    let mut out = format!("; the largest unbalanced force, {:.1e} N, is at vertex {vertex}", site.force_n);
    if let Some(h) = site.height_above_level_m {
        out += &format!(", {:.0} mm {} the fill level", h.abs() * 1e3, if h > 0.0 { "above" } else { "below" });
    }
    if let Some(r) = s.residual_rel_below_level {
        out += &format!("; below the level the relative residual is {r:.1e}");
    }
    if above_level(s) {
        // Measured on closed meshes filled to 20-70% of their height: 200 iterations without
        // converging (8 of 9 solves); with 100 Pa of head pressure all 15 in 20-161; torus,
        // bunny, fertility and spot (2026-12-06) filled to half their height or more in
        // 147-1166 (2026-12-06, before CREEP_AFTER), filled to a fifth in 1211-1986 with the
        // slack walls (2026-12-07; 1520-4460 before), and with the fabric's weight torus and
        // bunny in 547 and 473 against 1436 and 1211 (README).
        let weight = if self_weight {
            ""
        } else {
            "; on some molds so does the fabric's weight, which holds that fabric ([material] self_weight = true: \
             filled to a fifth of their height, torus and bunny converged in 547 and 473 iterations with it against \
             1436 and 1211 without, fertility 1082 against 1244, spot 1218 against 1961)"
        };
        out += &format!(
            "; fabric above the liquid carries no load of its own (it hangs slack or wrinkled, its shape barely \
             determined, and Newton creeps there): a small [infill] head_pressure (100 Pa keeps it taut) or a higher \
             fill_level helps{weight}; or more iterations (molds filled to half their height or more have converged \
             within 1200, filled to a fifth within 700-8300, kitten's 53k vertices in 1316 and bunny_hr's 30k in \
             8276 (8 and 24 minutes on a slow day); this solve was allowed {}: [solver] max_iterations = {})",
            s.max_iterations,
            suggested_iterations(s.max_iterations, true)
        );
    }
    out
}

/// The iterations a partial fill's message suggests at least: molds filled to a fifth of
/// their height converged in 733-8276 (measured at 0.5 m filled to 0.1 m, with the slack
/// walls: on 2026-12-07 fertility 1244, bunny 1211, torus 1436 from the target; on 2026-12-08
/// (thirty-seventh session), with the walls in the fine solve from the coarse start, spot 733,
/// kitten 1316 and bunny_hr 8276 (without the walls there 876, 3082 and 5980; the 8000
/// suggested before then fell short of bunny_hr's 8276), more than twice the limits of spot
/// (1734), kitten and bunny_hr (1000) (4000 and 3000).
const PARTIAL_FILL_ITERATIONS: usize = 10_000;

/// The iteration limit a message suggests after a solve allowed `limit` did not converge
/// (one number, whichever hints the message gives): twice as many, rounded up to a thousand,
/// at least 3000 (the floor of 1000 doubled, and the stiff small molds' need), and at least
/// [`PARTIAL_FILL_ITERATIONS`] when its largest unbalanced force sits above the liquid (`above`).
fn suggested_iterations(limit: usize, above: bool) -> usize {
    let more = limit.saturating_mul(2).div_ceil(1000).saturating_mul(1000).max(3000);
    if above { more.max(PARTIAL_FILL_ITERATIONS) } else { more }
}

/// The largest unbalanced force of a solve that did not converge sits above the liquid (a
/// partial fill's unloaded fabric).
fn above_level(s: &clothcast_sim::SimStats) -> bool {
    s.largest_residual.as_ref().and_then(|site| site.height_above_level_m).is_some_and(|h| h > 0.0)
}

/// A fabric stiffer than this against its load (`simulation.stiffness_ratio`: Y / (p H), p the
/// largest pressure, H the mold's height; Y / (ρ g H²) when filled to the top) barely
/// stretches, and Newton takes many short steps while the wrinkles settle, even in the stages
/// of growing stiffness it is solved in (`clothcast_sim::CONTINUATION_RATIO`): measured
/// on 2026-12-04, spot 0.1 m tall (ratio 350 / 700 / 2100 for Y = 50 / 100 / 300 kN/m) took
/// 52 / 79 / 148 iterations (76 / 127 / 408 directly), bunny 38 / 51 / 93; the default
/// scenarios at 0.5 m (ratio 14) take 11–59 on eight meshes. Such a solve that does not
/// converge within the default iterations may still be settling: its message names more.
const STIFF_RATIO: f64 = 1000.0;

/// The other membrane model, where it may converge: for plain StVK, whose compressed fabric is
/// a saddle of the energy where Newton can stall, the tension-field model (a fuzz case: an open
/// box held at its rim, 1 m tall, filled to 0.45 m, 1 MN/m: plain StVK 6·10⁻² after 200
/// iterations; the tension-field model 67); for the tension-field model creeping on a partial
/// fill's unloaded fabric, plain StVK (measured on 2026-12-04, eleven meshes filled to 0.1, 0.25
/// and 0.35 m of 0.5 m: plain StVK converged 28 of the 33 within 200 iterations (7-139), the
/// tension-field model 15; their equilibria differ, bunny at 0.35 m: largest displacement
/// 0.09 m against 0.23 m, so it is named as another model, not a fix).
fn model_hint(s: &clothcast_sim::SimStats, model: MaterialModel) -> &'static str {
    match model {
        MaterialModel::Stvk => {
            "; plain StVK lets the fabric carry compression, where its energy has saddles (a membrane \
             buckles) and Newton can stall: the default tension-field model ([material] model = \
             \"tension-field\"), in which such fabric wrinkles instead, converges more readily"
        }
        MaterialModel::TensionField if above_level(s) => {
            "; the plain St. Venant-Kirchhoff model ([material] model = \"stvk\") converges on most partial \
             fills, but lets the fabric carry compression, so that its mold hangs differently"
        }
        MaterialModel::TensionField => "",
    }
}

/// What to say of a solve that did not converge on a fabric very stiff for its mold
/// ([`clothcast_sim::SimStats::stiffness_ratio`]).
fn stiff_hint(s: &clothcast_sim::SimStats) -> String {
    let ratio = s.stiffness_ratio;
    if !(ratio > STIFF_RATIO) {
        return String::new();
    }
    let shown = if ratio < 1e7 { format!("{ratio:.0}") } else { format!("{ratio:.2e}") };
    format!(
        "; the fabric is very stiff for so small a mold (its stiffness over p H = {shown}: Y / (1 - ν²) for an \
         isotropic fabric, the stiffer yarn's for a woven one, p the largest pressure, H the mold's height): it barely \
         stretches, and Newton takes many short steps while the wrinkles settle, even in stages of growing \
         stiffness (simulation.stiffness_stages; spot 0.1 m tall of a 300 kN/m fabric: 148 iterations): more \
         iterations may help ([solver] max_iterations = {})",
        suggested_iterations(s.max_iterations, above_level(s))
    )
}

/// A principal stretch beyond this (50%: three times the largest stretch, 7/6, at which the
/// WOR11 woven fabrics were measured) is warned about: the mold would tear, or the fabric is far
/// too soft or the load too heavy for it.
const OVERSTRETCH: f64 = 1.5;

/// Warn when the fabric stretches beyond [`OVERSTRETCH`] somewhere (fertility at 1 m with the
/// default fabric: 72%, the mold hanging up to 2.97 m below its target), naming the face.
fn warn_overstretched(result: &SimResult, input: &Input) {
    let Some((f, l)) = result
        .stretch
        .iter()
        .enumerate()
        .map(|(f, s)| (f, s[0].max(s[1]).max(0.0).sqrt()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return;
    };
    if l > OVERSTRETCH {
        tracing::warn!(
            "the fabric stretches by up to {:.0}% (face {} of the input) and the mold moves up to {:.2} m from the \
             target: far beyond what woven fabric takes (WOR11 measured woven fabrics up to 17%); the mold would \
             tear, or the fabric is far too soft for this load: set [material] youngs_modulus to the fabric's, hold \
             the mold by more of it ([suspension]), lower the fill, or add supports",
            100.0 * (l - 1.0),
            input.face_to_input[f],
            result.stats.max_displacement_m
        );
    }
}

/// A solve that did not converge with the mold moved more than this many times its bounding
/// box's diagonal ran away: the scenario's load outgrows its fabric (refused as an input
/// problem, even with `--allow-unconverged`: there is no equilibrium to go on with).
const RUNAWAY: f64 = 10.0;

/// Run the simulation, refuse a non-converged result unless allowed.
pub fn run(cfg: &Config, input: &Input, progress: &Progress) -> Result<SimResult, Failure> {
    let sc = scenario(cfg, input, input.mesh.n_vertices())?;
    let (y, nu) = (cfg.material.youngs_modulus, cfg.material.poisson_ratio);
    let material: Box<dyn Material> = match cfg.material.model {
        MaterialModel::TensionField => Box::new(WrinklingStVenantKirchhoff::from_young_poisson(y, nu)),
        MaterialModel::Stvk => Box::new(StVenantKirchhoff::from_young_poisson(y, nu)),
    };
    let stage = progress.stage("simulating the filled mold");
    let result = simulate(&input.mesh, material.as_ref(), &sc, &mut |it| {
        stage.set_message(format!("simulating: Newton iteration {}, residual {:.1e}", it.iteration, it.residual_rel));
    })
    .map_err(|e| {
        // Named as in the input file.
        let e = e.renumbered(|v| input.input_vertex(v));
        if e.is_input_error() { Failure::Input(e.into()) } else { Failure::Internal(e.into()) }
    })?;
    drop(stage);
    let s = &result.stats;
    if !s.converged {
        let size = input.mesh.bbox().diagonal();
        let runaway = s.max_displacement_m > RUNAWAY * size;
        let why = format!(
            "the simulation did not converge ({:?} after {} Newton iterations, relative residual {:.2e} > tolerance {:.1e}){}",
            s.termination,
            s.newton_iterations,
            s.residual_rel,
            cfg.solver.tolerance,
            // Where the force sits means nothing on a mold that ran off.
            if runaway {
                String::new()
            } else {
                residual_site(s, input, cfg.material.self_weight) + &stiff_hint(s) + model_hint(s, cfg.material.model)
            }
        );
        if runaway {
            // No iteration count or damping brings this back: the scenario has no equilibrium
            // the solve can reach (tet.obj 3 m tall of a fabric of 1000 N/m: the mold had moved
            // 1400 km after 42 iterations).
            let times = s.max_displacement_m / size;
            let times = if times < 1e7 { format!("{times:.0}") } else { format!("{times:.1e}") };
            // A Poisson ratio near -1 leaves the fabric almost no resistance to a change of area.
            let nu = cfg.material.poisson_ratio;
            let nu_hint = if nu < -0.5 {
                format!(" (its poisson_ratio = {nu} leaves it little resistance to spreading: fabrics have 0–0.5)")
            } else {
                String::new()
            };
            return Err(Failure::Input(anyhow!(
                "{why}: the mold ran away under the load (it moved up to {:.1e} m, {times} times its own size): the \
                 fabric is far too soft for this load{nu_hint}, and no equilibrium was found; set [material] \
                 youngs_modulus to the fabric's (now {} N/m), lower the fill or head pressure, or hold the mold by more \
                 of it",
                s.max_displacement_m,
                cfg.material.youngs_modulus
            )));
        }
        if !cfg.solver.allow_unconverged {
            return Err(Failure::Internal(anyhow!(
                "{why}; raise [solver] max_iterations, check the scenario, or pass --allow-unconverged to continue anyway"
            )));
        }
        tracing::warn!("{why}; continuing because allow_unconverged is set");
        progress.say(format!("warning: {why}; continuing (--allow-unconverged)"));
    }
    warn_overstretched(&result, input);
    if let Some(floor) = s.solver.round_off_floor_rel {
        tracing::warn!(
            "the simulation stopped at a relative residual of {:.1e}, above the tolerance {:.0e}, where it cannot be \
             told from round-off (its floor on this mesh: {floor:.1e} of the load): sliver triangles (smallest angle \
             {:.1e}°) make the forces sensitive to the last digit of the positions; remesh them for a tighter solve",
            s.residual_rel,
            cfg.solver.tolerance,
            smallest_angle_deg(input)
        );
    }
    progress.say(format!(
        "simulation: {} in {} Newton iterations (residual {:.1e}), max displacement {:.2} mm, liquid {:.2} L, max pressure {:.0} Pa, {:.2} s",
        if s.converged { "converged" } else { "NOT converged" },
        s.newton_iterations,
        s.residual_rel,
        s.max_displacement_m * 1e3,
        s.liquid_volume_m3 * 1e3,
        s.pressure_max_pa,
        s.seconds
    ));
    Ok(result)
}

/// The files this stage writes in the output directory.
pub const FILES: [&str; 1] = ["deformed.ply"];

/// Write `deformed.ply`: equilibrium positions in the input's units (same vertex and face
/// order as the target), per-vertex displacement (m) and per-face λ1, λ2.
pub fn write_outputs(out: &Path, input: &Input, result: &SimResult) -> Result<(), Failure> {
    let m = &input.mesh;
    let pos: Vec<Vec3> = result.positions.iter().map(|p| p / input.to_metres).collect();
    let disp: Vec<Vec3> = m.vertices().map(|v| result.positions[v] - m.position(v)).collect();
    let tris: Vec<[u32; 3]> = m.faces().iter().map(|t| t.map(|v| v.0)).collect();
    let mut vattr = vec![Attribute::f64("displacement", disp.iter().map(|d| d.norm()).collect())];
    vattr.extend(Attribute::vec3("displacement", &disp));
    let fattr = [
        Attribute::f64("lambda1", result.stretch.iter().map(|s| s[0]).collect()),
        Attribute::f64("lambda2", result.stretch.iter().map(|s| s[1]).collect()),
    ];
    let comment = format!(
        "clothcast deformed mold (equilibrium under infill)\ncoordinates in input units ({} m per unit); displacement in metres\nlambda1 >= lambda2: squared principal stretches per face",
        input.to_metres
    );
    let path = out.join(FILES[0]);
    write_atomic(&path, |w| write_ply(w, PlyFormat::BinaryLittleEndian, &comment, &pos, &tris, &vattr, &fattr))
        .with_context(|| format!("cannot write {}", path.display()))
        .internal()
}

/// The smallest corner angle of the input mesh (degrees).
fn smallest_angle_deg(input: &Input) -> f64 {
    let m = &input.mesh;
    m.face_ids()
        .flat_map(|f| {
            let p = m.face_positions(f);
            (0..3).map(move |k| {
                let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                a.angle(&b).to_degrees()
            })
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    #[test]
    fn suggested_iterations_double_the_limit_in_thousands() {
        for (limit, more) in [(3, 3000), (1000, 3000), (1734, 4000), (8680, 18000), (20_000, 40_000)] {
            assert_eq!(super::suggested_iterations(limit, false), more, "{limit}");
        }
    }

    #[test]
    fn the_auto_limit_is_that_of_the_vertex_count_given() {
        // The validation stage resolves "auto" for the sewn mesh, which has more vertices than
        // the target: the limit must follow the count passed, not the input's.
        use clothcast_sim::newton::auto_max_iterations;
        let cfg = crate::config::Config::default();
        let input = crate::input::load(&cfg, &clothcast_mesh::repair::RepairOptions::default()).unwrap();
        let n = input.mesh.n_vertices();
        let target = super::scenario(&cfg, &input, n).unwrap().newton.max_iterations;
        let sewn = super::scenario(&cfg, &input, 3 * n).unwrap().newton.max_iterations;
        assert_eq!(target, auto_max_iterations(3 * n));
        assert_eq!(sewn, auto_max_iterations(9 * n));
        // Both inside the clamp's range on the built-in example, so they differ.
        assert!(sewn < target, "{sewn} {target}");
        // A fixed limit is the same for both.
        let fixed: crate::config::Config =
            crate::config::Config::from_toml("[solver]\nmax_iterations = 1234\n", "t").unwrap();
        assert_eq!(super::scenario(&fixed, &input, n).unwrap().newton.max_iterations, 1234);
        assert_eq!(super::scenario(&fixed, &input, 3 * n).unwrap().newton.max_iterations, 1234);
    }

    #[test]
    fn a_partial_fill_is_suggested_at_least_10000_iterations() {
        // Below the level (or no infill) twice the limit; above it at least 10000, and twice the
        // limit when that is more.
        for (limit, above, more) in [
            (1000, false, 3000),
            (1000, true, 10_000),
            (1734, true, 10_000),
            (8680, true, 18000),
            (20_000, true, 40_000),
        ] {
            assert_eq!(super::suggested_iterations(limit, above), more, "{limit} {above}");
        }
    }
}
