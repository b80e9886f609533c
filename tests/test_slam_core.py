"""The SLAM core's choices that make the narrow depth scan work on open floor: a constraint from one wall ties
the pose across the wall only (whichever way the wall runs), and tracking matches against the keyframes near
in space as well as the last ones in time."""
from __future__ import annotations

import math

import numpy as np
import pytest

from navigation.scan_geometry import Beams
from navigation.slam_core import GraphSlam, Keyframe, SlamParams
from navigation.slam_graph import PoseGraph
from navigation.slam_match import Match
from subsumption.planar import between, compose


def test_a_one_wall_constraint_moves_the_pose_across_the_wall_only():
    """A wall running at 45 degrees, seen by a robot facing north: the match pins the pose across the wall
    (5 mm) and not along it (1 m). In the graph, that closure must move the keyframe across the wall and leave
    it alone along the wall, against a looser odometry edge. (Map-frame standard deviations alone, the old
    way, would make it about 0.7 m in x and in y: the closure would hardly move anything.)"""
    across, along = np.array([1.0, 1.0]) / math.sqrt(2), np.array([1.0, -1.0]) / math.sqrt(2)
    covariance = np.zeros((3, 3))
    covariance[:2, :2] = 0.005 ** 2 * np.outer(across, across) + 1.0 ** 2 * np.outer(along, along)
    covariance[2, 2] = 0.001 ** 2
    odometry = np.array([1.0, 0.0, math.pi / 2])
    seen = odometry + np.r_[0.004 * across, 0.0]
    match = Match(seen, covariance, inliers=1.0, rms=0.005, used=100)
    graph = PoseGraph(np.zeros(3))
    graph.add_node(odometry, odometry, np.array([0.1, 0.1, 0.05]))
    graph.add_loop(0, 1, seen, GraphSlam()._uncertainty(match))
    moved = graph.optimise()[1][:2] - odometry[:2]
    assert 0.003 < moved @ across < 0.0045
    assert abs(moved @ along) < 0.0005


def _keyframe(x: float, y: float, yaw: float, travelled: float) -> Keyframe:
    empty = Beams(np.zeros(2), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool))
    pose = np.array([x, y, yaw])
    return Keyframe(0.0, pose, pose, empty, np.zeros((0, 2)), np.zeros((0, 2)), travelled)


def test_tracking_matches_keyframes_near_in_space_and_recently_driven():
    """Three keyframes, then 20 recent ones on the spot turning (a robot in a corner): the local map takes
    the 20 recent ones and, of the older, the one near and facing the same way; not the one facing away,
    nor the one near but driven past long ago (that is a loop closure's job)."""
    slam = GraphSlam(SlamParams(local_keyframes=20, local_radius=3.0, local_max_travel=6.0))
    slam._fov = math.radians(58)
    slam.keyframes = [_keyframe(0.5, 0.0, 0.0, 0.0),  # near, but 10 m of driving ago
                      _keyframe(1.0, 0.0, 0.1, 9.0),  # near, facing the same way: joins
                      _keyframe(1.0, 0.2, math.pi, 9.5)]  # near, facing away
    slam.keyframes += [_keyframe(2.0, 0.0, 0.0, 10.0) for _ in range(20)]
    assert slam._local_members() == [1] + list(range(3, 23))
    slam.params.local_radius = 0.0
    assert slam._local_members() == list(range(3, 23))


