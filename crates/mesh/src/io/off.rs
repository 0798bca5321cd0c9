//! OFF reading.
//!
//! Written by hand: `off-rs` reads positions as f32 only. Supports the header keywords OFF,
//! COFF, NOFF, CNOFF, STOFF (extra per-vertex values are ignored), counts on the header line or
//! the next one, `#` comments, polygons (fan-triangulated) with optional trailing colours.
//! Binary OFF is refused with a clear message.

use crate::Vec3;
use crate::error::MeshError;
use crate::soup::TriSoup;

/// Parse OFF text. `name` is used in error messages.
pub fn read_off(bytes: &[u8], name: &str) -> Result<TriSoup, MeshError> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MeshError::EmptyFile { path: name.into() });
    }
    let malformed =
        |line: usize, message: String| MeshError::Malformed { path: name.into(), line: Some(line), message };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        malformed(line, "not text (invalid UTF-8): binary OFF is not supported".into())
    })?;
    // Non-empty lines with comments stripped, with their 1-based numbers.
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());

    let (hl, header) = lines.next().ok_or_else(|| MeshError::EmptyFile { path: name.into() })?;
    let mut htok = header.split_ascii_whitespace();
    let kw = htok.next().unwrap_or("");
    let valid_kw = kw.ends_with("OFF") && kw[..kw.len() - 3].chars().all(|c| "STCN4n".contains(c));
    if !valid_kw {
        return Err(malformed(
            hl,
            format!("expected an OFF header, found {:?}", kw.chars().take(24).collect::<String>()),
        ));
    }
    if kw.contains('4') || kw.contains('n') {
        return Err(malformed(hl, format!("{kw}: only 3D OFF files are supported")));
    }
    let rest: Vec<&str> = htok.collect();
    if rest.first() == Some(&"BINARY") {
        return Err(malformed(hl, "binary OFF is not supported".into()));
    }
    let (cl, counts): (usize, Vec<&str>) = if rest.len() >= 2 {
        (hl, rest)
    } else {
        let (l, t) = lines.next().ok_or_else(|| MeshError::Truncated {
            path: name.into(),
            message: "missing the vertex/face counts".into(),
        })?;
        (l, t.split_ascii_whitespace().collect())
    };
    let parse_count = |s: Option<&&str>, what: &str| -> Result<usize, MeshError> {
        let s = s.ok_or_else(|| malformed(cl, format!("missing {what} count")))?;
        s.parse().map_err(|_| malformed(cl, format!("bad {what} count {s:?}")))
    };
    let nv = parse_count(counts.first(), "vertex")?;
    let nf = parse_count(counts.get(1), "face")?;

    let mut soup = TriSoup::default();
    soup.positions.reserve(nv.min(1 << 24));
    for i in 0..nv {
        let (l, t) = lines.next().ok_or_else(|| MeshError::Truncated {
            path: name.into(),
            message: format!("the header announces {nv} vertices, the file ends after {i}"),
        })?;
        let mut tok = t.split_ascii_whitespace();
        let mut c = [0.0f64; 3];
        for (k, slot) in c.iter_mut().enumerate() {
            let s = tok.next().ok_or_else(|| malformed(l, format!("vertex {i} needs 3 coordinates, found {k}")))?;
            *slot = s.parse().map_err(|_| malformed(l, format!("bad coordinate {s:?} of vertex {i}")))?;
        }
        soup.positions.push(Vec3::new(c[0], c[1], c[2]));
    }
    let mut corners = Vec::new();
    for f in 0..nf {
        let (l, t) = lines.next().ok_or_else(|| MeshError::Truncated {
            path: name.into(),
            message: format!("the header announces {nf} faces, the file ends after {f}"),
        })?;
        let mut tok = t.split_ascii_whitespace();
        let n: usize = tok
            .next()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| malformed(l, format!("face {f} must start with its vertex count")))?;
        if n < 3 {
            return Err(malformed(l, format!("face {f} has {n} vertices; at least 3 are needed")));
        }
        corners.clear();
        for k in 0..n {
            let s = tok.next().ok_or_else(|| malformed(l, format!("face {f} announces {n} vertices but lists {k}")))?;
            let idx: i64 = s.parse().map_err(|_| malformed(l, format!("bad index {s:?} in face {f}")))?;
            if idx < 0 || idx as usize >= nv {
                return Err(MeshError::IndexOutOfRange {
                    path: name.into(),
                    line: Some(l),
                    face: f,
                    index: idx,
                    vertices: nv,
                    first_index: 0,
                });
            }
            corners.push(idx as u32);
        }
        soup.push_polygon(&corners);
    }
    if let Some((l, _)) = lines.next() {
        return Err(malformed(
            l,
            format!(
                "data after the {nv} vertices and {nf} faces the header announces (are the header's counts right?)"
            ),
        ));
    }
    Ok(soup)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_faces_beyond_the_header_count() {
        let txt = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n";
        let e = read_off(txt.as_bytes(), "x.off").unwrap_err().to_string();
        assert!(e.contains("x.off") && e.contains("x.off:7") && e.contains("1 faces the header announces"), "{e}");
    }

    #[test]
    fn reads_polygons_and_counts_on_header_line() {
        let s = read_off(b"OFF 4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0 # c\n4 0 1 2 3 255 0 0\n", "q.off").unwrap();
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        let s = read_off(b"COFF\n# comment\n3 1 3\n0 0 0 1 1 1 1\n1 0 0 1 1 1 1\n0 1 0 1 1 1 1\n3 0 1 2\n", "t.off")
            .unwrap();
        assert_eq!(s.positions.len(), 3);
    }

    #[test]
    fn errors() {
        let e = read_off(b"OFF\n3 1 0\n0 0 0\n1 0 0\n", "t.off").unwrap_err();
        assert!(matches!(e, MeshError::Truncated { .. }), "{e}");
        let e = read_off(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "t.off").unwrap_err();
        assert!(e.to_string().contains("t.off:6: face 0 refers to vertex 3"), "{e}");
        let e = read_off(b"PLY\n", "t.off").unwrap_err();
        assert!(e.to_string().contains("expected an OFF header"), "{e}");
    }
}
