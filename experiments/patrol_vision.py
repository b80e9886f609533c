"""Level 4 of ``subsumption run patrol``: the suspicious target's encounter, scored against the ground truth.

The robot's own vision (detect, track, follow, pursuit in robots/patrol/patrol.yaml) runs on the rendered
camera pixels only. This module only *watches* and *scores*: it listens, as rostopic would, to the camera's
JPEG stream (for the strip), detect's alarm and target, track's box_info, follow's commands, pursuit's hold,
the collisions and the simulator's ground truth (the robot's true pose, the agents' poses); after the run it
projects each face card the world file describes into the camera (pinhole, pose and card geometry as the
renderer uses them) to know where the face truly was in every frame.

Metrics added to ``metrics.json`` (times in simulated seconds from the start):

- ``detected_at_s``: the first alarm raised on the target (its box on the target's face), when the scorer heard
  it; ``detected_in_image_s``: the time of the image it was found in (on the ROS graph a detection's time earlier);
- ``face_30px_at_s``: the first frame of the in-view run up to the stop in which the target's face was >= 30 px
  tall (if the robot stood still before it grew to 30 px: the first such frame after, so the next key is negative);
- ``stopped_at_s``: the first moment after the alarm that the robot stood still (true speed < 0.02 m/s and
  turn < 0.05 rad/s, from the ground truth's twist: see Truth.at_rest_after); ``stop_after_face_30px_s`` =
  stopped_at_s - face_30px_at_s (the issue's <= 0.5 s); ``stop_chain``: the same stop link by link (the
  alarm's image, the alarm, pursuit's stop, track's first box, follow's zero, the base's zero, at rest);
- ``followed_s``: how long follow's moving commands drove the robot (each until the next or the robot's
  ``cmd_timeout``); ``mean_follow_distance_m``: the mean true distance (centre to centre) to the target while
  following, from the moment the robot had closed in (the camera's true range to the face within CLOSED_IN_M
  of follow's distance_m) to the pursuit's end -- falling behind later counts, the approach does not;
  ``mean_follow_range_m`` the camera's range to the face card then (what distance_m sets);
  ``follow_closed_in_s`` how long that following drove; ``mean_follow_distance_with_approach_m`` over every
  moving command (the approach after the stop included: what ``mean_follow_distance_m`` meant before);
- ``lost_at_s``: the last confident box of the first pursuit; ``resumed_patrol_at_s``: the first goal the
  patrol sent after that pursuit ended;
- ``false_alarms``: alarms whose box was not on the target's face (an enrolled person, a poster), scored in the
  image the alarm was raised on (its stamp) with detect's target box heard nearest it; ``alarm_scores``: each
  alarm's times, box and IoU with the nearest suspect's true face box;
- ``box_lag_s``: how long after its image track's box was heard (median, max): on a loaded ROS graph, seconds;
- ``track_iou_in_view``: share of frames, while tracking, with the target's face in view, in which the box had
  IoU >= 0.5 with the true face box (frames in which a person stands between camera and face are not in
  view); ``collisions_while_following``; ``pursuits`` (one entry per pursuit);
- ``occlusions``: each stretch in a pursuit during which another agent (a person) hid the face, and how soon
  after it was back in view the box was on it again; ``refound_after_occlusion_s``: the worst of these for
  occlusions of at least 1 s (None: there was none; "never").

The pictures of the encounter and the record to score it again are written by
:mod:`experiments.patrol_vision_report`; where each face truly is comes from :mod:`experiments.face_truth`.
"""
from __future__ import annotations

import json
import math
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from geometry_msgs.msg import PointStamped, PoseArray, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, CompressedImage, RegionOfInterest
from std_msgs.msg import Bool, UInt32

from subsim.world import load_world
from subsumption.planar import yaw_of
from subsumption.runtime import NodeHandle
from vision.faces import FaceDetector
from vision.modules import Follow
from vision.recognition import enrol

from .face_truth import (FACING_MAX_DEG, IN_VIEW_MIN_PX, CameraModel, FaceCard, face_cards, in_view, iou, project_face,
                         roi_box, visible_part)


