//! Reading accessors: typed views into the buffers. Every range is checked against
//! the bytes there are before a value is read, and the memory of the values against
//! what is available before they are allocated, so a count of 10⁹ over a buffer of a
//! few bytes is one error and no allocation. Integer components are read as glTF says:
//! divided to [0, 1] or [−1, 1] where `normalized`, as they are otherwise
//! (`KHR_mesh_quantization`). Sparse accessors are read too.

use gltf::accessor::{DataType, Dimensions};
use gltf::Accessor;

use rayon::prelude::*;

use crate::limits::check_fits;

/// The fewest values a thread is given: fewer cost more to hand over than to decode.
pub const PARALLEL_MIN: usize = 4096;

/// The bytes `length` bytes from `offset` in buffer view `view`'s buffer, checked.
fn view_bytes<'b>(
    view: &gltf::buffer::View<'_>,
    buffers: &'b [Vec<u8>],
) -> Result<&'b [u8], String> {
    let buffer = &buffers[view.buffer().index()];
    let start = view.offset();
    let end = start.checked_add(view.length());
    end.and_then(|end| buffer.get(start..end)).ok_or_else(|| {
        format!(
            "buffer view {} reaches past the end of buffer {} ({} bytes from byte {start}, \
             of {})",
            view.index(),
            view.buffer().index(),
            view.length(),
            buffer.len()
        )
    })
}

