//! Mesh files: reading OBJ, PLY, STL and OFF into a [`TriSoup`]; writing OBJ and PLY with
//! custom properties; atomic file output.

pub mod obj;
pub mod off;
pub mod ply;
pub mod stl;

use crate::error::MeshError;
use crate::soup::TriSoup;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

pub use obj::{ObjUvs, read_obj, write_obj};
pub use off::read_off;
pub use ply::{Attribute, AttributeValues, PlyFormat, read_ply, read_ply_properties, write_ply};
pub use stl::read_stl;

/// A mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ.
    Obj,
    /// Stanford PLY.
    Ply,
    /// STL (binary or ASCII).
    Stl,
    /// Object File Format.
    Off,
}

impl MeshFormat {
    /// Format from a file extension (case-insensitive), if known.
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "obj" => Self::Obj,
            "ply" => Self::Ply,
            "stl" => Self::Stl,
            "off" => Self::Off,
            _ => return None,
        })
    }
}

/// Parse bytes in the given format; `name` appears in error messages.
pub fn read_mesh_bytes(bytes: &[u8], format: MeshFormat, name: &str) -> Result<TriSoup, MeshError> {
    match format {
        MeshFormat::Obj => read_obj(bytes, name),
        MeshFormat::Ply => read_ply(bytes, name),
        MeshFormat::Stl => read_stl(bytes, name),
        MeshFormat::Off => read_off(bytes, name),
    }
}

/// Read a mesh file, choosing the format from its extension.
pub fn read_mesh_file(path: &Path) -> Result<TriSoup, MeshError> {
    let name = path.display().to_string();
    let format = MeshFormat::from_path(path).ok_or_else(|| MeshError::UnknownFormat { path: name.clone() })?;
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io { path: path.to_path_buf(), error })?;
    if bytes.is_empty() {
        return Err(MeshError::EmptyFile { path: name });
    }
    read_mesh_bytes(&bytes, format, &name)
}

/// Write a file atomically: the content goes to a temporary file in the same directory, which
/// is flushed, synced and then renamed over `path`. If `write` fails, the temporary file is
/// removed and any existing `path` is left untouched.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let file_name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "output path has no file name"))?;
    let tmp: PathBuf = dir.join(format!(".{}.tmp-{}", file_name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp)?);
        write(&mut w)?;
        w.flush()?;
        w.get_ref().sync_all()?;
        drop(w);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_keeps_old_file_on_failure() {
        let dir = std::env::temp_dir().join(format!("clothcast-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("out.txt");
        write_atomic(&p, |w| w.write_all(b"good")).unwrap();
        let err = write_atomic(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"good");
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unknown_extension() {
        let e = read_mesh_file(Path::new("model.fbx")).unwrap_err();
        assert!(e.to_string().contains("unknown mesh format"), "{e}");
    }
}