ROOT = Path(__file__).resolve().parent.parent
VISION_LEVEL = 4                            # the first level with the camera's pixels
STAFF = ROOT / "robots" / "patrol" / "staff"  # photos of the people allowed in (subsumption enrol's folder)
OCCLUSION_MIN_S = 1.0  # occlusions shorter than this are not scored as "re-found after an occlusion"
STILL_V, STILL_W = 0.02, 0.05               # m/s, rad/s: standing still
ALARM_IOU = 0.3                             # an alarm's box on the true face (the detector's box is larger)
CLOSED_IN_M = 0.3                           # following counts from a camera range within this of follow's distance_m
STRIP_EVERY_S = 0.25                        # frames kept for the strip (while pursuing, and just before)


# Enrolment ------------------------------------------------------------------------------------------------------
def staff_model(out: Path, photos: Path = STAFF) -> Path:
    """D/staff.npz: the people in `photos` enrolled with ``subsumption enrol``'s code (reused when newer than
    every photo)."""
    path = out / "staff.npz"
    newest = max((p.stat().st_mtime for p in photos.rglob("*") if p.is_file()), default=0.0)
    if path.exists() and path.stat().st_mtime >= newest:
        return path
    out.mkdir(parents=True, exist_ok=True)
    enrol(photos, "lbph", FaceDetector("haar_alt2"), log=lambda _: None).save(path)
    return path


# Watching the run -----------------------------------------------------------------------------------------------
def _stamp(msg) -> float:
    return msg.header.stamp.to_sec()


