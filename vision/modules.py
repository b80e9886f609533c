"""The patrol robot's level-4 vision as subsumption modules: ``detect``, ``track`` and ``follow``.

::

    camera/rgb/image_raw ──► detect ──target (RegionOfInterest)──►[S]──► track ──box_info (CameraInfo)──► follow ──cmd_vel──►[S] motors
    camera/depth/image_raw ─┘   │                      terminal/target ──┘                 depth ─┘
                                ├─ alarm (PointStamped): once per suspect found: the inhibitor's upper line
                                ├─ suspect (PointStamped): where the suspect is, each time it is seen
                                ├─ intruder (DiagnosticStatus): the same, as a trigger for the patrol alarm module
                                └─ hold (Twist, zero): a face first seen unknown at the side: hold still

The image's header travels with the box in ``track``'s ``box_info``: a ``sensor_msgs/CameraInfo`` that is the
camera's own (K, P, size) with the image's header (stamp, optical frame) and ``roi`` = the tracked box (a zero
``roi`` while the target is lost) -- the way image_proc marks a region of an image. ``box``
(``RegionOfInterest``) and ``confident`` (``std_msgs/Bool``) are the same news unstamped, for simple readers. The
line from ``detect`` to ``track`` carries a plain ``RegionOfInterest`` (the operator's choice from
``terminal/target`` replaces it through a suppressor) and refers to the newest image.

Everything is computed from the pixels of ``sensor_msgs/Image`` (``rgb8``/``bgr8``; depth ``32FC1`` metres or
``16UC1`` millimetres, registered to the colour image) and ``CameraInfo``; nothing reads a simulator's truth.
"""
from __future__ import annotations

import math
import statistics
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PointStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, Image, RegionOfInterest
from std_msgs.msg import Bool

from subsumption import Input, Module, Output, Param
from subsumption.images import ImageEncodingError, to_depth_m, to_rgb
from subsumption.planar import yaw_of

from .boxes import Box, Pinhole, box_depth
from .faces import FaceDetector, to_gray
from .follow import FollowSettings, TargetMotion, follow_command, target_range
from .recognition import FaceModel, ModelError, enrol
from .tracking import TargetTracker, TrackerSettings


def camera_of(info: CameraInfo | None, width: int, height: int, hfov_deg: float) -> Pinhole:
    """The pinhole from CameraInfo's K, or from a field of view when there is no (valid) CameraInfo."""
    camera = Pinhole.from_k(info.K, info.width or width, info.height or height) if info is not None else None
    return camera or Pinhole.from_fov(width, height, math.radians(hfov_deg))


def located(box: Box, camera: Pinhole, depth_m, header, target_height_m: float) -> PointStamped:
    """Where the box's centre is in the camera's optical frame: depth where measured, else from the box's size."""
    z = box_depth(depth_m, box) if depth_m is not None else math.nan
    if not math.isfinite(z):
        z = camera.fy * target_height_m / max(box.h, 1.0)
    point = PointStamped()
    point.header = header
    point.point.x, point.point.y, point.point.z = camera.point(*box.centre, z)
    return point


def intruder_status(point: PointStamped) -> DiagnosticStatus:
    """A trigger for the patrol robot's alarm module (robots.patrol.alarm's conventions: name, level WARN,
    a sentence to say, where as key-values): here in the camera's optical frame, with bearing and range."""
    x, z = point.point.x, point.point.z
    bearing = math.degrees(math.atan2(-x, z))
    side = "ahead" if abs(bearing) < 3 else f"{abs(bearing):.0f} degrees to the {'left' if bearing > 0 else 'right'}"
    values = [KeyValue(key, f"{value:.2f}") for key, value in
              (("x", x), ("y", point.point.y), ("z", z), ("bearing_deg", bearing), ("range_m", math.hypot(x, z)))]
    values.append(KeyValue("frame", point.header.frame_id))
    return DiagnosticStatus(level=DiagnosticStatus.WARN, name="intruder",
                            message=f"Stranger {math.hypot(x, z):.1f} metres away, {side}", values=values)


LATE_FRAME_S = 0.5  # s: a camera frame older than this on arrival is reported in the log as late


def _stale(header, now: float, limit_s: float) -> bool:
    """A message stamped more than `limit_s` before `now`. Unstamped messages (stamp 0) are never stale."""
    stamp = header.stamp.to_sec()
    return stamp > 0.0 and now - stamp > limit_s


class _LateFrames:
    """Reports, at most every `every_s` seconds, the camera frames that arrived over LATE_FRAME_S old.

    Detect and track read the camera as a latest input (on ROS a queue of one): the frame in hand is the newest
    there is, however old, so it is used -- skipping it would not bring a fresher one, and on a loaded machine
    where every frame came 0.5-1 s late (a CI run) skipping them left detect blind for a whole run. The age
    travels on with the image's stamp (track's box_info), so follow still judges a box by it. What the log
    gets is the reason a robot reacts late: the machine too loaded to carry images in time."""

    def __init__(self, module: Module, every_s: float = 5.0):
        self.module, self.every_s = module, every_s
        self.late = 0
        self.oldest_s = 0.0

    def heard(self, header, now: float) -> None:
        if not _stale(header, now, LATE_FRAME_S):
            return
        self.late += 1
        self.oldest_s = max(self.oldest_s, now - header.stamp.to_sec())
        if self.module.log_every("late frames", self.every_s,
                                 f"{self.late} camera frame(s) arrived over {LATE_FRAME_S:g} s old (the oldest "
                                 f"{self.oldest_s:.2f} s): the machine is too loaded to carry images in time",
                                 "warn"):
            self.late, self.oldest_s = 0, 0.0