def test_the_bucket_grid_finds_the_same_nearest_neighbours_as_a_kd_tree():
    """Scan matching's nearest-neighbour search (a bucket grid, for speed) must be exact: against scipy's
    cKDTree on wall-like clouds (dense lines, duplicates, points far apart), with the bounds matching uses
    (0.05-0.5 m), queries inside, beside and far outside the cloud, and nothing found reads inf / n."""
    from scipy.spatial import cKDTree

    from navigation.slam_nearest import BucketGrid

    rng = np.random.default_rng(7)
    t = rng.uniform(0.0, 1.0, 3000)
    walls = np.column_stack((np.where(t < 0.5, 8.0 * t, 4.0), np.where(t < 0.5, 0.0, 6.0 * (t - 0.5))))
    clouds = [walls + rng.normal(0.0, 0.01, walls.shape), np.round(walls, 2),  # noisy walls; duplicates
              rng.uniform(-20.0, 20.0, (50, 2)), np.array([[1.0, 1.0]])]  # sparse; one point
    for points in clouds:
        queries = np.vstack((points[rng.integers(0, len(points), 300)] + rng.normal(0.0, 0.1, (300, 2)),
                             rng.uniform(-25.0, 25.0, (100, 2))))
        for bound in (0.05, 0.1, 0.4, 0.5):
            expected, _ = cKDTree(points).query(queries, distance_upper_bound=bound)
            found, index = BucketGrid(points).query(queries, bound)
            assert np.allclose(found, expected)
            hit = np.isfinite(found)
            assert np.allclose(np.hypot(*(points[index[hit]] - queries[hit]).T), found[hit])
            assert (index[~hit] == len(points)).all()


def test_the_bucket_grid_finds_the_nearest_point_facing_the_query_s_way_exactly():
    """With `facing`, the nearest of the points whose normal faces the query's way (positive dot product), as a
    brute-force search over those finds it; a normal per query and per point is required."""
    from navigation.slam_nearest import BucketGrid

    rng = np.random.default_rng(11)
    points = rng.uniform(-3.0, 3.0, (800, 2))
    angles = rng.uniform(-math.pi, math.pi, 800)
    normals = np.column_stack((np.cos(angles), np.sin(angles)))
    queries = rng.uniform(-3.5, 3.5, (200, 2))
    q_angles = rng.uniform(-math.pi, math.pi, 200)
    q_normals = np.column_stack((np.cos(q_angles), np.sin(q_angles)))
    grid = BucketGrid(points)
    for bound in (0.1, 0.4, 1.0):
        found, index = grid.query(queries, bound, facing=(q_normals, normals))
        for q in range(len(queries)):
            ok = normals @ q_normals[q] > 0
            d = np.hypot(*(points[ok] - queries[q]).T)
            best = d.min() if len(d) and d.min() <= bound else math.inf
            assert found[q] == pytest.approx(best)
            if math.isfinite(best):
                assert normals[index[q]] @ q_normals[q] > 0
    with pytest.raises(ValueError, match="a normal per query"):
        grid.query(queries, 0.4, facing=(q_normals[:5], normals))


def _corner_scan(pose: np.ndarray, fov: float = math.radians(58), reach: float = 4.0):
    """(points, normals) in the robot frame of a narrow scan from `pose` in a corner: walls x = 3 and y = 2."""
    points, normals = [], []
    for bearing in np.linspace(-fov / 2, fov / 2, 60):
        a = pose[2] + bearing
        d = np.array([math.cos(a), math.sin(a)])
        hits = []
        if d[0] > 1e-9:
            hits.append(((3.0 - pose[0]) / d[0], np.array([-1.0, 0.0])))
        if d[1] > 1e-9:
            hits.append(((2.0 - pose[1]) / d[1], np.array([0.0, -1.0])))
        if not hits:
            continue
        r, normal = min(hits, key=lambda h: h[0])
        if r > reach:
            continue
        c, s = math.cos(pose[2]), math.sin(pose[2])
        points.append([r * math.cos(bearing), r * math.sin(bearing)])
        normals.append([c * normal[0] + s * normal[1], -s * normal[0] + c * normal[1]])
    return np.array(points), np.array(normals)


