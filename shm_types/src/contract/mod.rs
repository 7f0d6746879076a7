//! The topic contract: every service a vpsom run opens, with its payload's iceoryx2 type name,
//! size, alignment and field layout, built from the Rust types themselves (`size_of`,
//! `align_of`, `offset_of!`, the `ZeroCopySend` type name), so it cannot drift from them.
//!
//! | file | content |
//! |---|---|
//! | `mod.rs` | the description types ([`Topic`], [`TypeLayout`], [`Field`], [`Elem`], [`Scalar`]), [`topics`], [`types`], [`constants`] |
//! | `describe.rs` | the per-type field lists (one line per field: name and unit; offsets and types are read from Rust) |
//! | `c_header.rs` | [`c_header`]: the C/C++ header `shm_types/include/vpsom_topics.h` |
//! | `python.rs` | [`python_module`]: the Python `ctypes` module `shm_types/python/vpsom_topics.py` |
//!
//! The two generated files are committed; `tests/contract.rs` fails when they differ from what
//! [`c_header`] and [`python_module`] produce now, and `UPDATE_CONTRACT=1 cargo test --release
//! -p shm_types --test contract` rewrites them. The same test compiles the header with `gcc`
//! (its `_Static_assert`s check every size and offset) and loads the module in `python3`
//! (comparing `ctypes.sizeof`/`alignment`/field offsets with the Rust values).
//!
//! # What iceoryx2 checks when a foreign process opens one of our services
//! iceoryx2 0.10 stores, per publish-subscribe service, a `MessageTypeDetails`: for the payload
//! and for the user header, a type variant (`FixedSize` for all of ours), a type name, a size
//! and an alignment. Opening the service fails (`IncompatibleTypes`) unless all four match. The
//! payload's type name is what `#[derive(ZeroCopySend)]` returns for its
//! `#[type_name("vpsom::<Name>")]` attribute ([`TypeLayout::type_name`]); without the attribute
//! it would be Rust's `core::any::type_name`, which no other language can reproduce. Our
//! services have no user header: iceoryx2 records it as `"()"`, size 0, alignment 1, which is
//! what the Python binding sets when no user header is given and what the C++ binding uses for
//! the default `void` header. In C++ the payload's type name is the struct's
//! `static constexpr const char* IOX2_TYPE_NAME` (the generated header adds it under
//! `__cplusplus`); in Python it is the class's `type_name()` static method (generated); in C
//! it is passed with the size and alignment to the builder's payload-type-details call.

mod c_header;
mod describe;
mod python;

pub use c_header::c_header;
pub use python::python_module;

/// First element of every service name: services are `vpsom/<namespace>/<topic>`
/// (`runtime::ports::SERVICE_ROOT` is this constant).
pub const SERVICE_ROOT: &str = "vpsom";

/// iceoryx2's type name of the (absent) user header of every service.
pub const USER_HEADER_TYPE_NAME: &str = "()";

/// iceoryx2 root directory of user `uid` (iceoryx2's `global.root-path`): every user's
/// services live apart (see `runtime::ports::access`). Format: [`IOX2_ROOT_FMT`] with the uid.
pub fn iceoryx2_root_path(uid: u32) -> String {
    format!("/tmp/vpsom-iox2-u{uid}/")
}

/// iceoryx2 file prefix of user `uid` (`global.prefix`). Format: [`IOX2_PREFIX_FMT`].
pub fn iceoryx2_prefix(uid: u32) -> String {
    format!("vpsom_u{uid}_")
}

/// `printf` format of [`iceoryx2_root_path`] (one unsigned: the uid).
pub const IOX2_ROOT_FMT: &str = "/tmp/vpsom-iox2-u%u/";
/// `printf` format of [`iceoryx2_prefix`].
pub const IOX2_PREFIX_FMT: &str = "vpsom_u%u_";

/// Full iceoryx2 service name of `topic` in a run's `namespace`.
pub fn service_name(namespace: &str, topic: &str) -> String {
    format!("{SERVICE_ROOT}/{namespace}/{topic}")
}