class _ScanStats:
    """What detect's scans cost and how fresh their frames were, logged every `every_s` s of the runtime's
    clock: whole-image scans (their period, the age of the frame scanned on its arrival at the scan, wall and
    thread-CPU time) and the quick looks. On the loaded ROS graph this is where the stop's vision links go:
    bench figures (CPU alone) do not show a scan's wall time there."""

    def __init__(self, module: Module, every_s: float = 10.0):
        self.module, self.every_s = module, every_s
        self._since = None
        self._last_whole = None
        self.whole: list[tuple[float, float, float, float]] = []  # (period s, frame age s, wall ms, cpu ms)
        self.looks: list[tuple[float, float]] = []                # (wall ms, cpu ms)

    def scanned(self, whole: bool, now: float, stamp: float, wall_s: float, cpu_s: float) -> None:
        if self._since is None:
            self._since = now
        if whole:
            period = now - self._last_whole if self._last_whole is not None else math.nan
            self._last_whole = now
            self.whole.append((period, now - stamp if stamp > 0 else math.nan, 1e3 * wall_s, 1e3 * cpu_s))
        else:
            self.looks.append((1e3 * wall_s, 1e3 * cpu_s))
        if now - self._since >= self.every_s:
            self.module.log(self.summary(now - self._since))
            self._since, self.whole, self.looks = now, [], []

    def summary(self, span_s: float) -> str:
        def med_max(values, unit: str, scale: float = 1.0) -> str:
            values = [v for v in values if math.isfinite(v)]
            if not values:
                return "-"
            return f"{scale * statistics.median(values):.0f}/{scale * max(values):.0f} {unit}"

        periods, ages, walls, cpus = zip(*self.whole) if self.whole else ((), (), (), ())
        text = (f"scan stats over {span_s:.1f} s: {len(self.whole)} whole-image scans, period "
                f"{med_max(periods, 'ms', 1e3)}, frame age {med_max(ages, 'ms', 1e3)}, wall "
                f"{med_max(walls, 'ms')}, cpu {med_max(cpus, 'ms')} (median/max)")
        if self.looks:
            text += (f"; {len(self.looks)} looks round faces, wall {med_max([w for w, _ in self.looks], 'ms')}, "
                     f"cpu {med_max([c for _, c in self.looks], 'ms')}")
        return text


_NOT_YET = object()  # a value not computed yet
_UNDECIDED = object()  # depth flows, but no depth image near enough to an image's instant has come (yet)
NEAR_DEPTH_S = 0.1  # s: a depth image this near a colour image's instant stands in for the one of that instant
NEAR_DEPTH_TURN_RAD = 0.05  # rad: ... while the robot turned less than this between the two (a box moves ~30 px)
DEPTH_FLOWING_S = 1.0  # s: depth images newer than this before a colour image: the camera's depth is working
FACE_HEIGHTS_M = (0.12, 0.30)  # m: how tall a face's box may be, for the depth check's "would be within" range
FACE_TALLEST_M = 0.45  # m: a box the depth makes taller than this (half again the tallest face) is no human face
LOOK_TURN_GAIN = 2.0  # (rad/s) per rad of heading left to turn back to a face seen once (at most look_turn)
LOOK_AIMED_RAD = 0.05  # rad: near enough to the face's bearing: stand still and look


@dataclass
class _Seen:
    """A face detect keeps in mind between scans: its last box, identity votes and whether it raised the alarm."""

    box: Box
    last_seen: float
    last_scan: int = 0
    known: dict[str, int] = field(default_factory=dict)
    unknown: int = 0
    alarmed: bool = False
    first_unknown_at: float | None = None  # when it was first seen unknown: the hold (`look_s`) counts from it
    heading: float | None = None  # its bearing then in the odometry frame (rad), if odometry was heard: see look_turn

    @property
    def settled_known(self) -> bool:
        return sum(self.known.values()) >= 3 and sum(self.known.values()) > 2 * self.unknown


