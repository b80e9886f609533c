"""The local planner (base_local_planner's / DWA's job): a velocity command that follows the global plan and
keeps off whatever the scan sees now.

Dynamic-window sampling, vectorised: for every (v, w) pair on a grid within the robot's limits the arc the robot
would drive in ``sim_time`` s is rolled out (velocities ramping towards the pair at the acceleration limits, as
the base really does), and scored. An arc passing closer than ``robot_radius + footprint_padding`` to any
obstacle point (the current scan's hits and the static map's walls near the robot, all in the robot's frame,
so a localisation error cannot hide what the laser sees) is not admissible; among the rest the cheapest
reaches furthest towards a carrot ``lookahead`` m along the plan, stays near the plan, keeps clear of obstacles
and moves. Close to the goal the speed is capped so the robot can stop on it; within ``xy_goal_tolerance`` it
turns on the spot to the goal's heading.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .moving_obstacles import MovingObstacles
from subsumption.planar import wrap

BLIND_SPOT_CARE = 2.0  # m: with something that moves this near, the robot does not back into its blind spot
LEAVE_HEADINGS = np.radians(np.arange(-180.0, 180.0, 15.0))  # headings heading_to_leave tries
LEAVE_TURN_COST = 0.1  # per rad of turning: of two ways out about as good, the nearer heading


@dataclass(frozen=True)
class LocalParams:
    """base_local_planner's names where the idea is the same."""

    max_vel_x: float = 0.5
    min_vel_x: float = -0.1  # a little backwards, to get out of a corner
    max_vel_theta: float = 1.5
    acc_lim_x: float = 1.5
    acc_lim_theta: float = 5.0
    sim_time: float = 1.5
    sim_granularity: float = 0.1  # s between rolled-out poses
    vx_samples: int = 7
    vth_samples: int = 21
    robot_radius: float = 0.18
    footprint_padding: float = 0.04
    lookahead: float = 0.8  # m along the plan to the carrot
    path_distance_bias: float = 0.6
    goal_distance_bias: float = 1.0
    occdist_scale: float = 0.05
    clearance_wanted: float = 0.35  # m beyond which clearance no longer counts
    xy_goal_tolerance: float = 0.1
    yaw_goal_tolerance: float = 0.1
    rotate_in_place_above: float = 1.2  # rad of heading error to the carrot that makes the robot turn first
    dynamic_padding: float = 0.0  # m more kept from obstacles off the map (people, robots), which may move
    prediction_horizon: float = 1.5  # s ahead that tracked moving obstacles are predicted (0: not at all)
    creep_vel_x: float = 0.1  # m/s the robot may still creep at where even braking cannot keep clear of a walker
    unseen_clearance: float = 0.18  # m an arc's centre keeps from ground not seen lately (see navigation.seen_space)


AT_GOAL = "at goal"  # Command.why when the goal's position and heading are both reached
TURNING_TO_PLAN = "turning towards the plan"  # Command.why when it turns on the spot to face the plan first


@dataclass
class Command:
    """One cycle's motor command and why; move_base acts on two of the reasons (:data:`AT_GOAL`,
    :data:`TURNING_TO_PLAN`)."""

    v: float
    w: float
    ok: bool  # an admissible command was found
    why: str = ""
    latched: bool = False  # the position is reached: only the heading is left to correct


def carrot(path: np.ndarray, position: np.ndarray, lookahead: float) -> tuple[np.ndarray, float, int]:
    """The point `lookahead` m along `path` (n, 2) past its point nearest to `position`; the distance from
    `position` to the path; the index of the nearest segment start."""
    if len(path) == 1:
        return path[0], float(np.hypot(*(path[0] - position))), 0
    a, b = path[:-1], path[1:]
    ab = b - a
    length2 = np.maximum((ab ** 2).sum(axis=1), 1e-12)
    t = np.clip(((position - a) * ab).sum(axis=1) / length2, 0.0, 1.0)
    nearest = a + t[:, None] * ab
    d = np.hypot(*(nearest - position).T)
    i = int(np.argmin(d))
    seg = np.sqrt(length2)
    remaining = lookahead + t[i] * seg[i]
    j = i
    while j < len(seg) and remaining > seg[j]:
        remaining -= seg[j]
        j += 1
    if j >= len(seg):
        return path[-1], float(d[i]), i
    return a[j] + ab[j] * (remaining / seg[j]), float(d[i]), i