@dataclass
class VisionObserver:
    """Records what level 4 did and the truth to score it by; works on any NodeHandle (both runtimes)."""

    node: NodeHandle | None     # None: a recording read back (from_record), nothing to listen to
    robot_path: list[tuple[float, float, float, float]] = field(default_factory=list)   # t, x, y, yaw
    robot_speed: list[tuple[float, float, float]] = field(default_factory=list)         # t, true v, w (twist)
    agent_path: list[tuple[float, list[tuple[float, float, float]]]] = field(default_factory=list)
    frame_times: list[float] = field(default_factory=list)
    boxes: list[tuple[float, np.ndarray | None]] = field(default_factory=list)    # image stamp, box or None
    box_heard: list[float] = field(default_factory=list)                         # when each box was heard
    # alarms: time heard, the image's stamp (the frame the face was found in), the point (camera optical frame)
    alarms: list[tuple[float, float, tuple[float, float, float]]] = field(default_factory=list)
    targets: list[tuple[float, np.ndarray]] = field(default_factory=list)       # time heard, detect's box
    commands: list[tuple[float, float, float]] = field(default_factory=list)     # t, v, w of follow
    base_commands: list[tuple[float, float, float]] = field(default_factory=list)  # t, v, w reaching the base
    stops: list[float] = field(default_factory=list)          # when pursuit's stop (the inhibitor) was heard true
    holds: list[tuple[float, bool]] = field(default_factory=list)
    collisions: list[float] = field(default_factory=list)
    frames: list[tuple[float, bytes]] = field(default_factory=list)              # kept JPEGs for the strip
    _recent: deque = field(default_factory=lambda: deque(maxlen=12))
    _latest: deque = field(default_factory=lambda: deque(maxlen=90))   # the last 3 s of frames (stamp, JPEG)
    _last_boxed: float = -math.inf
    _last_kept: float = -math.inf
    _pursuing_until: float = -math.inf
    _collision_count: int = 0

    def __post_init__(self) -> None:
        n = self.node
        if n is None:
            return
        n.subscribe("/ground_truth", Odometry, self._on_truth)
        n.subscribe("/agents", PoseArray, self._on_agents)
        n.subscribe("/camera/rgb/image_raw/compressed", CompressedImage, self._on_frame)
        n.subscribe("/track/box_info", CameraInfo, self._on_box)
        n.subscribe("/posters/passed_alarm", PointStamped, self._on_alarm)  # detect's, posters held back
        n.subscribe("/posters/passed_target", RegionOfInterest, self._on_target)
        n.subscribe("/follow/cmd_vel", Twist, lambda m: self.commands.append((n.now(), m.linear.x, m.angular.z)))
        n.subscribe("/pursuit/hold", Bool, self._on_hold)
        n.subscribe("/pursuit/stop", Bool, lambda m: self.stops.append(n.now()) if m.data else None)
        n.subscribe("/cmd_vel", Twist, lambda m: self.base_commands.append((n.now(), m.linear.x, m.angular.z)))
        n.subscribe("/collisions", UInt32, self._on_collisions)

    def _on_truth(self, msg: Odometry) -> None:
        p = msg.pose.pose
        self.robot_path.append((_stamp(msg), p.position.x, p.position.y, yaw_of(p.orientation)))
        self.robot_speed.append((_stamp(msg), msg.twist.twist.linear.x, msg.twist.twist.angular.z))

    def _on_agents(self, msg: PoseArray) -> None:
        self.agent_path.append((_stamp(msg), [(p.position.x, p.position.y, yaw_of(p.orientation)) for p in msg.poses]))

    def _on_frame(self, msg: CompressedImage) -> None:
        t = _stamp(msg)
        self.frame_times.append(t)
        self._latest.append((t, msg.data))
        if t - self._last_kept < STRIP_EVERY_S:
            return
        self._last_kept = t
        item = (t, bytes(msg.data))
        if t <= self._pursuing_until and len(self.frames) < 400:
            self.frames.append(item)
        else:
            self._recent.append(item)

    def _on_box(self, msg: CameraInfo) -> None:
        t = _stamp(msg)
        self.boxes.append((t, roi_box(msg.roi)))
        self.box_heard.append(self.node.now())
        # the frame this box is on, for the strip (on a loaded graph track skips most frames: those kept every
        # STRIP_EVERY_S would seldom have a box of their own)
        if self.boxes[-1][1] is not None and t - self._last_boxed >= STRIP_EVERY_S and len(self.frames) < 400:
            frame = next((item for item in reversed(self._latest) if abs(item[0] - t) < 1e-6), None)
            if frame is not None:
                self._last_boxed = t
                self.frames.append((t, bytes(frame[1])))

    def _on_alarm(self, msg: PointStamped) -> None:
        p = msg.point
        self.alarms.append((self.node.now(), _stamp(msg), (p.x, p.y, p.z)))

    def _on_target(self, msg: RegionOfInterest) -> None:
        box = roi_box(msg)
        if box is not None:
            self.targets.append((self.node.now(), box))

    def _on_hold(self, msg: Bool) -> None:
        now = self.node.now()
        if msg.data and now > self._pursuing_until:  # a pursuit starts: keep the frames just before it too
            self.frames.extend(item for item in self._recent if item[0] >= now - 2.0)
            self._recent.clear()
        self._pursuing_until = now + 1.0 if msg.data else now
        if not self.holds or self.holds[-1][1] != msg.data:
            self.holds.append((now, bool(msg.data)))

    def _on_collisions(self, msg: UInt32) -> None:
        if msg.data > self._collision_count:
            self.collisions.extend([self.node.now()] * (msg.data - self._collision_count))
            self._collision_count = msg.data


    # The record (vision_record.json): what was heard, without the pictures, so that a run can be scored again
    RECORDED = ("robot_path", "robot_speed", "agent_path", "frame_times", "boxes", "box_heard", "alarms", "targets",
                "commands", "base_commands", "stops", "holds", "collisions")

    def to_record(self) -> dict:
        def plain(value):
            if isinstance(value, np.ndarray):
                return [float(x) for x in value]
            if isinstance(value, (list, tuple)):
                return [plain(x) for x in value]
            return value
        return {name: plain(getattr(self, name)) for name in self.RECORDED}

    @classmethod
    def from_record(cls, data: dict) -> "VisionObserver":
        """An observer holding a run's record (to_record's dict), to score it again without ROS or the simulator."""
        def box(value):
            return None if value is None else np.array(value, float)
        return cls(None, robot_path=[tuple(r) for r in data["robot_path"]],
                   agent_path=[(t, [tuple(p) for p in poses]) for t, poses in data["agent_path"]],
                   frame_times=list(data["frame_times"]), boxes=[(t, box(b)) for t, b in data["boxes"]],
                   box_heard=list(data.get("box_heard", [])),
                   alarms=[(t, stamp, tuple(p)) for t, stamp, p in data["alarms"]],
                   targets=[(t, box(b)) for t, b in data["targets"]],
                   commands=[tuple(c) for c in data["commands"]], holds=[tuple(h) for h in data["holds"]],
                   robot_speed=[tuple(r) for r in data.get("robot_speed", [])],
                   base_commands=[tuple(c) for c in data.get("base_commands", [])],
                   stops=list(data.get("stops", [])),
                   collisions=list(data["collisions"]))