/// Bytes of one component of `data_type`.
fn component_size(data_type: DataType) -> usize {
    match data_type {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// Component `k` of the element at the start of `bytes`, as a number.
fn component(bytes: &[u8], k: usize, data_type: DataType, normalized: bool) -> f32 {
    let at = k * component_size(data_type);
    let b = &bytes[at..];
    match (data_type, normalized) {
        (DataType::F32, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        (DataType::U32, _) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
        (DataType::U8, false) => f32::from(b[0]),
        (DataType::U8, true) => f32::from(b[0]) / 255.0,
        (DataType::I8, false) => f32::from(b[0] as i8),
        (DataType::I8, true) => (f32::from(b[0] as i8) / 127.0).max(-1.0),
        (DataType::U16, false) => f32::from(u16::from_le_bytes([b[0], b[1]])),
        (DataType::U16, true) => f32::from(u16::from_le_bytes([b[0], b[1]])) / 65535.0,
        (DataType::I16, false) => f32::from(i16::from_le_bytes([b[0], b[1]])),
        (DataType::I16, true) => (f32::from(i16::from_le_bytes([b[0], b[1]])) / 32767.0).max(-1.0),
    }
}

/// The first `count` elements of `strided` as unsigned integers (indices) of
/// `data_type`, exactly: one loop per component type, so that none chooses per index.
fn unsigned_values(strided: &Strided<'_>, count: usize, data_type: DataType) -> Vec<u32> {
    let elements = strided.elements(count);
    match data_type {
        DataType::U8 => elements.map(|b| u32::from(b[0])).collect(),
        DataType::U16 => elements
            .map(|b| u32::from(u16::from_le_bytes([b[0], b[1]])))
            .collect(),
        _ => elements
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
    }
}

fn dimension_count(dimensions: Dimensions) -> usize {
    match dimensions {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

/// Where `count` elements of `element` bytes lie in `bytes`: from `offset`, `stride`
/// apart; checked to lie inside.
struct Strided<'b> {
    bytes: &'b [u8],
    offset: usize,
    stride: usize,
}

impl<'b> Strided<'b> {
    fn new(
        bytes: &'b [u8],
        offset: usize,
        stride: Option<usize>,
        element: usize,
        count: usize,
        what: &str,
    ) -> Result<Self, String> {
        let stride = stride.unwrap_or(element);
        if stride < element {
            return Err(format!(
                "{what}: its byteStride {stride} is less than its {element}-byte elements"
            ));
        }
        let last = (count as u64)
            .checked_sub(1)
            .map(|n| n as u128 * stride as u128 + offset as u128 + element as u128);
        if let Some(end) = last.filter(|&end| end > bytes.len() as u128) {
            return Err(format!(
                "{what}: its {count} elements reach byte {end} of a buffer view of {} bytes",
                bytes.len()
            ));
        }
        Ok(Strided {
            bytes,
            offset,
            stride,
        })
    }

    fn element(&self, i: usize) -> &'b [u8] {
        &self.bytes[self.offset + i * self.stride..]
    }

    /// The first `count` elements in order, each at least its element's size (`new`
    /// checked that they lie inside).
    fn elements(&self, count: usize) -> impl Iterator<Item = &'b [u8]> {
        self.bytes[self.offset..].chunks(self.stride).take(count)
    }

    /// [`Self::elements`], split between threads.
    fn par_elements(&self, count: usize) -> impl IndexedParallelIterator<Item = &'b [u8]> {
        let bytes = &self.bytes[self.offset..];
        bytes
            .par_chunks(self.stride)
            .take(count)
            .with_min_len(PARALLEL_MIN)
    }
}

/// The values of `accessor`, `N` components each (its type must have `N`, or with
/// `allow_wider` at least `N`: a VEC4 colour read as RGB).
pub fn read_vectors<const N: usize>(
    accessor: &Accessor<'_>,
    buffers: &[Vec<u8>],
    allow_wider: bool,
) -> Result<Vec<[f32; N]>, String> {
    let what = format!("accessor {}", accessor.index());
    let have = dimension_count(accessor.dimensions());
    if have != N && !(allow_wider && have > N && have <= 4) {
        return Err(format!(
            "{what} is of type {:?}; ember reads {N} components here",
            accessor.dimensions()
        ));
    }
    let count = accessor.count();
    check_fits(
        &format!("{what}'s {count} values"),
        (count as u64).saturating_mul(4 * N as u64),
    )?;
    let data_type = accessor.data_type();
    let normalized = accessor.normalized();
    let element = have * component_size(data_type);
    let read = |bytes: &[u8]| -> [f32; N] {
        std::array::from_fn(|k| component(bytes, k, data_type, normalized))
    };
    let mut values = match accessor.view() {
        Some(view) => {
            let bytes = view_bytes(&view, buffers)?;
            let strided = Strided::new(
                bytes,
                accessor.offset(),
                view.stride(),
                element,
                count,
                &what,
            )?;
            match data_type {
                // Most vertex data: decoded without a choice per component.
                DataType::F32 => strided
                    .par_elements(count)
                    .map(|b| {
                        let mut value = [0.0; N];
                        for (v, bytes) in value.iter_mut().zip(b[..4 * N].chunks_exact(4)) {
                            *v = f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
                        }
                        value
                    })
                    .collect(),
                _ => (0..count).map(|i| read(strided.element(i))).collect(),
            }
        }
        None if accessor.sparse().is_some() => vec![[0.0; N]; count],
        None => return Err(format!("{what} has no bufferView and no sparse values")),
    };
    if let Some(sparse) = accessor.sparse() {
        let (indices, replaced) = read_sparse(&sparse, buffers, count, element, &what)?;
        for (k, i) in indices.into_iter().enumerate() {
            values[i as usize] = read(replaced.element(k));
        }
    }
    Ok(values)
}

/// A sparse accessor's indices (checked below `count`) and where its values lie.
fn read_sparse<'b>(
    sparse: &gltf::accessor::sparse::Sparse<'_>,
    buffers: &'b [Vec<u8>],
    count: usize,
    element: usize,
    what: &str,
) -> Result<(Vec<u32>, Strided<'b>), String> {
    use gltf::accessor::sparse::IndexType;
    let n = sparse.count();
    let indices = sparse.indices();
    let index_type = match indices.index_type() {
        IndexType::U8 => DataType::U8,
        IndexType::U16 => DataType::U16,
        IndexType::U32 => DataType::U32,
    };
    let view = indices.view();
    let size = component_size(index_type);
    let strided = Strided::new(
        view_bytes(&view, buffers)?,
        indices.offset(),
        None,
        size,
        n,
        &format!("{what}'s sparse indices"),
    )?;
    check_fits("sparse indices", (n as u64).saturating_mul(4))?;
    let list = unsigned_values(&strided, n, index_type);
    if let Some(i) = list.iter().find(|&&i| i as usize >= count) {
        return Err(format!(
            "{what}: sparse index {i} is out of range ({count} elements)"
        ));
    }
    let values = sparse.values();
    let view = values.view();
    let replaced = Strided::new(
        view_bytes(&view, buffers)?,
        values.offset(),
        None,
        element,
        n,
        &format!("{what}'s sparse values"),
    )?;
    Ok((list, replaced))
}

/// The values of an index accessor (SCALAR of unsigned bytes, shorts or ints).
pub fn read_indices(accessor: &Accessor<'_>, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    let what = format!("index accessor {}", accessor.index());
    let data_type = accessor.data_type();
    if accessor.dimensions() != Dimensions::Scalar
        || !matches!(data_type, DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "{what} is {:?} of {:?}; indices are unsigned integer scalars",
            accessor.dimensions(),
            data_type
        ));
    }
    if accessor.sparse().is_some() {
        return Err(format!("{what} is sparse; ember reads dense indices"));
    }
    let count = accessor.count();
    check_fits(
        &format!("{what}'s {count} indices"),
        (count as u64).saturating_mul(4),
    )?;
    let Some(view) = accessor.view() else {
        return Err(format!("{what} has no bufferView"));
    };
    let size = component_size(data_type);
    let strided = Strided::new(
        view_bytes(&view, buffers)?,
        accessor.offset(),
        view.stride(),
        size,
        count,
        &what,
    )?;
    Ok(unsigned_values(&strided, count, data_type))
}
