"""gmapping's job as a subsumption module: builds the map from a range scan and odometry while the robot drives.

Inputs ``scan`` (sensor_msgs/LaserScan: a laser, or a depth camera's fake scan) and ``odom``
(nav_msgs/Odometry); the sensor's mounting comes from ``/tf_static``. Outputs, as ROS tools expect them:

* ``map`` (nav_msgs/OccupancyGrid, latched, frame ``map``; wire it to ``/map``), every
  ``map_update_interval`` seconds while it changes;
* ``map -> odom`` on ``/tf``, every ``transform_publish_period`` seconds, so that ``map -> odom ->
  base_link`` is where SLAM thinks the robot is;
* ``trajectory`` (nav_msgs/Path, latched, frame ``map``): the keyframes' optimised poses, for rviz and for
  scoring a run.

With ``map_file`` set, every map update is also saved there as a map_server map (YAML + PGM). The method
(scan matching plus a pose graph with loop closure) is in :mod:`navigation.slam_core`; parameters keep
gmapping's names where the idea is the same.
"""
from __future__ import annotations

import math
from pathlib import Path as FilePath

import genpy
import numpy as np
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from nav_msgs.srv import GetMap, GetMapResponse
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

from subsumption import Input, Module, Output, Param
from subsumption.mapfile import save_map

from .grid_messages import grid_msg
from .scan_geometry import MountListener, beams_of
from .scan_sync import ScanOdometrySync
from subsumption.planar import compose, pose_msg, transform_msg
from .slam_core import GraphSlam, SlamParams


SCANS_WAITING = 100  # scans kept until their odometry comes: a map builder that fell behind loses none


class SlamFeed:
    """A scan with the odometry pose of its instant and the sensor's mount, into the SLAM core: the one path both
    the live node (:class:`Slam`) and the offline bag mapper (:mod:`navigation.bag_map`) take, so that the same
    messages give the same map whichever way they come."""

    def __init__(self, params: SlamParams, max_urange: float = 0.0, initial_pose: list | None = None) -> None:
        self.params = params
        self.max_urange = max_urange
        self.initial_pose = list(initial_pose or [])
        self.core: GraphSlam | None = None

    def process(self, scan: LaserScan, odom: np.ndarray, mount: tuple[np.ndarray, bool]) -> bool:
        """True if the scan became a keyframe. The first scan starts the map at `initial_pose` composed with its
        odometry (the map frame is the odometry frame when `initial_pose` is empty)."""
        max_range = self.max_urange if self.max_urange > 0 else math.inf
        beams = beams_of(scan, mount, max_range)
        if self.core is None:
            origin = np.asarray(self.initial_pose, dtype=float) if len(self.initial_pose) == 3 else np.zeros(3)
            self.core = GraphSlam(self.params, compose(origin, odom))
        return self.core.add_scan(scan.header.stamp.to_sec(), odom, beams)


