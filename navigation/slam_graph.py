"""The pose graph behind the map: keyframe poses tied by scan-matching constraints, optimised by gtsam.

Consecutive keyframes are tied by what scan matching measured between them; a loop closure (a keyframe
matched against the scans of a place visited long before) ties two distant keyframes, under a Cauchy robust
kernel so that one wrong closure cannot bend the whole map. The consecutive ties may be robust too, with a wider
kernel: a tracking step that went wrong (a scan fitted a few degrees off, with a confident covariance) then gives
way when later closures contradict it, instead of turning everything after it. gtsam's iSAM2 keeps the solution
up to date incrementally: adding a keyframe costs little, a loop closure relinearises only what it touches.
"""
from __future__ import annotations

import gtsam
import numpy as np


def _pose2(p: np.ndarray) -> gtsam.Pose2:
    return gtsam.Pose2(float(p[0]), float(p[1]), float(p[2]))


def _noise(uncertainty: np.ndarray, robust: float = 0.0):
    """A noise model from standard deviations (3,) or a covariance (3, 3) in the newer pose's own frame."""
    uncertainty = np.asarray(uncertainty, dtype=float)
    if uncertainty.shape == (3, 3):
        model = gtsam.noiseModel.Gaussian.Covariance(uncertainty)
    else:
        model = gtsam.noiseModel.Diagonal.Sigmas(uncertainty)
    if robust > 0:
        return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Cauchy.Create(robust), model)
    return model


class PoseGraph:
    """Keyframe poses 0..n-1; node 0 is anchored where SLAM started."""

    def __init__(self, start: np.ndarray) -> None:
        self.isam = gtsam.ISAM2(gtsam.ISAM2Params())
        self._graph = gtsam.NonlinearFactorGraph()
        self._values = gtsam.Values()
        self._graph.add(gtsam.PriorFactorPose2(0, _pose2(start), _noise(np.array([1e-4, 1e-4, 1e-5]))))
        self._values.insert(0, _pose2(start))
        self.count = 1
        self.loops: list[tuple[int, int]] = []

    def add_node(self, guess: np.ndarray, relative: np.ndarray, sigmas: np.ndarray, robust: float = 0.0) -> int:
        """A new keyframe at `guess`, `relative` to the previous one with standard deviations `sigmas` (3,) or
        a covariance (3, 3), both in the new keyframe's frame; under a Cauchy kernel of that many standard deviations
        when `robust` > 0."""
        key = self.count
        self._graph.add(gtsam.BetweenFactorPose2(key - 1, key, _pose2(relative), _noise(sigmas, robust)))
        self._values.insert(key, _pose2(guess))
        self.count += 1
        return key

    def add_loop(self, older: int, newer: int, relative: np.ndarray, sigmas: np.ndarray,
                 robust: float = 1.0) -> None:
        """Add a loop closure between keyframes `older` and `newer`: their relative pose with per-axis sigmas, robust
        when `robust` > 0."""
        self._graph.add(gtsam.BetweenFactorPose2(older, newer, _pose2(relative), _noise(sigmas, robust)))
        self.loops.append((older, newer))

    def optimise(self, extra_iterations: int = 0) -> np.ndarray:
        """Fold in what was added since the last call; (n, 3) the poses of every keyframe."""
        self.isam.update(self._graph, self._values)
        for _ in range(extra_iterations):
            self.isam.update()
        self._graph = gtsam.NonlinearFactorGraph()
        self._values = gtsam.Values()
        return gtsam.utilities.extractPose2(self.isam.calculateEstimate())  # rows in key order
