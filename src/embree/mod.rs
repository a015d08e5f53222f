//! The safe wrapper around Intel Embree: the only module of ember with `unsafe`.
//!
//! It exposes a [`Device`] (with an error callback whose reports become
//! [`EmbreeError`]s and a memory monitor that measures and can cap what Embree
//! allocates), and a committed triangle [`Scene`] that answers single rays and 8-wide
//! packets from any number of threads, optionally with a [`HitFilter`] deciding which
//! intersections are hits (cut-outs, in `filter`). The differences between Embree 3 and Embree 4
//! (intersection contexts versus argument structs) stay inside this file, selected by
//! the `embree3`/`embree4` cfg that build.rs emits for the installed headers.

mod direct;
mod filter;
mod instance;
mod packet;
mod sys;

pub use direct::{raw_rays, RawRay};

use std::any::Any;
use std::ffi::{CStr, CString};
use std::marker::PhantomData;
use std::os::raw::{c_char, c_void};
use std::ptr;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex};

use glam::Vec3;

use crate::geometry::{Hit, HitFilter, Opaque, Ray};

/// Embree's "no geometry" id, written into `geomID` before a query.
const INVALID_ID: u32 = u32::MAX;

/// An error Embree reported, with its code and message.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("Embree {kind}: {message}")]
pub struct EmbreeError {
    pub kind: EmbreeErrorKind,
    pub message: String,
}

/// Embree's error codes (`RTCError`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EmbreeErrorKind {
    Unknown,
    InvalidArgument,
    InvalidOperation,
    OutOfMemory,
    UnsupportedCpu,
    Cancelled,
}

impl std::fmt::Display for EmbreeErrorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EmbreeErrorKind::Unknown => "error",
            EmbreeErrorKind::InvalidArgument => "invalid argument",
            EmbreeErrorKind::InvalidOperation => "invalid operation",
            EmbreeErrorKind::OutOfMemory => "out of memory",
            EmbreeErrorKind::UnsupportedCpu => "unsupported CPU",
            EmbreeErrorKind::Cancelled => "operation cancelled",
        })
    }
}

impl EmbreeErrorKind {
    fn from_code(code: sys::RTCError) -> Option<Self> {
        Some(match code {
            sys::RTC_ERROR_NONE => return None,
            sys::RTC_ERROR_INVALID_ARGUMENT => EmbreeErrorKind::InvalidArgument,
            sys::RTC_ERROR_INVALID_OPERATION => EmbreeErrorKind::InvalidOperation,
            sys::RTC_ERROR_OUT_OF_MEMORY => EmbreeErrorKind::OutOfMemory,
            sys::RTC_ERROR_UNSUPPORTED_CPU => EmbreeErrorKind::UnsupportedCpu,
            sys::RTC_ERROR_CANCELLED => EmbreeErrorKind::Cancelled,
            _ => EmbreeErrorKind::Unknown,
        })
    }
}

/// Meshes of at least this many triangles are built in Embree's compact layout
/// (`RTC_SCENE_FLAG_COMPACT`: a 4-wide BVH whose leaves hold vertex indices instead of
/// copies of the vertices). Measured on the 2M-triangle grid of issue 12, a render's
/// peak memory falls from 145 to 82 bytes per triangle and the build gets faster; rays
/// cost about the same on Sponza. Smaller meshes keep the default layout, whose hits
/// can differ from the compact one's in the last bits.
pub const COMPACT_FROM_TRIANGLES: usize = 1 << 20;

/// Build quality of the BVH Embree builds (`rtcSetSceneBuildQuality`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BuildQuality {
    Low,
    #[default]
    Medium,
    High,
}

impl BuildQuality {
    fn raw(self) -> sys::RTCBuildQuality {
        match self {
            BuildQuality::Low => sys::RTC_BUILD_QUALITY_LOW,
            BuildQuality::Medium => sys::RTC_BUILD_QUALITY_MEDIUM,
            BuildQuality::High => sys::RTC_BUILD_QUALITY_HIGH,
        }
    }
}

/// What `ember info` reports about the Embree library in use.
#[derive(Debug, Clone)]
pub struct DeviceInfo {
    /// Version of the loaded library, e.g. "3.13.5".
    pub version: String,
    /// Version of the headers the bindings were generated from.
    pub header_version: String,
    /// The widest packet the library runs natively (4, 8 or 16): SSE, AVX/AVX2 or AVX-512.
    pub native_packet_width: u32,
    /// "TBB", "internal" or "PPL".
    pub tasking_system: &'static str,
    /// The device configuration string it was created with.
    pub config: String,
}