class Slam(Module):
    """Builds an occupancy map from a range scan and odometry (gmapping's job): publishes ``map`` and
    ``map -> odom`` while it runs, and saves a map_server map."""

    scan = Input(LaserScan, "range scan (laser or depth camera), any frame mounted on the robot in /tf_static")
    odom = Input(Odometry, "odometry: pose of the base frame in the odom frame")
    map = Output(OccupancyGrid, "the map so far (latched, frame map): wire to /map", latch=True)
    trajectory = Output(Path, "keyframe poses as optimised so far (latched, frame map)", latch=True)

    delta = Param(0.05, "m per map cell (gmapping's delta)")
    maxUrange = Param(0.0, "m: returns beyond are used as free space only (0: the sensor's range_max)")
    linearUpdate = Param(0.2, "m driven between processed scans")
    angularUpdate = Param(0.2, "rad turned between processed scans")
    temporalUpdate = Param(-1.0, "s between processed scans regardless of motion (<0: off)")
    occ_thresh = Param(0.25, "hits / visits above which a cell is occupied")
    srr = Param(0.05, "odometry error in translation as a function of translation")
    srt = Param(0.05, "odometry error in translation as a function of rotation")
    str = Param(0.05, "odometry error in rotation as a function of translation")
    stt = Param(0.05, "odometry error in rotation as a function of rotation")
    odometry_adapt = Param(True, "learn odometry's error from the scans: per axis (along, across, heading), "
                                 "fitted to the errors of the last odometry_adapt_window keyframes where the scan "
                                 "pins that axis down, within 0.1 and 4 times srr..stt's model (off: the model)")
    odometry_adapt_window = Param(100, "keyframes odometry's error is learned over", min=20)
    odometry_adapt_min_fov = Param(2.0, "rad: a narrower scan (a depth camera's) does not learn odometry's error: "
                                        "it pins the pose down too seldom", min=0.0)
    scan_matching = Param(True, "off: odometry alone places the scans (a baseline for measurements)")
    local_keyframes = Param(20, "recent keyframes a new scan is matched against")
    local_radius = Param(3.0, "m: also match against earlier keyframes this near in space, facing the same way "
                              "(0: off)")
    local_near_keyframes = Param(20, "at most this many of those near keyframes (the nearest)")
    local_max_travel = Param(6.0, "m of driving since a near keyframe within which it joins the local map "
                                  "(older visits are left to loop closure)")
    loop_closure = Param(True, "look for loop closures")
    loop_search_radius = Param(3.0, "m around the estimated pose where earlier keyframes are tried")
    loop_min_travel = Param(6.0, "m of driving since a keyframe before it may close a loop")
    match_sigma = Param(0.02, "m: range noise the scan matcher assumes (its point-to-line residuals' scale)", min=0.001)
    match_voxel = Param(0.03, "m: a scan keeps one point per square this size for matching", min=0.001)
    match_points = Param(200, "at most this many of a new scan's points are matched in tracking (evenly spread)",
                         min=10)
    min_inliers = Param(0.3, "share of a scan that must fit the local map for tracking to trust the match (else "
                             "odometry places the keyframe)", min=0.0, max=1.0)
    match_min_structure = Param(0.0, "points' worth of scan evidence a direction needs before tracking moves "
                                     "along it (fewer: odometry decides that direction; 0: off, the fusion below "
                                     "weighs each direction instead)")
    match_information = Param(0.05, "scale of a scan's ICP information when it is fused with odometry's prior in "
                                    "tracking (a scan's points are not independent measurements)", min=0.0)
    match_corners = Param(0.05, "m: tracking also pairs a scan's points that have no normal (corners, door jambs) "
                               "with the local map's, point to point, at this sigma: they pin a pose down along a "
                               "corridor (0: off)", min=0.0)
    match_corners_min_fov = Param(2.0, "rad: a scan's field of view below which tracking pairs no corners (a "
                                       "narrow depth scan's hits without a normal are mostly where its view is cut "
                                       "off)", min=0.0)
    match_search_radius = Param(0.0, "m: tracking first searches the local map correlatively this far around "
                                     "odometry's prediction (every pose, exhaustively) and starts its ICP from the "
                                     "best one (0: ICP starts at the prediction)", min=0.0)
    match_search_angle = Param(0.1, "rad: how far in heading that search looks either side of the prediction",
                               min=0.0)
    match_near_first = Param(False, "with normal_radius_growth: tracking first matches the scan's near points (those "
                                    "whose normal the fixed 0.15 m radius gives), then all its points from that pose "
                                    "(a far point pairs with the right wall only once the heading is nearly right)")
    normal_radius_growth = Param(0.0, "a hit's normal is fitted to its neighbours within 0.15 m or this times its "
                                      "range, whichever is more (far walls for tracking; loop closures keep the "
                                      "fixed-radius points; 0: off)", min=0.0)
    match_facing = Param(True, "a scan point pairs only with map points whose normal faces its way, in tracking and "
                               "in the loop closures that descend from the estimate (a thin wall's two sides are "
                               "two surfaces); off: with the nearest, whatever its side")
    loop_min_inliers = Param(0.6, "share of a loop closure's query that must fit the earlier keyframes' points",
                             min=0.0, max=1.0)
    loop_max_rms = Param(0.025, "m: the point-to-line error of a loop closure's inliers at most", min=0.0)
    loop_neighbours = Param(6, "keyframes either side of a candidate whose scans form its map (closures by ICP "
                               "from the estimate)", min=0)
    loop_every = Param(2, "try a loop closure at every n-th keyframe")
    loop_min_structure = Param(3.0, "points' worth of scan evidence a loop closure needs in every direction "
                                    "(when loop_partial_structure is 0)")
    loop_partial_structure = Param(10.0, "points' worth of scan evidence a direction needs for a loop closure to "
                                         "constrain it; a closure may constrain only some (one wall seen again "
                                         "ties the pose across it, not along it; 0: all directions or none)")
    loop_query_keyframes = Param(5, "a loop closure matches the points of this many last keyframes together, "
                                     "placed where tracking put them (a wider view than one narrow scan; 1: its own)",
                                 min=1)
    loop_query_travel = Param(2.0, "m: only those of them driven within this distance of the newest", min=0.0)
    loop_query_points = Param(400, "at most this many of their points are matched (evenly spread)", min=20)
    loop_agree_window = Param(24, "keyframes within which a second loop closure must confirm the first before "
                                  "either enters the pose graph", min=1)
    loop_agree_distance = Param(0.05, "m: two loop closures agree when they move the robot alike to within this",
                                min=0.0)
    loop_agree_angle = Param(0.02, "rad: ... and to within this in heading", min=0.0)
    loop_agree_separation = Param(0.5, "m: with a scan wider than half a circle, two loop closures confirm each other "
                                       "only when found this far apart (turning on the spot, such a scan sees the "
                                       "same place again: one look, not two)", min=0.0)
    loop_correlative = Param(True, "search loop closures correlatively (likelihood field, branch and bound) in a "
                                   "window grown with the driving since the last closure (off: ICP from the estimate)")
    loop_correlative_min_fov = Param(2.0, "rad: a scan's field of view below which closures are searched by ICP from "
                                          "the estimate, not correlatively (a narrow scan shows too little of a place "
                                          "to tell it from a look-alike in a wide window)", min=0.0)
    loop_radius_growth = Param(0.1, "m of closure search window per m driven since the last accepted closure")
    loop_search_max = Param(8.0, "m: the closure search window's radius at most")
    loop_search_angle = Param(0.2, "rad: the closure search window's half-angle right after a closure")
    loop_angle_growth = Param(0.01, "rad of half-angle per m driven since the last accepted closure")
    loop_search_angle_max = Param(0.52, "rad: the closure search window's half-angle at most")
    loop_map_keyframes = Param(40, "at most this many earlier keyframes (the nearest) form the map a closure searches")
    loop_min_score = Param(0.5, "mean likelihood (0..1) of the query's points a correlative closure needs")
    loop_field_sigma = Param(0.05, "m: width of the closure search's likelihood field")
    loop_rival_distance = Param(2.0, "m: a correlative closure is ambiguous when a pose this far from its best ...")
    loop_rival_share = Param(0.9, "... scores this share of the best; it is then not used")
    track_robust = Param(3.0, "Cauchy scale of tracking's pose graph edges, in standard deviations (0: not robust): "
                              "a step that later loop closures contradict by far more gives way", min=0.0)
    loop_robust = Param(1.0, "Cauchy scale of loop closure factors, in standard deviations (0: not robust)")
    odom_history = Param(5.0, "s of odometry kept to pair a late scan with the pose of its instant (a node "
                              "catching up on a fast-played bag needs more)", min=0.1)
    map_update_interval = Param(5.0, "s between map publications (gmapping's map_update_interval)")
    transform_publish_period = Param(0.05, "s between map -> odom publications")
    map_frame = Param("map", "frame of the map")
    odom_frame = Param("", "odometry frame (empty: the odom message's header.frame_id)")
    base_frame = Param("", "robot frame (empty: the odom message's child_frame_id)")
    initial_pose = Param([], "[x, y, yaw] in the map of the odometry frame's origin, i.e. of the robot where its "
                             "odometry started (empty: the map frame is the odom frame)")
    map_file = Param("", "save the map here (map_server YAML + PGM) at every map update")

    def setup(self) -> None:
        names = {name: getattr(self, name) for name in self.interface.params}
        self.params = SlamParams.from_mapping(names)
        self.feed = SlamFeed(self.params, float(self.maxUrange), list(self.initial_pose))
        self.mounts = MountListener(self.node)
        self.sync = ScanOdometrySync(self._process, self._no_odometry, float(self.odom_history), SCANS_WAITING)
        self._changed = False
        self._warned: set[str] = set()
        self._tf = self.node.publisher("/tf", TFMessage)
        self.every(float(self.transform_publish_period), self._publish_transform)
        self.every(float(self.map_update_interval), self.publish_map)
        self.node.service("dynamic_map", GetMap, self._dynamic_map)  # gmapping's: the map as it is now

    # Inputs ---------------------------------------------------------------------------------------
    def on_odom(self, msg: Odometry) -> None:
        """Pass the odometry on for pairing with scans."""
        self.sync.on_odom(msg)

    def on_scan(self, msg: LaserScan) -> None:
        """Queue the scan to be paired with the odometry of its own stamp (SLAM processes it then)."""
        self.sync.on_scan(msg)

    @property
    def frames(self) -> tuple[str, str] | None:
        """(odom frame, base frame): the parameters, else what odometry messages say."""
        if self.sync.frames is None:
            return None
        return self.odom_frame or self.sync.frames[0], self.base_frame or self.sync.frames[1]

    def _warn_once(self, key: str, text: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            self.log(text, "warn")

    def _no_odometry(self, scan: LaserScan) -> None:
        self._warn_once("odom", f"no odometry at the time of scan {scan.header.stamp.to_sec():.3f} on "
                                f"{self.node.resolve('scan')}: scan skipped")

    def _process(self, scan: LaserScan, odom: np.ndarray) -> None:
        base = self.frames[1]
        mount = self.mounts.mount(base, scan.header.frame_id)
        if mount is None:
            self._warn_once("tf", f"no transform {base} -> {scan.header.frame_id} on /tf_static yet: scan skipped")
            return
        started = self.core is None
        if self.feed.process(scan, odom, mount):
            self._changed = True
            self._publish_transform()
        if started and self.core is not None:
            start = self.core.start
            self.log(f"started at ({start[0]:.2f}, {start[1]:.2f}, {start[2]:.2f}) in {self.map_frame}, "
                     f"{len(self.core.keyframes[0].beams.angles)} beams from {scan.header.frame_id}")

    @property
    def core(self) -> GraphSlam | None:
        """The SLAM back end fed so far (None before the first scan with its odometry)."""
        return self.feed.core

    # Outputs --------------------------------------------------------------------------------------
    def _publish_transform(self) -> None:
        if self.core is None or self.frames is None:
            return
        stamp = self.now() + float(self.transform_publish_period)  # forward-dated, as gmapping's tf_delay
        self._tf.publish(TFMessage([transform_msg(self.core.map_to_odom, stamp, self.map_frame, self.frames[0])]))

    def _dynamic_map(self, _request) -> GetMapResponse:
        """gmapping's ``dynamic_map`` service: the map built so far (an error before the first scan)."""
        if self.core is None:
            raise ValueError("no map yet: no scan with odometry has come in")
        return GetMapResponse(grid_msg(self.core.occupancy(exact=False), self.now(), self.map_frame))

    def publish_map(self) -> None:
        """Publish the map and the trajectory (and save them, with `map_file`) if anything changed."""
        if self.core is None or not self._changed:
            return
        self._changed = False
        now = self.now()
        # a map that is kept is exact; one that is only shown may leave keyframes a few millimetres where they were
        grid = self.core.occupancy(exact=bool(self.map_file))
        self.map.publish(grid_msg(grid, now, self.map_frame))
        self.trajectory.publish(self.path_msg(now))
        if self.map_file:
            save_map(grid, self.map_file)

    def path_msg(self, stamp: float) -> Path:
        """The keyframes' trajectory as a nav_msgs/Path in the map frame."""
        stamps, poses = self.core.trajectory() if self.core else (np.zeros(0), np.zeros((0, 3)))
        header = Header(0, genpy.Time.from_sec(stamp), self.map_frame)
        return Path(header=header, poses=[PoseStamped(Header(0, genpy.Time.from_sec(t), self.map_frame), pose_msg(p))
                                          for t, p in zip(stamps, poses)])

    def save(self, yaml_path: str | FilePath) -> FilePath:
        """Write the map as map_saver does (YAML + PGM)."""
        if self.core is None:
            raise RuntimeError(f"{self.node.name}: no map yet (no scan with odometry received)")
        return save_map(self.core.occupancy(), yaml_path)
