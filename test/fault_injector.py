#!/usr/bin/env python3
"""Fault injection for the pose estimator: replays a simulator bag's SensorFrames and TF in
simulated time (it publishes /clock itself, as `rosbag play --clock` does) while applying one
fault, and scores what the node publishes against the bag's ground truth.

Used as a library by test_faults.py (the replay runs inside the test node), and as a node of its
own for a sensor node that is restarted (a separate process with its own publisher):

    fault_injector.py follow --bag B --topic /cam5/sensor_frame [--xmlrpc-port P] __name:=cam5_sensor

publishes the bag's frames of one topic as the simulated clock (/clock, from the replayer)
passes their record times, from the moment it starts (older frames are skipped).

Every fault keeps to the bag's times: `s` is seconds since the bag's first message.
"""
import argparse
import bisect
import copy
import heapq
import io
import math
import random
import sys
import time

import numpy as np
import rosbag
import rospy
from geometry_msgs.msg import TransformStamped
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

from drill_pipe_pose.msg import PipeBox, SensorFrame

LABELS = ("box_end", "pin_end")


# ---------------------------------------------------------------------------------------------
# The bag


class BagData:
    """A simulate_bag bag in memory: the frames (deserialised), /tf_static, ground truth."""

    def __init__(self, path, topics=None):
        self.path = path
        self.frames = []          # (s, topic, msg), sorted by record time
        self.tf_static = []       # geometry_msgs/TransformStamped
        self.truth = {lab: ([], []) for lab in LABELS}  # label -> (stamps [s], 4x4 poses)
        self.t0 = None
        with rosbag.Bag(path) as bag:
            self.t0 = bag.get_start_time()
            self.t_end = bag.get_end_time()
            for topic, msg, t in bag.read_messages(topics=topics):
                s = t.to_sec() - self.t0
                if topic.endswith("/sensor_frame"):
                    self.frames.append((s, topic, msg))
                elif topic == "/tf_static":
                    self.tf_static.extend(msg.transforms)
                elif topic.startswith("/ground_truth/") and topic.rsplit("/", 1)[1] in LABELS:
                    lab = topic.rsplit("/", 1)[1]  # the ends' poses (not /ground_truth/joints)
                    self.truth[lab][0].append(msg.header.stamp.to_sec())
                    self.truth[lab][1].append(pose_matrix(msg.pose))
        self.frames.sort(key=lambda f: f[0])
        self.duration = self.t_end - self.t0
        self.cameras = sorted({f[2].camera for f in self.frames})

    def truth_at(self, label, stamp):
        """Ground truth of `label` at `stamp` [s]: the nearest sample (the scenes the fault tests
        use are static), or None when no sample lies within 50 ms."""
        stamps, poses = self.truth[label]
        if not stamps:
            return None
        i = bisect.bisect_left(stamps, stamp)
        best = min((j for j in (i - 1, i) if 0 <= j < len(stamps)), key=lambda j: abs(stamps[j] - stamp))
        if abs(stamps[best] - stamp) > 0.05:
            return None
        return poses[best]

    def static_transform(self, parent, child):
        for t in self.tf_static:
            if t.header.frame_id == parent and t.child_frame_id == child:
                return t
        raise KeyError(f"{parent} -> {child} not in the bag's /tf_static")


# ---------------------------------------------------------------------------------------------
# Geometry (as core/metrics.cpp and core/evaluation.cpp score an estimate)


def quat_matrix(q):
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def pose_matrix(pose):
    T = np.eye(4)
    o, p = pose.orientation, pose.position
    T[:3, :3] = quat_matrix((o.x, o.y, o.z, o.w))
    T[:3, 3] = (p.x, p.y, p.z)
    return T


