//! PLY reading (with `ply-rs-bw`: ASCII, binary little and big endian, typed parsing) and
//! writing with custom per-vertex and per-face properties.
//!
//! The writer is hand-written: it streams straight from slices (the crate's writer needs every
//! element as a hash map first, ~10× slower and much larger in memory). Output follows the
//! layout trimesh, MeshLab and Blender read: `vertex` with `double x, y, z` then the custom
//! properties, `face` with `list uchar int vertex_indices` then the custom properties.

use crate::Vec3;
use crate::error::MeshError;
use crate::soup::TriSoup;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Header, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType};
use std::collections::BTreeMap;
use std::io::Write;

/// Values of one custom property.
#[derive(Clone, Debug, PartialEq)]
pub enum AttributeValues {
    /// Written as `double`.
    F64(Vec<f64>),
    /// Written as `float`.
    F32(Vec<f32>),
    /// Written as `int`.
    I32(Vec<i32>),
    /// Written as `uchar`.
    U8(Vec<u8>),
}

impl AttributeValues {
    fn len(&self) -> usize {
        match self {
            Self::F64(v) => v.len(),
            Self::F32(v) => v.len(),
            Self::I32(v) => v.len(),
            Self::U8(v) => v.len(),
        }
    }
    fn ply_type(&self) -> &'static str {
        match self {
            Self::F64(_) => "double",
            Self::F32(_) => "float",
            Self::I32(_) => "int",
            Self::U8(_) => "uchar",
        }
    }
}

/// A named per-element property.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    /// Property name (letters, digits, `_`).
    pub name: String,
    /// One value per element.
    pub values: AttributeValues,
}

impl Attribute {
    /// A `double` property.
    pub fn f64(name: &str, values: Vec<f64>) -> Self {
        Self { name: name.into(), values: AttributeValues::F64(values) }
    }
    /// An `int` property.
    pub fn i32(name: &str, values: Vec<i32>) -> Self {
        Self { name: name.into(), values: AttributeValues::I32(values) }
    }
    /// A `uchar` property.
    pub fn u8(name: &str, values: Vec<u8>) -> Self {
        Self { name: name.into(), values: AttributeValues::U8(values) }
    }
    /// Three `double` properties `name_x`, `name_y`, `name_z` from vectors.
    pub fn vec3(name: &str, values: &[Vec3]) -> [Self; 3] {
        ["x", "y", "z"].map(|c| {
            let i = match c {
                "x" => 0,
                "y" => 1,
                _ => 2,
            };
            Self::f64(&format!("{name}_{c}"), values.iter().map(|v| v[i]).collect())
        })
    }
}

/// PLY encoding for [`write_ply`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlyFormat {
    /// Human-readable.
    Ascii,
    /// Compact (the default for outputs).
    BinaryLittleEndian,
}