def rollout(v0: float, w0: float, vs: np.ndarray, ws: np.ndarray, p: LocalParams) -> np.ndarray:
    """(k, steps, 3) poses in the robot's frame of arcs driven towards each (vs[k], ws[k])."""
    steps = max(1, int(round(p.sim_time / p.sim_granularity)))
    dt = p.sim_time / steps
    k = len(vs)
    poses = np.zeros((k, steps, 3))
    x = np.zeros(k)
    y = np.zeros(k)
    th = np.zeros(k)
    v = np.full(k, v0)
    w = np.full(k, w0)
    for s in range(steps):
        v = v + np.clip(vs - v, -p.acc_lim_x * dt, p.acc_lim_x * dt)
        w = w + np.clip(ws - w, -p.acc_lim_theta * dt, p.acc_lim_theta * dt)
        th_mid = th + 0.5 * w * dt
        x = x + v * dt * np.cos(th_mid)
        y = y + v * dt * np.sin(th_mid)
        th = th + w * dt
        poses[:, s, 0], poses[:, s, 1], poses[:, s, 2] = x, y, th
    return poses


def compute_command(pose: np.ndarray, velocity: tuple[float, float], path: np.ndarray, goal: np.ndarray,
                    obstacles: np.ndarray, p: LocalParams, latched: bool = False,
                    dynamic: np.ndarray | None = None, moving: MovingObstacles | None = None,
                    unseen: np.ndarray | None = None) -> Command:
    """The command for the robot at map `pose` (x, y, yaw) moving at `velocity` (v, w), following `path`
    (n, 2, map frame) to `goal` (x, y, yaw); `obstacles` (m, 2) are points in the robot's frame, `dynamic`
    (k, 2) those of them that are not on the map (people, robots): an arc may pass no closer than
    ``dynamic_padding`` beyond the safety radius to them, unless it takes the robot no closer to them than it is
    now (so a robot someone walked up to can still get away). `moving` (their tracks, robot frame) are predicted
    at constant velocity over ``prediction_horizon`` s: an arc is admissible only if at every rolled-out instant
    it keeps ``robot_radius + footprint_padding + dynamic_padding`` from where they will be then, or, where even
    braking at once cannot keep that (someone walking at the robot), it is at no instant closer than braking,
    or creeps (``creep_vel_x`` at most: the margin from where they are now still holds, and a walker stops for a
    robot in the way; without it a goal on a walker's beat could never be reached). The last stretch (within
    0.4 m, straight at the goal) creeps on the same terms where the prediction refuses its speed. `unseen` (robot
    frame) are the centres of the cells near the robot that the scan has not seen lately
    (:class:`navigation.seen_space.SeenSpace`): an arc that moves the robot keeps ``unseen_clearance`` from them (or
    gets no closer to them than it is): it drives only onto ground it has looked at; turning on the spot is free.

    The position counts as reached (``latched``: only turning is left) once the robot is within half the
    tolerance, so that the estimate's jitter does not take it out again while it turns; it stays reached while
    within the whole tolerance (base_local_planner's latch_xy_goal_tolerance, bounded)."""
    v0, w0 = velocity
    to_goal = goal[:2] - pose[:2]
    goal_dist = float(np.hypot(*to_goal))
    c, s = math.cos(pose[2]), math.sin(pose[2])
    to_local = np.array([[c, s], [-s, c]])
    tree = cKDTree(obstacles) if len(obstacles) else None
    safe = p.robot_radius + p.footprint_padding
    moving_tree = cKDTree(dynamic) if dynamic is not None and len(dynamic) and p.dynamic_padding > 0 else None
    if moving is not None and len(moving):  # what stands still is in `obstacles` and `dynamic` already
        walking = moving.velocities.any(axis=1)
        moving = MovingObstacles(moving.points[walking], moving.velocities[walking])
    predicted = moving is not None and len(moving) > 0 and p.prediction_horizon > 0
    # something that moves is near: the scan does not see behind the robot, where it may have gone, so no
    # backing up
    people_near = moving_tree is not None and float(moving_tree.query(np.zeros(2), k=1)[0]) < BLIND_SPOT_CARE

    if goal_dist <= p.xy_goal_tolerance * (1.0 if latched else 0.5):
        err = float(wrap(goal[2] - pose[2]))
        if abs(err) <= p.yaw_goal_tolerance:
            return Command(0.0, 0.0, True, AT_GOAL, latched=True)
        w = math.copysign(min(p.max_vel_theta, max(0.3, 2.0 * abs(err))), err)
        return Command(0.0, w, True, "turning to the goal's heading", latched=True)
    if goal_dist < 0.4:  # the last stretch: face the goal, then creep onto it
        goal_local = to_local @ to_goal
        bearing = math.atan2(goal_local[1], goal_local[0])
        if abs(bearing) > 0.35:
            return Command(0.0, math.copysign(min(p.max_vel_theta, max(0.4, 1.5 * abs(bearing))), bearing), True,
                           "facing the goal")
        v = min(0.25, p.max_vel_x, 0.8 * goal_dist + 0.03)
        w = 2.0 * bearing
        arc = rollout(v0, w0, np.array([v]), np.array([w]), p)[0, :, :2]
        steps = max(1, int(math.ceil(goal_dist / max(v, 1e-3) / p.sim_granularity)))
        clear = (tree is None or tree.query(arc[:steps], k=1)[0].min() > safe) and \
            bool(_seen_admissible(arc[None, :steps], unseen, p)[0])
        now_clear = True  # of what the scan sees off the map (people, robots) where it is now
        if moving_tree is not None:
            now_clear = moving_tree.query(arc[:steps], k=1)[0].min() > safe + p.dynamic_padding
        way_clear = now_clear  # and of where the walkers will be
        if now_clear and predicted:
            # creeping where even braking cannot keep clear, as the sampler may: the approach to room_people's
            # goal 5 (0.175 m from the walker's line) was refused at 0.25 m/s whenever she came near
            for speed in (v, min(v, p.creep_vel_x)):
                arcs = rollout(v0, w0, np.array([speed, 0.0]), np.array([w, 0.0]), p)
                way_clear = bool(_predicted_admissible(arcs, np.array([speed, 0.0]), moving, p,
                                                       safe + p.dynamic_padding)[0])
                if way_clear:
                    v = speed
                    break
        if clear and way_clear:
            return Command(v, w, True, "approaching the goal")
        if goal_dist <= p.xy_goal_tolerance:
            # within the tolerance already, and closer would take it nearer something: the position counts as
            # reached (room_people, seed 1, goal 25 ended 0.07 m from the goal with the walker against the robot,
            # aborted "every trajectory would touch an obstacle": the position was latched only within half the
            # tolerance)
            return Command(0.0, 0.0, True, "within the tolerance, the way closer is not clear", latched=True)

    target, off_path, nearest = carrot(path, pose[:2], p.lookahead)
    target_local = to_local @ (target - pose[:2])
    heading_err = math.atan2(target_local[1], target_local[0])
    if abs(heading_err) > p.rotate_in_place_above:
        w = math.copysign(min(p.max_vel_theta, max(0.4, 1.5 * abs(heading_err))), heading_err)
        if tree is None or _rotation_clear(tree, safe):
            return Command(0.0, w, True, TURNING_TO_PLAN)

    vmax = p.max_vel_x
    vmax = min(vmax, math.sqrt(2.0 * p.acc_lim_x * 0.6 * goal_dist) + 0.05, 0.3 + goal_dist)
    vs_grid = np.round(np.linspace(p.min_vel_x, vmax, p.vx_samples), 9)  # an exact 0: turning on the spot
    ws_grid = np.linspace(-p.max_vel_theta, p.max_vel_theta, p.vth_samples)
    vs, ws = (a.ravel() for a in np.meshgrid(vs_grid, ws_grid))
    poses = rollout(v0, w0, vs, ws, p)
    points = poses[:, :, :2].reshape(-1, 2)
    if tree is not None:
        clearance = tree.query(points, k=1)[0].reshape(len(vs), -1).min(axis=1)
    else:
        clearance = np.full(len(vs), np.inf)
    admissible = clearance > safe
    if tree is not None:  # already too close (someone walked up to the robot): what gets no closer may go
        now_all = float(tree.query(np.zeros(2), k=1)[0])
        if now_all <= safe:
            admissible |= clearance >= now_all - 1e-3
    if moving_tree is not None:
        dyn_clearance = moving_tree.query(points, k=1)[0].reshape(len(vs), -1).min(axis=1)
        now_clearance = float(moving_tree.query(np.zeros(2), k=1)[0])
        admissible &= (dyn_clearance > safe + p.dynamic_padding) | (dyn_clearance >= now_clearance - 1e-3)
    if predicted:
        stop = rollout(v0, w0, np.zeros(1), np.zeros(1), p)
        admissible &= _predicted_admissible(np.concatenate([poses, stop]), np.append(vs, 0.0), moving, p,
                                            safe + p.dynamic_padding)[:-1]
    if people_near:
        admissible &= vs >= 0
    seen_ok = _seen_admissible(poses[:, :, :2], unseen, p)
    end = poses[:, -1, :2]
    goal_local = to_local @ to_goal
    near_goal = goal_dist < p.lookahead
    aim = goal_local if near_goal else target_local
    to_aim = np.hypot(*(end - aim).T)
    # distance of each end point to the plan (in the robot frame)
    path_local = (path[nearest: nearest + 20] - pose[:2]) @ to_local.T
    off = _distance_to_polyline(end, path_local)
    clear_cost = np.clip(p.clearance_wanted - clearance, 0.0, None) / max(p.clearance_wanted, 1e-6)
    cost = (p.goal_distance_bias * to_aim + p.path_distance_bias * off + p.occdist_scale * 10 * clear_cost
            - 0.05 * vs)
    backwards = vs < 0
    cost[backwards] += 1.0  # backing up only when nothing else is possible
    if not (admissible & seen_ok).any() and admissible.any() and (tree is None or _rotation_clear(tree, safe)):
        # the way it would go crosses ground it has not seen lately: it turns on the spot to look there first
        looking = np.where(admissible, cost, np.inf)
        end_best = end[int(np.argmin(looking))]
        bearing = math.atan2(end_best[1], end_best[0]) if float(np.hypot(*end_best)) > 0.05 else 0.0
        if abs(bearing) > 0.1:
            w = math.copysign(min(p.max_vel_theta, max(0.4, 1.5 * abs(bearing))), bearing)
            return Command(0.0, w, True, "turning to look where it would drive")
    admissible &= seen_ok
    if not admissible.any():
        away = bearing_away_from(dynamic)
        if away is not None and abs(away) > 0.2:
            # people against it on two sides (each waiting for the robot): no arc gets away from both, but once
            # turned from them one does (office seed 2, 75-89 s: between two walkers, four rounds, aborted). A round
            # robot turning on the spot comes no nearer to anything.
            return Command(0.0, math.copysign(min(p.max_vel_theta, max(0.4, 1.5 * abs(away))), away), True,
                           "turning away from what is near")
        return Command(0.0, 0.0, False, "every trajectory would touch an obstacle")
    cost[~admissible] = np.inf
    best = int(np.argmin(cost))
    return Command(float(vs[best]), float(ws[best]), True, "following the plan")


