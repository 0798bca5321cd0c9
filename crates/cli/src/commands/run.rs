//! `clothcast run` (every stage) and the single-stage commands (`simulate`, ...): each runs the
//! pipeline up to its stage, writes that stage's files and `summary.json`.

use crate::args::RunArgs;
use crate::commands::resolve_scenario;
use crate::failure::{Blame, Failure};
use crate::input;
use crate::progress::Progress;
use crate::stages;
use crate::stages::validation::ValidationOutcome;
use crate::summary::{StageTime, Stages, Summary};
use anyhow::Context;
use clothcast_layout::{Segmentation, SplitHint, patch_extent};
use clothcast_mesh::io::write_atomic;
use clothcast_mesh::{FaceId, VertexId};
use std::path::Path;
use std::time::Instant;

/// Layouts made again, smaller, when a piece did not fit the roll (unless the same pieces come
/// back) ...
const ROLL_RETRIES: usize = 4;
/// ... and more, up to this many, while they help: fewer pieces too wide than the best layout
/// so far, or as many with a smaller largest overhang ...
const ROLL_RETRIES_MAX: usize = 8;
/// ... ending after this many in a row that did not.
const ROLL_STALLS: usize = 2;

/// Most layouts made again to split badly distorted pieces.
const DISTORTION_RETRIES: usize = 2;

/// A badly distorted piece's parts get at most this share of its extent (about two halves).
const DISTORTION_SPLIT: f64 = 0.6;

/// A piece's faces on the segmented mesh, and the target's faces they lie in (sorted, each
/// once): what a [`SplitHint`] names.
fn piece_faces(seg: &Segmentation, piece: u32) -> (Vec<FaceId>, Vec<FaceId>) {
    let own: Vec<FaceId> = seg.patch_of_face.enumerate().filter(|&(_, &p)| p == piece).map(|(g, _)| g).collect();
    let mut faces: Vec<FaceId> = own.iter().map(|&g| seg.face_parent[g]).collect();
    faces.sort_unstable();
    faces.dedup();
    (own, faces)
}

/// The last stage to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Until {
    /// Stop after the simulation.
    Simulation,
    /// Stop after the cross field.
    Field,
    /// Stop after the segmentation.
    Segmentation,
    /// Stop after the sewing patterns.
    Patterns,
    /// Every stage that exists.
    All,
}

