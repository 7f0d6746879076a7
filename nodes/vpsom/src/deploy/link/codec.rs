//! The used bytes of a large message, for the link's relay topics (`link/<topic>`, byte-slice
//! services: see `throttle.rs`). A `DepthFrame` is 614 KB whatever the camera size, a
//! `Detections` 309 KB with or without masks, an `ObjectMap` 707 KB for any number of objects;
//! their encodings here are what a consumer reads of them, and nothing else:
//!
//! | message | encoding (in order) |
//! |---|---|
//! | [`DepthFrame`] | `width`, `height`, `intrinsics`, `camera_pose`, `reserved`; the `width × height` pixels |
//! | [`Detections`] | `frame_seq`, `width`, `height`, `count`, `masks`; the `count` items; the `width × height` label pixels only if `masks == MASKS` |
//! | [`ObjectMap`] | `last_frame_seq`, `last_frame_stamp_ns`, `count`, `eps_sopm`, the three frame counts, `receipt_count`; the used receipts; per used object its scalar fields, its `rows × cols` SOPM cells (`sopm_prob`, then `sopm_obs`), its `sample_count` points and lines of sight, `support_height` |
//!
//! The [`Header`] is not part of an encoding: it travels as the slice service's user header
//! (`runtime::ports::SliceLoan::header_mut`), and [`Codec::decode`] takes it separately.
//! Fields are written in the host's byte order, as the fixed-size samples they replace were
//! (both ends of a link run the same build on the same architecture), and read unaligned (a
//! slice payload is only byte-aligned). Entries past the used part (pixels, items, cells,
//! points) are not sent; [`Codec::decode`] writes only the used part of its destination (a
//! zero-filled loan, so the rest reads 0).
//!
//! Decoding checks every length it reads against the type's capacity before using it, and
//! that the slice holds exactly the bytes its counts say: a truncated or oversized slice is a
//! [`DecodeError`], never a panic. The decoded message is then validated as any other sample
//! ([`shm_types::Validate`]) by the relay.
//!
//! No compression. Of the crates in `Cargo.lock`, `zstd` (foxglove's MCAP chunks) and `lz4`
//! could compress depth, but each would add an encode and a decode of every sample to the
//! tunnel thread of a loaded 2-CPU robot, and zenoh's own transport compression is built out on
//! purpose (the root `Cargo.toml`: RUSTSEC-2026-0041). The waste was the unused capacity, which
//! this encoding drops at no extra cost.

use shm_types::{
    DepthFrame, Detection, Detections, FrameReceipt, Header, MAX_DETECTIONS, MAX_FRAME_RECEIPTS,
    MAX_HEIGHT, MAX_OBJECT_POINTS, MAX_OBJECTS, MAX_SOPM_CELLS, MAX_WIDTH, MapObject, Message,
    ObjectMap, mask_mode,
};
use std::mem::size_of;

/// Why a slice did not decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The slice ended before the field its counts say comes next.
    #[error(
        "{message}: truncated at {field} (needs {need} more bytes at offset {at}, slice is {len})"
    )]
    Truncated {
        /// Message type.
        message: &'static str,
        /// The field being read.
        field: &'static str,
        /// Bytes it needs.
        need: usize,
        /// Where it starts.
        at: usize,
        /// The slice's length.
        len: usize,
    },
    /// The slice is longer than its counts say.
    #[error("{message}: {extra} bytes past the encoded message (slice is {len})")]
    Oversized {
        /// Message type.
        message: &'static str,
        /// Bytes left over.
        extra: usize,
        /// The slice's length.
        len: usize,
    },
    /// A count or size is beyond the type's capacity.
    #[error("{message}: {field} = {value} exceeds its capacity {max}")]
    Capacity {
        /// Message type.
        message: &'static str,
        /// The field.
        field: &'static str,
        /// Its value.
        value: usize,
        /// The capacity.
        max: usize,
    },
}

