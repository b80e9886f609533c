"""amcl's job as a subsumption module: where is the robot on a known map?

Inputs: ``scan`` (sensor_msgs/LaserScan, mounted per ``/tf_static``), ``odom`` (nav_msgs/Odometry), ``map``
(nav_msgs/OccupancyGrid, latched: from a map server, the simulator or SLAM) and ``initialpose``
(geometry_msgs/PoseWithCovarianceStamped in frame ``map``: what rviz's "2D Pose Estimate" sends). Outputs:
``amcl_pose`` (PoseWithCovarianceStamped) after every filter update, ``particlecloud`` (PoseArray) and
``map -> odom`` on ``/tf`` (so ``map -> odom -> base_link`` is the estimate), every
``transform_publish_period`` s, forward-dated by ``transform_tolerance`` as amcl does. With a start pose (the
``initial_pose_*`` parameters or an ``initialpose``, not ``global_localization``) ``map -> odom`` is published from
it as soon as the map and the first odometry are in, before the first scan: move_base can plan at once instead of
waiting for the first filter update while lower levels drive the robot off its first goal.

The filter (:mod:`navigation.amcl_core`) updates when odometry says the robot moved ``update_min_d`` or turned
``update_min_a``; before the first ``initialpose`` it starts from ``initial_pose_x/y/a`` with
``initial_cov_xx/yy/aa``, or all over the free space with ``global_localization``. Parameter names are amcl's.
Globally localizing (the parameter or the ``global_localization`` service), it also searches the whole map for its
last scans (:mod:`navigation.global_search`, ``global_search``) and restarts the filter round the pose found once no
look-alike rivals it: the filter alone settles on a mirror pose in a symmetric room or a look-alike corridor.
"""
from __future__ import annotations

import math
import threading
from concurrent.futures import Future

import genpy
import numpy as np
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty, EmptyResponse
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

from subsumption import Input, Module, Output, Param
from subsumption.module import ParamError

from .amcl_core import AmclParams, LikelihoodField, ParticleFilter, warm_up
from .grid_messages import GridMessageError, grid_of
from .global_search import START_COVARIANCE, GlobalSearch
from .scan_geometry import MountListener, beams_of
from .scan_sync import ScanOdometrySync
from subsumption.planar import between, compose, from_pose_msg, inverse, pose_msg, transform_msg