/// Write a triangle mesh with custom properties.
///
/// # Panics
/// If an attribute has the wrong length or an invalid name (a programming error).
#[track_caller]
pub fn write_ply(
    w: &mut impl Write,
    format: PlyFormat,
    comment: &str,
    positions: &[Vec3],
    faces: &[[u32; 3]],
    vertex_attributes: &[Attribute],
    face_attributes: &[Attribute],
) -> std::io::Result<()> {
    for a in vertex_attributes {
        assert_eq!(a.values.len(), positions.len(), "vertex attribute {} has the wrong length", a.name);
    }
    for a in face_attributes {
        assert_eq!(a.values.len(), faces.len(), "face attribute {} has the wrong length", a.name);
    }
    for a in vertex_attributes.iter().chain(face_attributes) {
        assert!(
            !a.name.is_empty() && a.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'),
            "invalid PLY property name {:?}",
            a.name
        );
    }
    writeln!(w, "ply")?;
    writeln!(w, "format {} 1.0", if format == PlyFormat::Ascii { "ascii" } else { "binary_little_endian" })?;
    for l in comment.lines() {
        writeln!(w, "comment {l}")?;
    }
    writeln!(w, "element vertex {}", positions.len())?;
    for c in ["x", "y", "z"] {
        writeln!(w, "property double {c}")?;
    }
    for a in vertex_attributes {
        writeln!(w, "property {} {}", a.values.ply_type(), a.name)?;
    }
    writeln!(w, "element face {}", faces.len())?;
    writeln!(w, "property list uchar int vertex_indices")?;
    for a in face_attributes {
        writeln!(w, "property {} {}", a.values.ply_type(), a.name)?;
    }
    writeln!(w, "end_header")?;
    let put = |w: &mut dyn Write, v: &AttributeValues, i: usize| -> std::io::Result<()> {
        match format {
            PlyFormat::Ascii => match v {
                AttributeValues::F64(x) => write!(w, " {}", x[i]),
                AttributeValues::F32(x) => write!(w, " {}", x[i]),
                AttributeValues::I32(x) => write!(w, " {}", x[i]),
                AttributeValues::U8(x) => write!(w, " {}", x[i]),
            },
            PlyFormat::BinaryLittleEndian => match v {
                AttributeValues::F64(x) => w.write_all(&x[i].to_le_bytes()),
                AttributeValues::F32(x) => w.write_all(&x[i].to_le_bytes()),
                AttributeValues::I32(x) => w.write_all(&x[i].to_le_bytes()),
                AttributeValues::U8(x) => w.write_all(&[x[i]]),
            },
        }
    };
    for (i, p) in positions.iter().enumerate() {
        match format {
            PlyFormat::Ascii => write!(w, "{} {} {}", p.x, p.y, p.z)?,
            PlyFormat::BinaryLittleEndian => {
                for c in [p.x, p.y, p.z] {
                    w.write_all(&c.to_le_bytes())?;
                }
            }
        }
        for a in vertex_attributes {
            put(w, &a.values, i)?;
        }
        if format == PlyFormat::Ascii {
            writeln!(w)?;
        }
    }
    for (i, t) in faces.iter().enumerate() {
        match format {
            PlyFormat::Ascii => write!(w, "3 {} {} {}", t[0], t[1], t[2])?,
            PlyFormat::BinaryLittleEndian => {
                w.write_all(&[3u8])?;
                for c in t {
                    w.write_all(&(*c as i32).to_le_bytes())?;
                }
            }
        }
        for a in face_attributes {
            put(w, &a.values, i)?;
        }
        if format == PlyFormat::Ascii {
            writeln!(w)?;
        }
    }
    Ok(())
}

// ---- reading ------------------------------------------------------------------------------

/// A scalar property's value as f64 (`None` for lists).
fn scalar(property: ply_rs_bw::ply::Property) -> Option<f64> {
    use ply_rs_bw::ply::Property as P;
    Some(match property {
        P::Char(x) => x as f64,
        P::UChar(x) => x as f64,
        P::Short(x) => x as f64,
        P::UShort(x) => x as f64,
        P::Int(x) => x as f64,
        P::UInt(x) => x as f64,
        P::Float(x) => x as f64,
        P::Double(x) => x,
        _ => return None,
    })
}

#[derive(Default)]
struct PlyVertex([f64; 3]);

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: ply_rs_bw::ply::Property) -> PropertyAccessResult {
        let Some(v) = scalar(property) else {
            return PropertyAccessResult::Ignored;
        };
        self.set(name, v)
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
    fn set_double(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        self.set(name, v)
    }
}

impl PlyVertex {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        match name {
            "x" => self.0[0] = v,
            "y" => self.0[1] = v,
            "z" => self.0[2] = v,
            _ => return PropertyAccessResult::Ignored,
        }
        PropertyAccessResult::Set
    }
}

#[derive(Default)]
struct PlyFace(Vec<i64>);

macro_rules! face_list {
    ($fn:ident, $t:ty) => {
        fn $fn(&mut self, name: &str, v: Vec<$t>) -> PropertyAccessResult {
            if name == "vertex_indices" || name == "vertex_index" {
                self.0 = v.into_iter().map(|x| x as i64).collect();
                PropertyAccessResult::Set
            } else {
                PropertyAccessResult::Ignored
            }
        }
    };
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }
    face_list!(set_list_char, i8);
    face_list!(set_list_uchar, u8);
    face_list!(set_list_short, i16);
    face_list!(set_list_ushort, u16);
    face_list!(set_list_int, i32);
    face_list!(set_list_uint, u32);
}