/// State the C callbacks write into; owned by the device and outliving it.
struct Callbacks {
    /// The first error reported since it was last taken.
    error: Mutex<Option<EmbreeError>>,
    /// Bytes Embree currently holds, as reported to the memory monitor.
    bytes_in_use: AtomicI64,
    /// Allocation cap in bytes; past it the monitor refuses and Embree reports
    /// out-of-memory. `i64::MAX` when unlimited.
    byte_limit: AtomicI64,
}

struct DeviceHandle {
    raw: sys::RTCDevice,
    callbacks: Box<Callbacks>,
    config: String,
}

// SAFETY: an RTCDevice may be used from any thread (Embree's API is thread-safe for
// device-level calls), and `Callbacks` is only touched through a Mutex and atomics.
unsafe impl Send for DeviceHandle {}
// SAFETY: as above.
unsafe impl Sync for DeviceHandle {}

impl Drop for DeviceHandle {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewDevice and this is the last reference we hold;
        // scenes keep the handle alive through an Arc, so none outlives the device.
        unsafe { sys::rtcReleaseDevice(self.raw) };
    }
}

/// An Embree device. Cheap to clone; scenes keep their device alive.
#[derive(Clone)]
pub struct Device {
    handle: Arc<DeviceHandle>,
}

unsafe extern "C" fn on_error(user: *mut c_void, code: sys::RTCError, message: *const c_char) {
    // SAFETY: `user` is the `Callbacks` box registered with this device, which lives as
    // long as the device; `message` is null or a NUL-terminated string from Embree.
    let callbacks = unsafe { &*(user as *const Callbacks) };
    let message = if message.is_null() {
        String::from("(no message)")
    } else {
        // SAFETY: non-null and NUL-terminated per Embree's API contract.
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    let kind = EmbreeErrorKind::from_code(code).unwrap_or(EmbreeErrorKind::Unknown);
    if let Ok(mut slot) = callbacks.error.lock() {
        slot.get_or_insert(EmbreeError { kind, message });
    }
}

unsafe extern "C" fn on_memory(user: *mut c_void, bytes: isize, post: bool) -> bool {
    // SAFETY: `user` is the `Callbacks` box registered with this device (see on_error).
    let callbacks = unsafe { &*(user as *const Callbacks) };
    let bytes = bytes as i64;
    let now = callbacks.bytes_in_use.fetch_add(bytes, Ordering::Relaxed) + bytes;
    // Only a report made before the allocation (`post == false`) can refuse it.
    if bytes > 0 && !post && now > callbacks.byte_limit.load(Ordering::Relaxed) {
        // Refusing makes Embree fail the allocation with RTC_ERROR_OUT_OF_MEMORY; it
        // does not report the matching release, so undo our count here.
        callbacks.bytes_in_use.fetch_sub(bytes, Ordering::Relaxed);
        return false;
    }
    true
}

impl Device {
    /// Creates a device with an Embree configuration string (`""` for defaults, or e.g.
    /// `"threads=2"`). A string Embree rejects is an error, not an abort.
    pub fn new(config: &str) -> Result<Device, EmbreeError> {
        let c_config = CString::new(config).map_err(|_| EmbreeError {
            kind: EmbreeErrorKind::InvalidArgument,
            message: "device configuration contains a NUL byte".into(),
        })?;
        // SAFETY: `c_config` is a valid NUL-terminated string for the duration of the call.
        let raw = unsafe { sys::rtcNewDevice(c_config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device asks for the error of the last failed device creation.
            let code = unsafe { sys::rtcGetDeviceError(ptr::null_mut()) };
            return Err(EmbreeError {
                kind: EmbreeErrorKind::from_code(code).unwrap_or(EmbreeErrorKind::Unknown),
                message: format!(
                    "cannot create a device: Embree rejects the configuration {config:?}"
                ),
            });
        }
        let callbacks = Box::new(Callbacks {
            error: Mutex::new(None),
            bytes_in_use: AtomicI64::new(0),
            byte_limit: AtomicI64::new(i64::MAX),
        });
        let user = &*callbacks as *const Callbacks as *mut c_void;
        // SAFETY: `raw` is a live device; `user` points into a Box that the device
        // handle owns and drops only after releasing the device.
        unsafe {
            sys::rtcSetDeviceErrorFunction(raw, Some(on_error), user);
            sys::rtcSetDeviceMemoryMonitorFunction(raw, Some(on_memory), user);
        }
        Ok(Device {
            handle: Arc::new(DeviceHandle {
                raw,
                callbacks,
                config: config.to_owned(),
            }),
        })
    }

    /// Takes the first error reported since the last call, if any.
    fn take_error(&self) -> Result<(), EmbreeError> {
        let mut slot = self
            .handle
            .callbacks
            .error
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        match slot.take() {
            Some(mut e) => {
                let limit = self.handle.callbacks.byte_limit.load(Ordering::Relaxed);
                if e.kind == EmbreeErrorKind::OutOfMemory && limit != i64::MAX {
                    e.message += &format!(" (the memory limit is {limit} bytes)");
                }
                Err(e)
            }
            None => Ok(()),
        }
    }

    fn property(&self, prop: sys::RTCDeviceProperty) -> isize {
        // SAFETY: a live device and a property id from the headers it was built with.
        unsafe { sys::rtcGetDeviceProperty(self.handle.raw, prop) }
    }

    /// Bytes Embree currently holds on this device (all scenes), from its memory monitor.
    pub fn bytes_in_use(&self) -> usize {
        self.handle
            .callbacks
            .bytes_in_use
            .load(Ordering::Relaxed)
            .max(0) as usize
    }

    /// Caps what Embree may allocate on this device; a build that needs more fails
    /// with an out-of-memory error. `None` lifts the cap.
    pub fn set_memory_limit(&self, bytes: Option<usize>) {
        let limit = bytes.map_or(i64::MAX, |b| b.min(i64::MAX as usize) as i64);
        self.handle
            .callbacks
            .byte_limit
            .store(limit, Ordering::Relaxed);
    }

    pub fn info(&self) -> DeviceInfo {
        let v = self.property(sys::RTC_DEVICE_PROPERTY_VERSION);
        let version = format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100);
        let h = sys::RTC_VERSION as i64;
        let header_version = format!("{}.{}.{}", h / 10000, (h / 100) % 100, h % 100);
        let native_packet_width =
            if self.property(sys::RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0 {
                16
            } else if self.property(sys::RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0 {
                8
            } else {
                4
            };
        let tasking_system = match self.property(sys::RTC_DEVICE_PROPERTY_TASKING_SYSTEM) {
            0 => "internal",
            1 => "TBB",
            2 => "PPL",
            _ => "unknown",
        };
        DeviceInfo {
            version,
            header_version,
            native_packet_width,
            tasking_system,
            config: self.handle.config.clone(),
        }
    }

    /// Builds and commits a scene of one triangle mesh. Triangle `i` of `triangles`
    /// is primitive `i` in every hit. The scene is robust
    /// (`RTC_SCENE_FLAG_ROBUST`): rays do not slip between triangles that share an
    /// edge, as with the native BVH's watertight test, so the two backends agree there.
    pub fn build_triangle_scene(
        &self,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        quality: BuildQuality,
    ) -> Result<Scene<'static>, EmbreeError> {
        self.build_scene(
            vertices,
            triangles,
            Buffers::Copied,
            quality,
            None::<Arc<Opaque>>,
        )
    }

    /// [`Device::build_triangle_scene`] where `filter` decides which intersections are
    /// hits, in intersection and occlusion queries alike: Embree calls it from the
    /// geometry's filter functions and traverses on past the hits it rejects. Only
    /// scenes with cut-outs need this; the others skip the callback entirely.
    pub fn build_filtered_triangle_scene<F: HitFilter>(
        &self,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        quality: BuildQuality,
        filter: Arc<F>,
    ) -> Result<Scene<'static>, EmbreeError> {
        self.build_scene(vertices, triangles, Buffers::Copied, quality, Some(filter))
    }

    /// [`Device::build_triangle_scene`] (or the filtered one) without copies of the
    /// mesh: Embree reads `vertices` and `triangles` where they are
    /// (`rtcSetSharedGeometryBuffer`), for as long as the scene borrows them. Embree
    /// reads a buffer's last item with a 16-byte load, 4 bytes past its end, so each
    /// vector needs room for one more item (`capacity() > len()`, which the borrow
    /// keeps); without that room the scene holds copies instead.
    pub fn build_shared_triangle_scene<'m, F: HitFilter>(
        &self,
        vertices: &'m Vec<Vec3>,
        triangles: &'m Vec<[u32; 3]>,
        quality: BuildQuality,
        filter: Option<Arc<F>>,
    ) -> Result<Scene<'m>, EmbreeError> {
        let room = vertices.capacity() > vertices.len() && triangles.capacity() > triangles.len();
        let buffers = match room {
            true => Buffers::Shared,
            false => Buffers::Copied,
        };
        self.build_scene(vertices, triangles, buffers, quality, filter)
    }

    /// The scene of one mesh. With [`Buffers::Shared`] the caller must give slices
    /// that stay borrowed for `'m` and have 4 readable bytes past their end (see
    /// [`Device::build_shared_triangle_scene`], the only caller that shares).
    fn build_scene<'m, F: HitFilter>(
        &self,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        buffers: Buffers,
        quality: BuildQuality,
        filter: Option<Arc<F>>,
    ) -> Result<Scene<'m>, EmbreeError> {
        check_mesh(vertices, triangles)?;
        if buffers == Buffers::Copied {
            self.check_buffer_memory(vertices.len(), triangles.len())?;
        }
        let _ = self.take_error();
        let compact = triangles.len() >= COMPACT_FROM_TRIANGLES;
        let mut scene = self.new_scene(quality, compact)?;
        let before = self.bytes_in_use();
        let mesh = MeshBuffers {
            vertices,
            triangles,
            buffers,
        };
        let geometry = self.triangle_geometry(&mesh, quality, filter.as_deref())?;
        // The scene owns the filter from here: it outlives every query, and the
        // geometry (whose user data points at it) dies with the scene.
        scene.filter = filter.map(|f| f as Arc<dyn Any + Send + Sync>);
        // SAFETY: the scene and the geometry are live and on this device; the scene
        // keeps its own reference, so dropping `geometry` right after is fine.
        unsafe { sys::rtcAttachGeometryByID(scene.raw, geometry.0, 0) };
        drop(geometry);
        self.take_error()?;
        // SAFETY: the scene is live and its one geometry is committed.
        unsafe { sys::rtcCommitScene(scene.raw) };
        self.take_error()?;
        scene.bytes = self.bytes_in_use().saturating_sub(before);
        Ok(scene)
    }

    /// Refuses buffers past the memory limit here rather than let Embree's monitor do
    /// it: Embree 3.13.5 leaks a device reference when a buffer allocation fails inside
    /// `rtcSetNewGeometryBuffer` (seen under valgrind), while a refusal during the BVH
    /// build (in `rtcCommitScene`) cleans up fully.
    fn check_buffer_memory(&self, vertices: usize, triangles: usize) -> Result<(), EmbreeError> {
        let buffer_bytes = (vertices * 12 + 16 + triangles * 12) as i64;
        let limit = self.handle.callbacks.byte_limit.load(Ordering::Relaxed);
        if (self.bytes_in_use() as i64).saturating_add(buffer_bytes) <= limit {
            return Ok(());
        }
        Err(EmbreeError {
            kind: EmbreeErrorKind::OutOfMemory,
            message: format!(
                "{vertices} vertices and {triangles} triangles need {buffer_bytes} bytes of \
                 buffers (the memory limit is {limit} bytes)"
            ),
        })
    }

    /// An empty robust scene of the given build quality, in the compact layout when
    /// asked, released when dropped.
    fn new_scene<'m>(
        &self,
        quality: BuildQuality,
        compact: bool,
    ) -> Result<Scene<'m>, EmbreeError> {
        // SAFETY: the device is live (`self` holds a reference to it).
        let raw = unsafe { sys::rtcNewScene(self.handle.raw) };
        if raw.is_null() {
            return Err(self
                .take_error()
                .err()
                .unwrap_or_else(|| invalid("cannot create a scene".into())));
        }
        // From here `Scene::drop` releases the handle on every path.
        let scene = Scene {
            raw,
            device: self.clone(),
            bytes: 0,
            filter: None,
            placed: Vec::new(),
            carried: (EMBREE_LARGE, EMBREE_LARGE),
            shared: PhantomData,
        };
        // SAFETY: `raw` is a live scene, not committed yet.
        let flags = unsafe { sys::rtcGetSceneFlags(raw) };
        let layout = match compact {
            true => sys::RTC_SCENE_FLAG_COMPACT,
            false => 0,
        };
        // SAFETY: as above; ROBUST and COMPACT are valid scene flags in Embree 3 and 4.
        unsafe { sys::rtcSetSceneFlags(raw, flags | sys::RTC_SCENE_FLAG_ROBUST | layout) };
        // SAFETY: as above.
        unsafe { sys::rtcSetSceneBuildQuality(raw, quality.raw()) };
        Ok(scene)
    }

    /// A committed triangle geometry holding copies of the mesh, or reading it in
    /// place, with `filter` as its filter functions when there is one. The caller keeps
    /// `filter` alive as long as any scene holds the geometry.
    fn triangle_geometry<F: HitFilter>(
        &self,
        mesh: &MeshBuffers<'_>,
        quality: BuildQuality,
        filter: Option<&F>,
    ) -> Result<Geometry, EmbreeError> {
        // SAFETY: the device is live.
        let raw = unsafe { sys::rtcNewGeometry(self.handle.raw, sys::RTC_GEOMETRY_TYPE_TRIANGLE) };
        if raw.is_null() {
            self.take_error()?;
            return Err(invalid("cannot create a triangle geometry".into()));
        }
        // From here `Geometry::drop` releases the handle on every path.
        let geometry = Geometry(raw);
        // SAFETY: `raw` is a live geometry, not committed yet.
        unsafe { sys::rtcSetGeometryBuildQuality(raw, quality.raw()) };
        match mesh.buffers {
            Buffers::Copied => self.copy_buffers(&geometry, mesh)?,
            Buffers::Shared => self.share_buffers(&geometry, mesh)?,
        }
        if let Some(filter) = filter {
            // SAFETY: the geometry is live and not committed; the caller keeps `filter`
            // alive as long as the geometry can be queried (see `build_scene`).
            unsafe { filter::install(raw, filter) };
        }
        // SAFETY: the geometry is live and its buffers are set.
        unsafe { sys::rtcCommitGeometry(raw) };
        Ok(geometry)
    }

    /// Gives the geometry buffers that Embree allocates itself (with the tail padding
    /// its 16-byte loads need), filled with copies of the mesh.
    fn copy_buffers(&self, geometry: &Geometry, mesh: &MeshBuffers<'_>) -> Result<(), EmbreeError> {
        let (vertices, triangles) = (mesh.vertices, mesh.triangles);
        let vertex_buffer = geometry
            .new_buffer(
                sys::RTC_BUFFER_TYPE_VERTEX,
                sys::RTC_FORMAT_FLOAT3,
                vertices.len(),
            )
            .cast::<[f32; 3]>();
        let index_buffer = geometry
            .new_buffer(
                sys::RTC_BUFFER_TYPE_INDEX,
                sys::RTC_FORMAT_UINT3,
                triangles.len(),
            )
            .cast::<[u32; 3]>();
        if vertex_buffer.is_null() || index_buffer.is_null() {
            self.take_error()?;
            return Err(invalid("cannot allocate the geometry buffers".into()));
        }
        for (i, v) in vertices.iter().enumerate() {
            // SAFETY: Embree allocated `vertices.len()` 12-byte, 4-byte aligned items at
            // `vertex_buffer`, owned by the live geometry and not yet read by anyone.
            unsafe { vertex_buffer.add(i).write(v.to_array()) };
        }
        // SAFETY: as above, `triangles.len()` items at `index_buffer`, which cannot
        // overlap the caller's slice.
        unsafe { ptr::copy_nonoverlapping(triangles.as_ptr(), index_buffer, triangles.len()) };
        Ok(())
    }

    /// Points the geometry at the mesh's own arrays.
    fn share_buffers(
        &self,
        geometry: &Geometry,
        mesh: &MeshBuffers<'_>,
    ) -> Result<(), EmbreeError> {
        let slots = [
            (
                sys::RTC_BUFFER_TYPE_VERTEX,
                sys::RTC_FORMAT_FLOAT3,
                mesh.vertices.as_ptr().cast::<c_void>(),
                mesh.vertices.len(),
            ),
            (
                sys::RTC_BUFFER_TYPE_INDEX,
                sys::RTC_FORMAT_UINT3,
                mesh.triangles.as_ptr().cast::<c_void>(),
                mesh.triangles.len(),
            ),
        ];
        for (kind, format, data, count) in slots {
            // SAFETY: the geometry is live and not committed; `data` points at `count`
            // 12-byte, 4-byte aligned items (Vec3 and [u32; 3] are three 4-byte
            // values) followed by at least 4 readable bytes, which stay borrowed and
            // unchanged for the life of the scene (`build_shared_triangle_scene`).
            unsafe {
                sys::rtcSetSharedGeometryBuffer(geometry.0, kind, 0, format, data, 0, 12, count)
            };
        }
        self.take_error()
    }
}

