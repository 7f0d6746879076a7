//! The plausibility bounds that [`Validate`](crate::Validate) applies beyond "finite" and
//! "within capacity". Each is wide enough for every value a working producer sends (the
//! simulator, mapper and planner stay far inside them; the session tests check that they never
//! publish a rejected sample) and narrow enough to catch garbage: uninitialised memory, a units
//! error (millimetres for metres, degrees for radians), an angle that was never wrapped.

use std::f32::consts::{FRAC_PI_2, TAU};

/// Largest `|x|`, `|y|` or `|z|` of a world-frame position, metres (1 km about the world origin).
/// Indoor scenes span tens of metres; at 1 km an `f32` still resolves 61 µm, far below any map
/// resolution. Also bounds an object's extent and an occupancy grid's far corner.
pub const MAX_WORLD_COORD_M: f32 = 1000.0;

/// Largest `|yaw|`, radians: two full turns either way. Receivers wrap yaws to `(-π, π]`; a
/// producer need not (a camera yaw summed from a wrapped base yaw and a wrapped neck yaw reaches
/// 2π), but a yaw past two turns is not an angle anyone computed on purpose, and wrapping a
/// huge `f32` loses all its precision.
pub const MAX_YAW_RAD: f32 = 2.0 * TAU;

/// Largest `|pitch|`, radians: straight down (`+π/2`) or straight up (`-π/2`). Receivers clamp
/// to their mount's range.
pub const MAX_PITCH_RAD: f32 = FRAC_PI_2;