/// An element we skip (its data is parsed and dropped).
struct Skip;
impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// Every scalar property of an element, by name (for reading outputs back).
#[derive(Default)]
struct AnyElement(Vec<(String, f64)>);
impl PropertyAccess for AnyElement {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: ply_rs_bw::ply::Property) -> PropertyAccessResult {
        let Some(v) = scalar(property) else {
            return PropertyAccessResult::Ignored;
        };
        self.0.push((name.to_string(), v));
        PropertyAccessResult::Set
    }
}

fn ply_err(name: &str, e: ply_rs_bw::parser::ParseError) -> MeshError {
    use std::io::ErrorKind;
    let message = tidy_message(&e.to_string().replace("\n\t", " "));
    match e.kind() {
        ErrorKind::UnexpectedEof => MeshError::Truncated { path: name.into(), message },
        _ => MeshError::Malformed { path: name.into(), line: e.line(), message },
    }
}

/// ply-rs reports a header line it cannot parse as "Line N: Couldn't parse line. String:
/// '<line>' Error: ParseError { <the grammar's expected set> }": the line itself, quoted, is what
/// helps (the line number is reported apart).
fn tidy_message(message: &str) -> String {
    const MARK: &str = "Couldn't parse line. String: '";
    match message.find(MARK) {
        Some(start) => {
            let line = message[start + MARK.len()..].split('\'').next().unwrap_or("").trim();
            format!(
                "cannot parse the header line `{line}` (an unknown keyword or property type? types are char, uchar, \
                 short, ushort, int, uint, float, double and their sized names such as int32, float64)"
            )
        }
        None => message.to_string(),
    }
}

fn read_header<'a>(bytes: &'a [u8], name: &str) -> Result<(Reader<&'a [u8]>, Header), MeshError> {
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MeshError::EmptyFile { path: name.into() });
    }
    if !bytes.starts_with(b"ply") {
        return Err(MeshError::Malformed {
            path: name.into(),
            line: Some(1),
            message: "missing the `ply` magic line".into(),
        });
    }
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| ply_err(name, e))?;
    Ok((reader, header))
}