/// A message with a compact encoding of its used part (see the module docs).
pub trait Codec: Message {
    /// The longest encoding of any value: the relay publisher's maximum slice length.
    const MAX_ENCODED: usize;
    /// Bytes [`Self::encode`] writes for `self`.
    fn encoded_len(&self) -> usize;
    /// Write the encoding into `out`, which is [`Self::encoded_len`] bytes long.
    fn encode(&self, out: &mut [u8]);
    /// Make `dst` (zero-filled, or holding an earlier message) the message `bytes` encode,
    /// with `header`: every field a consumer reads is written.
    fn decode(header: &Header, bytes: &[u8], dst: &mut Self) -> Result<(), DecodeError>;
}

/// Writes fields one after the other.
struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, b: &[u8]) {
        self.out[self.at..self.at + b.len()].copy_from_slice(b);
        self.at += b.len();
    }

    fn put<T: bytemuck::NoUninit>(&mut self, v: T) {
        self.bytes(bytemuck::bytes_of(&v));
    }

    fn all<T: bytemuck::NoUninit>(&mut self, v: &[T]) {
        self.bytes(bytemuck::cast_slice(v));
    }
}

/// Reads fields one after the other, refusing to read past the end.
struct Reader<'a> {
    message: &'static str,
    b: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, field: &'static str, n: usize) -> Result<&'a [u8], DecodeError> {
        let left = self.b.len() - self.at;
        if n > left {
            return Err(DecodeError::Truncated {
                message: self.message,
                field,
                need: n - left,
                at: self.at,
                len: self.b.len(),
            });
        }
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn get<T: bytemuck::AnyBitPattern>(&mut self, field: &'static str) -> Result<T, DecodeError> {
        Ok(bytemuck::pod_read_unaligned(
            self.take(field, size_of::<T>())?,
        ))
    }

    fn fill<T: bytemuck::Pod>(
        &mut self,
        field: &'static str,
        dst: &mut [T],
    ) -> Result<(), DecodeError> {
        let src = self.take(field, std::mem::size_of_val(dst))?;
        bytemuck::cast_slice_mut::<T, u8>(dst).copy_from_slice(src);
        Ok(())
    }

    /// `value` if it is at most `max`.
    fn capped(&self, field: &'static str, value: usize, max: usize) -> Result<usize, DecodeError> {
        if value > max {
            return Err(DecodeError::Capacity {
                message: self.message,
                field,
                value,
                max,
            });
        }
        Ok(value)
    }

    fn finish(self) -> Result<(), DecodeError> {
        match self.b.len() - self.at {
            0 => Ok(()),
            extra => Err(DecodeError::Oversized {
                message: self.message,
                extra,
                len: self.b.len(),
            }),
        }
    }
}

/// `DepthFrame` fields before the pixels: width, height, 6 intrinsics, 7 pose, reserved.
const DEPTH_FIXED: usize = 4 + 4 + 6 * 4 + 7 * 4 + 4;

impl Codec for DepthFrame {
    const MAX_ENCODED: usize = DEPTH_FIXED + MAX_WIDTH * MAX_HEIGHT * 2;

    fn encoded_len(&self) -> usize {
        DEPTH_FIXED + 2 * self.pixels().len()
    }

    fn encode(&self, out: &mut [u8]) {
        let mut w = Writer { out, at: 0 };
        w.put(self.width);
        w.put(self.height);
        let i = &self.intrinsics;
        w.all(&[i.fx, i.fy, i.cx, i.cy, i.min_range, i.max_range]);
        w.all(&self.camera_pose.translation);
        w.all(&self.camera_pose.rotation);
        w.put(self.reserved);
        w.all(self.pixels());
        debug_assert_eq!(w.at, w.out.len());
    }