def _corner_slam(query_keyframes: int, drift_y: float) -> tuple[GraphSlam, int]:
    """A robot turned on the spot in a corner (10 keyframes from facing the x = 3 wall to facing the y = 2 wall),
    drove 10 m, came back and turned the other way round, ending facing the x = 3 wall alone; its estimate has
    drifted `drift_y` m. Returns the SLAM core and the newest keyframe's index."""
    slam = GraphSlam(SlamParams(loop_query_keyframes=query_keyframes, loop_search_radius=3.0, loop_min_travel=6.0))
    slam._fov = math.radians(58)
    yaws = np.linspace(0.0, 1.05, 10)
    for travelled, turn, drift in ((0.0, yaws, 0.0), (10.0, yaws[::-1], drift_y)):
        for yaw in turn:
            truth = np.array([0.0, 0.0, yaw])
            points, normals = _corner_scan(truth)
            estimate = truth + np.array([0.0, drift, 0.0])
            kf = Keyframe(0.0, estimate, estimate, None, points, normals, travelled)
            slam.keyframes.append(kf)
            slam._stack(kf)
    return slam, len(slam.keyframes) - 1


def test_a_loop_closure_sees_the_last_keyframes_together():
    """The newest keyframe sees one wall: alone, it can close the loop across that wall only (along it, the
    closure stays loose and keeps the drift). Matched with the keyframes before it, taken while the robot
    turned, it sees the corner: the closure pins the pose along the wall too and takes the drift back."""
    alone, newest = _corner_slam(1, 0.03)
    query, _, _, _ = alone._loop_query(newest)
    assert np.allclose(query, alone.keyframes[newest].points)
    closure = alone._loop_candidate(newest)
    assert closure is not None and math.sqrt(closure.sigmas[1, 1]) > 0.3  # along the wall: not constrained
    together, newest = _corner_slam(10, 0.03)
    query, _, travelled, _ = together._loop_query(newest)
    assert len(query) > len(together.keyframes[newest].points) and travelled == 10.0
    closure = together._loop_candidate(newest)
    assert closure is not None and math.sqrt(closure.sigmas[1, 1]) < 0.05
    assert abs(closure.relative[1]) < 0.005  # the old keyframe and the newest stand at the same place: no drift


def test_two_closures_agree_only_as_two_looks_at_the_place():
    """Closures whose queries share keyframes are one look, not two: even asking for the same correction they do
    not confirm each other (a look-alike fit, 7 degrees off, once entered the graph so and bent generated 83's map).
    Closures whose queries are apart do."""
    from navigation.slam_core import LoopCandidate

    slam = GraphSlam(SlamParams())
    slam.keyframes = [_keyframe(0.1 * i, 0.0, 0.0, 0.1 * i) for i in range(30)]
    correction = np.array([0.0, 0.05, 0.0])  # each closure says: 5 cm to the left of where the trajectory has it

    def closure(older: int, newer: int, first: int) -> LoopCandidate:
        where = slam.keyframes[newer].pose + correction
        return LoopCandidate(older, newer, where - slam.keyframes[older].pose, np.eye(3) * 1e-4, first)

    a = closure(0, 20, first=16)
    assert not slam._agree(a, closure(1, 22, first=18))  # shares keyframes 18-20 with a
    assert slam._agree(a, closure(1, 26, first=21))       # apart