# Scoring --------------------------------------------------------------------------------------------------------
class Truth:
    """The robot's and the agents' true poses at any time (linear interpolation of the 10 Hz ground truth)."""

    def __init__(self, observer: VisionObserver) -> None:
        robot = np.array(observer.robot_path, float).reshape(-1, 4)
        self.rt = robot[:, 0]
        self.robot = robot[:, 1:].copy()
        self.robot[:, 2] = np.unwrap(self.robot[:, 2])
        agents = [(t, poses) for t, poses in observer.agent_path if poses]
        self.at = np.array([t for t, _ in agents], float)
        n = min((len(p) for _, p in agents), default=0)
        self.agents = np.array([p[:n] for _, p in agents], float).reshape(len(agents), n, 3)
        if len(agents):
            self.agents[:, :, 2] = np.unwrap(self.agents[:, :, 2], axis=0)
        speed = np.abs(np.array(observer.robot_speed, float).reshape(-1, 3))
        self.st, self.speeds = speed[:, 0], speed[:, 1:]   # the ground truth's twist: true |v|, |w|

    def robot_at(self, t: float) -> tuple[float, float, float]:
        return tuple(float(np.interp(t, self.rt, self.robot[:, k])) for k in range(3))

    def agent_at(self, index: int, t: float) -> tuple[float, float, float]:
        return tuple(float(np.interp(t, self.at, self.agents[:, index, k])) for k in range(3))

    def agent_poses_near(self, index: int, t: float) -> list[tuple[float, float, float]]:
        """The agent's pose at `t` (interpolated), and with the heading of each ground-truth sample around `t`
        instead. An agent turns in one simulation step (a waypoint agent's heading snaps to its next leg, a cued
        one turns when its cue fires): between the two samples around such a turn the interpolated heading has
        the agent half turned, as it never was, and its face in an image taken then is where the heading of one
        of the two samples puts it."""
        x, y, yaw = self.agent_at(index, t)
        i = int(np.searchsorted(self.at, t))
        around = sorted({min(max(k, 0), len(self.at) - 1) for k in (i - 1, i)})
        return [(x, y, yaw)] + [(x, y, float(self.agents[k, index, 2])) for k in around]

    def speed_at(self, t: float, dt: float = 0.1) -> tuple[float, float]:
        """True speed and turn rate at `t`: the ground truth's twist where recorded, else from the poses over the
        last `dt` (an average over that window: it lags a braking robot by about dt / 2)."""
        if len(self.st):
            return float(np.interp(t, self.st, self.speeds[:, 0])), float(np.interp(t, self.st, self.speeds[:, 1]))
        (x0, y0, a0), (x1, y1, a1) = self.robot_at(t - dt), self.robot_at(t)
        return math.hypot(x1 - x0, y1 - y0) / dt, abs(a1 - a0) / dt

    def at_rest_after(self, t0: float, within_s: float = 5.0) -> float | None:
        """The first moment from `t0` on at which the robot stood still (speed < STILL_V, turn < STILL_W).

        With the ground truth's twist (10 Hz samples): the threshold crossing between the last sample still
        moving and the first at rest, by linear interpolation. A braking robot's speed falls linearly to zero
        and then stays there, so the interpolated line lies above it: the time found is never early, and at
        most a sample period late. Without the twist (older records): the poses' difference over 0.1 s, tried
        every 0.02 s."""
        end = min(t0 + within_s, float(self.rt[-1]))
        if not len(self.st):
            t = t0
            while t < end:
                v, w = self.speed_at(t)
                if v < STILL_V and w < STILL_W:
                    return t
                t += 0.02
            return None
        limits = (STILL_V, STILL_W)
        for i in np.flatnonzero((self.st >= t0) & (self.st <= end)):
            if not all(self.speeds[i, k] < limits[k] for k in range(2)):
                continue
            if i == 0:
                return max(t0, float(self.st[i]))
            t_prev, t_now = float(self.st[i - 1]), float(self.st[i])
            crossing = t_prev
            for k in range(2):
                before, after = self.speeds[i - 1, k], self.speeds[i, k]
                if before >= limits[k]:
                    crossing = max(crossing, t_prev + (before - limits[k]) / (before - after) * (t_now - t_prev))
            return float(max(t0, crossing))
        return None


@dataclass
class Encounter:
    """The scored run: metrics, and what the pictures need."""

    metrics: dict
    face_boxes: dict[float, np.ndarray] = field(default_factory=dict)   # frame time -> true face box (target)
    pursuits: list[tuple[float, float]] = field(default_factory=list)   # (start, end) of each pursuit


