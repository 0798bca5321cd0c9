//! STL reading (binary and ASCII).
//!
//! Written by hand rather than with `stl_io`: `stl_io` decides "ASCII" whenever the file starts
//! with `solid `, which many binary exporters also write into the 80-byte header, and its errors
//! carry no line numbers. Here a file is binary when its size matches the triangle count in the
//! header (84 + 50·n bytes), ASCII otherwise. Identical corner positions are welded (bitwise
//! equal f32 triples), as STL stores no connectivity.

use crate::Vec3;
use crate::error::MeshError;
use crate::soup::TriSoup;
use std::collections::HashMap;

/// Parse an STL file. `name` is used in error messages.
pub fn read_stl(bytes: &[u8], name: &str) -> Result<TriSoup, MeshError> {
    if bytes.is_empty() || bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MeshError::EmptyFile { path: name.into() });
    }
    let binary_count =
        (bytes.len() >= 84).then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize);
    // ASCII STL starts with `solid` and is text; binary files may also start with `solid` in
    // their header, but their triangle data soon contains non-text bytes.
    let is_text = bytes.iter().take(1024).all(|&b| b.is_ascii_graphic() || b.is_ascii_whitespace());
    let looks_ascii = is_text
        && bytes.iter().position(|b| !b.is_ascii_whitespace()).is_some_and(|i| bytes[i..].starts_with(b"solid"));
    match binary_count {
        Some(n) if 84 + 50 * n as u128 == bytes.len() as u128 => read_binary(bytes, n),
        _ if looks_ascii => read_ascii(bytes, name),
        Some(n) if (bytes.len() as u128) < 84 + 50 * n as u128 => Err(MeshError::Truncated {
            path: name.into(),
            message: format!(
                "binary STL header announces {n} triangles ({} bytes), the file has {} bytes",
                84 + 50 * n as u128,
                bytes.len()
            ),
        }),
        Some(n) if bytes.len() - (84 + 50 * n) >= 50 => Err(MeshError::Malformed {
            path: name.into(),
            line: None,
            message: format!(
                "binary STL header announces {n} triangles ({} bytes), but the file has {} bytes: room for {} \
                 more triangles the header does not count (is its count wrong?)",
                84 + 50 * n,
                bytes.len(),
                (bytes.len() - 84 - 50 * n) / 50
            ),
        }),
        Some(n) => {
            // Fewer trailing bytes than a triangle's after the announced ones: tolerated (some
            // exporters pad).
            read_binary(&bytes[..84 + 50 * n], n)
        }
        None => Err(MeshError::Truncated {
            path: name.into(),
            message: format!("{} bytes is shorter than a binary STL header (84 bytes) and not ASCII STL", bytes.len()),
        }),
    }
}

struct Welder {
    index: HashMap<[u32; 3], u32>,
    soup: TriSoup,
}