    fn decode(header: &Header, bytes: &[u8], dst: &mut Self) -> Result<(), DecodeError> {
        let mut r = Reader {
            message: "DepthFrame",
            b: bytes,
            at: 0,
        };
        let width: u32 = r.get("width")?;
        let height: u32 = r.get("height")?;
        r.capped("width", width as usize, MAX_WIDTH)?;
        r.capped("height", height as usize, MAX_HEIGHT)?;
        let mut intr = [0f32; 6];
        r.fill("intrinsics", &mut intr)?;
        let mut t = [0f32; 3];
        r.fill("camera_pose", &mut t)?;
        let mut q = [0f32; 4];
        r.fill("camera_pose", &mut q)?;
        let reserved: u32 = r.get("reserved")?;
        dst.header = *header;
        dst.width = width;
        dst.height = height;
        let [fx, fy, cx, cy, min_range, max_range] = intr;
        dst.intrinsics = shm_types::Intrinsics {
            fx,
            fy,
            cx,
            cy,
            min_range,
            max_range,
        };
        dst.camera_pose.translation = t;
        dst.camera_pose.rotation = q;
        dst.reserved = reserved;
        r.fill("depth_mm", dst.pixels_mut())?;
        r.finish()
    }
}

/// `Detections` fields before the items: frame_seq, width, height, count, masks.
const DETS_FIXED: usize = 8 + 4 * 4;

impl Codec for Detections {
    const MAX_ENCODED: usize =
        DETS_FIXED + MAX_DETECTIONS * size_of::<Detection>() + MAX_WIDTH * MAX_HEIGHT;

    fn encoded_len(&self) -> usize {
        let labels = if self.masks == mask_mode::MASKS {
            self.label_pixels().len()
        } else {
            0
        };
        DETS_FIXED + size_of_val(self.detections()) + labels
    }

    fn encode(&self, out: &mut [u8]) {
        let mut w = Writer { out, at: 0 };
        w.put(self.frame_seq);
        w.put(self.width);
        w.put(self.height);
        w.put(self.detections().len() as u32);
        w.put(self.masks);
        w.all(self.detections());
        if self.masks == mask_mode::MASKS {
            w.all(self.label_pixels());
        }
        debug_assert_eq!(w.at, w.out.len());
    }

    fn decode(header: &Header, bytes: &[u8], dst: &mut Self) -> Result<(), DecodeError> {
        let mut r = Reader {
            message: "Detections",
            b: bytes,
            at: 0,
        };
        let frame_seq: u64 = r.get("frame_seq")?;
        let width: u32 = r.get("width")?;
        let height: u32 = r.get("height")?;
        let count: u32 = r.get("count")?;
        let masks: u32 = r.get("masks")?;
        r.capped("width", width as usize, MAX_WIDTH)?;
        r.capped("height", height as usize, MAX_HEIGHT)?;
        let n = r.capped("count", count as usize, MAX_DETECTIONS)?;
        dst.header = *header;
        dst.frame_seq = frame_seq;
        dst.width = width;
        dst.height = height;
        dst.count = count;
        dst.masks = masks;
        r.fill("items", &mut dst.items[..n])?;
        if masks == mask_mode::MASKS {
            r.fill("labels", dst.label_pixels_mut())?;
        }
        r.finish()
    }
}

/// `ObjectMap` fields before the receipts: 2 × u64, count, eps_sopm, 3 frame counts,
/// receipt_count.
const MAP_FIXED: usize = 2 * 8 + 6 * 4;
/// A receipt: frame_seq, state_seq, outcome, reserved.
const RECEIPT: usize = 8 + 8 + 4 + 4;
/// An object's fields before its cells: first_seen_ns, id, class_id, background, complete,
/// center, size, yaw, point_count, cluster_id, observations, h_sopm, c_asso, l_best,
/// sopm_shape, reserved, sopm_cols, sopm_rows, sample_count.
const OBJECT_FIXED: usize =
    8 + 4 + size_of::<shm_types::ClassId>() + 1 + 1 + 12 + 12 + 4 * 6 + 12 + 1 + 1 + 2 * 3;
/// An object's `support_height`.
const OBJECT_TAIL: usize = 4;

fn object_len(o: &MapObject) -> usize {
    let samples = (o.sample_count as usize).min(MAX_OBJECT_POINTS);
    OBJECT_FIXED + o.cell_count() * (4 + 2) + samples * 2 * 12 + OBJECT_TAIL
}

