//! The [`Message`] trait: every top-level payload carries a [`Header`], and a loaned shared-memory
//! sample can be zero-initialised in place ([`init_zeroed`]) without a stack temporary.

use crate::{
    DeadlineEvent, DepthFrame, Detections, Header, NavGoal, NeckGoal, ObjectMap, OccupancyGrid,
    PlannerDecision, RobotState, ZeroValid, zero_in_place,
};
use iceoryx2::prelude::ZeroCopySend;
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::sample_mut_uninit::SampleMutUninit;
use std::fmt::Debug;
use std::mem::MaybeUninit;

/// A top-level message: zero-valid, sendable through iceoryx2, and starting with a [`Header`]
/// that the runtime's publisher stamps (sequence number, source time).
pub trait Message: ZeroValid + Debug + 'static {
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
    PlannerDecision
);

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
