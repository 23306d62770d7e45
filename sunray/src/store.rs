//! A large table of plain values, held either as an owned `Vec` or as a checked view into
//! a memory-mapped file (a host's prepared scene, [`crate::prepared`]), so a cached scene's
//! corners, triangles and BVH nodes are used where they lie, never decoded into a copy.
//!
//! A [`Store`] keeps the table's pointer and length next to its backing, so reading it is
//! taking a slice (no branch on the backing); only changing it ([`Store::edit`]) turns a
//! mapped table into an owned one. A view is made only over a read-only mapping, within its
//! length and at an address aligned for the element type, on a little-endian host (the
//! files are written little-endian).

use memmap2::Mmap;
use std::sync::Arc;

/// A value any bytes of its size are a valid instance of (no references, no enums, no
/// `bool`), with an explicit little-endian byte form matching its in-memory layout, so a
/// table of them can be written field by field and viewed in place when read back.
///
/// # Safety
/// Every bit pattern of `size_of::<Self>()` bytes must be a valid `Self`, and [`Plain::put`]
/// must write exactly `size_of::<Self>()` bytes laid out as `Self` is in memory on a
/// little-endian host (padding as zeros).
pub unsafe trait Plain: Copy + Send + Sync + 'static {
    /// Appends the value's bytes (its memory layout, little-endian) to `out`.
    fn put(&self, out: &mut Vec<u8>);
}