class Detect(Module):
    """Finds faces in the camera image and tells enrolled people from strangers. A face that is unknown in
    `confirm` scans running is suspicious: `alarm` is sent once (the inhibitor's upper line that stops the robot)
    with where it is, `target` gets its box (for track), and `suspect` says where it is each time it is seen.

    Between the first unknown sight of a face near the image's side (`look_edge`) and its confirmation, `hold`
    sends zero motor commands every frame (for at most `look_s`): a robot that goes on turning meanwhile can turn
    the face out of its 57-degree view before the second look (level 5's scene on a loaded ROS graph: seen once at
    the image's edge, never confirmed, never seen again). A security robot that glimpses a stranger at the edge of
    its view stops to look. If the face is gone from the newest scan all the same (the first sight came while the
    robot was already turning it out of view), `hold` turns the robot back towards where odometry says the face
    was (`look_turn`), so that the next scans can find it again."""

    image = Input(Image, "camera/rgb/image_raw: rgb8 or bgr8", latest=True)
    depth = Input(Image, "camera/depth/image_raw, registered: 16UC1 mm (OpenNI's) or 32FC1 m", latest=True)
    camera_info = Input(CameraInfo, "camera/rgb/camera_info")
    odom = Input(Odometry, "odometry: the robot's heading, to turn back to a face seen once at the image's side "
                           "that the robot's turn carried out of view (`look_turn`; not wired: the hold stands still)")
    target = Output(RegionOfInterest, "the suspect's box in the newest image, when it is first confirmed")
    alarm = Output(PointStamped, "once per suspect: where it is (camera optical frame)")
    suspect = Output(PointStamped, "where the confirmed suspect is, every scan that sees it")
    intruder = Output(DiagnosticStatus, "the same sighting as a trigger for the patrol robot's alarm module "
                                        "(name 'intruder', level WARN, x/y/z in the camera's optical frame)")
    hold = Output(Twist, "zero motor commands, every frame while a face seen unknown near the image's side is "
                         "being confirmed (at most `look_s`; `look_edge`): through a suppressor over the lower "
                         "levels' motor line the robot holds still and does not turn the face out of view before "
                         "its second look")
    model = Param("", "face model file from `subsumption enrol`, or a folder of photos enrolled at start (empty: "
                  "nobody is enrolled, every face is a suspect)", per_run=True)
    detector = Param("haar_alt2", "face detector: haar_alt2, haar_alt, haar_default or lbp")
    rate = Param(10.0, "Hz: scans of the whole image (at most one per image)")
    cpu_share = Param(0.0, "share of a core detect's whole-image scans may take while no suspect is in view: > 0 "
                           "scans the newest frame as soon as that budget allows (never less often than `rate`), "
                           "so a face is not left waiting for the next paced scan; 0: paced at `rate`. The budget "
                           "is counted in CPU and wall time, so an in-process run with it is not repeatable to the "
                           "frame", min=0.0)
    min_face_px = Param(24, "px: height of the smallest face sought")
    scale_factor = Param(1.1, "ratio between the cascade's successive scan sizes: larger scans faster "
                              "and finds fewer small faces", min=1.01)
    full_every = Param(5, "while a suspect is in view (track and follow at work), only every Nth scan covers the "
                          "whole image; the others look round the faces being watched only (1: always the whole)",
                       min=1)
    confirm = Param(2, "scans in a row a face must be unknown to be a suspect (the scans after the first look "
                       "round it on the very next frames, not a scan period later: see on_image)")
    look_s = Param(1.5, "s: a face first seen unknown holds the robot still (`hold`) until it is confirmed or "
                        "judged staff, at most this long from that first sight (once per face remembered); 0: "
                        "no hold", min=0.0)
    look_edge = Param(0.25, "share of the image's width on either side in which a face first seen unknown holds the "
                            "robot (`look_s`): there the robot's own turn can carry it out of view before the second "
                            "look; nearer the middle the robot drives on, and sees the face larger. 0.5: anywhere",
                      min=0.0, max=0.5)
    look_turn = Param(0.6, "rad/s at most: while the hold lasts and the face is not in the newest scan, turn towards "
                           "its bearing at the first sight (odometry's heading then plus its angle in the image); "
                           "0: stand still only", min=0.0)
    forget_s = Param(3.0, "s: a face unseen this long is forgotten (found again, it is a new suspect)")
    face_height_m = Param(0.16, "m, for the range from a face's size when depth has no reading")
    depth_check_m = Param(4.0, "m: a box so large that a face of 0.12-0.30 m would be between 0.5 m and this far "
                               "must have a reading in the depth image of the same instant (or the nearest within "
                               "0.1 s); without one it is no face (a picture beyond the depth's range) and counts "
                               "for nothing, nor does one whose reading makes it taller than 0.45 m (a large "
                               "picture on a wall within the depth's range). 0: no check",
                          min=0.0)
    hfov_deg = Param(57.0, "degrees: horizontal field of view, used until a camera_info comes")
    below_horizon_px = Param(-1, "rows below the camera's horizon (camera_info's cy) that a whole-image scan covers; "
                                 "-1: all rows. A level camera lower than every face (a TurtleBot's Kinect, 0.29 m "
                                 "up) sees no face below its horizon: scanning the rows above it costs about half",
                             min=-1)

    def _face_model(self) -> FaceModel | None:
        """~model's people: a model file, or a folder of photos enrolled now (as `subsumption enrol` would, with
        this detector), so that a launch file can name the staff's photos themselves."""
        if not self.model:
            return None
        if Path(self.model).is_dir():
            return enrol(self.model, "lbph", FaceDetector(self.detector), log=lambda _: None)
        return FaceModel.load(self.model)

    def setup(self) -> None:
        self.faces = FaceDetector(self.detector, self.min_face_px, self.scale_factor)
        try:
            self.known_people = self._face_model()
        except ModelError as error:
            raise ModelError(f"{self.node.name}: parameter ~model: {error}") from None
        if self.known_people is None:
            self.log("no face model (~model): nobody is enrolled, every face is a suspect", "warn")
        else:
            self.log(f"face model {self.model}: {', '.join(self.known_people.people)} enrolled")
        self._seen: list[_Seen] = []
        self._width = 640  # the newest image's, for look_edge
        self._next_scan = -math.inf
        self._scan = 0
        self._chasing = False  # whether the last scan's faces included the suspect's (see _scan_faces)
        self._budget_at = (-math.inf, -math.inf)  # (runtime clock, wall clock) when cpu_share allows a scan again
        self._depths: deque = deque(maxlen=8)  # the newest depth images, to find the one of an image's instant
        self._headings: deque = deque(maxlen=64)  # (stamp, odometry yaw): the heading at an image's instant
        self._late_frames = _LateFrames(self)
        self._stats = _ScanStats(self)

    def on_depth(self, msg: Image) -> None:
        """Keep the depth image for the depth check of the frame of the same instant."""
        self._depths.append(msg)

    def on_odom(self, msg: Odometry) -> None:
        """Keep the heading at the odometry's stamp (to turn back towards a face seen at the image's edge)."""
        self._headings.append((msg.header.stamp.to_sec(), yaw_of(msg.pose.pose.orientation)))

    def on_image(self, msg: Image) -> None:
        """Scan the frame for faces (within the CPU share), raise the alarm for a confirmed stranger, hold the robot
        while looking."""
        now = self.now()
        self._on_frame(msg, now)
        looking = self._looking(now)
        if looking is not None:
            # every frame, scanned or not: the suppressor's window stays open while the look lasts (a frame
            # every 1/30 s, its time constant 0.5 s), and closes by itself once detect falls silent
            self.hold.publish(self._look_command(looking))

    def _on_frame(self, msg: Image, now: float) -> None:
        self._width = msg.width
        period = 1.0 / self.rate
        # a face unknown in the last scan and not yet confirmed is looked at again in the very next frame, round
        # where it is only (a few ms of a core, not a whole scan's ~80): the robot stops a scan period sooner, and
        # "in a row" still asks `confirm` images to agree. The paced scans go on at `rate` meanwhile. A next
        # frame a scan period or more later (a loaded graph) gets the paced whole-image scan instead: the face
        # may have moved out of the look's reach meanwhile.
        confirming = self._awaiting_confirmation(now, period)
        due = now >= self._next_scan - 0.25 * period  # slack: 30 Hz frames give 10 Hz scans
        early = (self.cpu_share > 0 and not self._chasing and now >= self._budget_at[0]
                 and time.perf_counter() >= self._budget_at[1])
        if not (due or early or confirming):
            return
        self._late_frames.heard(msg.header, now)
        if not confirming:
            self._next_scan = max(self._next_scan + period, now) if due else now + period
        try:
            rgb = to_rgb(msg)
        except ImageEncodingError as error:
            self.log(f"image: {error}", "warn")
            return
        gray = to_gray(rgb)
        depth = _NOT_YET  # converted only when a suspect is to be located (most scans find none)
        camera = camera_of(self.registers.camera_info, msg.width, msg.height, self.hfov_deg)
        self._seen = [s for s in self._seen if now - s.last_seen <= self.forget_s]
        self._scan += 1
        wall, cpu = time.perf_counter(), time.thread_time()
        faces, whole = (self._look_round(gray), False) if confirming else self._scan_faces(gray, camera)
        cpu = time.thread_time() - cpu
        self._stats.scanned(whole, now, msg.header.stamp.to_sec(), time.perf_counter() - wall, cpu)
        if whole and self.cpu_share > 0:
            # the next whole scan as soon as this one's CPU time fits the budget, both in the runtime's clock and
            # in wall time (a graph run at --rate 3 must not give detect 0.9 of a core): on every frame when scans
            # are cheap, every few on a busy picture; `rate` stays the least
            self._budget_at = (now + cpu / self.cpu_share, wall + cpu / self.cpu_share)
        same_instant = _NOT_YET  # the depth image of this image's instant, looked up for large boxes only
        for box, seen in self._associate(faces, now):
            if seen.last_scan != self._scan - 1:
                seen.unknown = 0  # missed a scan: "in a row" starts again
            if self._beyond_depth(box, camera):
                if same_instant is _NOT_YET:
                    same_instant = self._depth_at(msg.header.stamp.to_sec())
                if same_instant is _UNDECIDED:
                    seen.unknown = 0
                    self.log_every("depth late", 5.0, f"box at {box.ints()}: no depth image within "
                                   f"{NEAR_DEPTH_S:.1f} s of its image's instant (yet) to check it against; not "
                                   "counted this scan")
                    continue
                reading = box_depth(same_instant, box) if same_instant is not None else math.nan
                if same_instant is not None and not math.isfinite(reading):
                    seen.unknown = 0
                    self.log_every("no depth", 5.0, f"box at {box.ints()} has no depth reading: a face that size "
                                   f"would be within {camera.fy * FACE_HEIGHTS_M[1] / box.h:.1f} m; taken for no face")
                    continue
                tall_m = box.h * reading / camera.fy  # nan without a depth image to read
                if tall_m > FACE_TALLEST_M:
                    seen.unknown = 0  # a picture of something large (the cat poster across the room)
                    self.log_every("too tall", 5.0, f"box at {box.ints()} is {reading:.2f} m away by depth: "
                                   f"{tall_m:.2f} m tall, no human face; taken for no face")
                    continue
            seen.last_scan = self._scan
            if not seen.settled_known:
                self._vote(seen, gray, box)
                if seen.unknown > 0 and seen.first_unknown_at is None:
                    seen.first_unknown_at = now
                    seen.heading = self._bearing(box, camera, msg.header.stamp.to_sec())
                if seen.unknown == 1 and not seen.alarmed:
                    self.log_every("first sight", 1.0, f"unknown face at {box.ints()} in the image of "
                                   f"{msg.header.stamp.to_sec():.2f} s ({'look' if confirming else 'scan'})")
            if seen.unknown >= self.confirm:
                if depth is _NOT_YET:
                    depth = self._depth()
                point = located(box, camera, depth, msg.header, self.face_height_m)
                if not seen.alarmed:
                    seen.alarmed = True
                    self.alarm.publish(point)
                    self.target.publish(box.to_roi(msg.width, msg.height))
                    self.log(f"suspicious face at {box.ints()}, {point.point.z:.2f} m ahead")
                self.suspect.publish(point)
                self.intruder.publish(intruder_status(point))

    def _scan_faces(self, gray, camera: Pinhole) -> tuple[list[Box], bool]:
        """This scan's faces, and whether the scan covered the whole image. The whole image, except while a
        suspect was seen in the last scan: then, on all but every `full_every`-th scan, only round the faces still
        being watched (the suspect, and faces not yet known to be staff, so that their scans "in a row" go on) --
        a whole-image scan costs about 80 ms of a core, a look round a face a few, and track and follow need the
        rest of the frame time then. A new face is thus found within full_every scans while a suspect is in view
        (0.5 s), at once otherwise."""
        chasing = self._chasing = any(s.alarmed and s.last_scan == self._scan - 1 for s in self._seen)
        if not chasing or self._scan % self.full_every == 0:
            return self.faces.detect(gray, self._above_horizon(gray, camera)), True
        return self._look_round(gray), False

    def _above_horizon(self, gray, camera: Pinhole) -> Box | None:
        """The part of the image a whole-image scan covers: every row, or (`below_horizon_px` >= 0) the rows
        above the horizon of a level camera and that many below it."""
        if self.below_horizon_px < 0:
            return None
        height, width = gray.shape[:2]
        rows = min(height, max(0, int(math.ceil(camera.cy)) + 1 + int(self.below_horizon_px)))
        return Box(0.0, 0.0, float(width), float(rows))

    def _looking(self, now: float) -> _Seen | None:
        """The face the robot is to hold still for, if any: not yet judged, its last vote unknown, no suspect
        yet, first seen unknown less than `look_s` ago (once per face remembered: a face that never settles
        does not hold the robot for good), last seen within `look_edge` of the image's side."""
        if self.look_s <= 0:
            return None
        edge = self.look_edge * self._width
        return next((s for s in self._seen
                     if not s.alarmed and not s.settled_known and s.unknown > 0 and s.first_unknown_at is not None
                     and now - s.first_unknown_at < self.look_s and not edge <= s.box.centre[0] <= self._width - edge),
                    None)

    def _look_command(self, seen: _Seen) -> Twist:
        """The hold's command: zero while the face is in the newest scan (or nothing says where it went); else a
        turn back towards its bearing at the first sight, proportional and at most `look_turn`."""
        command = Twist()
        if seen.last_scan == self._scan or seen.heading is None or not self._headings or self.look_turn <= 0:
            return command
        error = math.remainder(seen.heading - self._headings[-1][1], 2.0 * math.pi)
        if abs(error) > LOOK_AIMED_RAD:
            command.angular.z = max(-self.look_turn, min(self.look_turn, LOOK_TURN_GAIN * error))
        return command

    def _bearing(self, box: Box, camera: Pinhole, stamp: float) -> float | None:
        """The box's centre as a heading in the odometry frame: odometry's heading nearest the image's stamp
        plus the angle of the box left of the optical axis (a camera looking along the base's x). None without
        odometry."""
        if not self._headings:
            return None
        return self._heading_at(stamp) + camera.bearing(box.centre[0])

    def _awaiting_confirmation(self, now: float, within_s: float) -> bool:
        """Whether a face seen in the last scan, less than `within_s` ago, is unknown so far but not yet a
        suspect (fewer than `confirm` unknown scans in a row)."""
        return any(s.last_scan == self._scan and not s.alarmed and not s.settled_known and now - s.last_seen < within_s
                   and 0 < s.unknown < self.confirm for s in self._seen)

    def _look_round(self, gray) -> list[Box]:
        """Faces round those seen in the last scan that are still being watched (not known to be staff): each
        looked for in 2.5 times its box, at 0.6-1.6 times its size."""
        found: list[Box] = []
        for seen in self._seen:
            if seen.settled_known or seen.last_scan != self._scan - 1:
                continue
            size = seen.box.h
            smallest = max(self.min_face_px - 4, int(0.6 * size))
            for box in self.faces.detect(gray, seen.box.scaled(2.5), min_face_px=smallest,
                                         max_face_px=int(1.6 * size) + 1):
                if all(box.iou(other) < 0.5 for other in found):
                    found.append(box)
        return sorted(found, key=lambda b: -b.area)

    def _beyond_depth(self, box: Box, camera: Pinhole) -> bool:
        """Whether a face as tall as `box` (0.12-0.30 m) would be within 0.5 m to `depth_check_m`, where a depth
        camera reads: then the depth image must have a reading in it (see `depth_check_m`)."""
        return (self.depth_check_m > 0 and camera.fy * FACE_HEIGHTS_M[1] / box.h <= self.depth_check_m
                and camera.fy * FACE_HEIGHTS_M[0] / box.h >= 0.5)

    def _depth_at(self, stamp: float):
        """The depth image (metres) for the colour image stamped `stamp`, for the depth check: the one stamped as
        it or, since the two streams arrive in either order, the nearest within NEAR_DEPTH_S while the robot
        turned less than NEAR_DEPTH_TURN_RAD between them (on a turning robot another instant's depth shows what
        is beside the box). None when the camera's depth is not working (no image within DEPTH_FLOWING_S, or it
        does not convert): the check is skipped. _UNDECIDED when depth flows but no image near enough has come:
        the box is not counted this scan (taking it unchecked let a poster across the room pass on a loaded
        graph, whose depth images came after their colour images)."""
        if not self._depths or stamp - self._depths[-1].header.stamp.to_sec() > DEPTH_FLOWING_S:
            return None
        nearest = min(self._depths, key=lambda d: abs(d.header.stamp.to_sec() - stamp))
        other = nearest.header.stamp.to_sec()
        if abs(other - stamp) >= 1e-3 and (abs(other - stamp) > NEAR_DEPTH_S
                                           or self._turned_between(other, stamp) > NEAR_DEPTH_TURN_RAD):
            return _UNDECIDED
        return self._metres(nearest)

    def _turned_between(self, start: float, end: float) -> float:
        """How far (rad) odometry's heading turned between two instants (its readings nearest them); 0 without
        odometry."""
        if not self._headings:
            return 0.0
        return abs(math.remainder(self._heading_at(end) - self._heading_at(start), 2.0 * math.pi))

    def _heading_at(self, stamp: float) -> float:
        """Odometry's heading at the reading nearest `stamp` (there must be one)."""
        return min(self._headings, key=lambda entry: abs(entry[0] - stamp))[1]

    def _depth(self):
        """The newest depth image (metres), None without one."""
        return self._metres(self.registers.depth)

    def _metres(self, msg: Image | None):
        if msg is None:
            return None
        try:
            return to_depth_m(msg)
        except ImageEncodingError as error:
            self.log_every("depth encoding", 5.0, f"depth: {error}", "warn")
            return None

    def _associate(self, boxes: list[Box], now: float) -> list[tuple[Box, _Seen]]:
        """Each box with the face remembered near its place (the same face, moved since: the farther, the longer
        ago it was seen; a turning robot sweeps a face across the image, about a face width or two a scan), of
        about the same size; or a new one. Nearest pairs first, so two faces side by side keep their own."""
        def gap(seen: _Seen, box: Box) -> float:
            (x0, y0), (x1, y1) = seen.box.centre, box.centre
            return math.hypot(x1 - x0, y1 - y0) / max(seen.box.w, box.w)

        pairs = sorted((gap(s, b), i, j) for i, s in enumerate(self._seen) for j, b in enumerate(boxes)
                       if 0.67 <= b.h / max(s.box.h, 1.0) <= 1.5 and gap(s, b) <= 0.6 + 12.0 * (now - s.last_seen))
        matched: dict[int, _Seen] = {}
        taken: set[int] = set()
        for _, i, j in pairs:
            if i not in taken and j not in matched:
                taken.add(i)
                matched[j] = self._seen[i]
        result = []
        for j, box in enumerate(boxes):
            seen = matched.get(j)
            if seen is None:
                seen = _Seen(box, now)
                self._seen.append(seen)
            else:
                seen.box, seen.last_seen = box, now
            result.append((box, seen))
        return result

    def _vote(self, seen: _Seen, gray, box: Box) -> None:
        if self.known_people is None:
            seen.unknown += 1
            return
        identity = self.known_people.identify(gray, box)
        if identity.known:
            seen.known[identity.name] = seen.known.get(identity.name, 0) + 1
            seen.unknown = 0  # "in a row"
        else:
            seen.unknown += 1