/// Run the pipeline up to `until`.
pub fn run(args: &RunArgs, progress: &Progress, until: Until) -> Result<(), Failure> {
    let t0 = Instant::now();
    let (cfg, repair) = resolve_scenario(args)?;
    // The check's fabric (a file, perhaps) is input too: read, or refused, before any work.
    let fabric =
        if until >= Until::All && cfg.validation.enabled { Some(stages::validation::fabric(&cfg)?) } else { None };
    let mut stages = Stages::default();

    let stage = progress.stage("loading mesh");
    let input = input::load(&cfg, &repair)?;
    stages.input = Some(StageTime { seconds: stage.seconds() });
    drop(stage);
    let m = &input.mesh;
    progress.say(format!(
        "input: {} ({} vertices, {} faces, genus {}, {} boundary loop(s), {:.3} m tall, area {:.4} m²)",
        input.label,
        m.n_vertices(),
        m.n_faces(),
        m.genus(),
        m.boundary_loops().len(),
        {
            let up = input.up;
            let (lo, hi) = m
                .positions()
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.dot(&up)), h.max(p.dot(&up))));
            hi - lo
        },
        m.total_area()
    ));
    for line in input.repairs.lines() {
        progress.say(format!("repair: {line}"));
    }
    // The output directory, and whether files can be written there, before the work (a
    // path naming a file, or a directory without write access, is the user's to fix).
    if args.out.exists() && !args.out.is_dir() {
        return Err(Failure::Input(anyhow::anyhow!(
            "the output path {} exists and is not a directory",
            args.out.display()
        )));
    }
    // The run's files go to a staging directory inside it first and are moved into it
    // together when the run completes (see `commit`).
    let staging = args.out.join(PARTIAL_DIR);
    if staging.exists() {
        // Left by a run that was killed.
        std::fs::remove_dir_all(&staging)
            .with_context(|| format!("cannot clear {}", staging.display()))
            .map_err(Failure::Input)?;
    }
    std::fs::create_dir_all(&staging)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))
        .map_err(Failure::Input)?;
    let result = (|| -> Result<(), Failure> {
        let out = staging.as_path();

        // Stage 1: simulation.
        let sim = stages::simulation::run(&cfg, &input, progress)?;
        stages.simulation = Some(StageTime { seconds: sim.stats.seconds });
        stages::simulation::write_outputs(out, &input, &sim)?;
        let mut written = stages::simulation::FILES.to_vec();

        // Stage 2: the cross field.
        let field = if until >= Until::Field {
            let f = stages::field::run(&cfg, &input, &sim, progress)?;
            stages.field = Some(StageTime { seconds: f.stats.seconds });
            stages::field::write_outputs(out, &input, &f)?;
            written.extend(stages::field::FILES);
            Some(f)
        } else {
            None
        };

        // Stages 3 and 4: segmentation, flattening and patterns. The layout splits patches wider
        // than the roll allows (by their extent on the surface); pieces that still do not fit
        // once flattened (a flattening stretches) are split in a new layout, each to its share of
        // the roll, up to `ROLL_RETRIES` times, then up to `ROLL_RETRIES_MAX` until two in a row
        // do not help.
        let mut hints: Vec<SplitHint> = Vec::new();
        let mut retries = 0;
        // The pieces too wide last time, how many layouts in a row have given the same, and how
        // many in a row have not helped.
        let (mut last_too_wide, mut repeats, mut stalls): (Vec<(u32, f64)>, usize, usize) = (Vec::new(), 0, 0);
        // The fewest pieces too wide so far, and their largest overhang.
        let mut best_fit = (usize::MAX, f64::INFINITY);
        // Layouts made again to split badly distorted pieces, and the least distorted complete
        // layout so far.
        let mut distortion_retries = 0;
        let mut best: Option<(Segmentation, stages::patterns::PatternsResult)> = None;
        // Cone-like tips inside pieces the flattening shrank around them: one layout made again with
        // a seam through each, kept when its most shrunk triangle is larger (the layout before it
        // waits in `before_cones`).
        let mut cones: Vec<VertexId> = Vec::new();
        let mut cones_tried = false;
        let mut before_cones: Option<(Segmentation, stages::patterns::PatternsResult)> = None;
        let mut resume: Option<(Segmentation, stages::patterns::PatternsResult)> = None;
        // Time of every layout made, and of the flattening and patterns of the ones redone.
        let (mut layout_seconds, mut redone_seconds) = (0.0, 0.0);
        let (segmentation, patterns) = loop {
            let Some(f) = field.as_ref().filter(|_| until >= Until::Segmentation) else { break (None, None) };
            // Time of the flattening and patterns (the layout's is counted apart).
            let mut attempt = Instant::now();
            let (seg, result) = match resume.take() {
                // The layout before the seams to the tips, taken back.
                Some((seg, p)) => (seg, Ok(p)),
                None => {
                    let seg = stages::segmentation::run(&cfg, &input, f, &hints, &cones, progress)?;
                    layout_seconds += seg.stats.seconds;
                    if until < Until::Patterns {
                        break (Some(seg), None);
                    }
                    attempt = Instant::now();
                    let result = stages::patterns::run(&cfg, &input, f, &seg, progress);
                    (seg, result)
                }
            };
            let too_wide = match &result {
                Err(Failure::Input(e)) => {
                    e.downcast_ref::<stages::patterns::TooWide>().map(|t| (t.to_string(), t.pieces.clone()))
                }
                _ => None,
            };
            if before_cones.is_some() && result.is_err() {
                // The layout with the seams to the tips failed (a piece too wide, or another
                // error): the one before it stands.
                progress.say("the layout with seams to the tips failed: keeping the layout before it");
                cones.clear();
                resume = before_cones.take();
                redone_seconds += attempt.elapsed().as_secs_f64();
                continue;
            }
            match (result, too_wide) {
                // A layout made again for distorted pieces that fails (a piece too wide, or
                // another error): the complete layout before it stands.
                (Err(_), _) if best.is_some() => {
                    redone_seconds += attempt.elapsed().as_secs_f64();
                    let (seg, p) = best.take().expect("checked");
                    break (Some(seg), Some(p));
                }
                (Err(_), Some((e, pieces))) => {
                    redone_seconds += attempt.elapsed().as_secs_f64();
                    // The same pieces may come back (the layout measures a patch before its seams
                    // are straightened, which can widen it): their hints are then cut further, so
                    // every new layout asks more (see ROLL_RETRIES). The same pieces a third time
                    // in a row: the layout could not split them (too few faces, or no cut into two
                    // disks), and it would not next time either.
                    repeats = if pieces == last_too_wide { repeats + 1 } else { 0 };
                    // Progress: fewer pieces too wide, or the largest overhang smaller. A layout
                    // made again moves other patches too, so a new piece can take an old one's
                    // place while the overhang shrinks (the dome at 2 m: 37, 8, 3, 1, 1, ... pieces).
                    let overhang = |p: &[(u32, f64)]| p.iter().map(|&(_, r)| r).fold(0.0, f64::max);
                    // Against the best layout so far (fewer pieces too wide, or as many with the
                    // largest overhang at least 0.1% smaller), so that a swing back and forth stalls.
                    let now = (pieces.len(), overhang(&pieces));
                    let helped =
                        retries == 0 || now.0 < best_fit.0 || (now.0 == best_fit.0 && now.1 < best_fit.1 * 0.999);
                    if helped {
                        best_fit = now;
                    }
                    stalls = if helped { 0 } else { stalls + 1 };
                    if retries == ROLL_RETRIES_MAX || repeats >= 2 || (retries >= ROLL_RETRIES && stalls >= ROLL_STALLS)
                    {
                        stages::segmentation::write_outputs(out, &input, &seg)?;
                        let finer = if cfg.mesh.refine {
                            format!("a finer mesh (--min-faces, now {}) may help", cfg.mesh.min_faces)
                        } else {
                            "refining the mesh ([mesh] refine = true, off in this scenario) may help".to_string()
                        };
                        return Err(Failure::Input(anyhow::anyhow!(
                            "{e} (after {} layout(s) splitting the pieces too wide: a patch with too few faces, or one no cut \
                         parts into two disks, cannot be split further; {finer})",
                            retries + 1
                        )));
                    }
                    for &(piece, ratio) in &pieces {
                        // Its pieces' extent: the patch's own, scaled as its flattened width is
                        // too wide, with 5% to spare.
                        let (own, faces) = piece_faces(&seg, piece);
                        let shrink = 0.95 / ratio.max(1.0);
                        // A piece too wide again after a hint on its region: the layout measures the
                        // patch before its seams are straightened and re-routed, which can make it
                        // wider, so the hint's own extent is cut further (by the same factor), not
                        // replaced by one that the older, smaller one overrides. (A large new piece
                        // holding half of a small earlier hint's faces inherits its extent too; the
                        // layout already keeps merges within it there.)
                        let earlier = hints
                            .iter()
                            .filter(|h| {
                                let common = h.faces.iter().filter(|f| faces.binary_search(f).is_ok()).count();
                                2 * common >= faces.len() || 2 * common >= h.faces.len()
                            })
                            .map(|h| h.max_extent)
                            .fold(f64::INFINITY, f64::min);
                        let max_extent = (patch_extent(&seg.mesh, &own) * shrink).min(earlier * shrink);
                        hints.push(SplitHint { faces, max_extent });
                    }
                    last_too_wide = pieces;
                    retries += 1;
                    progress
                        .say(format!("{e}: laying the patches out again with those split (layout {})", retries + 1));
                }
                (Err(e), None) => {
                    // What the layout was, for the user to look at.
                    stages::segmentation::write_outputs(out, &input, &seg)?;
                    return Err(e);
                }
                (Ok(p), _) => {
                    // Pieces shrunk around a cone-like tip inside them: the tips are cut through in
                    // a layout made again (once), which is kept if it shrinks the fabric less.
                    if !cones_tried && cfg.layout.cone_cuts {
                        cones = stages::patterns::shrunk_tips(&seg, &p);
                        if !cones.is_empty() {
                            cones_tried = true;
                            progress.say(format!(
                            "{} piece(s) cut far smaller than the target around a cone-like tip (area ratio under {}): \
                             laying the patches out again with a dart to each tip",
                            cones.len(),
                            stages::patterns::SHRUNK_PIECE
                        ));
                            before_cones = Some((seg, p));
                            redone_seconds += attempt.elapsed().as_secs_f64();
                            continue;
                        }
                    }
                    let (seg, p) = match before_cones.take() {
                        Some((s0, p0)) if p0.flat.report.area_ratio_min >= p.flat.report.area_ratio_min => {
                            progress.say(format!(
                                "the seams to the tips did not help (smallest area ratio {:.3} against {:.3}): \
                             keeping the layout before them",
                                p.flat.report.area_ratio_min, p0.flat.report.area_ratio_min
                            ));
                            cones.clear();
                            (s0, p0)
                        }
                        _ => (seg, p),
                    };
                    // Pieces that came out badly distorted (a corner or a strongly curved region
                    // inside them, which the developability score misses) are split in a new
                    // layout, up to DISTORTION_RETRIES times while that lowers their count; the
                    // layout with the fewest is kept (the earliest on a tie).
                    let distorted = p.flat.report.distorted_pieces.clone();
                    let fewer =
                        best.as_ref().is_none_or(|(_, b)| distorted.len() < b.flat.report.distorted_pieces.len());
                    let done = distorted.is_empty() || distortion_retries == DISTORTION_RETRIES || !fewer;
                    if !done {
                        for &piece in &distorted {
                            let (own, faces) = piece_faces(&seg, piece);
                            hints.push(SplitHint {
                                faces,
                                max_extent: patch_extent(&seg.mesh, &own) * DISTORTION_SPLIT,
                            });
                        }
                        progress.say(format!(
                            "{} piece(s) badly distorted: laying the patches out again with those split",
                            distorted.len()
                        ));
                    }
                    if fewer {
                        best = Some((seg, p));
                    }
                    if done {
                        let (seg, p) = best.take().expect("a complete layout");
                        break (Some(seg), Some(p));
                    }
                    distortion_retries += 1;
                    redone_seconds += attempt.elapsed().as_secs_f64();
                }
            }
        };
        if let Some(seg) = &segmentation {
            stages.segmentation = Some(StageTime { seconds: layout_seconds });
            stages::segmentation::write_outputs(out, &input, seg)?;
            written.extend(stages::segmentation::FILES);
        }
        let patterns = match (segmentation.as_ref(), patterns) {
            (Some(seg), Some(mut p)) => {
                stages::patterns::warn_distorted(&p.flat.report, &cfg);
                let t = std::time::Instant::now();
                let files = stages::patterns::write_outputs(out, &input, seg, &p)?;
                p.summary.seconds += t.elapsed().as_secs_f64();
                p.summary.files = files;
                p.summary.layout_retries = retries;
                p.summary.distortion_retries = distortion_retries;
                p.summary.cone_retries = usize::from(cones_tried);
                stages.flattening = Some(StageTime { seconds: p.flat.report.seconds + redone_seconds });
                stages.patterns = Some(StageTime { seconds: p.summary.seconds });
                Some(p)
            }
            _ => None,
        };
        let pattern_files: Vec<String> = patterns.as_ref().map(|p| p.summary.files.clone()).unwrap_or_default();

        // Stage 6: the check, the mold sewn from the patterns.
        let validation = match (&fabric, field.as_ref(), segmentation.as_ref(), patterns.as_ref()) {
            (Some(fabric), Some(f), Some(seg), Some(p)) => {
                let t = Instant::now();
                match stages::validation::run(&cfg, fabric, &input, &sim, f, seg, p, progress) {
                    Ok(v) => {
                        stages::validation::write_outputs(out, &input, seg, &v)?;
                        written.extend(stages::validation::FILES);
                        stages.validation = Some(StageTime { seconds: v.summary.seconds });
                        Some(ValidationOutcome::Done(Box::new(v.summary)))
                    }
                    // The patterns stand: the check's failure is reported, not the run's.
                    Err(Failure::Input(e) | Failure::Internal(e)) => {
                        tracing::warn!(
                            "the check (the sewn mold, filled) could not be made: {e:#}; the patterns stand"
                        );
                        stages.validation = Some(StageTime { seconds: t.elapsed().as_secs_f64() });
                        Some(ValidationOutcome::Failed { error: format!("{e:#}") })
                    }
                    Err(e) => return Err(e),
                }
            }
            _ => None,
        };

        let summary = Summary {
            version: env!("CARGO_PKG_VERSION"),
            input: input.summary(),
            scenario: cfg,
            stages,
            simulation: Some(sim.stats.clone()),
            field: field.map(|f| f.stats),
            segmentation: segmentation.map(|s| s.stats),
            flattening: patterns.as_ref().map(|p| p.flat.report.clone()),
            patterns: patterns.map(|p| p.summary),
            validation,
            seconds_total: t0.elapsed().as_secs_f64(),
        };
        let path = out.join("summary.json");
        let text = serde_json::to_string_pretty(&summary).internal()?;
        write_atomic(&path, |w| std::io::Write::write_all(w, text.as_bytes()))
            .with_context(|| format!("cannot write {}", path.display()))
            .internal()?;
        let mut written: Vec<String> = written.into_iter().map(String::from).collect();
        written.extend(pattern_files.iter().cloned());
        progress.say(format!(
            "wrote {} and {} in {}",
            path.file_name().and_then(|n| n.to_str()).unwrap_or("summary.json"),
            written.join(", "),
            args.out.display()
        ));
        if !pattern_files.is_empty() {
            progress.say(format!("patterns to cut: {}", args.out.join("patterns").display()));
        }
        Ok(())
    })();
    commit(&args.out, &staging, until, result)
}