/// A primitive field type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scalar {
    /// `u8` / `uint8_t` / `c_uint8`.
    U8,
    /// `u16`.
    U16,
    /// `u32`.
    U32,
    /// `u64`.
    U64,
    /// `i32`.
    I32,
    /// `i64`.
    I64,
    /// `f32` (IEEE-754 binary32).
    F32,
}

impl Scalar {
    /// Rust spelling (`"u16"`).
    pub fn rust(self) -> &'static str {
        match self {
            Scalar::U8 => "u8",
            Scalar::U16 => "u16",
            Scalar::U32 => "u32",
            Scalar::U64 => "u64",
            Scalar::I32 => "i32",
            Scalar::I64 => "i64",
            Scalar::F32 => "f32",
        }
    }

    /// C spelling (`"uint16_t"`).
    pub fn c(self) -> &'static str {
        match self {
            Scalar::U8 => "uint8_t",
            Scalar::U16 => "uint16_t",
            Scalar::U32 => "uint32_t",
            Scalar::U64 => "uint64_t",
            Scalar::I32 => "int32_t",
            Scalar::I64 => "int64_t",
            Scalar::F32 => "float",
        }
    }

    /// Python `ctypes` spelling (`"ctypes.c_uint16"`).
    pub fn ctypes(self) -> &'static str {
        match self {
            Scalar::U8 => "ctypes.c_uint8",
            Scalar::U16 => "ctypes.c_uint16",
            Scalar::U32 => "ctypes.c_uint32",
            Scalar::U64 => "ctypes.c_uint64",
            Scalar::I32 => "ctypes.c_int32",
            Scalar::I64 => "ctypes.c_int64",
            Scalar::F32 => "ctypes.c_float",
        }
    }
}

/// Element type of a field: a primitive or another message struct (by its Rust name).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Elem {
    /// A primitive.
    Scalar(Scalar),
    /// A nested `#[repr(C)]` struct, e.g. `"Header"`.
    Struct(&'static str),
}

impl Elem {
    /// Rust spelling of the element type.
    pub fn rust(self) -> &'static str {
        match self {
            Elem::Scalar(s) => s.rust(),
            Elem::Struct(name) => name,
        }
    }
}

/// One field of a [`TypeLayout`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// Field name (the same in Rust, C and Python).
    pub name: &'static str,
    /// Byte offset from the start of the struct (`offset_of!`).
    pub offset: usize,
    /// Size in bytes (`size_of` of the field's type).
    pub size: usize,
    /// Element type.
    pub elem: Elem,
    /// Array dimensions, outermost first (`[[f32; 3]; 64]` is `[64, 3]`); empty for a scalar.
    pub dims: Vec<usize>,
    /// Unit or meaning of each element: an SI unit (`"m"`, `"rad"`, `"ns"`, `"mm"`), `"px"`,
    /// `"1"` (dimensionless), `"count"`, `"id"`, `"enum <module>"` (values in [`constants`]),
    /// `"bool"` (0 or 1), `"struct"` (see the nested type), `"pad"` (always 0).
    pub unit: &'static str,
}

impl Field {
    /// Number of elements (product of [`Field::dims`], 1 for a scalar).
    pub fn count(&self) -> usize {
        self.dims.iter().product()
    }
}

/// Layout of one `#[repr(C)]` message type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TypeLayout {
    /// Rust name, e.g. `"DepthFrame"` (C: `vpsom_DepthFrame`, Python: `DepthFrame`).
    pub name: &'static str,
    /// iceoryx2 type name (`ZeroCopySend::type_name`), e.g. `"vpsom::DepthFrame"`.
    pub type_name: &'static str,
    /// `size_of`.
    pub size: usize,
    /// `align_of`.
    pub align: usize,
    /// Fields in offset order.
    pub fields: Vec<Field>,
}