class Track(Module):
    """TLD-style tracking of the target given on `target` (a box in the newest image): publishes its box with
    the image's header every frame (`box_info`), and whether it is sure (`confident`). A zero-size `target`
    stops tracking; so does a target lost for `give_up_s`."""

    image = Input(Image, "camera/rgb/image_raw", latest=True)
    camera_info = Input(CameraInfo, "camera/rgb/camera_info (copied into box_info)")
    target = Input(RegionOfInterest, "the box to track, in the newest image (detect's, or the operator's)")
    box_info = Output(CameraInfo, "header of the image, camera calibration, roi = the box (zero while lost)")
    box = Output(RegionOfInterest, "the box (zero while lost), unstamped")
    confident = Output(Bool, "whether the box is believed this frame")
    short_term = Param("mosse", "short-term tracker: mosse, medianflow, kcf, csrt or tld")
    min_face_px = Param(24, "smallest face the re-detector seeks (px)")
    scale_factor = Param(1.1, "step between the re-detector's scan sizes", min=1.01)
    full_search_every = Param(2, "while lost, every Nth search covers the whole image, the others round the last "
                                 "place (1: always the whole)", min=1)
    give_up_s = Param(20.0, "s lost before tracking stops (and box_info stops)")

    def setup(self) -> None:
        self.tracker = TargetTracker(TrackerSettings(short_term=self.short_term, min_face_px=self.min_face_px,
                                                       scale_factor=self.scale_factor,
                                                       full_search_every=self.full_search_every))
        self._rgb = None
        self._header = None   # the newest image's header (for the box sent at once on a new target)
        self._lost_since: float | None = None
        self._late_frames = _LateFrames(self)

    def on_target(self, msg: RegionOfInterest) -> None:
        """Take up a target box (from detect or the operator); an empty box stops tracking."""
        box = Box.from_roi(msg)
        if box.area == 0:
            self.tracker.stop()
            self.log("target cleared")
            return
        if self.tracker.box is not None and self.tracker.box.iou(box) >= 0.3:
            self.log(f"target at {box.ints()}: the one tracked at {self.tracker.box.ints()}, kept (what was learned "
                     f"of it too)")
            return
        if self._rgb is None:
            self.log("target given before any image: ignored", "warn")
            return
        settled = self.tracker.settle(self._rgb, box)  # the box is from an older image than the newest
        try:
            self.tracker.start(self._rgb, settled)
        except ValueError as error:
            self.log(f"target: {error}", "warn")
            return
        self._lost_since = None
        moved = "" if settled == box else f" (given at {box.ints()}: the face it was drawn round, in this image)"
        self.log(f"tracking a new target at {settled.ints()}{moved}")
        # the box in the newest image, at once: follow takes the target up (and stands still) now, not a frame
        # and a tracker update later
        self._publish(self._header, self._rgb.shape[1], self._rgb.shape[0], settled, True)

    def on_image(self, msg: Image) -> None:
        """Track the target in the newest frame and publish its box with the image's header."""
        self._late_frames.heard(msg.header, self.now())
        try:
            self._rgb = to_rgb(msg)
        except ImageEncodingError as error:
            self.log(f"image: {error}", "warn")
            return
        self._header = msg.header
        if not self.tracker.active:
            return
        state = self.tracker.update(self._rgb)
        if state.confident:
            self._lost_since = None
        elif self._lost_since is None:
            self._lost_since = self.now()
        elif self.now() - self._lost_since > self.give_up_s:
            self.log(f"target lost for {self.give_up_s:.0f} s: tracking stops")
            self.tracker.stop()
        self._publish(msg.header, msg.width, msg.height, state.box, state.confident)

    def _publish(self, header, width: int, height: int, box: Box, confident: bool) -> None:
        roi = box.to_roi(width, height) if confident else RegionOfInterest()
        info = CameraInfo() if self.registers.camera_info is None else _copy_info(self.registers.camera_info)
        info.header = header
        info.width, info.height = width, height
        info.roi = roi
        self.box_info.publish(info)
        self.box.publish(roi)
        self.confident.publish(Bool(confident))