def _agent_between(camera: CameraModel, truth: "Truth", agents, card: FaceCard, t: float) -> bool:
    """Whether another agent taller than the card's middle (a person) stands on the line from the camera to the
    card: its body's circle crosses the segment (scoring only: the robot never sees this)."""
    rx, ry, rt = truth.robot_at(t)
    cx = rx + math.cos(rt) * camera.x - math.sin(rt) * camera.y
    cy = ry + math.sin(rt) * camera.x + math.cos(rt) * camera.y
    ax, ay, at = truth.agent_at(card.agent, t)
    facing = at + card.yaw
    mx, my = ax + (card.radius + 0.01) * math.cos(facing), ay + (card.radius + 0.01) * math.sin(facing)
    dx, dy = mx - cx, my - cy
    length2 = dx * dx + dy * dy
    for index, agent in enumerate(agents):
        if index == card.agent or agent.height < card.centre or index >= truth.agents.shape[1]:
            continue
        px, py, _ = truth.agent_at(index, t)
        k = min(1.0, max(0.0, ((px - cx) * dx + (py - cy) * dy) / max(length2, 1e-9)))
        if math.hypot(cx + k * dx - px, cy + k * dy - py) < agent.radius:
            return True
    return False


def _occlusions(hidden: list[float], face_boxes: dict, boxes: list, spans: list) -> list[dict]:
    """Each stretch of frames in which another agent hid the target's face during a pursuit, how long it lasted,
    and how soon after the face was back in view the tracker had it again (a confident box with IoU >= 0.5)."""
    result = []
    stretches: list[list[float]] = []
    for t in sorted(hidden):
        if not any(s - 0.5 <= t <= e for s, e in spans):
            continue
        if stretches and t - stretches[-1][-1] <= 0.25:
            stretches[-1].append(t)
        else:
            stretches.append([t])
    for stretch in stretches:
        start, end = stretch[0], stretch[-1]
        back = next((t for t in sorted(face_boxes) if t > end), None)
        refound = None
        if back is not None:
            refound = next((t - back for t, box in boxes if t >= back and box is not None and t in face_boxes
                            and iou(box, face_boxes[t]) >= 0.5), None)
        result.append({"from_s": round(start, 3), "until_s": round(end, 3), "hidden_s": round(end - start, 3),
                       "back_in_view_s": None if back is None else round(back, 3),
                       "refound_after_s": None if refound is None else round(refound, 3)})
    return result


def _alarm_boxes(alarms: list, targets: list, within_s: float = 1.0) -> list[np.ndarray | None]:
    """detect's box for each alarm. detect sends ``alarm`` and then ``target`` once per suspect, back to back, but on
    the ROS graph they come on two connections, heard at slightly different times (and in either order): each
    alarm takes the nearest target heard within `within_s` that no earlier alarm took."""
    taken: set[int] = set()
    boxes = []
    for heard, _, _ in alarms:
        free = [(abs(tb - heard), k) for k, (tb, _) in enumerate(targets) if k not in taken and abs(tb - heard) <= within_s]
        if not free:
            boxes.append(None)
            continue
        _, k = min(free)
        taken.add(k)
        boxes.append(targets[k][1])
    return boxes


def _pursuits(holds: list[tuple[float, bool]], end: float) -> list[tuple[float, float]]:
    spans, start = [], None
    for t, on in holds:
        if on and start is None:
            start = t
        elif not on and start is not None:
            spans.append((start, t))
            start = None
    if start is not None:
        spans.append((start, end))
    return spans


def follow_distance_m(network: Path = ROOT / "robots" / "patrol" / "patrol.yaml") -> float:
    """The following distance follow keeps (its ``distance_m`` in the network file; its default if unset): the
    camera's range to the target's face, which the scorer compares with the true one."""
    default = float(Follow.interface.params["distance_m"].default)
    for level in yaml.safe_load(Path(network).read_text()).get("levels", []):
        for module in level.get("modules", []):
            if module.get("name") == "follow":
                return float((module.get("params") or {}).get("distance_m", default))
    return default


