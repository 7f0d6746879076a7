//! Zero-copy message types shared by every vpsom-rt process.
//!
//! Every payload here is `#[repr(C)]`, self-contained (no pointers, no heap, no `Drop`), of fixed
//! capacity, and carries a stable iceoryx2 type name (`vpsom::<Name>`) so that producers and
//! consumers built separately agree on the layout. Producers write a loaned sample in place;
//! consumers read it in place. Logic beyond accessors and validation lives elsewhere.
//!
//! Conventions (all messages):
//! - world frame: x forward/east, y left/north, z up, metres, floor at z = 0;
//! - camera frame: OpenCV optical frame (x right, y down, z forward);
//! - [`Pose3`] stores `parent_from_child` as a translation and a unit quaternion `[x, y, z, w]`;
//! - angles are radians; times are nanoseconds.
//!
//! Every type implements [`Validate`], which rejects NaN/inf, out-of-range counts and values
//! outside the documented rules (each type's `Validate` impl lists them; the plausibility bounds
//! are in [`bounds`]), and
//! [`ZeroValid`], which states that all-zero bytes are a valid value (so a loaned sample can be
//! zero-filled in place and then written field by field, and lockstep hosts can heap-allocate one
//! with [`boxed_zeroed`] without building it on the stack). The large frame types also implement
//! [`AnyBitPattern`], which lets a producer that overwrites every field it publishes skip that
//! fill ([`init_reused`]).
//!
//! # Files
//! | file | content |
//! |---|---|
//! | `messages.rs` | the message types, their capacities and enum values, `validate()` |
//! | `message.rs` | [`Message`], [`init_zeroed`], [`init_reused`] |
//! | `validate.rs` | [`Validate`], [`ValidationError`] |
//! | `bounds.rs` | [`bounds`]: the plausibility bounds validation applies (world extent, yaw, pitch) |
//! | `health.rs` | [`NodeHealth`]: every node's heartbeat and input counts (the `health` topic) |
//! | `classes.rs` | the COCO class table |
//! | `contract/` | [`contract`]: every topic's service name, type name, size, alignment, field offsets and units, and the generated C header and Python module |
//! | `include/vpsom_topics.h`, `python/vpsom_topics.py` | generated from [`contract`], committed |
//!
//! # Publishing from C, C++ or Python (the topic contract)
//! A robot's drivers (camera SDK, detector, base controller) can publish straight into a run's
//! shared memory with iceoryx2's own C, C++ or Python bindings (0.10, the version in
//! `Cargo.lock`). [`contract`] describes every topic; two files generated from it are committed
//! and checked against the Rust layout by `tests/contract.rs` (`gcc` compiles the header's
//! `_Static_assert`s, `python3` compares the `ctypes` offsets):
//! - C/C++: `#include "vpsom_topics.h"` (`shm_types/include/`). Structs are `vpsom_<Name>`,
//!   services `VPSOM_SERVICE("<namespace>", VPSOM_TOPIC_DEPTH)`, type names
//!   `VPSOM_TYPE_NAME_DEPTH_FRAME`; in C++ each struct carries `IOX2_TYPE_NAME`, so
//!   `service_builder(name).publish_subscribe<vpsom_DepthFrame>()` opens our service as it is.
//! - Python: `import vpsom_topics` (`shm_types/python/`), then
//!   `node.service_builder(iox2.ServiceName.new(vpsom_topics.service_name(ns, "depth")))
//!   .publish_subscribe(vpsom_topics.DepthFrame)`: the class's `type_name()` gives iceoryx2 the
//!   type name, ctypes the size and alignment.
//!
//! The node must use the run's iceoryx2 instance: every user has its own
//! ([`contract::iceoryx2_root_path`], [`contract::iceoryx2_prefix`]; Python:
//! `NodeBuilder.new().config(vpsom_topics.iceoryx2_config(iox2))`, C/C++: `global.root-path`
//! and `global.prefix` from `VPSOM_IOX2_ROOT_FMT` / `VPSOM_IOX2_PREFIX_FMT` with the uid), and
//! only that user's processes can open it.
//!
//! What the service must match: payload type name `vpsom::<Name>`, `size_of`, `align_of`, no
//! user header. Start `vpsom run` first and *open* the services (our nodes create them with the
//! `[ports]` settings of `config/default.toml`; a service created first by a driver with
//! iceoryx2's defaults may have smaller buffers than our subscribers ask for, and then our
//! nodes cannot open it). After each send, notify the event service of the same name: our
//! subscribers block on it between samples. Fill the [`Header`] (`seq` from 1, `stamp_ns` on
//! `CLOCK_MONOTONIC`), keep every `reserved` byte 0, and expect a sample that fails
//! [`Validate`] (NaN, counts past capacity, a non-unit quaternion) to be rejected and counted.

// The workspace denies unsafe code; this crate is where it is the point: in-place
// initialisation writes through raw pointers and trusts `ZeroValid`/`AnyBitPattern`, which
// bytemuck's derives establish field by field. Every unsafe block still carries a
// `// SAFETY:` comment (`clippy::undocumented_unsafe_blocks`, from the workspace lints).
#![allow(unsafe_code)]

pub mod bounds;
mod classes;
#[cfg(feature = "ipc")]
pub mod contract;
mod health;
mod message;
mod messages;
mod validate;

pub use classes::{COCO_CLASSES, ClassId, class_id, class_name, is_background_class};
pub use health::{HEALTH_NODE_LEN, HEALTH_TOPIC_LEN, InputHealth, MAX_HEALTH_INPUTS, NodeHealth};
pub use message::Message;
#[cfg(feature = "ipc")]
pub use message::{init_reused, init_zeroed};
pub use messages::*;
pub use validate::{Validate, ValidationError};