impl TypeLayout {
    /// Byte ranges `(offset, len)` not covered by any field (padding the compiler inserts);
    /// the generated C and Python layouts spell them out as `_padN` byte arrays.
    pub fn gaps(&self) -> Vec<(usize, usize)> {
        let mut gaps = Vec::new();
        let mut at = 0;
        for f in &self.fields {
            if f.offset > at {
                gaps.push((at, f.offset - at));
            }
            at = at.max(f.offset + f.size);
        }
        if self.size > at {
            gaps.push((at, self.size - at));
        }
        gaps
    }
}

/// One topic of a run: the service `vpsom/<namespace>/<topic>` and its payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Topic {
    /// Topic name, the last part of the service name (e.g. `"robot/state"`).
    pub topic: &'static str,
    /// Rust name of the payload type (a [`TypeLayout::name`]).
    pub payload: &'static str,
    /// Who publishes it in a simulated run; on a robot, `sim` topics come from its drivers.
    pub producer: &'static str,
    /// What it carries.
    pub doc: &'static str,
}

/// Every topic of a run, in the order of `vpsom::topics`.
pub fn topics() -> &'static [Topic] {
    describe::TOPICS
}

/// Every message type (topic payloads and the structs nested in them), dependencies first.
pub fn types() -> Vec<TypeLayout> {
    describe::types()
}

/// A named integer constant of the contract (capacities and enum values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Constant {
    /// Group: `"capacity"` or the Rust module of an enum (`"nav_status"`).
    pub group: &'static str,
    /// Name within the group (`"MAX_WIDTH"`, `"MOVING"`).
    pub name: &'static str,
    /// Value.
    pub value: u64,
}

/// Capacities and enum values, read from the Rust constants.
pub fn constants() -> Vec<Constant> {
    describe::constants()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Our types have no padding (tests/contract.rs checks it), so the `_padN` path of the
    /// generators is exercised here on a made-up layout: `u8` at 0, `u32` at 4, size 12.
    #[test]
    fn gaps_become_explicit_padding_in_c_and_python() {
        let field = |name, offset, size, s| Field {
            name,
            offset,
            size,
            elem: Elem::Scalar(s),
            dims: vec![],
            unit: "1",
        };
        let t = TypeLayout {
            name: "Holey",
            type_name: "vpsom::Holey",
            size: 12,
            align: 4,
            fields: vec![field("a", 0, 1, Scalar::U8), field("b", 4, 4, Scalar::U32)],
        };
        assert_eq!(t.gaps(), vec![(1, 3), (8, 4)]);
        let mut h = String::new();
        c_header::write_struct(&mut h, &t);
        let a = h.find("uint8_t a;").unwrap();
        let pad = h.find("uint8_t _pad1[3];").unwrap();
        let b = h.find("uint32_t b;").unwrap();
        assert!(a < pad && pad < b && h.contains("uint8_t _pad8[4];"), "{h}");
        let mut p = String::new();
        python::write_class(&mut p, &t);
        assert!(p.contains("(\"_pad1\", ctypes.c_uint8 * 3)"), "{p}");
        assert!(p.contains("(\"_pad8\", ctypes.c_uint8 * 4)"), "{p}");
    }

    #[test]
    fn names_and_dims_are_spelled_per_language() {
        assert_eq!(c_header::upper_snake("DepthFrame"), "DEPTH_FRAME");
        assert_eq!(c_header::upper_snake("robot/state"), "ROBOT_STATE");
        assert_eq!(c_header::upper_snake("Pose3"), "POSE3");
        let points = types()
            .into_iter()
            .find(|t| t.name == "MapObject")
            .unwrap()
            .fields
            .into_iter()
            .find(|f| f.name == "points")
            .unwrap();
        assert_eq!(points.dims, vec![crate::MAX_OBJECT_POINTS, 3]);
        assert_eq!(points.count(), 3 * crate::MAX_OBJECT_POINTS);
        assert!(c_header().contains("float points[64][3];"));
        assert!(python_module().contains("(\"points\", (ctypes.c_float * 3) * 64)"));
    }
}