def heading_to_leave(pose: np.ndarray, path: np.ndarray, obstacles: np.ndarray, p: LocalParams,
                     unseen: np.ndarray | None = None) -> float | None:
    """The heading (rad, robot frame; None: none) a robot at rest at map `pose` could turn to on the spot, from
    which an arc forwards (of the sampler's) keeps ``robot_radius + footprint_padding`` from every obstacle point
    and ``unseen_clearance`` from every cell not seen lately (or gets no nearer to them than now): of those, the one
    whose arc ends nearest the carrot on `path` and the path, plus a little for the turn, within
    ``rotate_in_place_above`` of the carrot's bearing (further, it would turn back before it drove). `obstacles` and
    `unseen` are robot-frame points, as for :func:`compute_command`, which this does not change: move_base's
    recovery turns the robot so (see MoveBase._stuck), when nothing that moves is near.

    Why: ahead there may be no way at all. Facing a desk 0.34 m away, within the depth camera's blind range (0.45 m),
    every arc from the robot's heading came nearer a sliver of floor before the desk that no beam reaches (each is
    cut short by the desk), and the recovery's full turn ended facing the desk again: the robot stood there until
    frontier exploration gave up (office, seed 1). Turned further, it drives off the way it came in, over floor it
    has just looked at. A careful driver that can go nowhere ahead turns to where it can go."""
    vs_grid = np.linspace(0.0, p.max_vel_x, p.vx_samples)[1:]
    ws_grid = np.linspace(-p.max_vel_theta, p.max_vel_theta, p.vth_samples)
    vs, ws = (a.ravel() for a in np.meshgrid(vs_grid, ws_grid))
    rest = rollout(0.0, 0.0, vs, ws, p)[:, :, :2]  # from rest, robot frame
    c, s = math.cos(pose[2]), math.sin(pose[2])
    to_local = np.array([[c, s], [-s, c]])
    target, _, nearest = carrot(path, pose[:2], p.lookahead)
    aim = to_local @ (target - pose[:2])
    path_local = (path[nearest: nearest + 20] - pose[:2]) @ to_local.T
    tree = cKDTree(obstacles) if len(obstacles) else None
    safe = p.robot_radius + p.footprint_padding
    now = float(tree.query(np.zeros(2), k=1)[0]) if tree is not None else math.inf
    aim_bearing = math.atan2(aim[1], aim[0])
    best, best_cost = None, math.inf
    for heading in LEAVE_HEADINGS:
        if abs(float(wrap(aim_bearing - heading))) > p.rotate_in_place_above:
            continue  # the plan that far round: the robot would turn back towards it before it drove
        ch, sh = math.cos(heading), math.sin(heading)
        arcs = np.stack((ch * rest[..., 0] - sh * rest[..., 1], sh * rest[..., 0] + ch * rest[..., 1]), axis=-1)
        ok = np.ones(len(arcs), dtype=bool)
        if tree is not None:
            clearance = tree.query(arcs.reshape(-1, 2), k=1)[0].reshape(arcs.shape[:2]).min(axis=1)
            ok = (clearance > safe) | ((now <= safe) & (clearance >= now - 1e-3))
        if ok.any():
            ok[ok] = _seen_admissible(arcs[ok], unseen, p)
        if not ok.any():
            continue
        ends = arcs[ok, -1]
        cost = float((p.goal_distance_bias * np.hypot(*(ends - aim).T)
                      + p.path_distance_bias * _distance_to_polyline(ends, path_local)).min()) \
            + LEAVE_TURN_COST * abs(float(heading))
        if cost < best_cost:
            best, best_cost = float(heading), cost
    return best