/// Payloads whose all-zero bit pattern is a valid value.
///
/// Implemented for every type that is [`bytemuck::Zeroable`], which each message type derives
/// (`#[derive(bytemuck::Zeroable)]`): the derive checks that **every field** is `Zeroable`, so a
/// field whose all-zero bytes are not a value (a reference, a `NonZero*`, an enum without a
/// zero variant, ...) fails to compile instead of making an unsound impl:
///
/// ```compile_fail,E0277
/// #[repr(u8)]
/// #[derive(Debug, Clone, Copy)]
/// enum Mode { Idle = 1, Busy = 2 } // no variant is 0
///
/// #[derive(bytemuck::Zeroable)]
/// #[repr(C)]
/// struct Status { seq: u64, mode: Mode } // error: `Mode: Zeroable` is not satisfied
/// ```
///
/// The same struct with a `u8` field compiles and is `ZeroValid`:
///
/// ```
/// # #[cfg(feature = "ipc")]
/// # use iceoryx2::prelude::ZeroCopySend;
/// #[derive(Debug, bytemuck::Zeroable)]
/// #[cfg_attr(feature = "ipc", derive(ZeroCopySend))]
/// #[repr(C)]
/// struct Status { seq: u64, mode: u8 }
///
/// let s = shm_types::boxed_zeroed::<Status>();
/// assert_eq!((s.seq, s.mode), (0, 0));
/// ```
pub trait ZeroValid: bytemuck::Zeroable + IpcSend {}

impl<T: bytemuck::Zeroable + IpcSend> ZeroValid for T {}

/// With the `ipc` feature (the runtime and the app turn it on), iceoryx2's `ZeroCopySend`: the
/// payload can be sent through shared memory. Without it (the logic crates, which never touch
/// iceoryx2), every type: the message types are plain `#[repr(C)]` data.
#[cfg(feature = "ipc")]
pub trait IpcSend: iceoryx2::prelude::ZeroCopySend {}
#[cfg(feature = "ipc")]
impl<T: iceoryx2::prelude::ZeroCopySend> IpcSend for T {}
/// See the `ipc` version: without the feature, every type.
#[cfg(not(feature = "ipc"))]
pub trait IpcSend {}
#[cfg(not(feature = "ipc"))]
impl<T> IpcSend for T {}

/// Payloads for which **every** bit pattern of `size_of::<Self>()` initialised bytes is a valid
/// value (not only all zeros), so memory that held an earlier value of the same type may be
/// handed out as a `Self` without being cleared first ([`init_reused`]).
///
/// Implemented for every [`ZeroValid`] type that is [`bytemuck::AnyBitPattern`], which
/// [`DepthFrame`] and [`Detections`] derive (`#[derive(bytemuck::AnyBitPattern)]`, which also
/// derives `Zeroable`): the derive checks that every field is `AnyBitPattern` (integers, floats,
/// arrays and structs of them), so a `bool`, `char`, enum, reference or pointer field fails to
/// compile:
///
/// ```compile_fail,E0277
/// #[derive(Debug, Clone, Copy, bytemuck::AnyBitPattern)]
/// #[repr(C)]
/// struct Frame { seq: u64, valid: bool } // error: `bool: AnyBitPattern` is not satisfied
/// ```
///
/// With a `u8` in its place it compiles and is `AnyBitPattern`:
///
/// ```
/// # #[cfg(feature = "ipc")]
/// # use iceoryx2::prelude::ZeroCopySend;
/// #[derive(Debug, Clone, Copy, bytemuck::AnyBitPattern)]
/// #[cfg_attr(feature = "ipc", derive(ZeroCopySend))]
/// #[repr(C)]
/// struct Frame { seq: u64, valid: u8 }
///
/// fn reusable<T: shm_types::AnyBitPattern>() {}
/// reusable::<Frame>();
/// ```
///
/// (`bytemuck::AnyBitPattern` requires `Copy`: `DepthFrame` and `Detections` are `Copy`, but are
/// ~600 KB and ~300 KB; keep them behind a `Box` or in a sample and never copy one by value.)
pub trait AnyBitPattern: ZeroValid + bytemuck::AnyBitPattern {}

impl<T: ZeroValid + bytemuck::AnyBitPattern> AnyBitPattern for T {}

/// A heap-allocated, zero-initialised `T`, built without a stack temporary (a `DepthFrame` is
/// ~1 MB). Used by in-process (lockstep) hosting and by tests.
pub fn boxed_zeroed<T: ZeroValid>() -> Box<T> {
    let layout = std::alloc::Layout::new::<T>();
    assert!(layout.size() > 0, "zero-sized payloads are not messages");
    // SAFETY: the layout is non-zero-sized (checked above); `ZeroValid` guarantees the all-zero
    // bit pattern is a valid `T`, so the allocation is initialised; the pointer comes from the
    // global allocator with `T`'s layout, which is what `Box::from_raw` requires.
    unsafe {
        let ptr = std::alloc::alloc_zeroed(layout) as *mut T;
        if ptr.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        Box::from_raw(ptr)
    }
}

/// Overwrite `value` with all-zero bytes in place (used to reset a reused buffer or to initialise a
/// loaned shared-memory sample without building a stack temporary).
pub fn zero_in_place<T: ZeroValid>(value: &mut std::mem::MaybeUninit<T>) -> &mut T {
    // SAFETY: `value` is a valid, exclusive, properly aligned place for one `T`; after writing
    // zero bytes it holds a valid `T` because `T: ZeroValid`.
    unsafe {
        std::ptr::write_bytes(value.as_mut_ptr(), 0, 1);
        value.assume_init_mut()
    }
}