def test_two_closures_from_one_spot_are_one_look_for_a_wide_scan():
    """A scan wider than half a circle, turning on the spot, sees the same place in every keyframe: two closures
    found from there are one look, however disjoint their queries (the corridors world's 270-degree laser, turning
    beside a box, matched the box's far face onto its near face from two keyframes of one turn: both asked for the
    same 0.6 m wrong correction, agreed and bent the map 2.6 degrees). Found `loop_agree_separation` apart they
    agree. A 180-degree or narrower scan turning on the spot sees other walls: its closures from one spot agree."""
    from navigation.slam_core import LoopCandidate
    from subsumption.planar import between

    slam = GraphSlam(SlamParams(loop_agree_separation=0.5))
    slam.keyframes = [_keyframe(2.0, 0.0, 0.15 * i, 0.0) for i in range(30)]  # on the spot, 0.15 rad a keyframe
    correction = np.array([0.0, 0.05, 0.0])  # each closure: 5 cm to the left (map frame) of the estimate

    def closure(older: int, newer: int, first: int) -> LoopCandidate:
        where = slam.keyframes[newer].pose + correction
        return LoopCandidate(older, newer, between(slam.keyframes[older].pose, where), np.eye(3) * 1e-4, first)

    slam._fov = math.radians(270)
    assert not slam._agree(closure(0, 20, first=16), closure(1, 26, first=21))  # disjoint queries, one spot
    for fov in (180, 58):
        slam._fov = math.radians(fov)
        assert slam._agree(closure(0, 20, first=16), closure(1, 26, first=21))
    slam._fov = math.radians(270)
    slam.keyframes = [_keyframe(0.1 * i, 0.0, 0.0, 0.1 * i) for i in range(30)]
    assert slam._agree(closure(0, 20, first=16), closure(1, 26, first=21))  # 0.6 m apart


def test_closures_are_searched_correlatively_only_for_a_wide_scan(monkeypatch):
    """A wide window searched with a narrow scan finds look-alikes (the 58-degree depth scan took false closures
    on open floor): below `loop_correlative_min_fov` a closure is the ICP from the estimate; a laser's wide scan
    is searched correlatively."""
    searched: list[int] = []
    monkeypatch.setattr(GraphSlam, "_loop_correlative", lambda self, index, *rest: searched.append(index))
    narrow, newest = _corner_slam(10, 0.03)
    assert narrow._loop_candidate(newest) is not None and searched == []
    wide, newest = _corner_slam(10, 0.03)
    wide._fov = math.radians(180)
    wide._loop_candidate(newest)
    assert searched == [newest]


def test_icp_starts_where_told_and_is_pulled_towards_the_prediction():
    """`match(start=...)` (tracking's near-walls-first stage hands its pose to the whole scan's match): the fit
    descends from `start`, while the odometry prior still pulls towards `guess`. A room's corner seen from a pose
    0.6 rad off is out of ICP's reach from there; started at the true pose, the fit stays on it."""
    from navigation.slam_match import Cloud, match

    wall_a = np.column_stack([np.linspace(-2.0, 4.0, 121), np.full(121, 2.0)])   # y = 2
    wall_b = np.column_stack([np.full(81, 3.0), np.linspace(-2.0, 2.0, 81)])     # x = 3
    world = np.vstack([wall_a, wall_b])
    normals = np.vstack([np.tile([0.0, 1.0], (121, 1)), np.tile([1.0, 0.0], (81, 1))])
    target = Cloud.of(world, normals)
    truth = np.array([0.5, 0.2, 0.3])
    c, s = math.cos(truth[2]), math.sin(truth[2])
    offset = world - truth[:2]
    scan = np.column_stack([c * offset[:, 0] + s * offset[:, 1], -s * offset[:, 0] + c * offset[:, 1]])
    guess = truth + np.array([0.0, 0.0, 0.6])
    weak = np.diag([1e-6, 1e-6, 1e-6])
    lost = match(scan, target, guess, weak)
    assert abs(lost.pose[2] - truth[2]) > 0.1
    found = match(scan, target, guess, weak, start=truth)
    assert np.allclose(found.pose, truth, atol=1e-3) and found.inliers > 0.95


