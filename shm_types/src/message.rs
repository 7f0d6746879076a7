//! The [`Message`] trait: every top-level payload carries a [`Header`], and (feature `ipc`) a
//! loaned shared-memory sample can be zero-initialised in place ([`init_zeroed`]) without a stack temporary, or, for
//! [`AnyBitPattern`] payloads, taken as it is ([`init_reused`]). Every message is [`Validate`]:
//! subscribers check each sample on receipt.

#[cfg(feature = "ipc")]
use crate::{AnyBitPattern, zero_in_place};
use crate::{
    DeadlineEvent, DepthFrame, Detections, FrameVisibility, Header, NavGoal, NeckGoal, NodeHealth,
    ObjectMap, OccupancyGrid, PlannerDecision, RobotState, Validate, ZeroValid,
};
#[cfg(feature = "ipc")]
use iceoryx2::{
    prelude::{ZeroCopySend, ipc},
    sample_mut::SampleMut,
    sample_mut_uninit::SampleMutUninit,
};
use std::fmt::Debug;
#[cfg(feature = "ipc")]
use std::mem::MaybeUninit;

/// A top-level message: zero-valid, sendable through iceoryx2, and starting with a [`Header`]
/// that the runtime's publisher stamps (sequence number, source time).
pub trait Message: ZeroValid + Validate + Debug + 'static {
    /// The message's header.
    fn header(&self) -> &Header;
    /// The message's header, mutable.
    fn header_mut(&mut self) -> &mut Header;
}

macro_rules! message {
    ($($t:ty),*) => {
        $(impl Message for $t {
            fn header(&self) -> &Header {
                &self.header
            }
            fn header_mut(&mut self) -> &mut Header {
                &mut self.header
            }
        })*
    };
}
message!(
    DepthFrame,
    Detections,
    RobotState,
    ObjectMap,
    OccupancyGrid,
    NavGoal,
    NeckGoal,
    DeadlineEvent,
    PlannerDecision,
    FrameVisibility,
    NodeHealth
);

#[cfg(feature = "ipc")]
/// Zero-fill a loaned, uninitialised iceoryx2 sample in place (in shared memory, no stack
/// temporary) and mark it initialised.
pub fn init_zeroed<S, T, H>(mut sample: SampleMutUninit<S, MaybeUninit<T>, H>) -> SampleMut<S, T, H>
where
    S: iceoryx2::service::Service,
    T: ZeroValid + Debug,
    H: ZeroCopySend + Debug,
{
    zero_in_place(sample.payload_mut());
    // SAFETY: `zero_in_place` wrote all-zero bytes over the whole payload, which is a valid `T`
    // because `T: ZeroValid`; the payload is therefore fully initialised.
    unsafe { sample.assume_init() }
}

#[cfg(feature = "ipc")]
/// Take a loaned, uninitialised iceoryx2 sample **as it is**, without clearing it: the payload
/// holds whatever this slot of the publisher's data segment last held: an earlier sample of the
/// same service (sent, or loaned and dropped) or the zeros the OS mapped the segment with. For
/// producers that overwrite every field they publish; saves the fill of [`init_zeroed`] (a
/// `DepthFrame` is 600 KB). Only for `ipc` services, whose data segment is shared memory.
pub fn init_reused<T, H>(
    sample: SampleMutUninit<ipc::Service, MaybeUninit<T>, H>,
) -> SampleMut<ipc::Service, T, H>
where
    T: AnyBitPattern + Debug,
    H: ZeroCopySend + Debug,
{
    // SAFETY: every byte of the payload is initialised. The data segment of an `ipc` publisher
    // is a POSIX shared-memory object that iceoryx2 creates exclusively (`O_EXCL`) for that
    // publisher and sizes with `ftruncate`, so the kernel maps it zero-filled. Afterwards a
    // payload slot is only ever written as `T`: the service is typed (its payload type name and
    // layout are fixed when it is created and checked by every port), every slot has the same
    // layout, and iceoryx2 hands a slot to one loan at a time, only after every subscriber has
    // released it. So each field's bytes hold zeros or a value once written to that same field,
    // and `T: AnyBitPattern` makes every such bit pattern a valid `T`.
    unsafe { sample.assume_init() }
}