/// Whether Embree copies the mesh into buffers of its own or reads the caller's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Buffers {
    Copied,
    Shared,
}

/// The mesh arrays a geometry is made from, and how Embree gets them.
struct MeshBuffers<'a> {
    vertices: &'a [Vec3],
    triangles: &'a [[u32; 3]],
    buffers: Buffers,
}

/// A triangle geometry handle, released when dropped (a scene it was attached to
/// keeps its own reference).
struct Geometry(sys::RTCGeometry);

impl Geometry {
    /// A new buffer of `count` 12-byte items in slot 0 of `kind`, allocated by Embree
    /// and owned by the geometry; null (with the error on the device) if it failed.
    fn new_buffer(
        &self,
        kind: sys::RTCBufferType,
        format: sys::RTCFormat,
        count: usize,
    ) -> *mut c_void {
        // SAFETY: the geometry is live; Embree checks the arguments and reports
        // errors to the device.
        unsafe { sys::rtcSetNewGeometryBuffer(self.0, kind, 0, format, 12, count) }
    }
}

impl Drop for Geometry {
    fn drop(&mut self) {
        // SAFETY: the handle came from rtcNewGeometry and is released once, here.
        unsafe { sys::rtcReleaseGeometry(self.0) };
    }
}

/// An invalid-argument error with `message`.
fn invalid(message: String) -> EmbreeError {
    EmbreeError {
        kind: EmbreeErrorKind::InvalidArgument,
        message,
    }
}

