//! Wavefront OBJ reading and writing.
//!
//! Written by hand rather than with `tobj`: `tobj` splits vertices per distinct `v/vt/vn`
//! combination (which breaks the topology we need), reports no line numbers, and reads f32
//! unless a feature is set. This reader keeps `v` indices as they are, parses f64, resolves
//! negative (relative) indices, fan-triangulates polygons, ignores `vt`/`vn`/groups/materials,
//! and names the line of every error. Unknown keywords are errors (so text garbage is reported
//! as such rather than read as an empty mesh).

use crate::Vec3;
use crate::error::MeshError;
use crate::soup::TriSoup;
use std::io::Write;

/// Keywords of the OBJ specification (and common extensions) that carry no surface data here.
const IGNORED: &[&str] = &[
    "vt",
    "vn",
    "vp",
    "g",
    "o",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "l",
    "p",
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
    "lod",
    "ctech",
    "stech",
    "bevel",
    "c_interp",
    "d_interp",
    "shadow_obj",
    "trace_obj",
    "maplib",
    "usemap",
    "call",
    "csh",
];

/// Parse OBJ text. `name` is used in error messages.
pub fn read_obj(bytes: &[u8], name: &str) -> Result<TriSoup, MeshError> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MeshError::EmptyFile { path: name.into() });
    }
    let malformed =
        |line: usize, message: String| MeshError::Malformed { path: name.into(), line: Some(line), message };
    let mut soup = TriSoup::default();
    // (polygon corners as written, line) resolved after all vertices are known, so that
    // positive indices may refer forward as some exporters do.
    let mut pending: Vec<(usize, Vec<i64>)> = Vec::new();
    let mut corners_scratch: Vec<i64> = Vec::new();
    let mut logical = String::new();
    let mut start_line = 0;
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_no = i + 1;
        let text = std::str::from_utf8(raw)
            .map_err(|_| malformed(line_no, "not text (invalid UTF-8): is this really an OBJ file?".into()))?;
        let text = text.strip_suffix('\r').unwrap_or(text);
        if logical.is_empty() {
            start_line = line_no;
        }
        if let Some(cont) = text.strip_suffix('\\') {
            logical.push_str(cont);
            logical.push(' ');
            continue;
        }
        logical.push_str(text);
        let line = logical.split('#').next().unwrap_or("");
        let mut tok = line.split_ascii_whitespace();
        match tok.next() {
            None => {}
            Some("v") => {
                let mut c = [0.0f64; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let t = tok
                        .next()
                        .ok_or_else(|| malformed(start_line, format!("vertex needs 3 coordinates, found {k}")))?;
                    *slot = t.parse().map_err(|_| malformed(start_line, format!("bad vertex coordinate {t:?}")))?;
                }
                soup.positions.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") | Some("fo") => {
                corners_scratch.clear();
                for t in tok {
                    let first = t.split('/').next().unwrap_or("");
                    let idx: i64 = first.parse().map_err(|_| malformed(start_line, format!("bad face index {t:?}")))?;
                    if idx == 0 {
                        return Err(malformed(start_line, "face index 0 (OBJ indices start at 1)".into()));
                    }
                    // Negative indices are relative to the vertices read so far.
                    let abs = if idx < 0 { soup.positions.len() as i64 + idx } else { idx - 1 };
                    if idx < 0 && abs < 0 {
                        return Err(MeshError::IndexOutOfRange {
                            path: name.into(),
                            line: Some(start_line),
                            face: pending.len(),
                            index: idx,
                            vertices: soup.positions.len(),
                            first_index: 1,
                        });
                    }
                    corners_scratch.push(abs);
                }
                if corners_scratch.len() < 3 {
                    return Err(malformed(
                        start_line,
                        format!("face has {} vertices; at least 3 are needed", corners_scratch.len()),
                    ));
                }
                pending.push((start_line, corners_scratch.clone()));
            }
            Some(k) if IGNORED.contains(&k) => {}
            Some(k) => {
                return Err(malformed(
                    start_line,
                    format!("unknown OBJ keyword {:?}: is this really an OBJ file?", truncate(k)),
                ));
            }
        }
        logical.clear();
    }
    let nv = soup.positions.len();
    let mut corners = Vec::new();
    for (face, (line, raw)) in pending.iter().enumerate() {
        corners.clear();
        for &abs in raw {
            if abs < 0 || abs as usize >= nv {
                return Err(MeshError::IndexOutOfRange {
                    path: name.into(),
                    line: Some(*line),
                    face,
                    index: abs + 1,
                    vertices: nv,
                    first_index: 1,
                });
            }
            corners.push(abs as u32);
        }
        soup.push_polygon(&corners);
    }
    Ok(soup)
}