// SAFETY: any 4 bytes are a u32; its bytes are its little-endian form.
unsafe impl Plain for u32 {
    fn put(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

// SAFETY: any 8 bytes are an f64; its bytes are its little-endian form.
unsafe impl Plain for f64 {
    fn put(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
}

// SAFETY: glam's DVec3 is `repr(C)` of three f64 (x, y, z), no padding.
unsafe impl Plain for glam::DVec3 {
    fn put(&self, out: &mut Vec<u8>) {
        for c in self.to_array() {
            c.put(out);
        }
    }
}

/// Why bytes of a mapping cannot be viewed as a table.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// The table would reach past the end of the mapping.
    #[error("a table of {len} items at {offset} reaches past the end ({size} bytes)")]
    OutOfBounds {
        /// Its first byte.
        offset: usize,
        /// Its items.
        len: usize,
        /// The mapping's length.
        size: usize,
    },
    /// The table's first byte is not aligned for its items.
    #[error("a table at {0} is not aligned for its items")]
    Misaligned(usize),
    /// This host is big-endian; the files are little-endian.
    #[error("mapped tables need a little-endian host")]
    BigEndian,
}

/// What holds a [`Store`]'s items.
enum Backing<T> {
    Owned(Vec<T>),
    Mapped(Arc<Mmap>),
}

/// A table owned or mapped (see the module's text); derefs to `&[T]`.
pub struct Store<T: Plain> {
    ptr: *const T,
    len: usize,
    backing: Backing<T>,
}

// SAFETY: a Store is a `&[T]` into memory it owns (a Vec, or a read-only mapping kept alive
// by its Arc); sending or sharing it is sending or sharing that slice.
unsafe impl<T: Plain> Send for Store<T> {}
// SAFETY: as above; nothing is changed through a shared Store.
unsafe impl<T: Plain> Sync for Store<T> {}

impl<T: Plain> Store<T> {
    /// A view of `len` items at byte `offset` of `map`, checked: within the mapping, aligned
    /// for `T`, on a little-endian host.
    pub fn mapped(map: &Arc<Mmap>, offset: usize, len: usize) -> Result<Store<T>, StoreError> {
        if cfg!(target_endian = "big") {
            return Err(StoreError::BigEndian);
        }
        let size = map.len();
        let end = len
            .checked_mul(std::mem::size_of::<T>())
            .and_then(|b| b.checked_add(offset));
        if end.is_none_or(|end| end > size) {
            return Err(StoreError::OutOfBounds { offset, len, size });
        }
        // SAFETY: offset <= end <= size: within (or one past the end of) the mapping.
        let ptr = unsafe { map.as_ptr().add(offset) };
        if ptr.align_offset(std::mem::align_of::<T>()) != 0 {
            return Err(StoreError::Misaligned(offset));
        }
        Ok(Store {
            ptr: ptr.cast(),
            len,
            backing: Backing::Mapped(Arc::clone(map)),
        })
    }

    /// Whether the items are a view into a mapped file.
    pub fn is_mapped(&self) -> bool {
        matches!(self.backing, Backing::Mapped(_))
    }

    /// Bytes of memory the store owns (a mapped table owns none: the page cache holds it).
    pub fn owned_bytes(&self) -> usize {
        match &self.backing {
            Backing::Owned(v) => v.capacity() * std::mem::size_of::<T>(),
            Backing::Mapped(_) => 0,
        }
    }

    /// The items as a `Vec` to change (a mapped table is copied first); the store takes
    /// them back when the returned guard is dropped.
    pub fn edit(&mut self) -> Edit<'_, T> {
        let vec = match &mut self.backing {
            Backing::Owned(v) => std::mem::take(v),
            Backing::Mapped(_) => self.to_vec(),
        };
        self.backing = Backing::Owned(Vec::new());
        self.ptr = std::ptr::NonNull::dangling().as_ptr();
        self.len = 0;
        Edit { store: self, vec }
    }

    fn owning(vec: Vec<T>) -> Store<T> {
        Store {
            ptr: vec.as_ptr(),
            len: vec.len(),
            backing: Backing::Owned(vec),
        }
    }
}

impl<T: Plain> std::ops::Deref for Store<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` and `len` describe the items of `backing` (a Vec not changed since,
        // or a checked view into a mapping the Arc keeps alive), aligned and initialised,
        // and every bit pattern is a valid T (Plain).
        unsafe { std::slice::from_raw_parts(self.ptr, self.len) }
    }
}

impl<'a, T: Plain> IntoIterator for &'a Store<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<T: Plain> From<Vec<T>> for Store<T> {
    fn from(vec: Vec<T>) -> Store<T> {
        Store::owning(vec)
    }
}

impl<T: Plain> Default for Store<T> {
    fn default() -> Store<T> {
        Store::owning(Vec::new())
    }
}

impl<T: Plain> Clone for Store<T> {
    fn clone(&self) -> Store<T> {
        match &self.backing {
            Backing::Owned(v) => Store::owning(v.clone()),
            Backing::Mapped(map) => Store {
                ptr: self.ptr,
                len: self.len,
                backing: Backing::Mapped(Arc::clone(map)),
            },
        }
    }
}

impl<T: Plain + std::fmt::Debug> std::fmt::Debug for Store<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let how = if self.is_mapped() { "mapped" } else { "owned" };
        write!(f, "Store({how}, {} items)", self.len)
    }
}

/// A store's items being changed as a `Vec` (see [`Store::edit`]).
pub struct Edit<'a, T: Plain> {
    store: &'a mut Store<T>,
    vec: Vec<T>,
}

impl<T: Plain> std::ops::Deref for Edit<'_, T> {
    type Target = Vec<T>;
    fn deref(&self) -> &Vec<T> {
        &self.vec
    }
}

impl<T: Plain> std::ops::DerefMut for Edit<'_, T> {
    fn deref_mut(&mut self) -> &mut Vec<T> {
        &mut self.vec
    }
}

impl<T: Plain> Drop for Edit<'_, T> {
    fn drop(&mut self) {
        *self.store = Store::owning(std::mem::take(&mut self.vec));
    }
}

/// The bytes of `items` as [`Plain::put`] writes them.
pub fn bytes_of<T: Plain>(items: &[T]) -> Vec<u8> {
    let mut out = Vec::with_capacity(std::mem::size_of_val(items));
    for item in items {
        item.put(&mut out);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A read-only mapping holding `bytes`.
    pub fn map_of(bytes: &[u8]) -> Arc<Mmap> {
        let mut m = memmap2::MmapMut::map_anon(bytes.len().max(1)).unwrap();
        m[..bytes.len()].copy_from_slice(bytes);
        Arc::new(m.make_read_only().unwrap())
    }

    #[test]
    fn a_mapped_table_reads_what_was_put_and_edits_into_an_owned_one() {
        let items: Vec<u32> = (0..100).map(|i| i * 7).collect();
        let mut bytes = vec![0u8; 4];
        bytes.extend(bytes_of(&items));
        let map = map_of(&bytes);
        let mut s = Store::<u32>::mapped(&map, 4, 100).unwrap();
        assert!(s.is_mapped() && s.owned_bytes() == 0);
        assert_eq!(&s[..], &items[..]);
        let copy = s.clone();
        s.edit().push(1);
        assert!(!s.is_mapped());
        assert_eq!(s.len(), 101);
        assert_eq!(&copy[..], &items[..], "a clone of a view is the same view");
        let owned: Store<u32> = vec![1, 2].into();
        assert_eq!(&owned.clone()[..], &[1, 2]);
        assert_eq!(&Store::<u32>::default()[..], &[] as &[u32]);
    }

    #[test]
    fn views_past_the_end_or_misaligned_are_refused() {
        let map = map_of(&[0u8; 64]);
        assert!(Store::<u32>::mapped(&map, 0, 16).is_ok());
        assert!(Store::<u32>::mapped(&map, 64, 0).is_ok());
        for (offset, len) in [
            (0, 17),
            (4, 16),
            (65, 0),
            (0, usize::MAX / 2),
            (usize::MAX, 1),
        ] {
            assert!(
                matches!(
                    Store::<u32>::mapped(&map, offset, len),
                    Err(StoreError::OutOfBounds { .. })
                ),
                "{offset} {len}"
            );
        }
        assert_eq!(
            Store::<f64>::mapped(&map, 4, 2).map(|_| ()),
            Err(StoreError::Misaligned(4))
        );
    }

    #[test]
    fn plain_values_put_their_memory_layout() {
        let v = glam::DVec3::new(1.5, -2.0, 3.25);
        let bytes = bytes_of(&[v, v * 2.0]);
        let map = map_of(&bytes);
        let s = Store::<glam::DVec3>::mapped(&map, 0, 2).unwrap();
        assert_eq!(&s[..], &[v, v * 2.0]);
    }
}