/// A mesh Embree can take: at least one triangle, and every index names a vertex.
fn check_mesh(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Result<(), EmbreeError> {
    if triangles.is_empty() {
        return Err(invalid("a scene needs at least one triangle".into()));
    }
    match triangles
        .iter()
        .flatten()
        .find(|&&i| i as usize >= vertices.len())
    {
        Some(bad) => Err(invalid(format!(
            "vertex index {bad} out of range for {} vertices",
            vertices.len()
        ))),
        None => Ok(()),
    }
}

/// A committed Embree scene of one triangle mesh, ready for ray queries from any thread.
/// `'m` is the borrow of the mesh arrays Embree reads in place, when they are shared
/// (see [`Device::build_shared_triangle_scene`]); `'static` when Embree holds copies.
pub struct Scene<'m> {
    raw: sys::RTCScene,
    device: Device,
    /// Bytes Embree allocated while building it (BVH, triangle copies, buffers).
    bytes: usize,
    /// The hit filter the geometry's filter functions call, if any. Only owned here
    /// (the callback reaches it through the geometry's user data); dropped after
    /// `Drop::drop` has released the scene.
    filter: Option<Arc<dyn Any + Send + Sync>>,
    /// The scenes this one places by instance geometries, if it is a top-level scene
    /// (see [`Device::build_instanced_scene`]): kept alive with their filters for as
    /// long as this scene can be queried, and released after it.
    placed: Vec<Scene<'m>>,
    /// The largest origin and direction coordinates of a ray Embree accepts here: its
    /// own limit, or less in a top-level scene whose instances would take a ray past
    /// that limit in their object space (see `Instance::carried`).
    carried: (f32, f32),
    /// The shared vertex and index arrays, borrowed for as long as the scene lives.
    shared: PhantomData<&'m [u8]>,
}