def predicted_clearance(poses: np.ndarray, moving: MovingObstacles, p: LocalParams) -> np.ndarray:
    """(k, steps) distance of each rolled-out pose (k, steps, 3) to the nearest moving obstacle where it will be
    at that instant (up to ``prediction_horizon`` s; later steps get inf)."""
    steps = poses.shape[1]
    dt = p.sim_time / steps
    times = dt * (np.arange(steps) + 1)
    within = times <= p.prediction_horizon + 1e-9
    clearance = np.full(poses.shape[:2], np.inf)
    if not within.any():
        return clearance
    t = times[within]
    future = moving.points[None, :, :] + t[:, None, None] * moving.velocities[None, :, :]  # (s, n, 2)
    rel = poses[:, within, None, :2] - future[None]  # (k, s, n, 2)
    clearance[:, within] = np.sqrt((rel ** 2).sum(axis=3)).min(axis=2)
    return clearance


def _predicted_admissible(poses: np.ndarray, vs: np.ndarray, moving: MovingObstacles, p: LocalParams,
                          keep: float) -> np.ndarray:
    """Which of the arcs (k, steps, 3) driven towards speeds `vs` (k), the last of them braking to a stop, keep
    `keep` from the moving obstacles' predicted positions at every instant, or, at the instants where braking
    cannot, are no closer than braking; where braking cannot, creeping is admissible too."""
    clearance = predicted_clearance(poses, moving, p)
    floor = np.minimum(clearance[-1], keep)  # what braking keeps, capped at what is asked
    admissible = (clearance >= floor[None, :] - 1e-3).all(axis=1)
    if floor.min() < keep - 1e-3:
        admissible |= np.abs(vs) <= p.creep_vel_x + 1e-9
    return admissible