/// The staging directory of a run, inside the output directory.
const PARTIAL_DIR: &str = ".clothcast-partial";

/// Where the files a failed run had written go, inside the output directory.
pub const FAILED_DIR: &str = "failed-run";

/// The files a run up to `until` writes when every stage it runs produces its files
/// (relative to the output directory; `summary.json` aside).
fn stage_outputs(until: Until) -> Vec<String> {
    let mut out: Vec<String> = stages::simulation::FILES.map(String::from).to_vec();
    if until >= Until::Field {
        out.extend(stages::field::FILES.map(String::from));
    }
    if until >= Until::Segmentation {
        out.extend(stages::segmentation::FILES.map(String::from));
    }
    if until >= Until::Patterns {
        out.extend(stages::patterns::files());
    }
    if until >= Until::All {
        out.extend(stages::validation::FILES.map(String::from));
    }
    out
}

/// End a run: its files move from `staging` into `out` when it succeeded, each replacing the
/// former one by a rename, `summary.json` last, after every destination was checked (a
/// directory where a file goes, or the reverse, fails the run before anything moves); a file
/// of the run's stages that this run did not write (the check's `cast.ply` when the check
/// failed or is off) is removed, and so is an earlier failed run's `failed-run/`, so that the
/// output directory holds one run's set. When it failed, the files in `out` stay those of the
/// last complete run, and what the failed run wrote (for the user to look at: the layout that
/// could not be cut, say) goes to `out/failed-run/`, replacing that of an earlier failure; the
/// error says so.
fn commit(out: &Path, staging: &Path, until: Until, result: Result<(), Failure>) -> Result<(), Failure> {
    let files = match result.and_then(|()| files_to_move(out, staging)) {
        Ok(files) => files,
        Err(e) => return Err(keep_failed(out, staging, e)),
    };
    for f in &files {
        let dest = out.join(f);
        if let Some(parent) = dest.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("cannot create {}", parent.display()))
                .internal()?;
        }
        std::fs::rename(staging.join(f), &dest)
            .with_context(|| format!("cannot move {} into {}", f.display(), out.display()))
            .internal()?;
    }
    // A complete run supersedes what an earlier one left: its stages' files it did not write,
    // and a failed run's files.
    for stale in stage_outputs(until) {
        let path = out.join(&stale);
        if !files.iter().any(|f| f == Path::new(&stale))
            && path.is_file()
            && let Err(e) = std::fs::remove_file(&path)
        {
            tracing::warn!("{} is from an earlier run and could not be removed: {e}", path.display());
        }
    }
    let failed = out.join(FAILED_DIR);
    if failed.symlink_metadata().is_ok_and(|m| m.is_dir())
        && let Err(e) = std::fs::remove_dir_all(&failed)
    {
        tracing::warn!("{} is from an earlier failed run and could not be removed: {e}", failed.display());
    }
    let _ = std::fs::remove_dir_all(staging);
    Ok(())
}

