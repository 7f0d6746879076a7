"""Example robot driver: publishes depth, detections, robot/state and nav/grid into a `vpsom run` namespace.

Replays a short generated sequence (a chair-sized box 1.5 m in front of a still camera on a wall
3 m away) at the contract rates: depth + detections at --camera-hz (config rates.camera_hz = 30),
robot/state at --state-hz (rates.state_hz = 50), and the navigation map (nav/grid: a pre-built
obstacle grid of the 4 m x 4 m room with the chair in it, as a robot's mapping stack gives) once a
second. After each sample it notifies the event service of the same name (the runtime's
subscribers block on it). --nan-pose N makes depth frame N (1-based) carry a NaN camera pose,
which the mapper must reject and count.

    python shm_types/python/replay_driver.py NAMESPACE [--frames 30] [--nan-pose 5]

Needs `pip install iceoryx2==0.10.0` (the iceoryx2 crate version in Cargo.lock).
Prints one JSON line: {"robot/state": n, "depth": n, "detections": n, "nav/grid": n,
"nan_pose_frames": n}.
"""

import argparse
import ctypes
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import iceoryx2 as iox2  # noqa: E402
import vpsom_topics as vt  # noqa: E402

W, H, FX = 320, 240, 277.0
BOX = (120, 80, 200, 160)  # u0, v0, u1, v1 px of the object in every frame
WALL_MM, OBJECT_MM = 3000, 1500
# Navigation grid: the room x in [-1, 3), y in [-2, 2) m (walls on its border), the chair's
# footprint x in [1.5, 1.8), y in [-0.25, 0.25) m.
GRID_ORIGIN, GRID_RES = (-1.5, -2.5), 0.05
GRID_W, GRID_H = 100, 100
ROOM = (-1.0, 3.0, -2.0, 2.0)
CHAIR = (1.5, 1.8, -0.25, 0.25)


class Port:
    """One publisher plus the notifier of its event service."""

    def __init__(self, node, namespace, topic):
        name = iox2.ServiceName.new(vt.service_name(namespace, topic))
        svc = node.service_builder(name).publish_subscribe(vt.TOPICS[topic]).open()
        ev = node.service_builder(name).event().open()
        self.publisher = svc.publisher_builder().create()
        self.notifier = ev.notifier_builder().create()
        self.sent = 0

    def send(self, fill, zero=True):
        sample = self.publisher.loan_uninit()
        payload = sample.payload().contents
        if zero:
            ctypes.memset(ctypes.addressof(payload), 0, ctypes.sizeof(payload))
        fill(payload)
        sample.assume_init().send()
        self.notifier.notify()
        self.sent += 1


def depth_rows():
    background = (ctypes.c_uint16 * W)(*([WALL_MM] * W))
    u0, v0, u1, v1 = BOX
    obj = [WALL_MM] * u0 + [OBJECT_MM] * (u1 - u0) + [WALL_MM] * (W - u1)
    return background, (ctypes.c_uint16 * W)(*obj)


def fill_grid(g):
    """The navigation map: occupied outside the room and on the chair, free elsewhere."""
    g.origin[:] = list(GRID_ORIGIN)
    g.resolution, g.width, g.height = GRID_RES, GRID_W, GRID_H

    def inside(box, x, y):
        return box[0] <= x < box[1] and box[2] <= y < box[3]

    cells = bytearray(GRID_W * GRID_H)
    for iy in range(GRID_H):
        y = GRID_ORIGIN[1] + (iy + 0.5) * GRID_RES
        for ix in range(GRID_W):
            x = GRID_ORIGIN[0] + (ix + 0.5) * GRID_RES
            free = inside(ROOM, x, y) and not inside(CHAIR, x, y)
            cells[iy * GRID_W + ix] = vt.GRID_CELL_FREE if free else vt.GRID_CELL_OCCUPIED
    ctypes.memmove(ctypes.addressof(g.cells), bytes(cells), len(cells))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("namespace", help="the run's namespace (vpsom run prints it)")
    ap.add_argument("--frames", type=int, default=30, help="depth+detections frames to send")
    ap.add_argument("--camera-hz", type=float, default=30.0)
    ap.add_argument("--state-hz", type=float, default=50.0)
    ap.add_argument("--nan-pose", type=int, default=0, help="frame number (1-based) sent with a NaN pose")
    ap.add_argument("--class", dest="cls", default="chair", help="COCO class of the object")
    args = ap.parse_args()

    # The run's own iceoryx2 instance (per-user root directory and prefix).
    node = iox2.NodeBuilder.new().config(vt.iceoryx2_config(iox2)).create(iox2.ServiceType.Ipc)
    topics = ("robot/state", "depth", "detections", "nav/grid")
    ports = {t: Port(node, args.namespace, t) for t in topics}
    background, object_row = depth_rows()
    row_bytes = W * 2
    class_id = vt.COCO_CLASSES.index(args.cls)
    t0 = time.monotonic_ns()
    cam_period, state_period = 1.0 / args.camera_hz, 1.0 / args.state_hz
    next_cam = next_state = next_grid = time.monotonic()
    frames = state_seq = grid_seq = nan_frames = 0

    def header(h, seq):
        now = time.monotonic_ns()
        h.seq, h.stamp_ns, h.sim_time_ns = seq, now, now - t0

    while frames < args.frames:
        now = time.monotonic()
        if now >= next_state:
            state_seq += 1

            def state(p):
                header(p.header, state_seq)
                p.localization_ok = 1
                p.odom_cov[0] = p.odom_cov[4] = p.odom_cov[8] = 1e-4

            ports["robot/state"].send(state)
            next_state += state_period
        if now >= next_grid:
            grid_seq += 1

            def grid(g):
                header(g.header, grid_seq)
                fill_grid(g)

            ports["nav/grid"].send(grid)
            next_grid += 1.0
        if now >= next_cam:
            frames += 1
            bad = frames == args.nan_pose

            def depth(p):
                header(p.header, frames)
                p.width, p.height = W, H
                i = p.intrinsics
                i.fx, i.fy, i.cx, i.cy, i.min_range, i.max_range = FX, FX, W / 2, H / 2, 0.3, 8.0
                p.camera_pose.translation[:] = [float("nan") if bad else 0.0, 0.0, 1.0]
                # world_from_camera: optical z forward along world +x, x right, y down.
                p.camera_pose.rotation[:] = [-0.5, 0.5, -0.5, 0.5]
                base = ctypes.addressof(p.depth_mm)
                for v in range(H):
                    row = object_row if BOX[1] <= v < BOX[3] else background
                    ctypes.memmove(base + v * row_bytes, row, row_bytes)
                p.reserved = 0

            def dets(p):
                header(p.header, frames)
                p.frame_seq = frames
                p.width, p.height, p.count, p.masks = W, H, 1, vt.MASK_MODE_BOXES
                d = p.items[0]
                d.class_id, d.label, d.score = class_id, 1, 0.9
                d.bbox[:] = list(BOX)

            ports["depth"].send(depth, zero=False)
            ports["detections"].send(dets)
            nan_frames += bad
            next_cam += cam_period
        time.sleep(max(0.0, min(next_cam, next_state) - time.monotonic()))

    counts = {t: p.sent for t, p in ports.items()}
    counts["nan_pose_frames"] = nan_frames
    print(json.dumps(counts), flush=True)


if __name__ == "__main__":
    main()