def canonical_rotation(z):
    z = np.asarray(z, float) / np.linalg.norm(z)
    a = np.array([0.0, 1.0, 0.0]) if abs(z[0]) > 0.87 else np.array([1.0, 0.0, 0.0])
    x = a - a.dot(z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def rotation_vector(R):
    c = max(-1.0, min(1.0, (np.trace(R) - 1) / 2))
    angle = math.acos(c)
    if angle < 1e-9:
        return np.zeros(3)
    if abs(math.pi - angle) < 1e-6:  # a half turn: the axis from the symmetric part
        axis = np.sqrt(np.maximum(np.diag(R) + 1, 0) / 2)
        return angle * axis
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2 * math.sin(angle))
    return angle * axis


def sigma_check(T_true, T_est, cov):
    """(position d^2, axis d^2, position error [m], axis error [deg]) of one estimate against the
    truth, in the reported covariance (6x6 row-major: x y z, rotation about world x y z):
    inside the 3-sigma ellipsoid when d^2 <= 9, as `evaluate` counts it."""
    C = np.array(cov, float).reshape(6, 6)
    e = T_est[:3, 3] - T_true[:3, 3]
    z_true, z_est = T_true[:3, 2], T_est[:3, 2]
    axis_deg = math.degrees(math.acos(max(-1.0, min(1.0, float(z_true.dot(z_est) /
                                                                 (np.linalg.norm(z_true) * np.linalg.norm(z_est)))))))
    R_true, R_est = canonical_rotation(z_true), canonical_rotation(z_est)
    r = T_true[:3, :3] @ rotation_vector(R_true.T @ R_est)
    P, Q = C[:3, :3], C[3:, 3:]
    d2_pos = float(e @ np.linalg.solve(P, e)) if np.trace(P) > 0 else float("nan")
    d2_rot = float(r @ np.linalg.solve(Q, r)) if np.trace(Q) > 0 else float("nan")
    return d2_pos, d2_rot, float(np.linalg.norm(e)), axis_deg


# ---------------------------------------------------------------------------------------------
# Faults. A fault sees every frame of the replay and every /tf_static or /tf it sends.


class Fault:
    """No fault (the baseline). Subclasses change frames, TF or the timeline."""

    name = "none"
    camera = None
    start = None   # [s] of the bag when the fault begins (None: none)
    end = None     # [s] when it ends (None: it lasts to the end of the replay)

    def segments(self, duration):
        """The bag's time spans to play, in order ([(from, to)]: more than one makes the clock
        jump)."""
        return [(0.0, duration)]

    def frame(self, s, topic, msg):
        """[(extra wall delay [s], topic, msg)] to publish for the bag's frame at `s`."""
        return [(0.0, topic, msg)]

    def tf_static(self, transforms, s):
        """The /tf_static transforms in force at `s`, from the bag's `transforms`."""
        return transforms

    def tf_static_changes(self):
        """Bag times [s] at which tf_static() changes."""
        return []

    def dynamic_tf(self, s):
        """Transforms to publish on /tf at `s` (30 Hz), or []."""
        return []

    def actions(self):
        """[(s, name)] of actions the test runs during the replay (the replayer calls
        `on_action(name)`)."""
        return []