def _seen_admissible(paths: np.ndarray, unseen: np.ndarray | None, p: LocalParams) -> np.ndarray:
    """Which of the rolled-out paths (k, steps, 2) keep ``unseen_clearance`` from every `unseen` point, or get no
    closer to each point within it than the robot is to that point now (all of them, with none given).

    Per point: with the nearest unseen cell's distance as the bound for all of them, an arc could close on a cell
    beside the robot (where a person who walked up out of view stands) down to the distance of a cell behind it
    (office seed 1: 0.25 m of a 0.30 m clearance)."""
    if unseen is None or not len(unseen):
        return np.ones(len(paths), dtype=bool)
    return _keeps_or_no_closer(paths, unseen, p.unseen_clearance)


def _keeps_or_no_closer(paths: np.ndarray, points: np.ndarray, keep: float) -> np.ndarray:
    """Which paths (k, steps, 2), robot frame, keep more than `keep` from every point (m, 2), or from each point
    nearer than that now get no closer than now."""
    tree = cKDTree(points)
    clearance = tree.query(paths.reshape(-1, 2), k=1)[0].reshape(paths.shape[:2]).min(axis=1)
    ok = clearance > keep
    now = np.hypot(*points.T)
    near = points[now <= keep + float(np.hypot(paths[..., 0], paths[..., 1]).max(initial=0.0))]
    if ok.all() or not len(near):
        return ok
    near_now = np.hypot(*near.T)
    least = np.full((len(paths), len(near)), np.inf)
    for s in range(paths.shape[1]):  # (k, m) per step: memory stays small
        d = np.hypot(paths[:, s, None, 0] - near[None, :, 0], paths[:, s, None, 1] - near[None, :, 1])
        np.minimum(least, d, out=least)
    return ok | ((least > keep) | (least >= near_now[None, :] - 1e-3)).all(axis=1)