def _copy_info(info: CameraInfo) -> CameraInfo:
    copy = CameraInfo()
    copy.distortion_model, copy.D, copy.K, copy.R, copy.P = info.distortion_model, info.D, info.K, info.R, info.P
    copy.binning_x, copy.binning_y = info.binning_x, info.binning_y
    return copy


class Follow(Module):
    """Follows the tracked target: its bearing turns the robot, its range (registered depth, or size) sets the
    speed that keeps `distance_m`, with the target's own speed (estimated from the range's rate of change and
    the robot's own commands) fed forward so that a target driving away is followed at that distance. Sends cmd_vel for every box; while the target is lost it holds still for
    `hold_s`, then falls silent so that the suppressor hands the motors back to the lower levels.

    On detect's alarm it sends a zero at once and stands still for `still_s`: the robot stops when the suspect is
    found, not a tracker's first box later (the inhibitor above only silences the lower levels, and a base goes
    on with its last command until its own timeout; on a loaded ROS graph track's first box came 0.16 s after
    the alarm)."""

    box_info = Input(CameraInfo, "track's box_info: roi = the target's box, zero while lost")
    alarm = Input(PointStamped, "detect's alarm: a suspect was just found (stand still now)")
    depth = Input(Image, "camera/depth/image_raw, registered: 32FC1 m or 16UC1 mm", latest=True)
    cmd_vel = Output(Twist, "motor command (into the motor line through a suppressor)")
    distance_m = Param(1.2, "m: following distance")
    max_v = Param(0.5, "m/s: fastest forward speed while following")
    max_w = Param(1.5, "rad/s: fastest turn while following")
    k_v = Param(0.8, "m/s per m of range error")
    k_w = Param(2.0, "rad/s per rad of bearing")
    target_height_m = Param(0.16, "m: true height of the target's box (a face) for range from size")
    stop_m = Param(0.6, "m: no forward motion with anything nearer in the robot's way (the Kinect sees nothing "
                        "within 0.45 m: stop before)")
    half_width_m = Param(0.25, "m: half the width of the robot's way (its radius plus a margin)", min=0.0)
    hold_s = Param(1.0, "s to stand still after the target is lost, before falling silent")
    still_s = Param(0.0, "s to stand still when a target is taken up (its first box after more than hold_s "
                         "without one), before following: the robot stops at once, detect, track and the alarm "
                         "act, the tracker learns the target from a still camera", min=0.0)
    new_target_after_s = Param(5.0, "s without a box after which a box is a new target (stand still `still_s` "
                                    "first); a target back sooner (from behind a passer-by) is followed at once",
                               min=0.0)
    speed_filter_s = Param(0.5, "s: time constant of the target speed estimate (fed forward)", min=0.01)
    hfov_deg = Param(57.0, "degrees: horizontal field of view, used when box_info has no K")
    max_box_age_s = Param(1.0, "s: a box on an older image steers nothing (held still as if lost): on a loaded "
                               "graph boxes queue behind slow callbacks, seconds late", min=0.05)

    def setup(self) -> None:
        self.settings = FollowSettings(self.distance_m, self.max_v, self.max_w, self.k_v, self.k_w,
                                       self.target_height_m, self.stop_m, half_width_m=self.half_width_m)
        self.settings.check()
        self._lost_since: float | None = None
        self._last_box_at: float | None = None
        self._still_until = -math.inf
        self.last = None
        self.motion = TargetMotion(time_constant_s=self.speed_filter_s)
        self._own_v = 0.0

    def on_alarm(self, msg: PointStamped) -> None:
        """A new suspect: stand still for `still_s` before following."""
        now = self.now()
        self._still_until = now + self.still_s
        self._last_box_at = now  # the target counts as taken up now: its first box does not restart the wait
        self._lost_since = None
        self._own_v = 0.0
        self.motion.reset()
        self.cmd_vel.publish(Twist())

    def on_box_info(self, msg: CameraInfo) -> None:
        """Steer towards the tracked box: range from depth (or the box's size) and bearing to a velocity command."""
        box = Box.from_roi(msg.roi)
        now = self.now()
        if _stale(msg.header, now, self.max_box_age_s):
            box = Box(0.0, 0.0, 0.0, 0.0)  # where the target was long ago is no way to steer: as if lost
        if box.area == 0:
            self._lost_since = now if self._lost_since is None else self._lost_since
            if now - self._lost_since <= self.hold_s:
                self.cmd_vel.publish(Twist())
            self._own_v = 0.0
            self.motion.reset()
            return
        self._lost_since = None
        if self._last_box_at is None or now - self._last_box_at > max(self.hold_s, self.new_target_after_s):
            # a target taken up: stand still first. Not a target back from an occlusion: standing a second more
            # there let the office's target drive 0.3 m further off (2.5 m behind it after the passer-by)
            self._still_until = now + self.still_s
        self._last_box_at = now
        depth = None
        if self.registers.depth is not None:
            try:
                depth = to_depth_m(self.registers.depth)
            except ImageEncodingError as error:
                self.log(f"depth: {error}", "warn")
        camera = camera_of(msg, msg.width or 640, msg.height or 480, self.hfov_deg)
        stamp = msg.header.stamp.to_sec() if msg.header.stamp.to_sec() > 0 else now
        range_m, source = target_range(box, camera, depth, self.settings.target_height_m)
        target_speed = self.motion.update(stamp, range_m, source, self._own_v)
        if now < self._still_until:  # standing still: the estimate learns the target's speed meanwhile
            self._own_v = 0.0
            self.cmd_vel.publish(Twist())
            return
        self.last = follow_command(box, camera, depth, self.settings, target_speed)
        self._own_v = self.last.v
        twist = Twist()
        twist.linear.x, twist.angular.z = self.last.v, self.last.w
        self.cmd_vel.publish(twist)


__all__ = ["Detect", "Track", "Follow", "camera_of", "located", "intruder_status"]