// SAFETY: a committed RTCScene is immutable and Embree documents that it may be
// traversed from many threads at once; nothing here mutates it after commit.
unsafe impl Send for Scene<'_> {}
// SAFETY: as above.
unsafe impl Sync for Scene<'_> {}

impl Drop for Scene<'_> {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewScene on `self.device`, which is still alive.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

/// Embree's limit on ray origin and direction components (`FLT_LARGE` in its sources).
const EMBREE_LARGE: f32 = crate::geometry::MAX_RAY_COORDINATE;

/// Whether Embree accepts the ray (its `RayK::valid()`): origin and direction components
/// within ±1.844e18, and no NaN in `tnear`/`tfar`. Debian's Embree 3.13.5 is built with
/// assertions and aborts the process on any other ray, and release builds give
/// undefined results; ember answers such rays as misses instead. Hostile inputs make
/// them: vertices near `f32::MAX`, or an `--eye` far outside the scene.
#[inline]
fn embree_accepts(ray: &Ray) -> bool {
    accepts_within(ray, (EMBREE_LARGE, EMBREE_LARGE))
}

/// Whether the ray's origin and direction components are within `(origin, dir)`, and
/// its `tnear`/`tfar` are not NaN.
#[inline]
fn accepts_within(ray: &Ray, (origin, dir): (f32, f32)) -> bool {
    let within = |v: glam::Vec3, limit: f32| v.abs().cmple(glam::Vec3::splat(limit)).all();
    within(ray.origin, origin) && within(ray.dir, dir) && !ray.tmin.is_nan() && !ray.tmax.is_nan()
}