def test_a_thin_wall_seen_from_its_other_side_is_not_fitted_onto_the_side_seen_before():
    """The office world's patrol maps came out turned by 4 degrees: through a door the depth scan saw the far
    side of a 0.15 m wall whose near side the map held, and ICP fitted one onto the other (pulling and turning
    the pose). With the scan's normals (facing the sensor) a point pairs only with map points facing its way:
    the pose stays at odometry's prediction; without them the fit is pulled across the wall."""
    from navigation.slam_match import Cloud, match, scan_normals

    seen_before = np.column_stack([np.linspace(0.0, 2.0, 41), np.full(41, 0.15)])  # the wall's north side, y = 0.15
    target = Cloud.of(seen_before, np.tile([0.0, 1.0], (41, 1)))                      # seen from the north
    truth = np.array([0.5, -1.0, 0.3])  # south of the wall, facing its south side (y = 0)
    south = np.column_stack([np.linspace(0.6, 2.6, 41), np.zeros(41)])
    c, s = math.cos(truth[2]), math.sin(truth[2])
    offset = south - truth[:2]
    scan = np.column_stack([c * offset[:, 0] + s * offset[:, 1], -s * offset[:, 0] + c * offset[:, 1]])
    normals = scan_normals(scan, 3, 0.15)
    prior = np.diag([1 / 0.05 ** 2, 1 / 0.05 ** 2, 1 / 0.03 ** 2])
    pulled = match(scan, target, truth, prior, information_scale=0.05)
    assert pulled.pose[1] - truth[1] > 0.05  # the old fit: dragged towards the other side
    kept = match(scan, target, truth, prior, information_scale=0.05, normals=normals)
    assert np.allclose(kept.pose, truth, atol=1e-6) and kept.inliers == 0.0


def test_a_scan_fits_the_side_of_a_thin_wall_it_saw_though_the_other_lies_nearer():
    """Both sides of a 0.15 m wall are in the map; odometry puts the robot 0.12 m too far north, so the south
    side's hits lie nearer the north side. With normals each hit pairs with the nearest map point facing its way
    (the south side) and the fit lands on the truth; without, the nearest is the north side and the fit stays
    there."""
    from navigation.slam_match import Cloud, match, scan_normals

    xs = np.linspace(0.0, 3.0, 61)
    north = np.column_stack([xs, np.full(61, 0.15)])
    south = np.column_stack([xs, np.zeros(61)])
    target = Cloud.of(np.vstack([north, south]), np.vstack([np.tile([0.0, 1.0], (61, 1)),
                                                            np.tile([0.0, -1.0], (61, 1))]))
    truth = np.array([1.0, -1.0, 0.0])
    seen = south[(xs > 0.2) & (xs < 2.8)]
    scan = seen - truth[:2]
    guess = truth + np.array([0.0, 0.12, 0.0])
    prior = np.diag([1 / 0.05 ** 2, 1 / 0.2 ** 2, 1 / 0.03 ** 2])
    fitted = match(scan, target, guess, prior, normals=scan_normals(scan, 3, 0.15))
    assert abs(fitted.pose[1] - truth[1]) < 0.01 and fitted.inliers > 0.95
    nearest = match(scan, target, guess, prior)
    assert nearest.pose[1] - truth[1] > 0.1



def test_corner_points_are_the_hits_no_line_runs_through():
    """A wall 2 m ahead with a post 1 m ahead in front of its middle, in beam order: the wall's hits get normals,
    the post does not: it is the corner `corner_points` keeps."""
    from navigation.slam_match import corner_points, scan_normals

    left = np.column_stack([np.full(10, 2.0), np.linspace(-0.5, -0.05, 10)])     # 5 cm apart
    right = np.column_stack([np.full(10, 2.0), np.linspace(0.05, 0.5, 10)])
    post = np.array([[1.0, 0.0]])
    hits = np.vstack([left, post, right])
    corners = corner_points(hits, scan_normals(hits, 3, 0.15), 0.03)
    assert corners.shape == (1, 2) and np.allclose(corners, post)