def bearing_away_from(dynamic: np.ndarray | None, near: float = 1.0) -> float | None:
    """Bearing (robot frame) straight away from what is off the map within `near` m (the sum of the unit
    vectors towards each point, reversed); None when nothing is that near or the pulls cancel. The local planner
    turns this way when no arc is admissible; move_base's give-way step starts from it."""
    if dynamic is None or not len(dynamic):
        return None
    distance = np.hypot(*dynamic.T)
    close = dynamic[distance < near]
    if not len(close):
        return None
    away = -(close / np.maximum(np.hypot(*close.T), 1e-6)[:, None]).sum(axis=0)
    if float(np.hypot(*away)) < 1e-6:
        return None
    return math.atan2(away[1], away[0])


def _rotation_clear(tree: cKDTree, safe: float) -> bool:
    """A round robot can turn on the spot unless something is already within its safety radius."""
    return tree.query(np.zeros(2), k=1)[0] > safe


def _distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    if len(line) == 1:
        return np.hypot(*(points - line[0]).T)
    a, b = line[:-1], line[1:]
    ab = b - a
    l2 = np.maximum((ab ** 2).sum(axis=1), 1e-12)
    rel = points[:, None, :] - a[None, :, :]
    t = np.clip((rel * ab[None]).sum(axis=2) / l2[None], 0.0, 1.0)
    nearest = a[None] + t[..., None] * ab[None]
    return np.hypot(*(points[:, None, :] - nearest).transpose(2, 0, 1)).min(axis=1)