/// The ray in Embree's layout, written as three whole 16-byte rows. Embree reads the
/// ray back at once with 16-byte vector loads; written field by field, those loads
/// would wait for a dozen scalar stores to retire (a store-forwarding stall), which
/// cost ~15 ns per query — a quarter of a primary ray on the bunny.
#[inline]
fn raw_ray(ray: &Ray) -> sys::RTCRay {
    let rows = [
        // org_x, org_y, org_z, tnear
        ray.origin.extend(ray.tmin),
        // dir_x, dir_y, dir_z, time
        ray.dir.extend(0.0),
        // tfar, mask (every bit), id, flags: integers as their f32 bit patterns
        glam::Vec4::new(ray.tmax, f32::from_bits(u32::MAX), 0.0, 0.0),
    ];
    // SAFETY: RTCRay is `#[repr(C, align(16))]` with twelve 4-byte fields in exactly
    // the order of these rows (48 bytes, the size `transmute` checks); every bit
    // pattern is a valid f32 or u32, and Vec4's lanes are plain f32.
    unsafe { std::mem::transmute::<[glam::Vec4; 3], sys::RTCRay>(rows) }
}

/// The instance a hit reports: Embree's `instID[0]`, which is the instance geometry's
/// id in a top-level scene and invalid in a scene of one mesh (instance 0).
#[inline]
fn instance_of(inst_id: u32) -> u32 {
    if inst_id == INVALID_ID {
        0
    } else {
        inst_id
    }
}