def test_only_a_wide_scan_keeps_corners():
    """A 58-degree depth scan's hits without a normal are mostly where its view is cut off: `match_corners` is
    for scans of at least `match_corners_min_fov` (a 180-degree laser's, not a depth camera's). The same wall with
    a post before it, seen 1 degree a beam: the wide scan's keyframe keeps the post as a corner, the narrow one
    none."""
    def first_keyframe_corners(degrees: float) -> np.ndarray:
        angles = np.radians(np.arange(-degrees / 2, degrees / 2 + 0.5, 1.0))
        ranges = 2.0 / np.cos(angles)                        # a wall 2 m ahead
        ranges[np.abs(angles) < 1e-9] = 1.0                  # a post 1 m ahead, straight on
        hit = ranges < 10.0
        slam = GraphSlam(SlamParams(match_corners=0.05))
        slam.add_scan(0.0, np.zeros(3), Beams(np.zeros(2), angles, np.where(hit, ranges, 10.0), hit))
        return slam.keyframes[0].corners

    wide, narrow = first_keyframe_corners(180), first_keyframe_corners(58)
    assert any(np.allclose(c, [1.0, 0.0]) for c in wide)
    assert len(narrow) == 0


def test_a_corridor_s_door_jambs_pin_the_pose_along_it_point_to_point():
    """A corridor's two walls say nothing about where along it the robot is: with the prediction 8 cm out along
    the corridor and a loose odometry prior, point-to-line ICP leaves it there. Two door jambs' corner points,
    paired point to point (`Corners`), bring it back to within a centimetre; across the corridor and in heading
    the fit is the same either way, and the fit is surer along the corridor."""
    from navigation.slam_match import Cloud, Corners, match
    from navigation.slam_nearest import BucketGrid

    xs = np.linspace(-4.0, 4.0, 161)
    walls = np.vstack([np.column_stack([xs, np.full_like(xs, 1.0)]), np.column_stack([xs, np.full_like(xs, -1.0)])])
    normals = np.vstack([np.tile([0.0, -1.0], (len(xs), 1)), np.tile([0.0, 1.0], (len(xs), 1))])
    jambs = np.array([[1.5, 1.02], [1.5, 1.05], [-2.0, -1.02]])   # stubs standing off the walls
    truth = np.array([0.3, 0.1, 0.02])
    c, s = math.cos(truth[2]), math.sin(truth[2])

    def seen(points: np.ndarray) -> np.ndarray:  # map points in the robot's frame at the true pose
        offset = points - truth[:2]
        return np.column_stack([c * offset[:, 0] + s * offset[:, 1], -s * offset[:, 0] + c * offset[:, 1]])

    target = Cloud.of(walls, normals)
    guess = truth + np.array([0.08, 0.0, 0.0])
    prior = np.diag([1 / 0.1 ** 2, 1 / 0.1 ** 2, 1 / 0.05 ** 2])
    without = match(seen(walls), target, guess, prior)
    assert abs(without.pose[0] - guess[0]) < 0.01           # nothing along the corridor: the prediction stays
    corners = Corners(seen(jambs), BucketGrid(jambs), sigma=0.05)
    with_corners = match(seen(walls), target, guess, prior, corners=corners)
    assert abs(with_corners.pose[0] - truth[0]) < 0.01     # the jambs bring it back
    assert abs(with_corners.pose[1] - without.pose[1]) < 0.005 and abs(with_corners.pose[2] - without.pose[2]) < 0.002
    assert with_corners.covariance[0, 0] < 0.5 * without.covariance[0, 0]


