"""Graph SLAM on range scans and odometry, as plain numpy in and out (no topics: :mod:`navigation.slam`
wires it to them).

Method (chosen on measurements, see docs/mapping.md): scan matching plus a pose graph with loop closure.

* **Keyframes.** A scan is processed when odometry says the robot moved ``linearUpdate`` metres or turned
  ``angularUpdate`` radians since the last processed one (gmapping's rule), or ``temporalUpdate`` seconds passed.
  Between keyframes the pose is the last keyframe's plus odometry.
* **Tracking.** Each keyframe's scan is matched (point-to-line ICP, :mod:`navigation.slam_match`) against the points
  of the last ``local_keyframes`` keyframes and of up to ``local_near_keyframes`` earlier ones near it in space
  (within ``local_radius``, facing its way, driven past less than ``local_max_travel`` m ago: a robot turning in a
  corner keeps matching the first scans it took there instead of its own drifting recent ones), starting from, and
  pulled towards, odometry's prediction with gmapping's odometry error model (``srr``, ``srt``, ``str``, ``stt``).
  The two are fused by their information: the scan's ICP information scaled by ``match_information`` (its points are
  not independent measurements: taken at face value a scan of 200 points claims 0.03 degrees where it is good to
  about 0.5, and overrides odometry even along a corridor it does not constrain), odometry's from the model. Along a
  direction the scan pins down the scan decides, along one it does not (a flat wall, a corridor) odometry does, and
  in between both in proportion; the keyframe's graph edge carries that fused covariance. With ``odometry_adapt``
  odometry's error is then learned from the scans: where a scan alone pins an axis of the step down (along it,
  across it, heading), its own pose against odometry's prediction is a sample of odometry's real error; per axis a
  variance growing with distance and turn is fitted to the last ``odometry_adapt_window`` samples, and the match is
  fused again with it (a robot whose odometry is better than the model is trusted more, one whose odometry is worse
  less; docs/real_data.md). A point pairs with the nearest map point whose normal faces its way (``match_facing``;
  normals face the sensor that saw them): a thin wall's far side, seen through a door, is not fitted onto its near
  side seen before. Then, with ``match_corners`` (a sigma in m), the fit is refined from there with the scan's
  corners too: the hits that no line runs through (door jambs, posts, corners), each paired point to point with the
  nearest corner of the local map. A corridor's walls leave the pose free along it; its jambs do not (tracking's
  heading error a step on ACES: 0.45 -> 0.33 degrees at 0% drift, 0.88 -> 0.65 at 10%). Only from the lines' fit:
  from a pose still far off, a corner's wrong pair has no line to slide along and holds the fit where it started.
  With ``match_search_radius`` (off by default) ICP starts where a correlative search of the local map near the
  prediction (:mod:`navigation.slam_correlative`, as for closures) puts the scan best, not at the prediction.
  (``match_min_structure`` > 0 additionally freezes, at odometry's prediction, every direction with less than that
  many points' worth of evidence: an all-or-nothing rule that at 40, as before, kept odometry's heading error on
  real logs.)
* **Loop closure.** At every ``loop_every``-th keyframe the points of the last ``loop_query_keyframes`` keyframes
  (driven within ``loop_query_travel`` m, placed where tracking put them: a wider view than one narrow scan) are
  matched against the scans of an earlier keyframe near its estimated pose and facing the same way, taken at least
  ``loop_min_travel`` metres of driving earlier. A good fit (``loop_min_inliers``, ``loop_max_rms``) is only a
  candidate, and it constrains only the directions in which the scan has ``loop_partial_structure`` points' worth of
  evidence (a wall seen again ties the pose across the wall; along it the fit stays where the trajectory put it,
  with a loose 0.5 m). It enters the pose graph (:mod:`navigation.slam_graph`, gtsam's iSAM2, Cauchy-robust loop
  factors) once a second candidate within ``loop_agree_window`` keyframes, whose query shares no scan with its own
  (a second look, not the same one again), asks for the same correction of the trajectory; then the whole trajectory
  is re-optimised. Every constraint enters the graph with its whole covariance, turned into the keyframe's frame, so
  a one-wall constraint stays one-directional. Tracking's edges are Cauchy-robust too, at a wider ``track_robust``
  standard deviations: a step fitted a few degrees off with a confident covariance gives way to the closures that
  contradict it, instead of turning the map after it.
* **Correlative search** (``loop_correlative``, the default for a scan of at least ``loop_correlative_min_fov``; the
  ICP-from-the-estimate above serves narrower scans, and every scan when it is off: a 58-degree depth scan of a few
  metres shows too little of a place to tell it from a look-alike anywhere in a window of metres). The window a
  closure is searched in grows with the driving since the last accepted closure, as the pose's uncertainty does
  (``loop_search_radius`` + ``loop_radius_growth`` per metre, up to ``loop_search_max``; the half-angle likewise, up
  to ``loop_search_angle_max``). The ``loop_map_keyframes`` earlier keyframes nearest the estimate within that
  radius form a likelihood field, and the query's best pose in the window is found exactly by
  :mod:`navigation.slam_correlative` (branch and bound). It is used only if it scores ``loop_min_score`` and no pose
  ``loop_rival_distance`` or more away scores ``loop_rival_share`` of it (a look-alike corridor), then refined by
  the ICP above from there, tied to the earlier keyframe whose points the query then lies on (not merely the
  nearest: the map's keyframes need not agree with each other before the loop is closed), and from then on treated
  as any candidate (the agreement of two, the covariance).
* **Map.** Every keyframe's scan is drawn into gmapping's hit/visit counts (:mod:`navigation.slam_grid`) at its
  optimised pose; when the map is asked for (:meth:`GraphSlam.occupancy`), each keyframe an optimisation moved
  since is taken out and drawn again.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, fields, replace

import numba
import scipy.optimize
import numpy as np

from .scan_geometry import Beams
from subsumption.mapfile import OccupancyMap
from subsumption.planar import between, compose, inverse, transform_points, wrap
from .slam_graph import PoseGraph
from .slam_grid import CountGrid
from .slam_correlative import LikelihoodField, search
from .slam_match import Cloud, Corners, Match, corner_points, evenly_index, match, scan_normals, thin
from .slam_nearest import BucketGrid

CHI2_1_MEDIAN = 0.4549  # the median of a squared standard normal: a median of squared errors over this is a variance
ODOMETRY_MIN_SAMPLES = 20  # odometry_adapt: errors seen on an axis before its fit replaces the model
ODOMETRY_FLOOR = 0.005  # m (rad): the error model's constant term, gmapping's
SEARCH_POINTS = 400  # match_search_radius: at most this many of a scan's points (evenly spread) are searched
REDRAW_TOLERANCE = (0.005, 0.002)  # m, rad: a shown map's keyframe moved less than this is not drawn again


def _step_size(moved: np.ndarray) -> tuple[float, float]:
    """A step's metres driven and radians turned (the arguments of odometry's error model)."""
    return math.hypot(moved[0], moved[1]), abs(float(wrap(moved[2])))


def _rotation(heading: float) -> np.ndarray:
    """(3, 3): a pose offset in the map frame turned into the frame of a pose with this heading."""
    c, s = math.cos(heading), math.sin(heading)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


@numba.njit(cache=True, nogil=True)
def _place(points, normals, starts, counts, poses):
    """Keyframes' points and normals (robot frame, rows ``starts[m]:starts[m] + counts[m]`` of the stacked
    arrays) turned into the map frame at their poses, one after the other."""
    total = 0
    for m in range(starts.shape[0]):
        total += counts[m]
    world = np.empty((total, 2))
    turned = np.empty((total, 2))
    k = 0
    for m in range(starts.shape[0]):
        c, s = math.cos(poses[m, 2]), math.sin(poses[m, 2])
        for i in range(starts[m], starts[m] + counts[m]):
            x, y = points[i, 0], points[i, 1]
            world[k, 0] = poses[m, 0] + c * x - s * y
            world[k, 1] = poses[m, 1] + s * x + c * y
            turned[k, 0] = c * normals[i, 0] - s * normals[i, 1]
            turned[k, 1] = s * normals[i, 0] + c * normals[i, 1]
            k += 1
    return world, turned


@dataclass
class SlamParams:
    """Parameters, with gmapping's names where the idea is the same. Each is also a parameter of the slam node
    (:class:`navigation.slam.Slam`), with the same default and a help string; docs/real_data.md says how each was
    chosen."""

    delta: float = 0.05  # m per map cell
    maxUrange: float = 0.0  # m: returns beyond are used as free space only (0: the sensor's range_max)
    linearUpdate: float = 0.2  # m driven between processed scans
    angularUpdate: float = 0.2  # rad turned between processed scans
    temporalUpdate: float = -1.0  # s between processed scans regardless of motion (<0: off)
    occ_thresh: float = 0.25  # hits / visits above which a cell is occupied
    srr: float = 0.05  # odometry error in translation as a function of translation
    srt: float = 0.05  # odometry error in translation as a function of rotation
    str: float = 0.05  # odometry error in rotation as a function of translation
    stt: float = 0.05  # odometry error in rotation as a function of rotation
    odometry_adapt: bool = True  # learn odometry's error per axis from the scans (see _learn_odometry; off: the model)
    odometry_adapt_window: int = 100  # keyframes it is learned over
    odometry_adapt_min_fov: float = 2.0  # rad: narrower scans (a depth camera's) leave odometry's model as it is
    scan_matching: bool = True  # off: odometry alone places the scans (a baseline to measure against)
    local_keyframes: int = 20  # recent keyframes a new scan is matched against
    local_radius: float = 3.0  # m: also match against earlier keyframes this near in space (0: off)
    local_near_keyframes: int = 20  # at most this many of those (the nearest)
    local_max_travel: float = 6.0  # m of driving since a near keyframe within which it joins the local map
    normal_radius_growth: float = 0.0  # a hit's normal is fitted to its neighbours within 0.15 m or this times its
    #                                    range, whichever is more
    match_near_first: bool = False  # with normal_radius_growth: tracking matches the near points (fixed-radius normals)
    #                                 first, then all from there
    match_facing: bool = True  # a point pairs only with map points whose normal faces its way, in tracking and in
    #                            closures by ICP from the estimate (a thin wall's two sides are two surfaces); off:
    #                            with the nearest whatever its side
    match_sigma: float = 0.02  # m: range noise assumed by the matcher
    match_voxel: float = 0.03  # m: a scan keeps one point per square this size for matching
    match_points: int = 200  # at most this many of a new scan's points are matched (evenly spread)
    min_inliers: float = 0.3  # share of a scan that must fit for a match to be trusted
    match_min_structure: float = 0.0  # points' worth of evidence a direction needs before tracking moves along it
    #                                   (fewer: odometry's prediction holds there; 0: off, the fusion weighs instead)
    match_information: float = 0.05  # scale of a scan's ICP information in tracking: its points are not independent
    #                                  measurements, and at face value (1) it outweighs odometry's prior everywhere
    match_corners: float = 0.05  # m: tracking also pairs the points without a normal (corners, jambs) point to point,
    #                             at this sigma (0: off); they pin a pose down along a corridor, where lines do not
    match_corners_min_fov: float = 2.0  # rad: narrower scans (a depth camera's) pair no corners
    match_search_radius: float = 0.0  # m: tracking first searches the local map correlatively this far around
    #                                   odometry's prediction, and ICP starts from the best pose (0: off)
    match_search_angle: float = 0.1  # rad: ... and this far in heading
    loop_closure: bool = True
    loop_search_radius: float = 3.0  # m around the estimated pose where earlier keyframes are tried
    loop_min_travel: float = 6.0  # m of driving since a keyframe before it may close a loop
    loop_min_inliers: float = 0.6  # share of the scan that must fit for a loop closure
    loop_max_rms: float = 0.025  # m point-to-line error of a loop closure's inliers
    loop_every: int = 2  # try a loop closure at every n-th keyframe
    loop_neighbours: int = 6  # keyframes either side of a candidate whose scans form its local map
    loop_min_structure: float = 3.0  # points' worth of evidence a closure needs in every direction
    loop_partial_structure: float = 10.0  # >0: a closure may constrain only the directions with this much evidence
    loop_agree_window: int = 24  # keyframes within which two closures must agree before either is used
    loop_agree_distance: float = 0.05  # m: two closures agree when they move the robot alike to within this
    loop_agree_angle: float = 0.02  # rad, and this
    loop_agree_separation: float = 0.5  # m: with a scan wider than half a circle, two closures agree only when
    #                                     found this far apart (turning on the spot, it sees the same place again)
    loop_query_keyframes: int = 5  # a closure matches the points of this many last keyframes together (1: its own)
    loop_query_travel: float = 2.0  # m: ... of those driven within this distance of the newest
    loop_query_points: int = 400  # at most this many of them (evenly spread)
    loop_correlative: bool = True  # search closures correlatively in a window that grows with the travel since the
    #                                last closure (off: the ICP from the estimate within loop_search_radius)
    loop_correlative_min_fov: float = 2.0  # rad: narrower scans search closures by ICP from the estimate
    loop_radius_growth: float = 0.1  # m of window per m driven since the last accepted closure
    loop_search_max: float = 8.0  # m: the window's radius at most
    loop_search_angle: float = 0.2  # rad: the window's half-angle right after a closure
    loop_angle_growth: float = 0.01  # rad per m driven since the last accepted closure
    loop_search_angle_max: float = 0.52  # rad: the half-angle at most
    loop_map_keyframes: int = 40  # at most this many earlier keyframes (the nearest) form the map a closure searches
    loop_min_score: float = 0.5  # mean likelihood of the query's points a correlative closure needs (0..1)
    loop_field_sigma: float = 0.05  # m: the likelihood field's width
    loop_rival_distance: float = 2.0  # m: a closure is ambiguous when a pose this far from its best ...
    loop_rival_share: float = 0.9  # ... scores this share of the best, and is then not used
    track_robust: float = 3.0  # Cauchy scale of tracking's graph edges, in standard deviations (0: not robust): a
    #                            step that later closures contradict by far more gives way
    loop_robust: float = 1.0  # Cauchy scale of closure factors, in standard deviations (0: not robust): a wrong
    #                           closure cannot bend the whole map, at the price of a closure that corrects metres

    @classmethod
    def from_mapping(cls, values: dict) -> "SlamParams":
        """The parameters named in `values` (a node's parameter dict), the rest at their defaults; unknown names are
        ignored."""
        names = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in values.items() if k in names})


@dataclass
class Keyframe:
    stamp: float
    odom: np.ndarray  # (3,) odometry pose when the scan was taken
    pose: np.ndarray  # (3,) current estimate, map frame
    beams: Beams  # what is drawn into the map
    points: np.ndarray  # (m, 2) hit points, robot frame
    normals: np.ndarray  # (m, 2) their normals, robot frame (NaN: none)
    travelled: float  # m driven since the start, by odometry
    near: np.ndarray | None = None  # (m,) bool: the points whose normal the fixed 0.15 m radius gives (None: all)
    corners: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # hits without a normal, robot frame
    drawn: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))  # pose its scan is drawn at


@dataclass
class LoopCandidate:
    """A loop closure found by matching, waiting for a second one that agrees with it."""

    older: int
    newer: int
    relative: np.ndarray  # newer's pose in older's frame, as matched
    sigmas: np.ndarray
    first: int = -1  # the first keyframe of its query (see GraphSlam._loop_query)
    added: bool = False


@dataclass
class SlamStats:
    keyframes: int = 0
    matches_rejected: int = 0
    matches_degenerate: int = 0  # tracking matches with a direction left to odometry
    loop_attempts: int = 0
    loop_unconstrained: int = 0  # fits rejected for too little structure in some direction
    loop_candidates: int = 0  # fits good enough to wait for agreement
    loop_partial: int = 0  # of those, fits that constrain only some directions (loop_partial_structure)
    loop_closures: int = 0  # closures in the pose graph
    loop_ambiguous: int = 0  # correlative fits rejected for a rival as good elsewhere in the window


class GraphSlam:
    """Feed scans with their odometry poses (:meth:`add_scan`); read the map, the trajectory and
    ``map -> odom``."""

    def __init__(self, params: SlamParams | None = None, start: np.ndarray | tuple = (0.0, 0.0, 0.0)) -> None:
        self.params = params or SlamParams()
        self.start = np.asarray(start, dtype=float)
        self.grid = CountGrid(self.params.delta, self.params.occ_thresh)
        self.keyframes: list[Keyframe] = []
        self.graph: PoseGraph | None = None
        self.stats = SlamStats()
        self._local: Cloud | None = None
        self._local_corners: BucketGrid | None = None  # match_corners: the local map's corners
        self._local_field: LikelihoodField | None = None  # match_search_radius: the local map's likelihood field
        self._map_to_odom = self.start.copy()  # until the first scan: odom starts at the start pose
        self.last_match: Match | None = None
        self._pending: list[LoopCandidate] = []
        # every keyframe's points and normals (robot frame) stacked, rows [_starts[i], _starts[i] + len) being
        # keyframe i's: the local map is gathered from here by one kernel (see _cloud)
        self._stacked_points = np.zeros((0, 2))
        self._stacked_normals = np.zeros((0, 2))
        self._stacked_near = np.zeros(0, bool)
        self._stacked_rows = 0
        self._starts: list[int] = []
        self._fov = 2 * math.pi
        self._last_closure_travel = 0.0  # m driven when the last closure was accepted (the window grows from there)
        # odometry_adapt: per axis, the last odometry_adapt_window samples (d^2, a^2, squared error) and their fit
        self._odometry_samples = [deque(maxlen=self.params.odometry_adapt_window) for _ in range(3)]
        self._odometry_fit: list[np.ndarray | None] = [None, None, None]

    # What others read ------------------------------------------------------------------------------
    @property
    def map_to_odom(self) -> np.ndarray:
        """The map -> odom transform (x, y, yaw) the latest optimisation gives."""
        return self._map_to_odom

    def pose_of(self, odom: np.ndarray) -> np.ndarray:
        """The robot's pose in the map for an odometry pose (now or since the last keyframe)."""
        return compose(self._map_to_odom, odom)

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (n,), poses (n, 3)) of the keyframes, as optimised so far."""
        return (np.array([k.stamp for k in self.keyframes]),
                np.array([k.pose for k in self.keyframes]).reshape(-1, 3))

    # Input ----------------------------------------------------------------------------------------
    def add_scan(self, stamp: float, odom: np.ndarray, beams: Beams) -> bool:
        """Take one scan (robot frame) with the odometry pose at its time; True if it became a keyframe."""
        odom = np.asarray(odom, dtype=float)
        p = self.params
        last = self.keyframes[-1] if self.keyframes else None
        moved = between(last.odom, odom) if last is not None else np.zeros(3)
        if last is not None:  # gmapping's rule: far enough, turned enough, or long enough since the last keyframe
            due = p.temporalUpdate >= 0 and stamp - last.stamp >= p.temporalUpdate
            if math.hypot(moved[0], moved[1]) < p.linearUpdate and abs(moved[2]) < p.angularUpdate and not due:
                return False
        hits = beams.hits()
        near = scan_normals(hits, 3, 0.15) if len(hits) else np.zeros((0, 2))
        grows = len(hits) and p.normal_radius_growth > 0
        grown = scan_normals(hits, 3, 0.15, p.normal_radius_growth) if grows else near
        points, normals, kept = thin(hits, grown, p.match_voxel, return_index=True)
        if last is None and len(beams.angles):
            self._fov = float(beams.angles.max() - beams.angles.min())
        corners = corner_points(hits, grown, p.match_voxel) if self._uses_corners() else np.zeros((0, 2))
        near = np.isfinite(near[kept, 0])  # the points the fixed radius gives a normal too (loop closures use these)
        if last is None:
            self._add_first(stamp, odom, beams, points, normals, near, corners)
            return True
        guess = compose(last.pose, moved)
        pose, sigmas = self._track(points, normals, guess, moved, near, corners)
        self._add_keyframe(stamp, odom, pose, beams, points, normals, near, sigmas,
                           last.travelled + math.hypot(moved[0], moved[1]), corners)
        return True

    # Steps ----------------------------------------------------------------------------------------
    def _add_first(self, stamp, odom, beams, points, normals, near, corners) -> None:
        kf = Keyframe(stamp, odom, self.start.copy(), beams, points, normals, 0.0, near, corners=corners)
        self.keyframes.append(kf)
        self._stack(kf)
        self.graph = PoseGraph(self.start)
        self._draw(kf)
        self._after_change()

    def _odometry_model(self, moved: np.ndarray) -> np.ndarray:
        """Odometry's error for the step `moved` by gmapping's model, (along, across, heading) sigmas, unscaled."""
        p = self.params
        d, a = _step_size(moved)
        s_xy = p.srr * d + p.srt * a + ODOMETRY_FLOOR
        s_th = p.str * d + p.stt * a + ODOMETRY_FLOOR
        return np.array([s_xy, s_xy, s_th])

    def _odometry_sigmas(self, moved: np.ndarray) -> np.ndarray:
        """Odometry's error for the step `moved`, (along, across, heading) sigmas: the model, or with
        ``odometry_adapt`` what was fitted to odometry's real errors so far, within 0.1 and 4 times the model."""
        model = self._odometry_model(moved)
        d, a = _step_size(moved)
        sigmas = model.copy()
        for axis, fit in enumerate(self._odometry_fit):
            if fit is not None:
                sigmas[axis] = math.sqrt(fit[0] * d * d + fit[1] * a * a + ODOMETRY_FLOOR ** 2)
        return np.clip(sigmas, 0.1 * model, 4 * model)

    def _track(self, points: np.ndarray, normals: np.ndarray, guess: np.ndarray, moved: np.ndarray,
               near: np.ndarray | None = None, corners: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The new keyframe's pose (and its uncertainty) by ICP against the local map, from odometry's prediction
        and pulled towards it. With `match_near_first`, the points whose normals the fixed radius gives (`near`)
        are matched first and the whole scan from there: a far point pairs with the right wall only once the
        heading is nearly right (2 degrees off, 10% drift's step error, moves a hit 20 m away by 0.7 m, onto
        another wall's line, and such wrong pairs hold the whole fit there)."""
        p = self.params
        odom_sigmas = self._odometry_sigmas(moved)
        if not p.scan_matching or self._local is None or len(self._local) < 10 or len(points) < 10:
            return guess, odom_sigmas
        to_step = _rotation(float(guess[2] - moved[2]))  # the last keyframe's frame, odometry's error model's
        model = self._odometry_model(moved)
        info = to_step.T @ np.diag(1.0 / model ** 2) @ to_step  # matched with the model as it is, unscaled
        start = self._searched_start(points, corners, guess)
        if p.match_near_first and near is not None and 10 <= near.sum() < len(near):
            some = evenly_index(int(near.sum()), p.match_points)
            first = match(points[near][some], self._local, guess, info, sigma=p.match_sigma,
                          information_scale=p.match_information, start=start,
                          normals=self._facing(normals[near][some]))
            if first.inliers >= p.min_inliers:
                start = first.pose
        some = evenly_index(len(points), p.match_points)

        def fit(start_at: np.ndarray | None, corner_pairs: Corners | None = None) -> Match:
            return match(points[some], self._local, guess, info, sigma=p.match_sigma,
                         min_structure=p.match_min_structure, information_scale=p.match_information,
                         start=start_at, normals=self._facing(normals[some]), corners=corner_pairs)

        m = fit(start)
        corner_pairs = self._corners(corners)
        if corner_pairs is not None and m.inliers >= p.min_inliers:
            # the corners refine the lines' fit, from there: a corner has no line to slide along, so from a pose
            # still far off (a turn odometry got 12 degrees wrong) its wrong pairs hold the fit where it started
            m = fit(m.pose, corner_pairs)
        self.last_match = m
        if m.inliers < self.params.min_inliers:
            self.stats.matches_rejected += 1
            return guess, odom_sigmas
        self.stats.matches_degenerate += m.degenerate > 0
        if p.odometry_adapt and self._fov >= p.odometry_adapt_min_fov:
            m = self._learn_odometry(m, guess, info, to_step, model, moved)
        return m.pose, self._uncertainty(m)

    def _searched_start(self, points: np.ndarray, corners: np.ndarray | None, guess: np.ndarray) -> np.ndarray | None:
        """Where tracking's ICP starts (None: at odometry's prediction): with ``match_search_radius``, the best pose
        of the scan's points (its corners included) in the local map's likelihood field within that radius and
        ``match_search_angle`` of the prediction, searched exhaustively (Olson's real-time correlative scan
        matching, :mod:`navigation.slam_correlative`). ICP descends to the nearest fit from where it starts; from a
        prediction a few degrees or decimetres off (a turn at 10% odometry drift) that can be the wrong one, and the
        prior then holds it there. The search only chooses the start: ICP's fit and the fusion with odometry are
        the same."""
        p = self.params
        if p.match_search_radius <= 0 or self._local is None or len(self._local) < 10:
            return None
        if self._local_field is None:
            target = self._local.points
            if self._local_corners is not None:
                target = np.vstack([target, self._local_corners.points])
            self._local_field = LikelihoodField.of(target, p.delta, p.loop_field_sigma)
        scan = points if corners is None or not len(corners) else np.vstack([points, corners])
        scan = scan[evenly_index(len(scan), SEARCH_POINTS)]
        found = search(scan, self._local_field, guess, p.match_search_radius, p.match_search_angle)
        return found.pose if found.score > 0 else None

    def _learn_odometry(self, m: Match, guess: np.ndarray, prior: np.ndarray, to_step: np.ndarray,
                        model: np.ndarray, moved: np.ndarray) -> Match:
        """`m` (matched with odometry's model as its prior) fused again with what odometry's error has been so far
        (``odometry_adapt``).

        Odometry's real error on this step is seen where the scan alone pins an axis down (its own standard
        deviation there under half the model's): the scan's own pose, undone from the fused one, against
        odometry's prediction. Per axis (along the step, across it, heading), a variance ``alpha d^2 + beta a^2``
        (d metres driven, a radians turned) is fitted to the last ``odometry_adapt_window`` such errors: its
        shape by non-negative least squares, its level by their median (a few wrong matches do not move it). The
        scan's evidence is kept as it is: (S + P_learned) x = (S + P_model) e."""
        scan = np.linalg.inv(m.covariance) - prior  # the scan's own information (S), map frame
        scan_step = to_step @ scan @ to_step.T
        prior_step = to_step @ prior @ to_step.T
        fused = to_step @ np.array([*(m.pose[:2] - guess[:2]), wrap(m.pose[2] - guess[2])])
        scan_cov = np.linalg.pinv(scan_step)
        error = fused + scan_cov @ prior_step @ fused  # the scan's own pose, from the prediction
        d, a = _step_size(moved)
        for axis in range(3):
            if scan_cov[axis, axis] > (0.5 * model[axis]) ** 2:
                continue  # the scan does not pin this axis down well enough to tell odometry's error
            samples = self._odometry_samples[axis]
            samples.append((d * d, a * a, max(error[axis] ** 2 - scan_cov[axis, axis], 0.0)))
            if len(samples) >= ODOMETRY_MIN_SAMPLES:
                rows = np.array(samples)
                shape = scipy.optimize.nnls(rows[:, :2], rows[:, 2])[0]
                variance = rows[:, :2] @ shape + ODOMETRY_FLOOR ** 2
                self._odometry_fit[axis] = shape * float(np.median(rows[:, 2] / variance)) / CHI2_1_MEDIAN
        information = scan_step + np.diag(1.0 / self._odometry_sigmas(moved) ** 2)
        offset = np.linalg.solve(information, (scan_step + prior_step) @ fused)
        pose = guess + to_step.T @ offset
        pose[2] = wrap(pose[2])
        covariance = to_step.T @ np.linalg.inv(information) @ to_step
        return replace(m, pose=pose, covariance=0.5 * (covariance + covariance.T))

    def _uses_corners(self) -> bool:
        """Whether tracking pairs corners (``match_corners``): only for a scan of at least
        ``match_corners_min_fov``. A narrow depth scan's hits without a normal are mostly where its view is cut
        off, at its edges and behind nearer objects: they move as the robot does and would drag the pose."""
        return self.params.match_corners > 0 and self._fov >= self.params.match_corners_min_fov

    def _corners(self, scan_corners: np.ndarray | None) -> Corners | None:
        """The new scan's corners with the local map's, for tracking to pair point to point (``match_corners``)."""
        if scan_corners is None or self._local_corners is None:  # no corners kept (_after_change, add_scan)
            return None
        return Corners(scan_corners, self._local_corners, self.params.match_corners)

    def _facing(self, normals: np.ndarray | None) -> np.ndarray | None:
        """The normals :func:`match` keeps a thin wall's sides apart by, or None with ``match_facing`` off."""
        return normals if self.params.match_facing else None

    def _uncertainty(self, m: Match) -> np.ndarray:
        """A match's covariance for the pose graph, turned into the matched pose's own frame (gtsam's Pose2
        errors are there), plus 1 cm and 0.005 rad: a scan of one wall constrains the pose across the wall and
        not along it whichever way the wall runs. (Only the map-frame standard deviations, as before, lost
        that: with one-directional loop closures, generated 47's depth-scan map went from 0.035 to 0.114 m.)"""
        floor = np.array([0.01, 0.01, 0.005])
        to_local = _rotation(float(m.pose[2]))
        covariance = to_local @ m.covariance @ to_local.T
        return 0.5 * (covariance + covariance.T) + np.diag(floor ** 2)

    def _add_keyframe(self, stamp, odom, pose, beams, points, normals, near, sigmas, travelled, corners) -> None:
        last = self.keyframes[-1]
        kf = Keyframe(stamp, odom, pose, beams, points, normals, travelled, near, corners=corners)
        self.keyframes.append(kf)
        self._stack(kf)
        index = self.graph.add_node(pose, between(last.pose, pose), sigmas, robust=self.params.track_robust)
        closed = False
        if self.params.loop_closure and index % max(1, self.params.loop_every) == 0:
            closed = self._close_loop(index)
        poses = self.graph.optimise(extra_iterations=2 if closed else 0)
        for k, new in zip(self.keyframes, poses):
            k.pose = new
        self._after_change()

    def _close_loop(self, index: int) -> bool:
        """Match keyframe `index` against an earlier visit; a fit becomes a closure of the pose graph only once
        another fit, of a keyframe within ``loop_agree_window``, moves the trajectory the same way. A wrong
        closure (a look-alike wall, the table's other edge) rarely repeats with the same offset; a right one
        does, because the drift it corrects is the same for keyframes a few steps apart."""
        p = self.params
        found = self._loop_candidate(index)
        self._pending = [c for c in self._pending if index - c.newer <= p.loop_agree_window]
        if found is None:
            return False
        self.stats.loop_candidates += 1
        agreeing = [c for c in self._pending if self._agree(c, found)]
        self._pending.append(found)
        if not agreeing:
            return False
        for c in agreeing + [found]:
            if not c.added:
                self.graph.add_loop(c.older, c.newer, c.relative, c.sigmas, robust=p.loop_robust)
                c.added = True
                self.stats.loop_closures += 1
        self._last_closure_travel = self.keyframes[index].travelled
        return True

    def _implied(self, c: LoopCandidate) -> np.ndarray:
        """The map correction closure `c` asks for: the transform taking c.newer's estimate to where the closure
        puts it."""
        where = compose(self.keyframes[c.older].pose, c.relative)
        return compose(where, inverse(self.keyframes[c.newer].pose))

    def _agree(self, a: LoopCandidate, b: LoopCandidate) -> bool:
        p = self.params
        if a.newer == b.newer:
            return False
        if not (a.newer < b.first or b.newer < a.first):
            return False  # their queries share scans: the second fit is not a second look at the place
        if self._fov > math.pi and self._distance(a.newer, b.newer) < p.loop_agree_separation:
            return False  # nor is a wide scan's fit from the same spot: turning there, it sees the same place again
        pose = self.keyframes[b.newer].pose
        via_a = compose(self._implied(a), pose)
        via_b = compose(self._implied(b), pose)
        return (math.hypot(via_a[0] - via_b[0], via_a[1] - via_b[1]) <= p.loop_agree_distance
                and abs(float(wrap(via_a[2] - via_b[2]))) <= p.loop_agree_angle)

    def _distance(self, i: int, j: int) -> float:
        """m between keyframes `i` and `j` as estimated."""
        a, b = self.keyframes[i].pose, self.keyframes[j].pose
        return math.hypot(a[0] - b[0], a[1] - b[1])

    def _loop_query(self, index: int) -> tuple[np.ndarray, np.ndarray, float, int]:
        """(points, normals, travelled, first): what a loop closure at keyframe `index` matches, in its frame: the
        points (and their normals) of
        the last ``loop_query_keyframes`` keyframes driven within ``loop_query_travel`` m, placed where tracking put
        them; how far the robot had driven at the first of them; and its index. A narrow scan's one keyframe on
        open floor sees one box face; the last few together, taken while the robot turned or drove on, see the
        place from a wider view, as a wider sensor would, and tracking's error between them is millimetres."""
        p = self.params
        kf = self.keyframes[index]
        members = [i for i in range(max(0, index - p.loop_query_keyframes + 1), index + 1)
                   if kf.travelled - self.keyframes[i].travelled <= p.loop_query_travel]
        starts = np.array([self._starts[i] for i in members], dtype=np.int64)
        counts = np.array([len(self.keyframes[i].points) for i in members], dtype=np.int64)
        poses = np.array([between(kf.pose, self.keyframes[i].pose) for i in members])
        points, normals = _place(self._stacked_points, self._stacked_normals, starts, counts, poses)
        near = self._near_mask(members)
        points, normals = points[near], normals[near]
        some = evenly_index(len(points), p.loop_query_points)
        return points[some], normals[some], self.keyframes[members[0]].travelled, members[0]

    def _loop_candidate(self, index: int) -> LoopCandidate | None:
        p = self.params
        kf = self.keyframes[index]
        query, normals, travelled, first = self._loop_query(index)
        if len(query) < 20:
            return None
        if p.loop_correlative and self._fov >= p.loop_correlative_min_fov:
            return self._loop_correlative(index, query, travelled, first)
        old = [i for i, k in enumerate(self.keyframes[:index]) if travelled - k.travelled >= p.loop_min_travel]
        if not old:
            return None
        poses = np.array([self.keyframes[i].pose for i in old])
        distance = np.hypot(poses[:, 0] - kf.pose[0], poses[:, 1] - kf.pose[1])
        facing = np.abs(wrap(poses[:, 2] - kf.pose[2])) <= self._fov / 2 + 0.5  # the views can overlap
        near = np.flatnonzero((distance <= p.loop_search_radius) & facing)
        if not len(near):
            return None
        candidate = old[int(near[np.argmin(distance[near])])]
        members = [i for i in range(candidate - p.loop_neighbours, candidate + p.loop_neighbours + 1)
                   if 0 <= i < index and travelled - self.keyframes[i].travelled >= p.loop_min_travel]
        cloud = self._cloud(members, near_only=True)
        if len(cloud) < 20:
            return None
        self.stats.loop_attempts += 1
        m = self._refine_closure(query, normals, cloud, kf.pose, max_distance=0.5)  # sides kept apart (match_facing)
        if m is None:
            return None
        return LoopCandidate(candidate, index, between(self.keyframes[candidate].pose, m.pose), self._uncertainty(m),
                             first)

    def _refine_closure(self, query: np.ndarray, normals: np.ndarray | None, cloud, start: np.ndarray,
                        max_distance: float):
        """ICP of a closure's query scan against the older keyframes' points from `start`: the match, or None when
        it fits too few points, too loosely, or leaves every direction unconstrained (counted). With the query's
        `normals` (the ICP from the estimate, which descends from up to ``loop_search_radius`` off: a thin wall's
        other side is within its reach) a point pairs only with the side it saw (``match_facing``); the correlative
        search's pose is refined without them (with them, Freiburg 079's map was worse: 0.086 -> 0.12 m ATE at 0%
        drift, docs/real_data.md)."""
        p = self.params
        weak_prior = np.diag([1 / 0.5 ** 2, 1 / 0.5 ** 2, 1 / 0.2 ** 2])
        partial = p.loop_partial_structure > 0
        normals = self._facing(normals)
        m = match(query, cloud, start, weak_prior, max_distance=max_distance, sigma=p.match_sigma, iterations=30,
                  normals=normals)
        if partial and m.structure[0] < p.loop_partial_structure:  # some direction weak: fit the others only
            m = match(query, cloud, start, weak_prior, max_distance=max_distance, sigma=p.match_sigma,
                      iterations=30, min_structure=p.loop_partial_structure, normals=normals)
        if m.inliers < p.loop_min_inliers or m.rms > p.loop_max_rms:
            return None
        if (m.degenerate == 3) if partial else (m.structure[0] < p.loop_min_structure):
            self.stats.loop_unconstrained += 1
            return None
        self.stats.loop_partial += m.degenerate > 0
        return m

    def _loop_correlative(self, index: int, query: np.ndarray, travelled: float, first: int) -> LoopCandidate | None:
        """A closure searched, not descended to: the window (radius and half-angle) grows with the driving since the
        last accepted closure, as the pose's uncertainty does; the earlier keyframes whose poses lie in it (and face
        so that their views may overlap) form a likelihood field (:mod:`navigation.slam_correlative`); the query's
        best pose there, if it scores ``loop_min_score``, is refined by ICP against the same keyframes' points,
        which also gives the closure's covariance (one-directional where the place is a corridor)."""
        p = self.params
        kf = self.keyframes[index]
        since = max(0.0, kf.travelled - self._last_closure_travel)
        radius = min(p.loop_search_radius + p.loop_radius_growth * since, p.loop_search_max)
        half_angle = min(p.loop_search_angle + p.loop_angle_growth * since, p.loop_search_angle_max)
        old = [i for i, k in enumerate(self.keyframes[:index]) if travelled - k.travelled >= p.loop_min_travel]
        if not old:
            return None
        poses = np.array([self.keyframes[i].pose for i in old])
        distance = np.hypot(poses[:, 0] - kf.pose[0], poses[:, 1] - kf.pose[1])
        facing = np.abs(wrap(poses[:, 2] - kf.pose[2])) <= self._fov / 2 + 0.5 + half_angle
        near = np.flatnonzero((distance <= radius) & facing)
        if not len(near):
            return None
        near = near[np.argsort(distance[near], kind="stable")[:p.loop_map_keyframes]]
        members = sorted(old[i] for i in near)
        cloud = self._cloud(members, near_only=True)
        if len(cloud) < 20:
            return None
        self.stats.loop_attempts += 1
        field = LikelihoodField.of(cloud.points, self.params.delta, p.loop_field_sigma)
        found = search(query, field, kf.pose, radius, half_angle, apart=p.loop_rival_distance,
                       rival_share=p.loop_rival_share, floor=p.loop_min_score)
        if found.score < p.loop_min_score:
            return None
        if found.rival > 0:  # a look-alike elsewhere in the window: the same corridor further on, the next room
            self.stats.loop_ambiguous += 1
            return None
        m = self._refine_closure(query, None, cloud, found.pose, max_distance=0.2)  # the search placed it: see below
        if m is None:
            return None
        older = self._matched_keyframe(members, cloud, query, m.pose)
        return LoopCandidate(older, index, between(self.keyframes[older].pose, m.pose), self._uncertainty(m), first)

    def _matched_keyframe(self, members: list[int], cloud: Cloud, query: np.ndarray, pose: np.ndarray) -> int:
        """The keyframe whose scan a closure's query, placed at `pose`, lies on: the member nearest to most of the
        query's points (within 0.1 m). The closure is kept relative to that keyframe's estimate, which is right only
        if it is that keyframe's points the query fitted. The members' estimates need not agree with each other: at
        the end of a long circuit, the drifted last keyframes can be drawn on top of the start, and the member
        nearest to the pose may be one whose scan saw something else (on ACES at 10% drift a closure so tied was 7 m
        and 15 degrees wrong)."""
        owner = self._owners(members, near_only=True)  # the cloud's rows, by member
        _, nearest = cloud.tree.query(transform_points(pose, query), 0.1)
        hit = nearest < len(owner)
        votes = np.bincount(owner[nearest[hit]], minlength=len(members))
        return members[int(np.argmax(votes))]

    def _local_members(self) -> list[int]:
        """The keyframes the next scan is matched against: the last ``local_keyframes``, and with
        ``local_radius`` the ``local_near_keyframes`` nearest earlier ones within that radius, facing so that
        their views can overlap, driven past less than ``local_max_travel`` metres ago (drift since then is
        small; older visits are the loop closure's job, which corrects the trajectory between)."""
        p = self.params
        n = len(self.keyframes)
        first_recent = max(0, n - p.local_keyframes)
        members = list(range(first_recent, n))
        if p.local_radius <= 0 or first_recent == 0:
            return members
        last = self.keyframes[-1]
        older = self.keyframes[:first_recent]
        poses = np.array([k.pose for k in older])
        travelled = np.array([k.travelled for k in older])
        distance = np.hypot(poses[:, 0] - last.pose[0], poses[:, 1] - last.pose[1])
        facing = np.abs(wrap(poses[:, 2] - last.pose[2])) <= self._fov / 2 + 0.5
        near = np.flatnonzero((distance <= p.local_radius) & facing & (last.travelled - travelled < p.local_max_travel))
        near = near[np.argsort(distance[near], kind="stable")[:p.local_near_keyframes]]
        return sorted(near.tolist()) + members

    def _stack(self, kf: Keyframe) -> None:
        """Append a new keyframe's points and normals to the stacked arrays (grown by doubling)."""
        rows = len(kf.points)
        end = self._stacked_rows + rows
        if end > len(self._stacked_points):
            size = max(2 * len(self._stacked_points), end, 1024)
            for name in ("_stacked_points", "_stacked_normals", "_stacked_near"):
                old = getattr(self, name)
                grown = np.zeros((size,) + old.shape[1:], old.dtype)
                grown[:self._stacked_rows] = old[:self._stacked_rows]
                setattr(self, name, grown)
        self._stacked_points[self._stacked_rows:end] = kf.points
        self._stacked_normals[self._stacked_rows:end] = kf.normals
        self._stacked_near[self._stacked_rows:end] = True if kf.near is None else kf.near
        self._starts.append(self._stacked_rows)
        self._stacked_rows += rows

    def _near_mask(self, indices: list[int]) -> np.ndarray | slice:
        """Which of the keyframes' stacked points (in the order :func:`_place` gives them) have a fixed-radius
        normal: all of them (a whole slice, no copy) when no normal comes from a grown radius."""
        if self.params.normal_radius_growth <= 0:
            return slice(None)
        return np.concatenate([self._stacked_near[self._starts[i]:self._starts[i] + len(self.keyframes[i].points)]
                               for i in indices]) if indices else np.zeros(0, bool)

    def _cloud(self, indices: list[int], near_only: bool = False) -> Cloud:
        """The keyframes' points and normals in the map frame at their current poses, with the search structure.
        All at once, in one kernel: the poses change a little at nearly every optimisation, so there is little to
        cache per keyframe. `near_only`: only the points with a fixed-radius normal (loop closures: far walls'
        normals, fitted over decimetres, fit tracking's short steps but not a closure's tight RMS test). The points
        come keyframe by keyframe in the order of `indices` (:meth:`_owners` says whose each is)."""
        if not indices:
            return Cloud.of(np.zeros((0, 2)), np.zeros((0, 2)))
        starts = np.array([self._starts[i] for i in indices], dtype=np.int64)
        counts = np.array([len(self.keyframes[i].points) for i in indices], dtype=np.int64)
        poses = np.array([self.keyframes[i].pose for i in indices])
        world, turned = _place(self._stacked_points, self._stacked_normals, starts, counts, poses)
        if near_only:
            keep = self._near_mask(indices)
            world, turned = world[keep], turned[keep]
        return Cloud.of(world, turned)

    def _owners(self, indices: list[int], near_only: bool = False) -> np.ndarray:
        """For each point of ``_cloud(indices, near_only)``, in its order, the position in `indices` of the keyframe
        it came from."""
        counts = np.array([len(self.keyframes[i].points) for i in indices], dtype=np.int64)
        owners = np.repeat(np.arange(len(indices)), counts)
        return owners[self._near_mask(indices)] if near_only else owners

    def _draw(self, kf: Keyframe) -> None:
        self.grid.integrate(kf.pose, kf.beams, 1.0)
        kf.drawn = kf.pose.copy()

    def occupancy(self, exact: bool = True) -> OccupancyMap:
        """The map: every keyframe's scan drawn at its current pose. Drawn when asked for, not at every keyframe:
        the optimisation after a closure moves most keyframes a little, and only a map that is read needs them
        drawn again. `exact`: every keyframe that moved at all is drawn again, so the same poses give the same map
        whenever it is asked for (what is saved); otherwise a keyframe within ``REDRAW_TOLERANCE`` of where it was
        drawn stays there (a map that is only shown, published while mapping goes on)."""
        self._redraw_moved(*((0.0, 0.0) if exact else REDRAW_TOLERANCE))
        return self.grid.to_map()

    def _redraw_moved(self, tolerance_xy: float, tolerance_yaw: float) -> None:
        """Take each keyframe that moved more than the tolerances since it was drawn out of the counts and draw
        it where it is."""
        poses = np.array([k.pose for k in self.keyframes])
        drawn = np.array([k.drawn for k in self.keyframes])
        delta = poses - drawn
        moved = ((np.hypot(delta[:, 0], delta[:, 1]) > tolerance_xy) | (np.abs(wrap(delta[:, 2])) > tolerance_yaw)
                 | np.isnan(delta[:, 0]))
        for i in np.flatnonzero(moved):
            kf = self.keyframes[i]
            if not np.isnan(kf.drawn[0]):
                self.grid.integrate(kf.drawn, kf.beams, -1.0)
            self._draw(kf)

    def _after_change(self) -> None:
        last = self.keyframes[-1]
        self._map_to_odom = compose(last.pose, inverse(last.odom))
        members = self._local_members()
        self._local = self._cloud(members)
        self._local_field = None  # match_search_radius: the local map's likelihood field, made when first searched
        if self._uses_corners():
            placed = [transform_points(self.keyframes[i].pose, self.keyframes[i].corners) for i in members]
            target = np.vstack(placed) if placed else np.zeros((0, 2))
            self._local_corners = BucketGrid(target) if len(target) else None
        self.stats.keyframes = len(self.keyframes)
