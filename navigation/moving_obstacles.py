"""Where the things the scan sees off the map are going: clusters tracked from scan to scan with a constant-velocity
estimate, so the local planner can keep off where a person *will* be, not only where she is.

Why: scoring arcs against the scan as it is now let the robot drive on into a person walking towards it (the
office with people walking, seed 1, 75 s: she came out of a door 1.46 m ahead, closing at 1.3 m/s; arcs curving a
little aside were clear of where she stood, and the robot touched her 0.8 s later). The simulator's walkers, like
polite people, stop for a robot in their way; a robot that keeps off their predicted path never meets them.

From the scan only (never the truth): the hits more than a margin from the static map's walls (move_base's
``_dynamic``), in the odometry frame so that the robot's own motion does not look like theirs, are grouped into
clusters (points within ``cluster_tolerance`` of each other, connected components); each cluster's centroid is
matched to the nearest track predicted to this scan's time within a gate (a global assignment), and the track's
velocity is the smoothed centroid displacement over time. A track not seen for ``timeout`` s is dropped; a track
younger than ``min_hits`` scans, or slower than ``min_speed``, counts as standing still (the centroid of the arc a
laser sees of a person shifts as the robot passes: that must not become a walk).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from subsumption.planar import inverse, transform_points


@dataclass(frozen=True)
class TrackerParams:
    cluster_tolerance: float = 0.2  # m: hits this close belong to one thing
    gate: float = 0.6  # m a cluster may be from a track's prediction to continue it
    max_speed: float = 1.8  # m/s: faster is a mismatch (two things swapped), the track restarts still
    smoothing: float = 0.4  # weight of a new velocity measurement (exponential smoothing)
    min_speed: float = 0.15  # m/s below which a track counts as standing
    min_hits: int = 3  # scans a track must be seen in before its velocity counts
    timeout: float = 0.6  # s a track is kept unseen (predicted on) before it is dropped
    lost_keep: float = 0.0  # s a walker whose predicted place the scan cannot see is kept (0: timeout as any)
    lost_slow: float = 0.0  # s a walker out of sight is remembered for lost_near (the robot's speed), hidden or not
    lost_spread: float = 0.3  # m/s its uncertainty grows while it is out of sight
    lost_spread_max: float = 0.5  # m: at most
    person_radius: float = 0.25  # m: a walker keeps its centre this far beyond a robot's rim (it stops for robots)
    robot_radius: float = 0.18  # m: the robot's own, for where a walker that stops for it stands


@dataclass
class Track:
    position: np.ndarray  # centroid, odometry frame
    velocity: np.ndarray  # m/s, odometry frame
    points: np.ndarray  # the cluster's hits relative to the centroid (its shape), odometry frame axes
    seen: float  # time last seen
    hits: int = 1
    ident: int = 0
    heading: np.ndarray | None = None  # unit direction it last walked in (odometry frame); None: never seen walk
    hidden: bool = False  # out of sight past the timeout, its predicted place hidden from the scan (update)


@dataclass
class MovingObstacles:
    """Predicted obstacles in the robot's frame: `points` (n, 2) as seen now (each track's last shape at its
    position predicted to now) and `velocities` (n, 2) of the track each point belongs to."""

    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    velocities: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def __len__(self) -> int:
        return len(self.points)

    def at(self, t: float) -> np.ndarray:
        """Where the points will be `t` s from now, moving on at constant velocity."""
        return self.points + t * self.velocities


def clusters(points: np.ndarray, tolerance: float) -> list[np.ndarray]:
    """`points` (n, 2) grouped into arrays of points each within `tolerance` of another of its group."""
    if len(points) == 0:
        return []
    pairs = cKDTree(points).query_pairs(tolerance, output_type="ndarray")
    n = len(points)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)) if len(pairs) else \
        coo_matrix((n, n))
    count, labels = connected_components(graph, directed=False)
    return [points[labels == i] for i in range(count)]


class ObstacleTracker:
    """Constant-velocity tracks of clusters of off-map hits, updated once per scan."""

    def __init__(self, params: TrackerParams | None = None) -> None:
        self.params = params or TrackerParams()
        self.tracks: list[Track] = []
        self._next_id = 1
        self.time: float | None = None

    def clear(self) -> None:
        """Forget every track (a new map, a recovery)."""
        self.tracks = []
        self.time = None

    def update(self, now: float, odom: np.ndarray, off_map: np.ndarray, hidden=None) -> None:
        """One scan: `off_map` (n, 2) its hits not on the map in the base frame, the robot at `odom` (x, y, yaw)
        in the odometry frame at time `now`. `hidden(points)`, base frame, says which points this scan cannot see
        (out of its view, too near, behind a hit): a walker predicted there is kept up to ``lost_keep`` s."""
        p = self.params
        if self.time is not None and now < self.time:  # the clock went back (a simulation restarted)
            self.clear()
        world = transform_points(odom, off_map) if len(off_map) else np.zeros((0, 2))
        groups = clusters(world, p.cluster_tolerance)
        centres = np.array([g.mean(axis=0) for g in groups]) if groups else np.zeros((0, 2))
        for t in self.tracks:
            t.hidden = now - t.seen > p.timeout and self._hidden_walker(t, now, odom, hidden)
        self.tracks = [t for t in self.tracks if now - t.seen <= p.timeout or t.hidden
                       or (t.heading is not None and now - t.seen <= p.lost_slow)]
        matched_tracks, matched_groups = set(), set()
        if self.tracks and len(centres):
            predicted = np.array([t.position + (now - t.seen) * t.velocity for t in self.tracks])
            cost = np.hypot(*(predicted[:, None, :] - centres[None, :, :]).transpose(2, 0, 1))
            big = 1e6
            rows, cols = linear_sum_assignment(np.where(cost <= p.gate, cost, big))
            for r, c in zip(rows, cols):
                if cost[r, c] > p.gate:
                    continue
                self._continue(self.tracks[r], centres[c], groups[c], now)
                matched_tracks.add(r)
                matched_groups.add(c)
        for c, group in enumerate(groups):
            if c not in matched_groups:
                self.tracks.append(Track(centres[c], np.zeros(2), group - centres[c], now, 1, self._next_id))
                self._next_id += 1
        self.time = now

    def _continue(self, track: Track, centre: np.ndarray, group: np.ndarray, now: float) -> None:
        p = self.params
        dt = now - track.seen
        if dt > 1e-6:
            measured = (centre - track.position) / dt
            if float(np.hypot(*measured)) > p.max_speed:
                track.velocity, track.hits = np.zeros(2), 0  # a mismatch: start again, standing
            else:
                track.velocity = track.velocity + p.smoothing * (measured - track.velocity) if track.hits > 1 \
                    else measured
        track.position, track.points, track.seen = centre, group - centre, now
        track.hits += 1
        if self._believed_moving(track):
            track.heading = track.velocity / float(np.hypot(*track.velocity))

    def moving(self, now: float, odom: np.ndarray) -> MovingObstacles:
        """The tracks predicted to `now`, in the base frame of the robot at `odom`: every track's points, with its
        velocity when it is believed to move (else zero)."""
        if not self.tracks:
            return MovingObstacles()
        points, velocities = [], []
        to_base = inverse(odom)
        c, s = np.cos(-odom[2]), np.sin(-odom[2])
        rotate = np.array([[c, -s], [s, c]])
        for t in self.tracks:
            if now - t.seen > self.params.timeout:  # out of sight, kept: see lost()
                continue
            v = t.velocity if self._believed_moving(t) else np.zeros(2)
            at = t.position + (now - t.seen) * v + t.points
            points.append(transform_points(to_base, at))
            velocities.append(np.repeat((rotate @ v)[None], len(at), axis=0))
        if not points:
            return MovingObstacles()
        return MovingObstacles(np.concatenate(points), np.concatenate(velocities))

    def _hidden_walker(self, track: Track, now: float, odom: np.ndarray, hidden) -> bool:
        """Whether a walker not seen for longer than the timeout is to be kept (and circled by lost()) because its
        predicted place is hidden from the scan, up to lost_keep s: it walked out of a narrow view, not away."""
        if hidden is None or self.params.lost_keep <= 0 or track.heading is None or \
                now - track.seen > self.params.lost_keep:
            return False
        centre = self.lost_place(track, now, odom)
        return bool(hidden(transform_points(inverse(odom), centre[None]))[0])

    def lost_place(self, track: Track, now: float, odom: np.ndarray) -> np.ndarray:
        """Where a track is predicted now (odometry frame), walking on at its velocity but stopping short of the
        robot at `odom` (a walker waits for a robot in its way)."""
        v = track.velocity if self._believed_moving(track) else np.zeros(2)
        start, travel = track.position, now - track.seen
        keep = self.params.robot_radius + self.params.person_radius + 0.05
        steps = np.linspace(0.0, travel, 11)
        places = start[None] + steps[:, None] * v[None]
        clear = np.hypot(*(places - odom[:2]).T) >= keep
        if clear.all() or not clear[0]:
            return places[-1]
        return places[int(np.argmin(clear)) - 1]

    def lost(self, now: float, odom: np.ndarray) -> np.ndarray:
        """Points (base frame of the robot at `odom`) round each walker out of sight longer than the timeout: its
        predicted place, circled at its radius plus its grown uncertainty (``lost_spread`` m/s, at most
        ``lost_spread_max``)."""
        p = self.params
        out = []
        ring = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
        circle = np.column_stack((np.cos(ring), np.sin(ring)))
        for t in self.tracks:
            age = now - t.seen
            if age <= p.timeout or not t.hidden:
                continue
            centre = self.lost_place(t, now, odom)
            radius = p.person_radius + min(p.lost_spread * age, p.lost_spread_max)
            out.append(np.concatenate([centre[None], centre + radius * circle]))
        if not out:
            return np.zeros((0, 2))
        return transform_points(inverse(odom), np.concatenate(out))

    def lost_near(self, now: float, odom: np.ndarray, reach: float) -> bool:
        """Whether a walker went out of the scan's sight at most ``lost_slow`` s ago and is ahead of the robot at
        `odom` and within `reach` m of its centre, where it was last seen or where it is predicted (walking on,
        stopping short of the robot): a walker who stopped for the robot is not where a walk would have taken her,
        and the scan seeing that place empty does not say where she is.

        Why: a narrow scan loses a walker the robot draws level with; driving on at speed, the robot can run into
        its side (the patrol robot overtook the target robot it had just lost, which stood in its blind range).
        Slowing down keeps the robot behind such a walker without circling it as an obstacle, which near walls left
        the planner no way through."""
        if self.params.lost_slow <= 0:
            return False
        heading = np.array([np.cos(odom[2]), np.sin(odom[2])])
        for t in self.tracks:
            age = now - t.seen
            if age <= self.params.timeout or age > self.params.lost_slow or t.heading is None:
                continue
            for place in (t.position, self.lost_place(t, now, odom)):
                offset = place - odom[:2]
                if float(offset @ heading) > 0.0 and float(np.hypot(*offset)) < reach:
                    return True
        return False

    def walked_near(self, odom: np.ndarray, radius: float, now: float | None = None,
                    within: float = np.inf) -> list[tuple[np.ndarray, np.ndarray]]:
        """(position, heading) in the base frame of the robot at `odom` of the tracks within `radius` m of it that
        were seen walking, standing now or not: where a walker that stopped for the robot wants to go on. With
        `now`, only those seen within the last `within` s."""
        to_base = inverse(odom)
        c, s = np.cos(-odom[2]), np.sin(-odom[2])
        rotate = np.array([[c, -s], [s, c]])
        found = []
        for t in self.tracks:
            if t.heading is None or (now is not None and now - t.seen > within):
                continue
            position = transform_points(to_base, t.position[None])[0]
            if float(np.hypot(*position)) <= radius:
                found.append((position, rotate @ t.heading))
        return found

    def movers(self) -> list[Track]:
        """The tracks believed to move (for logs and pictures)."""
        return [t for t in self.tracks if self._believed_moving(t)]

    def _believed_moving(self, track: Track) -> bool:
        """Seen in `min_hits` scans at least, and at `min_speed` or faster: a walk, not a centroid's jitter."""
        return track.hits >= self.params.min_hits and float(np.hypot(*track.velocity)) >= self.params.min_speed
