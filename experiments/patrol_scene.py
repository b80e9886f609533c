"""What a patrol level's scene must show to have happened, judged on the run's own metrics before they are written.

Levels 0-3 show behaviour over the whole run (backing away, wandering, exploring, patrolling) that their figures
measure: nothing a run can miss. Levels 4 and 5 are encounters, and a run can miss them (the face seen for a
frame and never confirmed, an operator who never saw the target and sent nothing), so their runs carry a verdict:
``scene_happened`` (bool) and ``scene_missing`` (what did not happen, in SCENE_EVENTS' order) in metrics.json.
The events are what the robot did (its alarm, its pursuit, follow's commands, the patrol's goals); whether the
alarm's box was on the true face and how soon the robot stood still are the scorer's figures beside them.

The verdict is a step of the run (:func:`experiments.patrol.execute` adds it to the result before metrics.json
is written, once); `subsumption experiment patrol` and the benches read it from the file.
"""
from __future__ import annotations

from collections.abc import Callable

# level -> the events of its scene: (what, whether it happened in a run with these metrics)
SCENE_EVENTS: dict[int, tuple[tuple[str, Callable[[dict], bool]], ...]] = {
    4: (("intruder alarm raised", lambda m: any(a.get("name") == "intruder" for a in m.get("alarm_log") or [])),
        ("pursuit started (levels 0-3 stopped)", lambda m: bool(m.get("pursuits"))),
        ("target followed", lambda m: (m.get("followed_s") or 0.0) > 0.0),
        ("patrol resumed", lambda m: m.get("resumed_patrol_at_s") is not None)),
    5: (("target selected by the operator", lambda m: bool((m.get("operator") or {}).get("selected"))),
        ("operator commands sent", lambda m: (m.get("operator_commands") or 0) > 0),
        ("robot released by the operator", lambda m: (m.get("operator") or {}).get("released_at_s") is not None),
        ("patrol resumed after the release", lambda m: m.get("resumed_patrol_at_s") is not None)),
}


def scene_missing(level: int, metrics: dict) -> list[str] | None:
    """What of `level`'s scene did not happen in a run with these metrics ([]: all of it happened); None for a
    level whose scene has no events to check."""
    events = SCENE_EVENTS.get(level)
    if events is None:
        return None
    return [what for what, happened in events if not happened(metrics)]


def scene_verdict(level: int, metrics: dict) -> dict:
    """The keys a run of `level` adds to its metrics: ``scene_happened`` and ``scene_missing`` for a level whose
    scene has events, nothing for the others (their metrics.json keeps the keys it always had)."""
    missing = scene_missing(level, metrics)
    return {} if missing is None else {"scene_happened": not missing, "scene_missing": missing}