impl Codec for ObjectMap {
    const MAX_ENCODED: usize = MAP_FIXED
        + MAX_FRAME_RECEIPTS * RECEIPT
        + MAX_OBJECTS
            * (OBJECT_FIXED + MAX_SOPM_CELLS * (4 + 2) + MAX_OBJECT_POINTS * 2 * 12 + OBJECT_TAIL);

    fn encoded_len(&self) -> usize {
        MAP_FIXED
            + self.receipts().len() * RECEIPT
            + self.objects().iter().map(object_len).sum::<usize>()
    }

    fn encode(&self, out: &mut [u8]) {
        let mut w = Writer { out, at: 0 };
        w.put(self.last_frame_seq);
        w.put(self.last_frame_stamp_ns);
        w.put(self.objects().len() as u32);
        w.put(self.eps_sopm);
        w.put(self.frames_integrated);
        w.put(self.frames_rejected);
        w.put(self.frames_unmatched);
        w.put(self.receipt_count);
        for r in self.receipts() {
            w.put(r.frame_seq);
            w.put(r.state_seq);
            w.put(r.outcome);
            w.put(r.reserved);
        }
        for o in self.objects() {
            w.put(o.first_seen_ns);
            w.put(o.id);
            w.put(o.class_id);
            w.put(o.background);
            w.put(o.complete);
            w.all(&o.center);
            w.all(&o.size);
            w.put(o.yaw);
            w.put(o.point_count);
            w.put(o.cluster_id);
            w.put(o.observations);
            w.put(o.h_sopm);
            w.put(o.c_asso);
            w.all(&o.l_best);
            w.put(o.sopm_shape);
            w.put(o.reserved);
            w.put(o.sopm_cols);
            w.put(o.sopm_rows);
            let samples = (o.sample_count as usize).min(MAX_OBJECT_POINTS);
            w.put(samples as u16);
            let cells = o.cell_count();
            w.all(&o.sopm_prob[..cells]);
            w.all(&o.sopm_obs[..cells]);
            w.all(&o.points[..samples]);
            w.all(&o.point_los[..samples]);
            w.put(o.support_height);
        }
        debug_assert_eq!(w.at, w.out.len());
    }