class Amcl(Module):
    """Localizes the robot on a known map with a particle filter (amcl's job): publishes ``amcl_pose``,
    ``particlecloud`` and ``map -> odom``."""

    scan = Input(LaserScan, "range scan, any frame mounted on the robot in /tf_static")
    odom = Input(Odometry, "odometry: pose of the base frame in the odom frame")
    map = Input(OccupancyGrid, "the known map (latched)")
    initialpose = Input(PoseWithCovarianceStamped, "a pose to start from, frame map (rviz: 2D Pose Estimate)")
    amcl_pose = Output(PoseWithCovarianceStamped, "the estimate after each filter update, frame map; latched as "
                       "amcl latches it, so a client that starts later still hears where the robot is", latch=True)
    particlecloud = Output(PoseArray, "the particles, frame map")

    min_particles = Param(300, "fewest particles the filter keeps (the floor of KLD sampling)")
    max_particles = Param(5000, "most particles the filter keeps (the ceiling of KLD sampling)")
    kld_err = Param(0.01, "KLD-sampling: largest error between true and estimated distribution")
    kld_z = Param(0.99, "KLD-sampling: probability that the error stays below kld_err")
    update_min_d = Param(0.1, "m moved before a filter update")
    update_min_a = Param(0.2, "rad turned before a filter update")
    resample_interval = Param(1, "filter updates between resamplings")
    recovery_alpha_slow = Param(0.001, "decay of the long-term average likelihood (0: no recovery)")
    recovery_alpha_fast = Param(0.1, "decay of the short-term average likelihood")
    odom_alpha1 = Param(0.02, "rotation noise from rotation")
    odom_alpha2 = Param(0.02, "rotation noise from translation")
    odom_alpha3 = Param(0.02, "translation noise from translation")
    odom_alpha4 = Param(0.02, "translation noise from rotation")
    laser_max_beams = Param(60, "beams used per update, evenly spread")
    laser_z_hit = Param(0.95, "weight of the hit part of the model")
    laser_z_rand = Param(0.05, "weight of the random part of the model")
    laser_sigma_hit = Param(0.05, "m: spread of the hit part of the model")
    laser_likelihood_max_dist = Param(2.0, "m: distances to walls are capped here")
    laser_max_range = Param(-1.0, "m: returns beyond are ignored (<= 0: the scan's range_max)")
    laser_model_type = Param("likelihood_field_two_sided", "likelihood_field_two_sided (beam ends scored on "
                             "both sides of a wall surface and beams' paths checked for walls; beams that saw "
                             "nothing count too), likelihood_field_prob (amcl's: product of the hits' "
                             "likelihoods) or likelihood_field (amcl's 1 + sum of their cubes)")
    initial_pose_x = Param(0.0, "m: x of the start pose in the map frame, before any initialpose", per_run=True)
    initial_pose_y = Param(0.0, "m: y of the start pose in the map frame", per_run=True)
    initial_pose_a = Param(0.0, "rad: heading of the start pose in the map frame", per_run=True)
    initial_cov_xx = Param(0.25, "m^2: variance of the start pose in x")
    initial_cov_yy = Param(0.25, "m^2: variance of the start pose in y")
    initial_cov_aa = Param((math.pi / 12) ** 2, "rad^2: variance of the start heading")
    global_localization = Param(False, "start with particles all over the free space instead")
    global_search = Param(True, "with global localization (the parameter or the service), also search the whole map "
                                "for the last scans (navigation.global_search) and start the filter round the pose "
                                "found once it is unambiguous")
    search_in_background = Param(True, "run each whole-map search on a thread of its own while the filter goes on "
                                       "(a search takes up to seconds on a large map); false: in the scan's callback, "
                                       "which an in-process run repeats exactly")
    transform_publish_period = Param(0.05, "s between map -> odom publications")
    transform_tolerance = Param(0.1, "s the map -> odom transform is dated ahead")
    global_frame_id = Param("map", "frame of the map")
    odom_frame_id = Param("", "odometry frame (empty: the odom message's header.frame_id)")
    base_frame_id = Param("", "robot frame (empty: the odom message's child_frame_id)")
    seed = Param(0, "random seed of the filter (a run is reproducible)")
    save_pose_period = Param(2.0, "s between saves of the estimate to ~saved_map_to_odom (0: never), as amcl's "
                                  "save_pose_rate saves ~initial_pose_*", min=0.0)
    saved_map_to_odom = Param([], "[x, y, yaw]: the map -> odom correction a previous amcl of this name saved; a "
                                  "respawned amcl starts from it and the odometry it hears, not from initial_pose_* "
                                  "(where the robot stood at the start, not where it is). Set [] at launch.")

    def setup(self) -> None:
        self.params = AmclParams.from_mapping({name: getattr(self, name) for name in self.interface.params})
        self.filter: ParticleFilter | None = None
        self.mounts = MountListener(self.node)
        self.sync = ScanOdometrySync(self._process)
        self._pending_pose: tuple[np.ndarray, np.ndarray] | None = None
        self._search: GlobalSearch | None = None  # under way while globally localizing (global_search)
        self._search_running: Future | None = None  # a search under way (on a thread of its own) or done
        self._last_odom: np.ndarray | None = None  # odometry at the last filter update
        # odometry when the initial pose held: the first message. The initial pose (parameters) is where the robot
        # stood at the start; if the first scan is processed only later (a loaded ROS graph: 35 s in, the robot
        # driven meanwhile by lower levels), the motion since is predicted, not dropped (it was: lost at once)
        self._first_odom: np.ndarray | None = None
        self._map_to_odom: np.ndarray | None = None
        self._start: np.ndarray | None = None  # the start pose, until the first map -> odom is known
        self._force_update = True
        self._tf = self.node.publisher("/tf", TFMessage)
        self._resume: np.ndarray | None = None  # a saved map -> odom to start from (a respawn)
        saved = self.saved_map_to_odom
        if isinstance(saved, list) and len(saved) == 3 and all(isinstance(v, (int, float)) and math.isfinite(v)
                                                                 for v in saved):
            self._resume = np.array(saved, dtype=float)
            self.log(f"resuming from the saved map -> odom ({saved[0]:.2f}, {saved[1]:.2f}, {saved[2]:.2f}): "
                     f"the robot is where odometry says, corrected as before")
        elif saved:
            raise ParamError(f"{self.node.resolve('~saved_map_to_odom')} must be [] or [x, y, yaw], got {saved!r}")
        warm_up()  # now, before the simulation runs, not at the first scan
        self.every(float(self.transform_publish_period), self._publish_transform)
        if self.save_pose_period > 0:
            self.every(float(self.save_pose_period), self._save_pose)
        # amcl's services (std_srvs/Empty), in the node's namespace as amcl has them: /global_localization ...
        self.node.service("global_localization", Empty, self._global_localization)
        self.node.service("request_nomotion_update", Empty, self._nomotion_update)

    def _global_localization(self, _request) -> EmptyResponse:
        """Particles all over the free space of the map (amcl's ``global_localization``): the robot is lost."""
        if self.filter is None:
            raise ValueError(f"no map on {self.node.resolve('map')} yet")
        self.filter.spread_globally()
        self._start_search()
        self._pending_pose = None
        self._force_update = True
        self.log(f"global localization: {len(self.filter.particles)} particles over the free space"
                 f"{', and a search of the whole map for the last scans' if self._search else ''}")
        return EmptyResponse()

    def _start_search(self) -> None:
        """A whole-map search for the robot (:mod:`navigation.global_search`), with `global_search`."""
        self._search = GlobalSearch(self.filter.field.grid) if self.global_search else None
        self._search_running = None

    def _searching(self, odom: np.ndarray, stamp: float, hits: np.ndarray) -> None:
        """Feed the search this scan; run a search when one is due (with `search_in_background` on a thread of its
        own: a whole-map search takes from a fraction of a second to several on a large map, and the filter goes on
        meanwhile); take up a pose found, moved by the odometry since its scan."""
        query = self._search.feed(stamp, odom, hits)
        if query is not None and self._search_running is None:
            if self.search_in_background:
                self._search_running = in_background(self._search.attempt, query)
            else:
                self._search_running = Future()
                self._search_running.set_result(self._search.attempt(query))
        running = self._search_running
        if running is None or not running.done():
            return
        self._search_running = None
        found = running.result()
        if found is None:
            return
        self._search = None
        pose = found.now(odom)
        self.filter.set_pose(pose, START_COVARIANCE)
        self.log(f"global localization: the whole-map search put the robot at ({pose[0]:.2f}, {pose[1]:.2f}, "
                 f"{math.degrees(pose[2]):.0f} deg), score {found.score:.2f}, after {found.attempts} searches")

    def _nomotion_update(self, _request) -> EmptyResponse:
        """The next scan updates the filter although the robot has not moved (amcl's ``request_nomotion_update``)."""
        self._force_update = True
        return EmptyResponse()

    @property
    def frames(self) -> tuple[str, str] | None:
        """The odometry and robot frames (parameters first, else the odometry messages'), or None before the first
        odometry."""
        if self.sync.frames is None:
            return None
        return self.odom_frame_id or self.sync.frames[0], self.base_frame_id or self.sync.frames[1]

    # Inputs ---------------------------------------------------------------------------------------
    def on_map(self, msg: OccupancyGrid) -> None:
        """Take a new map: the likelihood field is built for it (a malformed grid is logged and ignored)."""
        try:
            grid = grid_of(msg, self.node.resolve("map"))
        except GridMessageError as error:
            self.log(f"map ignored: {error}", "error")
            return
        field = LikelihoodField(grid, self.laser_likelihood_max_dist)
        previous = self.filter
        self.filter = ParticleFilter(field, self.params, seed=int(self.seed))
        if previous is not None and len(previous.particles):  # a new map: keep the belief
            self.filter.particles, self.filter.weights = previous.particles, previous.weights
        elif self._pending_pose is not None:
            self.filter.set_pose(*self._pending_pose)
        elif self.global_localization:
            self.filter.spread_globally()
            self._start_search()
        elif self._resume is not None:
            self._start = None  # set from the saved correction and the first odometry (_transform_from_start)
        else:
            self._start = np.array([self.initial_pose_x, self.initial_pose_y, self.initial_pose_a])
            self.filter.set_pose(self._start,
                                 np.diag([self.initial_cov_xx, self.initial_cov_yy, self.initial_cov_aa]))
        self._transform_from_start()
        self._force_update = True
        self.log(f"map {grid.shape[1]} x {grid.shape[0]} cells at {grid.resolution} m; "
                 f"{len(self.filter.particles)} particles")

    def on_initialpose(self, msg: PoseWithCovarianceStamped) -> None:
        """Start the filter again around a pose given in the map frame (rviz's "2D Pose Estimate"); another frame is
        refused."""
        frame = msg.header.frame_id.lstrip("/")
        if frame and frame != self.global_frame_id:
            self.log(f"initialpose ignored: frame {msg.header.frame_id!r}, expected {self.global_frame_id!r}", "warn")
            return
        mean = from_pose_msg(msg.pose.pose)
        c = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)
        covariance = c[np.ix_([0, 1, 5], [0, 1, 5])]
        if not np.all(np.isfinite(mean)) or not np.all(np.isfinite(covariance)):
            self.log("initialpose ignored: not finite", "warn")
            return
        self._pending_pose = (mean, covariance)
        self._start = mean
        self._search = None  # told where it is: no longer lost
        if self.filter is not None:
            self.filter.set_pose(mean, covariance)
        if self._last_odom is None:  # a pose given now holds at the latest odometry, not the first
            self._first_odom = self.sync.odom
        self._transform_from_start()
        self._force_update = True
        self.log(f"initial pose ({mean[0]:.2f}, {mean[1]:.2f}, {mean[2]:.2f})")

    def on_odom(self, msg: Odometry) -> None:
        """Keep the odometry for pairing with scans, and publish map -> odom from the start pose until the first
        update."""
        if self._first_odom is None:
            self._first_odom = from_pose_msg(msg.pose.pose)
        self.sync.on_odom(msg)
        self._transform_from_start()

    def _transform_from_start(self) -> None:
        """Before the first filter update: ``map -> odom`` from the start pose and the first odometry (the
        robot is where it was put), published at once. Nothing without a map, a start pose or odometry.
        Without it move_base had no pose until the first filter update, and lower levels drove the robot off
        its first goal meanwhile."""
        if self._map_to_odom is not None or self.filter is None or self._first_odom is None:
            return
        if self._start is None and self._resume is not None and self._pending_pose is None:
            self._start = compose(self._resume, self._first_odom)
            self.filter.set_pose(self._start, np.diag([self.initial_cov_xx, self.initial_cov_yy,
                                                       self.initial_cov_aa]))
        if self._start is None:
            return
        self._map_to_odom = compose(self._start, inverse(self._first_odom))
        self._publish_transform()

    def on_scan(self, msg: LaserScan) -> None:
        """Queue the scan to be paired with the odometry of its own stamp (the filter updates then)."""
        self.sync.on_scan(msg)

    def _process(self, scan: LaserScan, odom: np.ndarray) -> None:
        if self.filter is None:
            self.log_once("map", f"no map on {self.node.resolve('map')} yet: waiting for one")
            return
        base = self.frames[1]
        mount = self.mounts.mount(base, scan.header.frame_id)
        if mount is None:
            self.log_once("tf", f"no transform {base} -> {scan.header.frame_id} on /tf_static yet: scan skipped")
            return
        if self._last_odom is None:
            self._last_odom = self._first_odom  # the first update: the motion since the initial pose
        if self._last_odom is not None and not self._force_update:
            step = between(self._last_odom, odom)
            if math.hypot(step[0], step[1]) < self.update_min_d and abs(step[2]) < self.update_min_a:
                return
        if self._last_odom is not None:
            self.filter.predict(self._last_odom, odom)
        self._last_odom = odom
        self._force_update = False
        max_range = self.laser_max_range if self.laser_max_range > 0 else math.inf
        all_beams = beams_of(scan, mount, max_range)
        beams = all_beams.subsample(int(self.laser_max_beams))
        reach = min(scan.range_max, max_range)
        self.filter.correct(beams.endpoints(), reach, beams.hit, beams.origin)
        stamp = scan.header.stamp.to_sec()
        if self._search is not None:
            self._searching(odom, stamp, all_beams.hits())
        estimate = self.filter.estimate()
        self._map_to_odom = compose(estimate.pose, inverse(odom))
        self.amcl_pose.publish(self._pose_msg(estimate.pose, estimate.covariance, stamp))
        self.particlecloud.publish(PoseArray(header=Header(0, genpy.Time.from_sec(stamp), self.global_frame_id),
                                             poses=[pose_msg(p) for p in self.filter.particles[:: max(1, len(self.filter.particles) // 500)]]))
        self._publish_transform()

    # Outputs --------------------------------------------------------------------------------------
    def _pose_msg(self, pose: np.ndarray, covariance: np.ndarray, stamp: float) -> PoseWithCovarianceStamped:
        msg = PoseWithCovarianceStamped()
        msg.header = Header(0, genpy.Time.from_sec(stamp), self.global_frame_id)
        msg.pose.pose = pose_msg(pose)
        full = np.zeros((6, 6))
        full[np.ix_([0, 1, 5], [0, 1, 5])] = covariance
        msg.pose.covariance = full.ravel().tolist()
        return msg

    def _publish_transform(self) -> None:
        if self._map_to_odom is None or self.frames is None:
            return
        stamp = self.now() + float(self.transform_tolerance)
        self._tf.publish(TFMessage([transform_msg(self._map_to_odom, stamp, self.global_frame_id, self.frames[0])]))

    def _save_pose(self) -> None:
        """The correction on the parameter server, for an amcl started again under this name (a respawn)."""
        if self._map_to_odom is not None:
            self.node.set_param("saved_map_to_odom", [round(float(v), 4) for v in self._map_to_odom])

    def pose_now(self) -> np.ndarray | None:
        """The current estimate: the last filter update moved on by odometry since."""
        if self._map_to_odom is None or self.sync.odom is None:
            return None
        return compose(self._map_to_odom, self.sync.odom)


def in_background(work, *args) -> Future:
    """`work(*args)` on a daemon thread of its own, its result in the Future returned. A daemon thread, not a
    thread pool's: a whole-map search can run for a minute on a large map, and a pool's worker is joined at
    interpreter exit, so a node told to shut down would wait for it."""
    future: Future = Future()

    def run() -> None:
        try:
            future.set_result(work(*args))
        except BaseException as error:  # noqa: BLE001 - handed to the caller through the Future
            future.set_exception(error)

    threading.Thread(target=run, name="amcl_global_search", daemon=True).start()
    return future