/// The files a complete run wrote (relative to `staging`), `summary.json` last (it names the
/// others), once nothing is in the way of any of them in `out`.
fn files_to_move(out: &Path, staging: &Path) -> Result<Vec<std::path::PathBuf>, Failure> {
    let mut files = Vec::new();
    list_files(staging, Path::new(""), &mut files)
        .with_context(|| format!("cannot list {}", staging.display()))
        .internal()?;
    files.sort_by_key(|f| (f == Path::new("summary.json"), f.clone()));
    for f in &files {
        let dest = out.join(f);
        let blocked = dest.symlink_metadata().is_ok_and(|m| m.is_dir())
            || f.ancestors()
                .skip(1)
                .filter(|a| !a.as_os_str().is_empty())
                .any(|a| out.join(a).symlink_metadata().is_ok_and(|m| !m.is_dir()));
        if blocked {
            return Err(Failure::Input(anyhow::anyhow!(
                "cannot put {} in place: a directory or file of that name is in the way",
                dest.display()
            )));
        }
    }
    Ok(files)
}

/// A failed run's end: what it wrote goes to `out/failed-run/` (replacing an earlier failed
/// run's), and the error says where the files are.
fn keep_failed(out: &Path, staging: &Path, e: Failure) -> Failure {
    let wrote_any = std::fs::read_dir(staging).map(|mut d| d.next().is_some()).unwrap_or(false);
    if !wrote_any {
        let _ = std::fs::remove_dir_all(staging);
        return e;
    }
    let failed = out.join(FAILED_DIR);
    let kept = (|| {
        match failed.symlink_metadata() {
            Ok(m) if m.is_dir() => std::fs::remove_dir_all(&failed)?,
            Ok(_) => std::fs::remove_file(&failed)?,
            Err(_) => {}
        }
        std::fs::rename(staging, &failed)
    })();
    let complete = if out.join("summary.json").is_file() {
        format!("those in {} are the last complete run's", out.display())
    } else {
        format!("no complete run is in {}", out.display())
    };
    let note = match kept {
        Ok(()) => format!("the files this run wrote before it failed are in {}; {complete}", failed.display()),
        Err(io) => format!("the files this run wrote before it failed are in {} ({io})", staging.display()),
    };
    match e {
        Failure::Input(e) => Failure::Input(anyhow::anyhow!("{e:#} ({note})")),
        Failure::Internal(e) => Failure::Internal(anyhow::anyhow!("{e:#} ({note})")),
        other => other,
    }
}

/// The files under `dir` (recursively), as paths relative to it prefixed by `prefix`.
fn list_files(dir: &Path, prefix: &Path, out: &mut Vec<std::path::PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let rel = prefix.join(entry.file_name());
        if entry.file_type()?.is_dir() {
            list_files(&entry.path(), &rel, out)?;
        } else {
            out.push(rel);
        }
    }
    Ok(())
}