impl Welder {
    fn new() -> Self {
        Self { index: HashMap::new(), soup: TriSoup::default() }
    }
    fn vertex(&mut self, p: [f32; 3]) -> u32 {
        let key = p.map(f32::to_bits);
        let next = self.soup.positions.len() as u32;
        let id = *self.index.entry(key).or_insert(next);
        if id == next {
            self.soup.positions.push(Vec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
        }
        id
    }
}

fn read_binary(bytes: &[u8], n: usize) -> Result<TriSoup, MeshError> {
    let mut w = Welder::new();
    let f = |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    for t in 0..n {
        let base = 84 + 50 * t + 12; // skip the normal
        let c: [u32; 3] = [0, 1, 2].map(|k| {
            let o = base + 12 * k;
            w.vertex([f(o), f(o + 4), f(o + 8)])
        });
        w.soup.push_polygon(&c);
    }
    Ok(w.soup)
}

fn read_ascii(bytes: &[u8], name: &str) -> Result<TriSoup, MeshError> {
    let malformed =
        |line: usize, message: String| MeshError::Malformed { path: name.into(), line: Some(line), message };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        malformed(line, "not text (invalid UTF-8) and not a valid binary STL".into())
    })?;
    let mut w = Welder::new();
    let mut corners: Vec<u32> = Vec::with_capacity(3);
    let mut in_facet = false;
    let mut facet_line = 0;
    let mut ended = false;
    for (i, line) in text.lines().enumerate() {
        let l = i + 1;
        let mut tok = line.split_ascii_whitespace();
        match tok.next() {
            None => {}
            Some("solid") | Some("outer") | Some("endloop") => {}
            Some("endsolid") => ended = true,
            Some("facet") => {
                if in_facet {
                    return Err(malformed(l, "facet starts before the previous one ended".into()));
                }
                in_facet = true;
                facet_line = l;
                corners.clear();
            }
            Some("vertex") => {
                if !in_facet {
                    return Err(malformed(l, "vertex outside a facet".into()));
                }
                let mut c = [0.0f32; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let s = tok.next().ok_or_else(|| malformed(l, format!("vertex needs 3 coordinates, found {k}")))?;
                    *slot = s.parse().map_err(|_| malformed(l, format!("bad coordinate {s:?}")))?;
                }
                corners.push(w.vertex(c));
            }
            Some("endfacet") => {
                if corners.len() != 3 {
                    return Err(malformed(
                        facet_line,
                        format!("facet has {} vertices, STL facets have 3", corners.len()),
                    ));
                }
                w.soup.push_polygon(&corners);
                in_facet = false;
            }
            Some(k) => {
                return Err(malformed(
                    l,
                    format!("unexpected {:?} in ASCII STL", k.chars().take(24).collect::<String>()),
                ));
            }
        }
    }
    if in_facet || !ended {
        return Err(MeshError::Truncated {
            path: name.into(),
            message: if in_facet {
                format!("facet starting at line {facet_line} never ends")
            } else {
                "missing `endsolid`".into()
            },
        });
    }
    Ok(w.soup)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(tris: &[[[f32; 3]; 3]], header: &[u8]) -> Vec<u8> {
        let mut b = vec![b' '; 80];
        b[..header.len()].copy_from_slice(header);
        b.extend((tris.len() as u32).to_le_bytes());
        for t in tris {
            b.extend([0u8; 12]);
            for c in t {
                for x in c {
                    b.extend(x.to_le_bytes());
                }
            }
            b.extend([0u8; 2]);
        }
        b
    }

    #[test]
    fn binary_with_solid_header_and_welding() {
        let t = [[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]], [[1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]];
        let b = binary(&t, b"solid exported by a CAD tool");
        let s = read_stl(&b, "b.stl").unwrap();
        assert_eq!(s.positions.len(), 4);
        assert_eq!(s.triangles, vec![[0, 1, 2], [1, 3, 2]]);
        let e = read_stl(&b[..b.len() - 7], "b.stl").unwrap_err();
        assert!(matches!(e, MeshError::Truncated { .. }), "{e}");
    }

    #[test]
    fn binary_with_uncounted_triangles_is_refused() {
        let t = [[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]], [[1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]];
        let mut b = binary(&t, b"header");
        b[80..84].copy_from_slice(&1u32.to_le_bytes());
        let e = read_stl(&b, "b.stl").unwrap_err().to_string();
        assert!(e.contains("announces 1 triangles") && e.contains("room for 1 more"), "{e}");
        // A few bytes of padding stay tolerated.
        let mut p = binary(&t, b"header");
        p.extend([0u8; 10]);
        assert_eq!(read_stl(&p, "b.stl").unwrap().triangles.len(), 2);
    }

    #[test]
    fn ascii() {
        let txt = b"solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 0 1 0\n endloop\nendfacet\nendsolid t\n";
        let s = read_stl(txt, "a.stl").unwrap();
        assert_eq!(s.triangles.len(), 1);
        let e = read_stl(&txt[..txt.len() - 21], "a.stl").unwrap_err();
        assert!(matches!(e, MeshError::Truncated { .. }), "{e}");
        let e = read_stl(b"solid t\nfacet normal 0 0 1\nvertex 0 0\n", "a.stl").unwrap_err();
        assert!(e.to_string().contains("a.stl:3"), "{e}");
    }
}