fn empty_hit() -> sys::RTCHit {
    // SAFETY: RTCHit is plain old data (floats and integers); all-zero is valid.
    let mut hit: sys::RTCHit = unsafe { std::mem::zeroed() };
    hit.geomID = INVALID_ID;
    hit.primID = INVALID_ID;
    hit
}

/// The per-query argument Embree 3 wants: an intersection context.
#[cfg(embree3)]
fn context(coherent: bool) -> sys::RTCIntersectContext {
    // SAFETY: plain old data; the fields that matter are set right below, as the
    // header's inline rtcInitIntersectContext (not exported, so not bound) does.
    let mut ctx: sys::RTCIntersectContext = unsafe { std::mem::zeroed() };
    ctx.flags = if coherent {
        sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT
    } else {
        sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
    };
    ctx.filter = None;
    ctx.instID = [INVALID_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize];
    ctx
}

/// Rays per packet of the packet API (`rtcIntersect8`/`rtcOccluded8`).
pub const PACKET_WIDTH: usize = 8;

/// The active-lane mask of a packet: -1 for active, 0 for inactive. Embree loads it
/// with aligned vector instructions, so it needs the packet's 32-byte alignment.
#[repr(C, align(32))]
struct LaneMask([i32; PACKET_WIDTH]);