    fn decode(header: &Header, bytes: &[u8], dst: &mut Self) -> Result<(), DecodeError> {
        let mut r = Reader {
            message: "ObjectMap",
            b: bytes,
            at: 0,
        };
        let last_frame_seq = r.get("last_frame_seq")?;
        let last_frame_stamp_ns = r.get("last_frame_stamp_ns")?;
        let count: u32 = r.get("count")?;
        let n = r.capped("count", count as usize, MAX_OBJECTS)?;
        let eps_sopm = r.get("eps_sopm")?;
        let frames_integrated = r.get("frames_integrated")?;
        let frames_rejected = r.get("frames_rejected")?;
        let frames_unmatched = r.get("frames_unmatched")?;
        let receipt_count: u32 = r.get("receipt_count")?;
        dst.header = *header;
        dst.last_frame_seq = last_frame_seq;
        dst.last_frame_stamp_ns = last_frame_stamp_ns;
        dst.count = count;
        dst.eps_sopm = eps_sopm;
        dst.frames_integrated = frames_integrated;
        dst.frames_rejected = frames_rejected;
        dst.frames_unmatched = frames_unmatched;
        dst.receipt_count = receipt_count;
        let receipts = (receipt_count as usize).min(MAX_FRAME_RECEIPTS);
        for d in &mut dst.receipts[..receipts] {
            *d = FrameReceipt {
                frame_seq: r.get("receipts")?,
                state_seq: r.get("receipts")?,
                outcome: r.get("receipts")?,
                reserved: r.get("receipts")?,
            };
        }
        for o in &mut dst.objects[..n] {
            o.first_seen_ns = r.get("first_seen_ns")?;
            o.id = r.get("id")?;
            o.class_id = r.get("class_id")?;
            o.background = r.get("background")?;
            o.complete = r.get("complete")?;
            r.fill("center", &mut o.center)?;
            r.fill("size", &mut o.size)?;
            o.yaw = r.get("yaw")?;
            o.point_count = r.get("point_count")?;
            o.cluster_id = r.get("cluster_id")?;
            o.observations = r.get("observations")?;
            o.h_sopm = r.get("h_sopm")?;
            o.c_asso = r.get("c_asso")?;
            r.fill("l_best", &mut o.l_best)?;
            o.sopm_shape = r.get("sopm_shape")?;
            o.reserved = r.get("reserved")?;
            o.sopm_cols = r.get("sopm_cols")?;
            o.sopm_rows = r.get("sopm_rows")?;
            let samples: u16 = r.get("sample_count")?;
            let samples = r.capped("sample_count", samples as usize, MAX_OBJECT_POINTS)?;
            o.sample_count = samples as u16;
            let cells = r.capped(
                "sopm_rows x sopm_cols",
                o.sopm_rows as usize * o.sopm_cols as usize,
                MAX_SOPM_CELLS,
            )?;
            r.fill("sopm_prob", &mut o.sopm_prob[..cells])?;
            r.fill("sopm_obs", &mut o.sopm_obs[..cells])?;
            r.fill("points", &mut o.points[..samples])?;
            r.fill("point_los", &mut o.point_los[..samples])?;
            o.support_height = r.get("support_height")?;
        }
        r.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::{boxed_zeroed, frame_outcome};

    fn header() -> Header {
        Header {
            seq: 42,
            stamp_ns: 1_000,
            sim_time_ns: 2_000,
        }
    }

    fn frame(w: u32, h: u32) -> Box<DepthFrame> {
        let mut f = boxed_zeroed::<DepthFrame>();
        f.header = header();
        f.width = w;
        f.height = h;
        f.intrinsics = shm_types::Intrinsics {
            fx: 500.0,
            fy: 501.0,
            cx: 159.5,
            cy: 119.5,
            min_range: 0.5,
            max_range: 5.0,
        };
        f.camera_pose.translation = [1.0, 2.0, 1.4];
        f.camera_pose.rotation = [0.0, 0.0, 0.0, 1.0];
        for (k, p) in f.pixels_mut().iter_mut().enumerate() {
            *p = (k % 5000) as u16;
        }
        f
    }

    fn encode<T: Codec>(m: &T) -> Vec<u8> {
        let mut out = vec![0u8; m.encoded_len()];
        m.encode(&mut out);
        out
    }

    fn decode<T: Codec>(bytes: &[u8]) -> Result<Box<T>, DecodeError> {
        let mut d = boxed_zeroed::<T>();
        T::decode(&header(), bytes, &mut d)?;
        Ok(d)
    }

    #[test]
    fn a_depth_frame_is_its_used_pixels_and_round_trips() {
        let f = frame(320, 240);
        let b = encode(&*f);
        assert_eq!(b.len(), DEPTH_FIXED + 320 * 240 * 2);
        assert!(b.len() < size_of::<DepthFrame>() / 3);
        let d = decode::<DepthFrame>(&b).unwrap();
        assert_eq!(d.header, f.header);
        assert_eq!((d.width, d.height), (f.width, f.height));
        assert_eq!(d.intrinsics, f.intrinsics);
        assert_eq!(d.camera_pose, f.camera_pose);
        assert_eq!(d.pixels(), f.pixels());
        // The longest frame fits the capacity exactly.
        assert_eq!(encode(&*frame(640, 480)).len(), DepthFrame::MAX_ENCODED);
    }

    fn detections(masks: bool) -> Box<Detections> {
        let mut d = boxed_zeroed::<Detections>();
        d.header = header();
        d.frame_seq = 41;
        d.width = 64;
        d.height = 48;
        d.count = 3;
        d.masks = if masks {
            mask_mode::MASKS
        } else {
            mask_mode::BOXES
        };
        for k in 0..3 {
            d.items[k] = Detection {
                class_id: 41 + k as u16,
                label: if masks { k as u16 + 1 } else { 0 },
                score: 0.5 + 0.1 * k as f32,
                bbox: [k as u16, 1, 10 + k as u16, 20],
                mask_pixels: if masks { 10 } else { 0 },
            };
        }
        if masks {
            for k in 0..3 {
                d.label_pixels_mut()[k * 10..k * 10 + 10].fill(k as u8 + 1);
            }
        }
        d
    }

    #[test]
    fn detections_are_their_items_and_masks_only_in_mask_mode() {
        for masks in [false, true] {
            let s = detections(masks);
            let b = encode(&*s);
            let labels = if masks { 64 * 48 } else { 0 };
            assert_eq!(b.len(), DETS_FIXED + 3 * size_of::<Detection>() + labels);
            let d = decode::<Detections>(&b).unwrap();
            assert_eq!(d.header, s.header);
            assert_eq!(
                (d.frame_seq, d.width, d.height, d.count, d.masks),
                (s.frame_seq, s.width, s.height, s.count, s.masks)
            );
            assert_eq!(d.detections(), s.detections());
            if masks {
                assert_eq!(d.label_pixels(), s.label_pixels());
            }
            shm_types::Validate::validate(&*d).unwrap();
        }
    }

    fn map() -> Box<ObjectMap> {
        let mut m = boxed_zeroed::<ObjectMap>();
        m.header = header();
        m.last_frame_seq = 40;
        m.last_frame_stamp_ns = 999;
        m.count = 2;
        m.eps_sopm = 0.3;
        m.frames_integrated = 30;
        m.frames_rejected = 1;
        m.frames_unmatched = 2;
        m.receipt_count = 2;
        m.receipts[0] = FrameReceipt {
            frame_seq: 39,
            state_seq: 77,
            outcome: frame_outcome::INTEGRATED,
            reserved: 0,
        };
        m.receipts[1] = FrameReceipt {
            frame_seq: 40,
            state_seq: 78,
            outcome: frame_outcome::NO_DETECTIONS,
            reserved: 0,
        };
        for (k, o) in m.objects[..2].iter_mut().enumerate() {
            o.first_seen_ns = 100 + k as u64;
            o.id = 7 + k as u32;
            o.class_id = 41;
            o.background = 0;
            o.complete = k as u8;
            o.center = [1.0, 2.0 + k as f32, 0.8];
            o.size = [0.1, 0.1, 0.12];
            o.yaw = 0.3;
            o.point_count = 500;
            o.cluster_id = -1;
            o.observations = 12;
            o.h_sopm = 0.4;
            o.c_asso = 0.9;
            o.l_best = [0.0, 1.0, 0.0];
            o.sopm_shape = 0;
            o.sopm_cols = 12;
            o.sopm_rows = 3 + k as u16;
            o.sample_count = 5 + k as u16;
            for c in 0..o.cell_count() {
                o.sopm_prob[c] = c as f32 / 100.0;
                o.sopm_obs[c] = c as u16;
            }
            for i in 0..o.sample_count as usize {
                o.points[i] = [1.0, 2.0, i as f32 * 0.01];
                o.point_los[i] = [0.0, 0.0, -1.0];
            }
            o.support_height = 0.0;
        }
        m
    }

    #[test]
    fn a_map_is_its_used_objects_cells_and_samples_and_round_trips() {
        let m = map();
        let b = encode(&*m);
        assert_eq!(b.len(), m.encoded_len());
        // Two objects with 36 and 48 cells and 11 samples in all: 1 032 bytes, not 707 KB.
        assert_eq!(b.len(), 1032);
        let d = decode::<ObjectMap>(&b).unwrap();
        assert_eq!(d.header, m.header);
        assert_eq!(
            (d.last_frame_seq, d.last_frame_stamp_ns, d.count, d.eps_sopm),
            (m.last_frame_seq, m.last_frame_stamp_ns, m.count, m.eps_sopm)
        );
        assert_eq!(
            (d.frames_integrated, d.frames_rejected, d.frames_unmatched),
            (m.frames_integrated, m.frames_rejected, m.frames_unmatched)
        );
        assert_eq!(d.receipt_count, m.receipt_count);
        assert_eq!(d.receipts(), m.receipts());
        for (a, b) in d.objects().iter().zip(m.objects()) {
            assert_eq!(
                (a.first_seen_ns, a.id, a.class_id, a.background, a.complete),
                (b.first_seen_ns, b.id, b.class_id, b.background, b.complete)
            );
            assert_eq!((a.center, a.size, a.yaw), (b.center, b.size, b.yaw));
            assert_eq!(
                (a.point_count, a.cluster_id, a.observations),
                (b.point_count, b.cluster_id, b.observations)
            );
            assert_eq!(
                (a.h_sopm, a.c_asso, a.l_best),
                (b.h_sopm, b.c_asso, b.l_best)
            );
            assert_eq!(
                (a.sopm_shape, a.reserved, a.sopm_cols, a.sopm_rows),
                (b.sopm_shape, b.reserved, b.sopm_cols, b.sopm_rows)
            );
            assert_eq!(a.cells(), b.cells());
            assert_eq!(a.sopm_obs[..a.cell_count()], b.sopm_obs[..b.cell_count()]);
            assert!(a.samples().eq(b.samples()));
            assert_eq!(a.support_height, b.support_height);
        }
        shm_types::Validate::validate(&*d).unwrap();
        // The full map fits the capacity exactly.
        let mut full = boxed_zeroed::<ObjectMap>();
        full.count = MAX_OBJECTS as u32;
        full.receipt_count = MAX_FRAME_RECEIPTS as u32;
        for o in &mut full.objects {
            o.sopm_rows = 18;
            o.sopm_cols = 36;
            o.sample_count = MAX_OBJECT_POINTS as u16;
        }
        assert_eq!(full.encoded_len(), ObjectMap::MAX_ENCODED);
        assert!(decode::<ObjectMap>(&encode(&*full)).is_ok());
    }

    /// Every cut of an encoding is refused (never a panic), and so is one byte too many.
    fn refuses_truncated_and_oversized<T: Codec>(bytes: &[u8]) {
        for cut in 0..bytes.len() {
            let e = decode::<T>(&bytes[..cut]).err();
            assert!(
                matches!(
                    e,
                    Some(DecodeError::Truncated { .. } | DecodeError::Capacity { .. })
                ),
                "cut at {cut} of {}: {e:?}",
                bytes.len()
            );
        }
        let mut long = bytes.to_vec();
        long.push(0);
        assert!(matches!(
            decode::<T>(&long),
            Err(DecodeError::Oversized { extra: 1, .. })
        ));
    }

    #[test]
    fn truncated_or_oversized_slices_are_refused() {
        refuses_truncated_and_oversized::<DepthFrame>(&encode(&*frame(8, 6)));
        refuses_truncated_and_oversized::<Detections>(&encode(&*detections(false)));
        refuses_truncated_and_oversized::<Detections>(&encode(&*detections(true)));
        refuses_truncated_and_oversized::<ObjectMap>(&encode(&*map()));
    }

    #[test]
    fn counts_beyond_capacity_are_refused_before_use() {
        let mut b = encode(&*frame(8, 6));
        b[..4].copy_from_slice(&(MAX_WIDTH as u32 + 1).to_ne_bytes());
        let e = decode::<DepthFrame>(&b).unwrap_err();
        assert!(
            matches!(e, DecodeError::Capacity { field: "width", .. }),
            "{e}"
        );
        let mut b = encode(&*detections(false));
        b[16..20].copy_from_slice(&(MAX_DETECTIONS as u32 + 1).to_ne_bytes());
        let e = decode::<Detections>(&b).unwrap_err();
        assert!(
            matches!(e, DecodeError::Capacity { field: "count", .. }),
            "{e}"
        );
        let mut b = encode(&*map());
        b[16..20].copy_from_slice(&(MAX_OBJECTS as u32 + 1).to_ne_bytes());
        let e = decode::<ObjectMap>(&b).unwrap_err();
        assert!(
            matches!(e, DecodeError::Capacity { field: "count", .. }),
            "{e}"
        );
    }
}