def test_a_closure_is_tied_to_the_keyframe_whose_scan_it_fits():
    """The end of a long circuit, drifted, is estimated on top of its start: keyframe 1's estimate stands where
    keyframe 0's does, but its scan saw another room. A closure whose query fits keyframe 0's walls is that
    keyframe's, even though keyframe 1's estimate is the nearer to the matched pose: tied to keyframe 1, the
    correction would be wrong by as much as the two estimates disagree (on ACES at 10% drift, 7 m and 15
    degrees)."""
    slam = GraphSlam(SlamParams())
    xs = np.linspace(-2.0, 2.0, 81)
    room = np.vstack([np.column_stack([xs, np.full_like(xs, 1.5)]), np.column_stack([np.full_like(xs, 2.5), xs])])
    other = np.column_stack([xs, 0.6 * xs - 3.0])             # a wall the start never saw
    for pose, points in ((np.array([0.0, 0.0, 0.0]), room), (np.array([0.05, 0.0, 0.0]), other)):
        kf = Keyframe(0.0, pose, pose, None, points - pose[:2], np.full_like(points, np.nan), 0.0)
        slam.keyframes.append(kf)
        slam._stack(kf)
    matched = np.array([0.06, 0.0, 0.0])                      # nearer keyframe 1's estimate than keyframe 0's
    query = room[::3] - matched[:2]
    cloud = slam._cloud([0, 1])
    assert slam._matched_keyframe([0, 1], cloud, query, matched) == 0
    assert slam._matched_keyframe([0, 1], cloud, other[::3] - matched[:2], matched) == 1



def _square_loop(side: int = 10) -> np.ndarray:
    """Poses 1 m apart round a square of `side` m, turning left at its corners."""
    poses = [np.zeros(3)]
    for k in range(4 * side - 1):
        step = np.array([1.0, 0.0, 0.0 if (k + 1) % side else math.pi / 2])
        poses.append(compose(poses[-1], step))
    return np.array(poses)


def _bent_square_rms(robust: float) -> float:
    """RMS position error round a 40 m square whose 5th step is tracked 5 degrees off with a confident 0.17-degree
    sigma (a scan fitted onto the wrong wall), after three plain closures at the end say where the start really is;
    added and optimised one keyframe at a time as GraphSlam does, tracking's edges under a Cauchy kernel of
    `robust` standard deviations (0: plain)."""
    truth = _square_loop()
    graph, estimate = PoseGraph(truth[0]), truth[0].copy()
    for k in range(1, len(truth)):
        step = between(truth[k - 1], truth[k])
        if k == 5:
            step[2] += math.radians(5.0)
        estimate = compose(estimate, step)
        graph.add_node(estimate, step, np.array([0.02, 0.02, 0.003]), robust=robust)
        graph.optimise()
    for older, newer in ((0, 39), (1, 38), (2, 37)):
        graph.add_loop(older, newer, between(truth[older], truth[newer]), np.array([0.05, 0.05, 0.01]), robust=0.0)
        poses = graph.optimise(extra_iterations=2)
    for _ in range(10):
        poses = graph.optimise(extra_iterations=2)
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - truth[:, :2]) ** 2, axis=1))))


def test_a_wrong_tracking_step_gives_way_to_closures_when_tracking_edges_are_robust():
    """With plain tracking edges (track_robust 0) the closures' correction is spread over every step and the map
    keeps a bend; under the default 3-sigma Cauchy kernel the wrong step gives way more. (Measured: 0.260 m RMS
    plain, 0.222 m robust. A kernel that wide gives way only to what contradicts a step by far more than its sigma:
    a 1-sigma one here, 0.03 m, would also let every right step give way to the first wrong closure.)"""
    plain, robust = _bent_square_rms(0.0), _bent_square_rms(3.0)
    assert robust < 0.9 * plain


def test_every_slam_core_parameter_is_a_node_parameter_with_the_same_default():
    """A user tunes the mapper through the slam node's parameters (rosparam, `subsumption map --param`): every
    field of :class:`SlamParams` must be one, defaulting to the same value, or the docs name a knob nobody can
    turn."""
    from dataclasses import fields

    from navigation.slam import Slam

    declared = Slam.interface.params
    missing = [f.name for f in fields(SlamParams) if f.name not in declared]
    assert not missing, f"SlamParams fields the slam node does not declare: {missing}"
    differing = {f.name: (f.default, declared[f.name].default) for f in fields(SlamParams)
                 if declared[f.name].default != f.default}
    assert not differing, f"(core default, node default) differ: {differing}"