def _follow_distances(moving: list[tuple[float, float, float]], spans: list[tuple[float, float]], truth: "Truth",
                      camera: CameraModel, card: FaceCard, holds_s: float) -> dict:
    """The distance kept while following, apart from the approach: in each pursuit, follow's moving commands from
    the first one at which the camera's true range to the target's face card was within CLOSED_IN_M of
    follow's distance_m (the robot had closed in) to the pursuit's end -- falling behind later (the target
    speeding off, a person in the way) counts. ``mean_follow_distance_m`` is the true centre-to-centre distance
    then (what encounter.png plots), ``mean_follow_range_m`` the camera's range to the face card then (what
    follow's distance_m sets), ``follow_closed_in_s`` how long those commands drove; a pursuit that never
    closed in adds nothing (both None if none did). ``mean_follow_distance_with_approach_m``: over every moving
    command, the approach after the stop included (this key's meaning before).
    The private ``_closed_in`` lists each pursuit's closed-in time for its entry in ``pursuits``."""
    set_m = follow_distance_m()

    def where(t: float) -> tuple[float, float]:
        robot, agent = truth.robot_at(t), truth.agent_at(card.agent, t)
        _, range_m = project_face(camera, robot, card, agent, max_turn_deg=180.0)
        return math.hypot(agent[0] - robot[0], agent[1] - robot[1]), range_m

    every = [where(t)[0] for t, _, _ in moving]
    distances, ranges, closed_in, kept_s = [], [], [], 0.0
    for start, end in spans:
        inside = [t for t, _, _ in moving if start <= t <= end]
        first = next((t for t in inside if where(t)[1] <= set_m + CLOSED_IN_M), None)
        closed_in.append(None if first is None else round(first, 3))
        if first is None:
            continue
        kept = [t for t in inside if t >= first]
        for t in kept:
            distance, range_m = where(t)
            distances.append(distance)
            ranges.append(range_m)
        kept_s += sum(min(t1 - t0, holds_s) for t0, t1 in zip(kept, kept[1:]))

    def mean(values: list[float]) -> float | None:
        return round(float(np.mean(values)), 3) if values else None

    return {"mean_follow_distance_m": mean(distances), "mean_follow_range_m": mean(ranges),
            "follow_closed_in_s": round(kept_s, 2), "mean_follow_distance_with_approach_m": mean(every),
            "_closed_in": closed_in}


def _stop_chain(observer: VisionObserver, truth: "Truth", face_30px: float | None, image: float, heard: float,
                stopped: float | None) -> dict:
    """The stop's latency link by link, as times (s) from the run's start: the first frame with the face >= 30 px;
    the image the alarm was raised on (detect's confirming scan); the alarm heard; pursuit's stop (the inhibitor's
    upper line) heard; track's first box of the new target heard, and the image it is on; follow's first zero
    command heard; the first zero command on the base's cmd_vel (through the arbiters); the robot at rest (true
    speed). ``speed_at_zero`` is the true (v, w) when the base got its zero: the braking that follows is the
    simulated base's (its acceleration limits). None: not heard (an older record without that topic)."""
    def first(times, after: float):
        return next((round(t, 3) for t in sorted(times) if t >= after - 1e-6), None)

    stop = first(observer.stops, image)
    # raised: the first of its consequences the scorer heard (alarm and stop come on two connections, in either
    # order); what follows it (track's box, follow's and the base's zero) is looked for from then on, so that a
    # zero the base got before (the navigation standing at a goal) is not taken for the stop's
    raised = min(heard, stop) if stop is not None else heard
    box = next(((h, t) for (t, b), h in zip(observer.boxes, observer.box_heard) if b is not None and h >= raised),
               (None, None))
    zeros = [t for t, v, w in observer.base_commands if v == 0.0 and w == 0.0]
    base_zero = first(zeros, raised)
    return {"face_30px": face_30px, "alarm_image": round(image, 3), "alarm_heard": round(heard, 3),
            "stop_heard": stop,
            "box_heard": None if box[0] is None else round(box[0], 3),
            "box_image": None if box[1] is None else round(box[1], 3),
            "follow_zero": first([t for t, v, w in observer.commands if v == 0.0 and w == 0.0], raised),
            "base_zero": base_zero,
            "speed_at_zero": None if base_zero is None else [round(x, 3) for x in truth.speed_at(base_zero)],
            "at_rest": stopped}