class Flapping(Fault):
    """The camera's frames stop and start: off [start, start+1), on 1 s, off 1 s, ..."""

    name = "flapping"

    def __init__(self, camera, start=2.0, end=5.0, period=1.0):
        self.camera, self.start, self.end, self.period = camera, start, end, period

    def frame(self, s, topic, msg):
        if msg.camera == self.camera and self.start <= s < self.end:
            if int((s - self.start) // self.period) % 2 == 0:
                return []
        return [(0.0, topic, msg)]


class Late(Fault):
    """The camera's frames arrive `delay` seconds (wall) after their time, stamps unchanged."""

    name = "late"

    def __init__(self, camera, delay=0.3, start=2.0, end=5.0):
        self.camera, self.delay, self.start, self.end = camera, delay, start, end

    def frame(self, s, topic, msg):
        if msg.camera == self.camera and self.start <= s < self.end:
            return [(self.delay, topic, msg)]
        return [(0.0, topic, msg)]


class TfGone(Fault):
    """The camera's colour-to-depth TF (the driver's, as kinect2_bridge publish_tf sends it) is
    published on /tf at 30 Hz, stamped 0.1 s ahead; it stops for [start, end) and comes back.

    The node looks a frame's transforms up in its own copy of /tf_static first (latest), then in
    the live tf2 buffer at the frame's stamp. A transform it has once had on /tf_static it keeps
    for its whole life, so the camera's depth frame is renamed here (frame ids of the depth image
    and depth CameraInfo) to one that never appears on /tf_static: every lookup of this camera
    goes to the live buffer, whatever earlier test cases sent."""

    name = "tf_gone"

    def __init__(self, camera, start=2.0, end=4.0, ahead=0.1):
        self.camera, self.start, self.end, self.ahead = camera, start, end, ahead
        self.depth_frame = f"{camera}_ir_optical_frame_driver"
        self.template = None

    def bind(self, bag):
        t = copy.deepcopy(bag.static_transform(f"{self.camera}_rgb_optical_frame",
                                               f"{self.camera}_ir_optical_frame"))
        t.child_frame_id = self.depth_frame
        self.template = t

    def frame(self, s, topic, msg):
        if msg.camera == self.camera:
            msg = copy.deepcopy(msg)
            msg.depth.header.frame_id = self.depth_frame
            msg.depth_info.header.frame_id = self.depth_frame
        return [(0.0, topic, msg)]

    def dynamic_tf(self, s):
        if self.start <= s < self.end:
            return []
        return [self.template]


class TfJump(Fault):
    """At `start` the camera's world -> <cam>_link on /tf_static is republished moved `shift`
    metres along the camera's view (its optical z), while the camera has not moved: the drift
    watch must flag it."""

    name = "tf_jump"

    def __init__(self, camera, shift=0.05, start=2.0):
        self.camera, self.shift, self.start = camera, shift, start

    def tf_static_changes(self):
        return [self.start]

    def tf_static(self, transforms, s):
        if s < self.start:
            return transforms
        out = []
        for t in transforms:
            if t.header.frame_id == "world" and t.child_frame_id == f"{self.camera}_link":
                t = copy.deepcopy(t)
                r = t.transform.rotation
                view = quat_matrix((r.x, r.y, r.z, r.w))[:, 2]  # <cam>_link = optical frame
                t.transform.translation.x += self.shift * view[0]
                t.transform.translation.y += self.shift * view[1]
                t.transform.translation.z += self.shift * view[2]
            out.append(t)
        return out


class ManyBoxes(Fault):
    """The camera's detector sends `count` boxes per frame in [start, end): its own boxes and
    random ones over the colour image (seeded)."""

    name = "many_boxes"

    def __init__(self, camera, seed, count=1000, start=2.0, end=5.0):
        self.camera, self.seed, self.count, self.start, self.end = camera, seed, count, start, end

    def frame(self, s, topic, msg):
        if msg.camera != self.camera or not (self.start <= s < self.end):
            return [(0.0, topic, msg)]
        msg = copy.deepcopy(msg)
        w, h = msg.color_info.width, msg.color_info.height
        rng = random.Random(self.seed * 1000003 + int(round(s * 1000)))
        while len(msg.boxes) < self.count:
            bw, bh = rng.uniform(8, 80), rng.uniform(8, 80)
            x, y = rng.uniform(0, w - bw), rng.uniform(0, h - bh)
            msg.boxes.append(PipeBox(label=LABELS[len(msg.boxes) % 2], confidence=rng.uniform(0.3, 1.0),
                                     x_min=x, y_min=y, x_max=x + bw, y_max=y + bh))
        return [(0.0, topic, msg)]


class HugeFrame(Fault):
    """One frame of the camera at `start` declares a depth sensor `factor` x `factor` times the
    Kinect v2's (100x its pixel count with factor 10: 5120 x 4240, 43 MB of 16UC1) with the
    intrinsics scaled to match, and carries that many pixels: the real frame's crop, upsampled,
    in its place, zeros (no measurement) elsewhere. A consistent frame: only a size limit can
    refuse it.

    It is serialised beforehand and published `lead` seconds (wall) before its time (negative:
    after), so that tens of MB on loopback and their deserialisation in the node do not make it
    miss its cycle: a frame that misses its cycle is dropped as too late before anything looks
    at it, and the case would test the synchroniser, not the size limit."""

    name = "huge_frame"

    def __init__(self, camera, factor=10, start=2.0, end=3.0, lead=0.2):
        self.camera, self.factor, self.start, self.end, self.lead = camera, factor, start, end, lead
        self.sent_at = None
        self.bytes = 0

    def frame(self, s, topic, msg):
        if msg.camera != self.camera or s < self.start or self.sent_at is not None:
            return [(0.0, topic, msg)]
        self.sent_at = s
        big = self.enlarge(msg)
        buff = io.BytesIO()
        big.serialize(buff)
        return [(-self.lead, topic, Serialized(buff.getvalue(), big.header))]

    def enlarge(self, msg):
        k = self.factor
        m = copy.deepcopy(msg)
        info = m.depth_info
        roi = info.roi
        W, H = info.width * k, info.height * k
        crop = np.frombuffer(msg.depth.data, dtype="<u2").reshape(msg.depth.height, msg.depth.step // 2)
        crop = crop[:, :msg.depth.width]
        full = np.zeros((H, W), dtype="<u2")
        x0, y0 = (roi.x_offset * k, roi.y_offset * k) if roi.width else (0, 0)
        big = np.repeat(np.repeat(crop, k, axis=0), k, axis=1)
        full[y0:y0 + big.shape[0], x0:x0 + big.shape[1]] = big
        info.width, info.height = W, H
        K = list(info.K)
        K[0], K[2], K[4], K[5] = K[0] * k, (K[2] + 0.5) * k - 0.5, K[4] * k, (K[5] + 0.5) * k - 0.5
        info.K = K
        P = list(info.P)
        P[0], P[2], P[5], P[6] = P[0] * k, (P[2] + 0.5) * k - 0.5, P[5] * k, (P[6] + 0.5) * k - 0.5
        info.P = P
        info.roi.x_offset = info.roi.y_offset = info.roi.width = info.roi.height = 0
        m.depth.width, m.depth.height, m.depth.step = W, H, 2 * W
        m.depth.data = full.tobytes()
        self.bytes = len(m.depth.data)
        return m


class Serialized(SensorFrame):
    """A SensorFrame serialised beforehand: publishing it only copies its bytes."""

    __slots__ = ["_raw"]

    def __init__(self, raw, header):
        super().__init__()
        self._raw = raw
        self.header = header

    def serialize(self, buff):
        buff.write(self._raw)


class ClockBack(Fault):
    """The bag plays to `at`, then the clock jumps back to `to` and it plays on from there."""

    name = "clock_back"

    def __init__(self, at=4.5, to=2.0):
        self.at, self.to = at, to
        self.start = at  # (of the first segment: the replayer maps it to wall time)

    def segments(self, duration):
        return [(0.0, self.at), (self.to, duration)]


class Silent(Fault):
    """The cameras send nothing for the whole replay (dead from the start)."""

    name = "silent"

    def __init__(self, cameras):
        self.cameras = set(cameras)
        self.start = 0.0

    def frame(self, s, topic, msg):
        return [] if msg.camera in self.cameras else [(0.0, topic, msg)]


class Action(Fault):
    """No change to the data; the test acts at `start` (kills the estimator, restarts a sensor
    node ...). `skip`: cameras whose frames the replayer leaves to another process."""

    def __init__(self, name, start=2.0, skip=()):
        self.name, self.start, self.skip = name, start, set(skip)

    def frame(self, s, topic, msg):
        return [] if msg.camera in self.skip else [(0.0, topic, msg)]

    def actions(self):
        return [(self.start, self.name)]


# ---------------------------------------------------------------------------------------------
# The replayer


class Replayer:
    """Publishes /clock, /tf_static (latched), /tf and the cameras' SensorFrames of a BagData in
    simulated time at `rate`, with one Fault applied. Call from a rospy node."""

    def __init__(self, bag, rate=1.0, clock_hz=200.0, tf_hz=30.0):
        self.bag, self.rate, self.clock_hz, self.tf_hz = bag, rate, clock_hz, tf_hz
        self.clock_pub = rospy.Publisher("/clock", Clock, queue_size=20)
        self.static_pub = rospy.Publisher("/tf_static", TFMessage, queue_size=10, latch=True)
        self.tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=50)
        self.frame_pubs = {}
        for _, topic, _ in bag.frames:
            if topic not in self.frame_pubs:
                self.frame_pubs[topic] = rospy.Publisher(topic, SensorFrame, queue_size=50,
                                                         tcp_nodelay=True)

    def publish_static(self, transforms, stamp):
        msg = TFMessage()
        for t in transforms:
            t = copy.deepcopy(t)
            t.header.stamp = rospy.Time.from_sec(stamp)
            msg.transforms.append(t)
        self.static_pub.publish(msg)

    def run(self, fault, pre_roll=1.0, tail=1.5, on_action=None, on_mark=None, marks=()):
        """Plays the bag through `fault`. Returns the timeline: wall time (time.monotonic()) of
        each segment's start, of the fault's start and end, of every action and mark, and of the
        end of the replay. `marks`: [(s, name)] at which on_mark(name) is called (RSS samples)."""
        bag, rate = self.bag, self.rate
        segments = fault.segments(bag.duration)
        t0 = bag.t0
        if hasattr(fault, "bind"):
            fault.bind(bag)
        events = []  # (wall offset, seq, kind, payload)
        seq = 0

        def push(w, kind, payload=None):
            nonlocal seq
            heapq.heappush(events, (w, seq, kind, payload))
            seq += 1

        # Wall offset of bag time s in segment i.
        starts, w = [], pre_roll
        for a, b in segments:
            starts.append(w)
            w += (b - a) / rate
        w_end = w

        def wall_of(i, s):
            return starts[i] + (s - segments[i][0]) / rate

        # /clock: frozen at the first segment's start during the pre-roll, then running.
        step = 1.0 / self.clock_hz
        w = 0.0
        while w < w_end + tail:
            if w < pre_roll:
                s = segments[0][0]
            elif w >= w_end:
                s = segments[-1][1]
            else:
                i = max(j for j in range(len(starts)) if starts[j] <= w)
                s = segments[i][0] + (w - starts[i]) * rate
            push(w, "clock", s)
            w += step
        # /tf_static: at the start of every segment (a clock jump back clears tf2's buffers) and
        # at each change the fault makes.
        base = list(bag.tf_static)
        for i, (a, b) in enumerate(segments):
            push(0.3 if i == 0 else starts[i] + 0.2, "static", a)
            for s in fault.tf_static_changes():
                if a <= s < b:
                    push(wall_of(i, s), "static", s)
        # /tf (dynamic transforms of the fault), the frames, actions, marks.
        for i, (a, b) in enumerate(segments):
            s = a - (pre_roll * rate if i == 0 else 0.0)
            tf_step = 1.0 / self.tf_hz
            while s < b:
                w = wall_of(i, s) if s >= a else (s - a) / rate + starts[i]
                if w >= 0.05:
                    push(w, "tf", s)
                s += tf_step
            for fs, topic, msg in bag.frames:
                if a <= fs < b:
                    for delay, t2, m2 in fault.frame(fs, topic, msg):
                        push(wall_of(i, fs) + delay, "frame", (t2, m2))
            for s, name in fault.actions():
                if a <= s < b and i == 0:
                    push(wall_of(i, s), "action", name)
            for s, name in marks:
                if a <= s < b and i == 0:
                    push(wall_of(i, s), "mark", name)
        timeline = {"segments": [], "actions": {}, "marks": {}}
        fault_w = None
        if fault.start is not None:
            i = next((j for j, (a, b) in enumerate(segments) if a <= fault.start <= b), 0)
            fault_w = wall_of(i, fault.start)
        end_w = None
        if fault.end is not None:
            end_w = wall_of(0, fault.end)

        wall0 = time.monotonic()
        timeline["start"] = wall0
        timeline["segments"] = [(wall0 + s, seg) for s, seg in zip(starts, segments)]
        timeline["fault_start"] = wall0 + fault_w if fault_w is not None else None
        timeline["fault_end"] = wall0 + end_w if end_w is not None else None
        timeline["replay_end"] = wall0 + w_end
        timeline["late_frames"] = 0
        while events:
            w, _, kind, payload = heapq.heappop(events)
            due = wall0 + w
            now = time.monotonic()
            if due > now:
                time.sleep(due - now)
            elif kind == "frame" and now - due > 0.05:
                timeline["late_frames"] += 1  # the replayer fell behind (a loaded machine)
            if kind == "clock":
                self.clock_pub.publish(Clock(clock=rospy.Time.from_sec(t0 + payload)))
            elif kind == "static":
                self.publish_static(fault.tf_static(base, payload), t0 + payload)
            elif kind == "tf":
                ts = fault.dynamic_tf(payload)
                if ts:
                    msg = TFMessage()
                    for t in ts:
                        t = copy.deepcopy(t)
                        t.header.stamp = rospy.Time.from_sec(t0 + payload + getattr(fault, "ahead", 0.0))
                        msg.transforms.append(t)
                    self.tf_pub.publish(msg)
            elif kind == "frame":
                topic, msg = payload
                self.frame_pubs[topic].publish(msg)
            elif kind == "action":
                timeline["actions"][payload] = time.monotonic()
                if on_action:
                    on_action(payload)
            elif kind == "mark":
                timeline["marks"][payload] = time.monotonic()
                if on_mark:
                    on_mark(payload)
        timeline["end"] = time.monotonic()
        return timeline


# ---------------------------------------------------------------------------------------------
# A sensor node of its own (restart tests)


def follow(args):
    rospy.init_node("fault_follower", anonymous=False, xmlrpc_port=args.xmlrpc_port,
                    tcpros_port=args.tcpros_port)
    bag = BagData(args.bag, topics=[args.topic])
    pub = rospy.Publisher(args.topic, SensorFrame, queue_size=50, tcp_nodelay=True)
    frames = [(s + bag.t0, m) for s, t, m in bag.frames if t == args.topic]
    now = rospy.get_rostime().to_sec()
    while now == 0.0 and not rospy.is_shutdown():
        time.sleep(0.002)
        now = rospy.get_rostime().to_sec()
    i = bisect.bisect_left([t for t, _ in frames], now - 0.02)
    print(f"fault_injector follow: {args.topic} from {now:.3f} s (frame {i} of {len(frames)})",
          flush=True)
    while not rospy.is_shutdown() and i < len(frames):
        now = rospy.get_rostime().to_sec()
        while i < len(frames) and frames[i][0] <= now:
            pub.publish(frames[i][1])
            i += 1
        time.sleep(0.002)
    # The bag is done: stay up (a sensor node does not leave) until killed.
    while not rospy.is_shutdown():
        time.sleep(0.1)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("follow", help="publish one topic of a bag as /clock passes its times")
    f.add_argument("--bag", required=True)
    f.add_argument("--topic", required=True)
    f.add_argument("--xmlrpc-port", type=int, default=0, help="the node's XML-RPC port (0: any)")
    f.add_argument("--tcpros-port", type=int, default=0, help="its TCPROS port (0: any)")
    args = p.parse_args(rospy.myargv()[1:])
    if args.cmd == "follow":
        follow(args)


if __name__ == "__main__":
    main()
