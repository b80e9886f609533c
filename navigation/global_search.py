"""Global localization by search: where on a known map does what the robot has seen lately fit, over the whole
map and every heading.

A particle filter started all over a map (amcl's ``global_localization``) keeps the poses that explain the first
scans, and on a building of look-alike corridors those are often wrong: the filter settles on one of them within a
few updates and KLD-sampling shrinks the set to it. Cartographer localizes globally the other way round: it searches
the whole map for the pose at which the robot's recent scans fit best, with the branch-and-bound matcher of its loop
closures, and accepts the pose only when it is unambiguous. This module does that with the loop closures'
correlative matcher (:mod:`navigation.slam_correlative`):

* the map's occupied cells become a likelihood field at ``resolution`` (coarser than the map: a whole-map window
  at 5 cm would be millions of poses per heading);
* the query is the hits of the scans of the last ``query_travel`` metres of driving, joined by odometry in the
  frame of the newest (odometry drifts little over a few metres, and a longer stretch of corridor with its doors
  and corners is far less ambiguous than one scan), thinned to ``query_points`` within ``query_reach`` of it;
* every ``attempt_every`` metres of driving the query is scored at every pose of the map and every heading; the
  best pose counts when it scores ``min_score`` and no pose ``rival_distance`` or more away scores
  ``rival_share`` of it (the same rule the loop closures use against look-alikes).

The caller starts its filter round the pose found (``subsumption localize --global``).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from subsumption.mapfile import OCCUPIED, OccupancyMap
from subsumption.planar import between, compose

from .slam_correlative import Correlation, LikelihoodField, search
from .slam_match import evenly

# the particle filter's spread round a pose found: the search's own resolution (0.1 m) and a few of its heading steps
START_COVARIANCE = np.diag([0.1 ** 2, 0.1 ** 2, math.radians(3.0) ** 2])


@dataclass(frozen=True)
class GlobalSearchParams:
    resolution: float = 0.1  # m: cells of the likelihood field searched
    sigma: float = 0.1  # m: how fast a point's likelihood falls off with its distance to the nearest wall
    min_score: float = 0.5  # mean likelihood of the query's points the best pose needs
    rival_distance: float = 2.0  # m: a pose this far from the best ...
    rival_share: float = 0.9  # ... that scores this share of it makes the match ambiguous
    query_travel: float = 10.0  # m of driving whose scans form the query
    query_reach: float = 10.0  # m: query points farther than this from the newest pose are left out
    query_points: int = 300  # the query thinned to at most this many points
    query_scans: int = 300  # at most this many of the latest scans are kept for the query
    attempt_every: float = 2.0  # m of driving between searches


@dataclass
class Found:
    """A pose found: where the robot was at `stamp` (map frame), its odometry pose then, the search's score, and the
    searches it took."""

    stamp: float
    pose: np.ndarray
    odom: np.ndarray
    score: float
    attempts: int

    def now(self, odom: np.ndarray) -> np.ndarray:
        """Where the robot is on the map at odometry pose `odom`, moved since by odometry (a search that ran in the
        background while the robot drove on)."""
        return compose(self.pose, between(self.odom, odom))


@dataclass(frozen=True)
class Query:
    """A search due: the points, and the scan's stamp and odometry pose they are in the frame of."""

    stamp: float
    odom: np.ndarray
    points: np.ndarray


class GlobalSearch:
    """Feed it each scan's hits (base frame) with the odometry pose of its instant. :meth:`add` searches when a
    search is due and returns the pose on the map once one is good and unambiguous (None until then); a node that
    must not wait for a search splits it: :meth:`feed` says when one is due, :meth:`attempt` runs it (on a thread of
    its own if need be: the matcher releases the GIL)."""

    def __init__(self, grid: OccupancyMap, params: GlobalSearchParams = GlobalSearchParams()) -> None:
        self.params = params
        rows, cols = np.nonzero(grid.occupancy == OCCUPIED)  # walls as amcl's field takes them
        if not len(rows):
            raise ValueError(f"{grid.source or 'the map'}: no occupied cell to localize against")
        walls = np.column_stack([grid.origin[0] + (cols + 0.5) * grid.resolution,
                                 grid.origin[1] + (rows + 0.5) * grid.resolution])
        self.field = LikelihoodField.of(walls, params.resolution, params.sigma)
        low, high = walls.min(axis=0), walls.max(axis=0)
        self._centre = np.array([(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, 0.0])
        self._window = float(max(high - low) / 2 + params.resolution)
        # (odometry pose, hits, travelled) of the scans of the last query_travel metres, and at most query_scans
        # of them (a robot turning on the spot drives no metres)
        self._seen: deque[tuple[np.ndarray, np.ndarray, float]] = deque(maxlen=params.query_scans)
        self._travelled = 0.0
        self._next_attempt = 0.0
        self.attempts = 0
        self.last: Correlation | None = None  # the last search's result, for logs

    def add(self, stamp: float, odom: np.ndarray, hits: np.ndarray) -> Found | None:
        """Keep a scan, search when a search is due; the pose once one is found (None until then)."""
        query = self.feed(stamp, odom, hits)
        return self.attempt(query) if query is not None else None

    def feed(self, stamp: float, odom: np.ndarray, hits: np.ndarray) -> Query | None:
        """Keep a scan; the query when a search is due (every ``attempt_every`` metres of driving), else None."""
        p = self.params
        if self._seen:
            last = self._seen[-1][0]
            self._travelled += math.hypot(odom[0] - last[0], odom[1] - last[1])
        self._seen.append((np.asarray(odom, float).copy(), np.asarray(hits, float).reshape(-1, 2),
                           self._travelled))
        while self._seen and self._travelled - self._seen[0][2] > p.query_travel:
            self._seen.popleft()
        if self._travelled < self._next_attempt:
            return None
        self._next_attempt = self._travelled + p.attempt_every
        points = self.query()
        return Query(stamp, self._seen[-1][0], points) if len(points) >= 20 else None

    def attempt(self, query: Query) -> Found | None:
        """Search the whole map and every heading for `query`; the pose when it is good and has no rival."""
        p = self.params
        self.attempts += 1
        found = self.last = self.correlate(query.points)
        if found.score < p.min_score or found.rival > 0:
            return None
        return Found(query.stamp, found.pose, query.odom, found.score, self.attempts)

    def correlate(self, points: np.ndarray, floor: float | None = None) -> Correlation:
        """`points` (robot frame) searched over the whole map and every heading, with the rival rule; no pose scoring
        `floor` or less is refined (default ``min_score``: the branch and bound then prunes every pose that could not
        be taken; 0: none)."""
        p = self.params
        return search(points, self.field, self._centre, self._window, math.pi, apart=p.rival_distance,
                      rival_share=p.rival_share, floor=p.min_score if floor is None else floor)

    def query(self) -> np.ndarray:
        """The hits of the scans kept, in the frame of the newest odometry pose, thinned."""
        p = self.params
        newest = self._seen[-1][0]
        parts = []
        for odom, hits, _ in self._seen:
            x, y, yaw = between(newest, odom)
            c, s = math.cos(yaw), math.sin(yaw)
            parts.append(np.column_stack([x + c * hits[:, 0] - s * hits[:, 1], y + s * hits[:, 0] + c * hits[:, 1]]))
        points = np.concatenate(parts) if parts else np.zeros((0, 2))
        return evenly(points[np.hypot(points[:, 0], points[:, 1]) <= p.query_reach], p.query_points)


__all__ = ["GlobalSearch", "GlobalSearchParams", "Found", "Query", "START_COVARIANCE"]