def score(observer: VisionObserver, world_file: Path, goals_sent: list[tuple[float, str, int]],
          duration: float) -> Encounter:
    """Every level-4 metric of the run, from what `observer` heard; `goals_sent` is the patrol observer's."""
    world = load_world(world_file)
    camera = CameraModel.of(world.robots[0].camera)
    cards = face_cards(world)
    solid = (world.map, world.map.solid)
    truth = Truth(observer)
    metrics: dict = {"detected_at_s": None, "face_30px_at_s": None, "stopped_at_s": None,
                     "stop_after_face_30px_s": None, "stop_chain": None, "followed_s": 0.0,
                     "mean_follow_distance_m": None, "mean_follow_range_m": None, "follow_closed_in_s": 0.0,
                     "mean_follow_distance_with_approach_m": None,
                     "lost_at_s": None, "resumed_patrol_at_s": None, "false_alarms": 0,
                     "alarms_on_target": 0, "alarm_scores": [], "detected_in_image_s": None,
                     "track_iou_in_view": None, "track_frames_in_view": 0, "box_lag_s": None, "collisions_while_following": 0,
                     "occlusions": [], "refound_after_occlusion_s": None, "pursuits": []}
    encounter = Encounter(metrics)
    if not len(truth.rt) or not cards:
        return encounter
    suspects = [c for c in cards if c.name == "target"] or cards

    def face_at(t: float, card: FaceCard, max_turn_deg: float = FACING_MAX_DEG,
                min_px: float = IN_VIEW_MIN_PX, hidden: list | None = None, cut: bool = False,
                agent: tuple[float, float, float] | None = None) -> np.ndarray | None:
        pose = truth.agent_at(card.agent, t) if agent is None else agent
        box, _ = project_face(camera, truth.robot_at(t), card, pose, solid, max_turn_deg)
        if cut:  # the part in the image, the rest cut off by its edge
            box = visible_part(box, camera, min_px)
        elif not in_view(box, camera, min_px):
            return None
        if box is None:
            return None
        if _agent_between(camera, truth, world.agents, card, t):
            if hidden is not None:
                hidden.append(t)
            return None
        return box

    # alarms: on a suspect's face (seen from any side it shows), or false. Each alarm is scored in the image it was
    # raised on (its stamp): on the ROS graph it is heard a detection's time later, the robot moving meanwhile.
    on_target: list[tuple[float, float]] = []   # (raised: heard, its image's time)
    for (heard, stamp, _), box in zip(observer.alarms, _alarm_boxes(observer.alarms, observer.targets)):
        t = stamp if stamp > 0.0 else heard
        # (the detector's box holds forehead and chin too: a face it finds may be under IN_VIEW_MIN_PX here; and
        # the part of a face in the image counts: in-process, seed 1, the target came in 1.1 m from the robot, its
        # face 10 px above the image's top edge, and the alarm on it was counted false)
        # (an agent that turned between two ground-truth samples: its face as either sample's heading has it too,
        # Truth.agent_poses_near; a TurtleBot 2 run raised the alarm in the first image after the stranger turned,
        # and the interpolated half turn made it false)
        faces = [f for c in suspects for pose in truth.agent_poses_near(c.agent, t)
                 if (f := face_at(t, c, 89.0, 8.0, cut=True, agent=pose)) is not None]
        best = max((iou(box, f) for f in faces), default=0.0) if box is not None else 0.0
        hit = bool(best >= ALARM_IOU)
        metrics["alarm_scores"].append({"heard_s": round(heard, 3), "image_s": round(t, 3),
                                        "box": None if box is None else [int(v) for v in box],
                                        "iou": round(float(best), 3), "on_target": hit})
        if hit:
            on_target.append((heard, t))
        else:
            metrics["false_alarms"] += 1
    metrics["alarms_on_target"] = len(on_target)
    hidden: list[float] = []  # frames in which another agent (a person walking between) hides the face
    for t in observer.frame_times:
        face = face_at(t, suspects[0], hidden=hidden)
        if face is not None:
            encounter.face_boxes[t] = face
    if on_target:
        detected, seen = on_target[0]
        metrics["detected_at_s"] = round(detected, 3)
        metrics["detected_in_image_s"] = round(seen, 3)
        rest = truth.at_rest_after(detected)
        metrics["stopped_at_s"] = None if rest is None else round(rest, 3)
        # the first frame with the face >= 30 px in the run of in-view frames leading to the stop; if the robot
        # stood still before the face grew to 30 px, the first such frame after (the difference is then negative)
        until = metrics["stopped_at_s"] if metrics["stopped_at_s"] is not None else detected
        first = None
        for t in sorted(encounter.face_boxes):
            box = encounter.face_boxes[t]
            if t > until + 1e-6:
                if first is None and t > detected and box[3] - box[1] >= 30:
                    first = t
                    break
                continue
            first = (t if first is None else first) if box[3] - box[1] >= 30 else None
        metrics["face_30px_at_s"] = None if first is None else round(first, 3)
        if first is not None and metrics["stopped_at_s"] is not None:
            metrics["stop_after_face_30px_s"] = round(metrics["stopped_at_s"] - first, 3)
        metrics["stop_chain"] = _stop_chain(observer, truth, first, seen, detected, metrics["stopped_at_s"])
    spans = _pursuits(observer.holds, duration)
    encounter.pursuits = spans
    # following: follow's moving commands; distance to the target meanwhile
    # a command drives the robot until the next one or the robot's cmd_timeout, whichever comes first: on a
    # loaded ROS graph track (and so follow) answers fewer frames, its commands further apart, yet they drive
    moving = [(t, v, w) for t, v, w in observer.commands if abs(v) > 1e-3 or abs(w) > 1e-3]
    holds_s = world.robots[0].limits.cmd_timeout
    followed = 0.0
    for (t0, _, _), (t1, _, _) in zip(moving, moving[1:]):
        followed += min(t1 - t0, holds_s)
    metrics["followed_s"] = round(followed, 2)
    metrics.update(_follow_distances(moving, spans, truth, camera, suspects[0], holds_s))
    # tracking: IoU against the true face box in every tracked frame with the face in view
    hits = frames = 0
    for start, end in spans:
        for t, box in observer.boxes:
            if start - 0.5 <= t <= end and t in encounter.face_boxes:
                frames += 1
                hits += box is not None and iou(box, encounter.face_boxes[t]) >= 0.5
    metrics["track_frames_in_view"] = frames
    metrics["track_iou_in_view"] = round(float(hits) / frames, 4) if frames else None
    lags = [heard - t for (t, _), heard in zip(observer.boxes, observer.box_heard)]
    metrics["box_lag_s"] = ({"median": round(float(np.median(lags)), 3), "max": round(float(max(lags)), 3)}
                            if lags else None)
    metrics["collisions_while_following"] = sum(1 for c in observer.collisions
                                                if any(s <= c <= e for s, e in spans))
    sent_times = sorted(t for t, _, _ in goals_sent)
    closed_in = metrics.pop("_closed_in")
    for k, (start, end) in enumerate(spans):
        confident = [t for t, box in observer.boxes if box is not None and start - 0.5 <= t <= end]
        resumed = next((t for t in sent_times if t >= end - 1e-6), None)
        metrics["pursuits"].append({"start_s": round(start, 3), "end_s": round(end, 3),
                                    "closed_in_at_s": closed_in[k],
                                    "lost_at_s": round(confident[-1], 3) if confident else None,
                                    "resumed_patrol_at_s": None if resumed is None or end >= duration
                                    else round(resumed, 3)})
    metrics["occlusions"] = _occlusions(hidden, encounter.face_boxes, observer.boxes, spans)
    refound = [o["refound_after_s"] for o in metrics["occlusions"] if o["hidden_s"] >= OCCLUSION_MIN_S]
    metrics["refound_after_occlusion_s"] = (None if not refound else "never" if None in refound else max(refound))
    if metrics["pursuits"]:
        metrics["lost_at_s"] = metrics["pursuits"][0]["lost_at_s"]
        metrics["resumed_patrol_at_s"] = metrics["pursuits"][0]["resumed_patrol_at_s"]
    return encounter


def rescore(record: Path, world_file: Path, goals_sent: list[tuple[float, str, int]] = (),
            duration: float | None = None) -> dict:
    """The level-4 metrics of a recorded run (its vision_record.json) in `world_file` (its world.yaml)."""
    observer = VisionObserver.from_record(json.loads(Path(record).read_text()))
    end = duration if duration is not None else max((t for t, *_ in observer.robot_path), default=0.0)
    return score(observer, Path(world_file), list(goals_sent), end).metrics


__all__ = ["rescore", "VISION_LEVEL", "STAFF", "staff_model", "VisionObserver", "Encounter", "score"]