fn truncate(s: &str) -> String {
    s.chars().take(24).collect()
}

/// Per-corner texture coordinates for [`write_obj`]: a list of `vt` values and, per face, the
/// `vt` index of each corner.
pub struct ObjUvs<'a> {
    /// Texture coordinates.
    pub uvs: &'a [[f64; 2]],
    /// For each face, the indices into `uvs` of its three corners.
    pub face_uvs: &'a [[u32; 3]],
}

/// Write an OBJ: `v`, optional `vt`, faces `f v/vt` (1-based), grouped with `g name` when
/// `groups` is given (each group lists its faces; faces in no group are written first).
pub fn write_obj(
    w: &mut impl Write,
    header: &str,
    positions: &[Vec3],
    faces: &[[u32; 3]],
    uvs: Option<ObjUvs<'_>>,
    groups: Option<&[(String, Vec<u32>)]>,
) -> std::io::Result<()> {
    for l in header.lines() {
        writeln!(w, "# {l}")?;
    }
    for p in positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    if let Some(u) = &uvs {
        for t in u.uvs {
            writeln!(w, "vt {} {}", t[0], t[1])?;
        }
    }
    let write_face = |w: &mut dyn Write, f: usize| -> std::io::Result<()> {
        let t = faces[f];
        match &uvs {
            Some(u) => {
                let q = u.face_uvs[f];
                writeln!(w, "f {}/{} {}/{} {}/{}", t[0] + 1, q[0] + 1, t[1] + 1, q[1] + 1, t[2] + 1, q[2] + 1)
            }
            None => writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1),
        }
    };
    match groups {
        None => {
            for f in 0..faces.len() {
                write_face(w, f)?;
            }
        }
        Some(gs) => {
            let mut grouped = vec![false; faces.len()];
            for (_, fs) in gs {
                for &f in fs {
                    grouped[f as usize] = true;
                }
            }
            for f in 0..faces.len() {
                if !grouped[f] {
                    write_face(w, f)?;
                }
            }
            for (name, fs) in gs {
                writeln!(w, "g {name}")?;
                for &f in fs {
                    write_face(w, f as usize)?;
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygons_negative_indices_and_ignored_records() {
        let text = b"# comment\nmtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\ng quad\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -4 -2 -1\n";
        let s = read_obj(text, "t.obj").unwrap();
        assert_eq!(s.positions.len(), 4);
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
        assert_eq!(s.source_polygons, 2);
    }

    #[test]
    fn errors_name_the_line() {
        let e = read_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("t.obj:4"), "{e}");
        assert!(matches!(e, MeshError::IndexOutOfRange { index: 7, vertices: 3, .. }));
        let e = read_obj(b"v 0 0\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("t.obj:1: vertex needs 3 coordinates"), "{e}");
        let e = read_obj(b"hello world\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("unknown OBJ keyword"), "{e}");
        assert!(matches!(read_obj(b"  \n", "t.obj"), Err(MeshError::EmptyFile { .. })));
        let e = read_obj(b"v 0 0 0\nf 1 1\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("at least 3"), "{e}");
    }

    #[test]
    fn nan_is_read_and_left_to_validation() {
        let s = read_obj(b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").unwrap();
        assert!(s.positions[0].x.is_nan());
    }

    #[test]
    fn write_read_round_trip() {
        let p = vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 1e-17)];
        let mut buf = Vec::new();
        let uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        write_obj(
            &mut buf,
            "test",
            &p,
            &[[0, 1, 2]],
            Some(ObjUvs { uvs: &uv, face_uvs: &[[0, 1, 2]] }),
            Some(&[("patch_0".to_string(), vec![0])]),
        )
        .unwrap();
        let text = String::from_utf8(buf.clone()).unwrap();
        assert!(text.contains("g patch_0\nf 1/1 2/2 3/3"));
        let s = read_obj(&buf, "rt.obj").unwrap();
        assert_eq!(s.positions, p);
    }
}