impl Scene<'_> {
    /// Bytes Embree allocated to build this scene.
    pub fn memory_bytes(&self) -> usize {
        self.bytes
    }

    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Whether a hit filter decides this scene's hits (cut-outs).
    pub fn is_filtered(&self) -> bool {
        self.filter.is_some()
    }

    /// Nearest hit of one ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !accepts_within(ray, self.carried) {
            return None;
        }
        let mut rayhit = sys::RTCRayHit {
            ray: raw_ray(ray),
            hit: empty_hit(),
        };
        #[cfg(embree3)]
        {
            let mut ctx = context(false);
            // SAFETY: the scene is committed; `ctx` and `rayhit` are valid, properly
            // aligned (bindgen keeps RTCRayHit's 16-byte alignment) and live for the call.
            unsafe { sys::rtcIntersect1(self.raw, &mut ctx, &mut rayhit) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as above; a null argument struct means Embree's defaults.
            unsafe { sys::rtcIntersect1(self.raw, &mut rayhit, ptr::null_mut()) };
        }
        (rayhit.hit.geomID != INVALID_ID).then_some(Hit {
            t: rayhit.ray.tfar,
            prim: rayhit.hit.primID,
            u: rayhit.hit.u,
            v: rayhit.hit.v,
            instance: instance_of(rayhit.hit.instID[0]),
        })
    }

    /// Whether anything blocks the ray segment.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if !accepts_within(ray, self.carried) {
            return false;
        }
        let mut raw = raw_ray(ray);
        #[cfg(embree3)]
        {
            let mut ctx = context(false);
            // SAFETY: committed scene; `ctx` and `raw` are valid for the call.
            unsafe { sys::rtcOccluded1(self.raw, &mut ctx, &mut raw) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: committed scene; `raw` is valid; null arguments mean defaults.
            unsafe { sys::rtcOccluded1(self.raw, &mut raw, ptr::null_mut()) };
        }
        // Embree marks an occluded ray by setting tfar to -inf.
        raw.tfar < 0.0 && raw.tfar.is_infinite()
    }

    /// Nearest hits of up to 8 rays as one packet (`rtcIntersect8`). `coherent` hints
    /// that the rays are similar (camera rays), which Embree can exploit.
    pub fn intersect8(&self, rays: &[Ray], hits: &mut [Option<Hit>], coherent: bool) {
        assert!(rays.len() <= PACKET_WIDTH && hits.len() >= rays.len());
        let mut valid = LaneMask([0; PACKET_WIDTH]);
        // SAFETY: RTCRayHit8 is plain old data; all-zero is valid and every active lane
        // is filled below.
        let mut packet: sys::RTCRayHit8 = unsafe { std::mem::zeroed() };
        for (lane, ray) in rays.iter().enumerate() {
            // A ray Embree would reject stays inactive: a miss.
            valid.0[lane] = if accepts_within(ray, self.carried) {
                -1
            } else {
                0
            };
            let (r, h) = (&mut packet.ray, &mut packet.hit);
            r.org_x[lane] = ray.origin.x;
            r.org_y[lane] = ray.origin.y;
            r.org_z[lane] = ray.origin.z;
            r.dir_x[lane] = ray.dir.x;
            r.dir_y[lane] = ray.dir.y;
            r.dir_z[lane] = ray.dir.z;
            r.tnear[lane] = ray.tmin;
            r.tfar[lane] = ray.tmax;
            r.mask[lane] = u32::MAX;
            h.geomID[lane] = INVALID_ID;
            h.primID[lane] = INVALID_ID;
        }
        #[cfg(embree3)]
        {
            let mut ctx = context(coherent);
            // SAFETY: committed scene; `valid` has 8 lanes, 32-byte aligned; `packet` is 32-byte aligned
            // (bindgen keeps RTCRayHit8's alignment) and lives for the call.
            unsafe { sys::rtcIntersect8(valid.0.as_ptr(), self.raw, &mut ctx, &mut packet) };
        }
        #[cfg(embree4)]
        {
            let _ = coherent;
            // SAFETY: as above; null arguments mean defaults.
            unsafe { sys::rtcIntersect8(valid.0.as_ptr(), self.raw, &mut packet, ptr::null_mut()) };
        }
        for (lane, hit) in hits.iter_mut().take(rays.len()).enumerate() {
            *hit = (packet.hit.geomID[lane] != INVALID_ID).then_some(Hit {
                t: packet.ray.tfar[lane],
                prim: packet.hit.primID[lane],
                u: packet.hit.u[lane],
                v: packet.hit.v[lane],
                instance: instance_of(packet.hit.instID[0][lane]),
            });
        }
    }

    /// Occlusion of up to 8 rays as one packet (`rtcOccluded8`).
    pub fn occluded8(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert!(rays.len() <= PACKET_WIDTH && occluded.len() >= rays.len());
        let mut valid = LaneMask([0; PACKET_WIDTH]);
        // SAFETY: RTCRay8 is plain old data; active lanes are filled below.
        let mut packet: sys::RTCRay8 = unsafe { std::mem::zeroed() };
        for (lane, ray) in rays.iter().enumerate() {
            // A ray Embree would reject stays inactive: not occluded.
            valid.0[lane] = if accepts_within(ray, self.carried) {
                -1
            } else {
                0
            };
            packet.org_x[lane] = ray.origin.x;
            packet.org_y[lane] = ray.origin.y;
            packet.org_z[lane] = ray.origin.z;
            packet.dir_x[lane] = ray.dir.x;
            packet.dir_y[lane] = ray.dir.y;
            packet.dir_z[lane] = ray.dir.z;
            packet.tnear[lane] = ray.tmin;
            packet.tfar[lane] = ray.tmax;
            packet.mask[lane] = u32::MAX;
        }
        #[cfg(embree3)]
        {
            let mut ctx = context(false);
            // SAFETY: committed scene; 8 valid lanes, 32-byte aligned; aligned packet alive for the call.
            unsafe { sys::rtcOccluded8(valid.0.as_ptr(), self.raw, &mut ctx, &mut packet) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as above; null arguments mean defaults.
            unsafe { sys::rtcOccluded8(valid.0.as_ptr(), self.raw, &mut packet, ptr::null_mut()) };
        }
        for (lane, o) in occluded.iter_mut().take(rays.len()).enumerate() {
            *o = packet.tfar[lane] == f32::NEG_INFINITY;
        }
    }
}