/// An ASCII PLY line holding more values than its element's properties: refused with its line
/// (`ply-rs-bw` reads the values it expects from each line and drops the rest, so a face
/// `3 0 2 1 5 5` or a vertex with a fourth coordinate would pass unseen). Lines it cannot
/// count (a list length that is not a number) are left to the parser, which names them.
fn check_ascii_lines(bytes: &[u8], header: &Header, name: &str) -> Result<(), MeshError> {
    // The body starts after the line `end_header`.
    let (mut start, mut first_line) = (0, 1);
    loop {
        let Some(k) = bytes[start..].iter().position(|&b| b == b'\n') else { return Ok(()) };
        let line = &bytes[start..start + k];
        start += k + 1;
        first_line += 1;
        if line.trim_ascii() == b"end_header" {
            break;
        }
    }
    let body_start = start;
    let text = String::from_utf8_lossy(&bytes[body_start..]);
    let mut lines = text.lines().enumerate().map(|(i, l)| (first_line + i, l)).filter(|(_, l)| !l.trim().is_empty());
    for (key, def) in &header.elements {
        for i in 0..def.count {
            let Some((line, l)) = lines.next() else { return Ok(()) };
            let tokens: Vec<&str> = l.split_ascii_whitespace().collect();
            let mut used = 0;
            for prop in def.properties.values() {
                match prop.data_type {
                    PropertyType::Scalar(_) => used += 1,
                    PropertyType::List(..) => {
                        let Some(n) = tokens.get(used).and_then(|t| t.parse::<usize>().ok()) else { return Ok(()) };
                        if n >= tokens.len() {
                            // More than the line holds: the parser names it.
                            return Ok(());
                        }
                        used += 1 + n;
                    }
                }
            }
            if tokens.len() > used {
                return Err(MeshError::Malformed {
                    path: name.into(),
                    line: Some(line),
                    message: format!(
                        "{key} {i} has {} values where its properties hold {used}: are the header's counts and properties right?",
                        tokens.len()
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Parse a PLY file (ASCII, binary little or big endian): `vertex` x, y, z (any numeric type)
/// and `face` `vertex_indices`/`vertex_index` lists; other elements and properties are skipped.
pub fn read_ply(bytes: &[u8], name: &str) -> Result<TriSoup, MeshError> {
    let (mut reader, header) = read_header(bytes, name)?;
    if header.encoding == ply_rs_bw::ply::Encoding::Ascii {
        check_ascii_lines(bytes, &header, name)?;
    }
    let mut soup = TriSoup::default();
    let mut polygons: Vec<Vec<i64>> = Vec::new();
    let mut has_vertex = false;
    for (key, def) in &header.elements {
        match key.as_str() {
            "vertex" => {
                for c in ["x", "y", "z"] {
                    if !def.properties.contains_key(c) {
                        return Err(MeshError::Malformed {
                            path: name.into(),
                            line: None,
                            message: format!("vertex element has no `{c}` property"),
                        });
                    }
                }
                has_vertex = true;
                let vs = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| ply_err(name, e))?;
                soup.positions = vs.into_iter().map(|v| Vec3::new(v.0[0], v.0[1], v.0[2])).collect();
            }
            "face" => {
                if !def.properties.contains_key("vertex_indices") && !def.properties.contains_key("vertex_index") {
                    return Err(MeshError::Malformed {
                        path: name.into(),
                        line: None,
                        message: "face element has no `vertex_indices` list".into(),
                    });
                }
                // The indices must be a list of integers (a list of floats would be read as
                // empty faces, and reported as faces of 0 vertices).
                let key = if def.properties.contains_key("vertex_indices") { "vertex_indices" } else { "vertex_index" };
                if let Some(prop) = def.properties.get(key)
                    && !matches!(
                        prop.data_type,
                        PropertyType::List(
                            _,
                            ScalarType::Char
                                | ScalarType::UChar
                                | ScalarType::Short
                                | ScalarType::UShort
                                | ScalarType::Int
                                | ScalarType::UInt
                        )
                    )
                {
                    return Err(MeshError::Malformed {
                        path: name.into(),
                        line: None,
                        message: format!(
                            "face `{key}` is declared as {:?}: vertex indices must be a list of integers",
                            prop.data_type
                        ),
                    });
                }
                polygons = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| ply_err(name, e))?
                    .into_iter()
                    .map(|f| f.0)
                    .collect();
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| ply_err(name, e))?;
            }
        }
    }
    if !has_vertex {
        return Err(MeshError::Malformed { path: name.into(), line: None, message: "no `vertex` element".into() });
    }
    let counts = || header.elements.iter().map(|(k, d)| format!("{} {k}", d.count)).collect::<Vec<_>>().join(", ");
    let rest: &[u8] = reader.get_ref();
    // (Whitespace or NUL padding after the data is tolerated.)
    if rest.iter().any(|&b| !b.is_ascii_whitespace() && b != 0) {
        return Err(MeshError::Malformed {
            path: name.into(),
            line: None,
            message: format!(
                "{} bytes of data after the elements the header announces ({}): are its counts right?",
                rest.len(),
                counts()
            ),
        });
    }
    let nv = soup.positions.len();
    let mut corners = Vec::new();
    for (f, poly) in polygons.iter().enumerate() {
        if poly.len() < 3 {
            return Err(MeshError::Malformed {
                path: name.into(),
                line: None,
                message: format!(
                    "face {f} has {} vertices; at least 3 are needed (the header announces {}: are its counts right?)",
                    poly.len(),
                    counts()
                ),
            });
        }
        corners.clear();
        for &i in poly {
            if i < 0 || i as usize >= nv {
                return Err(MeshError::IndexOutOfRange {
                    path: name.into(),
                    line: None,
                    face: f,
                    index: i,
                    vertices: nv,
                    first_index: 0,
                });
            }
            corners.push(i as u32);
        }
        soup.push_polygon(&corners);
    }
    Ok(soup)
}

/// Custom scalar properties of a PLY file, per element name then property name (x/y/z and
/// list properties excluded). Used to read outputs back in tests and tools.
pub fn read_ply_properties(
    bytes: &[u8],
    name: &str,
) -> Result<BTreeMap<String, BTreeMap<String, Vec<f64>>>, MeshError> {
    let (mut reader, header) = read_header(bytes, name)?;
    let mut out = BTreeMap::new();
    for (key, def) in &header.elements {
        let elems = Parser::<AnyElement>::new()
            .read_payload_for_element(&mut reader, def, &header)
            .map_err(|e| ply_err(name, e))?;
        let mut props: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        for e in elems {
            for (k, v) in e.0 {
                if !matches!(k.as_str(), "x" | "y" | "z") {
                    props.entry(k).or_default().push(v);
                }
            }
        }
        out.insert(key.clone(), props);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        (
            vec![Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.25), Vec3::new(0., 1., 0.)],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn round_trip_both_formats_with_properties() {
        let (p, f) = square();
        for fmt in [PlyFormat::Ascii, PlyFormat::BinaryLittleEndian] {
            let mut buf = Vec::new();
            write_ply(
                &mut buf,
                fmt,
                "test",
                &p,
                &f,
                &[Attribute::f64("displacement", vec![0.0, 0.5, 1.0, 1.5])],
                &[Attribute::i32("patch", vec![3, 7]), Attribute::u8("anisotropic", vec![1, 0])],
            )
            .unwrap();
            let s = read_ply(&buf, "t.ply").unwrap();
            assert_eq!(s.positions, p);
            assert_eq!(s.triangles, f);
            let props = read_ply_properties(&buf, "t.ply").unwrap();
            assert_eq!(props["vertex"]["displacement"], vec![0.0, 0.5, 1.0, 1.5]);
            assert_eq!(props["face"]["patch"], vec![3.0, 7.0]);
            assert_eq!(props["face"]["anisotropic"], vec![1.0, 0.0]);
        }
    }

    #[test]
    fn data_beyond_the_header_counts_is_refused() {
        let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n";
        // Four vertices under a count of two: the last two are read as the face and a surplus.
        let text = format!("{head}0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n");
        let e = read_ply(text.as_bytes(), "c.ply").unwrap_err().to_string();
        assert!(e.contains("c.ply:12") && e.contains("face 0 has 3 values") && e.contains("counts"), "{e}");
        // Binary, or the surplus on lines of the right length: the bytes left over are named.
        let text = format!("{}0 0 0\n1 0 0\n3 0 1 0\n3 0 1 0\n", head);
        let e = read_ply(text.as_bytes(), "c.ply").unwrap_err().to_string();
        assert!(e.contains("2 vertex, 1 face") && e.contains("counts right"), "{e}");
        // A face with two values too many, on line 12.
        let text = format!("{}0 0 0\n1 0 0\n0 1 0\n3 0 1 2 5 5\n", head.replace("vertex 2", "vertex 3"));
        let e = read_ply(text.as_bytes(), "x.ply").unwrap_err().to_string();
        assert!(e.contains("x.ply:13") && e.contains("face 0 has 6 values where its properties hold 4"), "{e}");
        // Trailing blank lines are fine.
        let ok = format!("{}\n\n", head.replace("vertex 2", "vertex 3") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2");
        assert_eq!(read_ply(ok.as_bytes(), "c.ply").unwrap().triangles.len(), 1);
    }

    #[test]
    fn big_endian_and_errors() {
        let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
        for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
            for c in v {
                b.extend(c.to_be_bytes());
            }
        }
        b.push(3);
        for i in [0u32, 1, 2] {
            b.extend(i.to_be_bytes());
        }
        let s = read_ply(&b, "be.ply").unwrap();
        assert_eq!(s.positions[1], Vec3::new(1., 0., 0.));
        assert_eq!(s.triangles, vec![[0, 1, 2]]);
        let e = read_ply(&b[..b.len() - 3], "be.ply").unwrap_err();
        assert!(matches!(e, MeshError::Truncated { .. }), "{e}");
        let mut bad = b.clone();
        let n = bad.len();
        bad[n - 4..].copy_from_slice(&9u32.to_be_bytes());
        let e = read_ply(&bad, "be.ply").unwrap_err();
        assert!(matches!(e, MeshError::IndexOutOfRange { index: 9, .. }), "{e}");
        assert!(read_ply(b"plyx\ngarbage", "g.ply").is_err());
        // Face indices declared as floats: named as such, not read as faces of 0 vertices.
        let floats = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
            element face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let e = read_ply(floats, "f.ply").unwrap_err().to_string();
        assert!(e.contains("must be a list of integers"), "{e}");
    }
}
