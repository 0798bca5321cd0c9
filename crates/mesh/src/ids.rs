//! Typed element ids (`u32` newtypes) and per-element containers indexed by them.
//!
//! Ids keep vertex, face, edge and halfedge indices from being mixed up; containers
//! (`VertexData<T>`, `FaceData<T>`, ...) are plain vectors that can only be indexed by the
//! matching id.

use std::fmt;
use std::marker::PhantomData;
use std::ops::{Index, IndexMut};

macro_rules! id_type {
    ($(#[$doc:meta])* $name:ident, $prefix:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
        #[derive(serde::Serialize, serde::Deserialize)]
        #[serde(transparent)]
        pub struct $name(pub u32);

        impl $name {
            /// The sentinel for "no element" (used only inside connectivity tables).
            pub const INVALID: Self = Self(u32::MAX);

            /// The id as a `usize` index.
            #[inline(always)]
            pub fn idx(self) -> usize {
                self.0 as usize
            }

            /// Build an id from a `usize` index.
            ///
            /// # Panics
            /// If `i` does not fit in `u32` (meshes are limited to 2^32 − 1 elements).
            #[inline(always)]
            #[track_caller]
            pub fn new(i: usize) -> Self {
                assert!(i < u32::MAX as usize, "element index {i} exceeds the u32 id range");
                Self(i as u32)
            }

            /// True unless this is the [`Self::INVALID`] sentinel.
            #[inline(always)]
            pub fn is_valid(self) -> bool {
                self.0 != u32::MAX
            }
        }

        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                if self.is_valid() {
                    write!(f, concat!($prefix, "{}"), self.0)
                } else {
                    write!(f, concat!($prefix, "INVALID"))
                }
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}", self.0)
            }
        }
    };
}

id_type!(
    /// A vertex of a [`crate::Mesh`].
    VertexId,
    "v"
);
id_type!(
    /// A triangle of a [`crate::Mesh`].
    FaceId,
    "f"
);
id_type!(
    /// An undirected edge of a [`crate::Mesh`].
    EdgeId,
    "e"
);
id_type!(
    /// A directed halfedge of a [`crate::Mesh`]: halfedge `3f + k` runs from corner `k` to
    /// corner `k + 1` of face `f`.
    HalfedgeId,
    "h"
);

/// A vector of `T` indexed by the id type `I`.
#[derive(Clone, PartialEq)]
pub struct ElementData<I, T> {
    data: Vec<T>,
    _id: PhantomData<fn(I) -> I>,
}

/// Per-vertex data.
pub type VertexData<T> = ElementData<VertexId, T>;
/// Per-face data.
pub type FaceData<T> = ElementData<FaceId, T>;
/// Per-edge data.
pub type EdgeData<T> = ElementData<EdgeId, T>;
/// Per-halfedge data.
pub type HalfedgeData<T> = ElementData<HalfedgeId, T>;

impl<I, T: fmt::Debug> fmt::Debug for ElementData<I, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.data.fmt(f)
    }
}

impl<I, T> Default for ElementData<I, T> {
    fn default() -> Self {
        Self { data: Vec::new(), _id: PhantomData }
    }
}

impl<I, T> ElementData<I, T> {
    /// Wrap a vector.
    pub fn from_vec(data: Vec<T>) -> Self {
        Self { data, _id: PhantomData }
    }
    /// `n` copies of `value`.
    pub fn filled(n: usize, value: T) -> Self
    where
        T: Clone,
    {
        Self::from_vec(vec![value; n])
    }
    /// Number of elements.
    pub fn len(&self) -> usize {
        self.data.len()
    }
    /// True when there are no elements.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// The values as a slice (index `i` is element `i`).
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }
    /// The values as a mutable slice.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.data
    }
    /// Unwrap into the underlying vector.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }
    /// Iterate over values.
    pub fn iter(&self) -> std::slice::Iter<'_, T> {
        self.data.iter()
    }
    /// Iterate mutably over values.
    pub fn iter_mut(&mut self) -> std::slice::IterMut<'_, T> {
        self.data.iter_mut()
    }
    /// Map every value.
    pub fn map<U>(&self, f: impl FnMut(&T) -> U) -> ElementData<I, U> {
        ElementData::from_vec(self.data.iter().map(f).collect())
    }
}

macro_rules! impl_index {
    ($id:ty) => {
        impl<T> Index<$id> for ElementData<$id, T> {
            type Output = T;
            #[inline(always)]
            fn index(&self, i: $id) -> &T {
                &self.data[i.idx()]
            }
        }
        impl<T> IndexMut<$id> for ElementData<$id, T> {
            #[inline(always)]
            fn index_mut(&mut self, i: $id) -> &mut T {
                &mut self.data[i.idx()]
            }
        }
        impl<T> ElementData<$id, T> {
            /// Iterate over `(id, value)` pairs.
            pub fn enumerate(&self) -> impl Iterator<Item = ($id, &T)> {
                self.data.iter().enumerate().map(|(i, v)| (<$id>::new(i), v))
            }
        }
    };
}
impl_index!(VertexId);
impl_index!(FaceId);
impl_index!(EdgeId);
impl_index!(HalfedgeId);

impl<I, T> FromIterator<T> for ElementData<I, T> {
    fn from_iter<It: IntoIterator<Item = T>>(iter: It) -> Self {
        Self::from_vec(iter.into_iter().collect())
    }
}

impl<'a, I, T> IntoIterator for &'a ElementData<I, T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.data.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_and_containers() {
        let mut d: VertexData<f64> = VertexData::filled(3, 0.0);
        d[VertexId(2)] = 5.0;
        assert_eq!(d.as_slice(), &[0.0, 0.0, 5.0]);
        assert_eq!(format!("{:?}", VertexId(4)), "v4");
        assert!(!FaceId::INVALID.is_valid());
        let pairs: Vec<_> = d.enumerate().map(|(v, x)| (v.0, *x)).collect();
        assert_eq!(pairs, vec![(0, 0.0), (1, 0.0), (2, 5.0)]);
    }
}
