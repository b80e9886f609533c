"""Which scalar floating-point fields of a message are NaN or infinite.

A NaN heading or an infinite force is not a value a module can act on: turned into a motor command it drives
the robot who knows where. Modules therefore drop such messages on their inputs before any register or
callback sees them (:class:`~subsumption.module.Input`'s ``finite`` option, on by default) and count them.

Only *scalar* float32/float64 fields are looked at, including those of nested messages (``pose.position.x``);
arrays are left alone, because sensor arrays legitimately hold NaN and infinity (REP 117: a LaserScan's
``+inf`` means "nothing in range") and scanning them would cost a pass over every scan. For the same reason
the few scalar fields REP 117 lets be infinite, ``sensor_msgs/Range.range`` (``+inf`` nothing detected,
``-inf`` too close), may be infinite here, never NaN.

The field paths of a message class are found once (from genpy's ``__slots__``/``_slot_types``) and cached, so
the check costs one attribute read and one comparison per scalar field.
"""
from __future__ import annotations

import math
from functools import lru_cache
from operator import attrgetter
from typing import Any, Callable

FLOAT_TYPES = {"float32", "float64"}
# scalar fields whose message definition gives infinity a meaning (REP 117): NaN is still refused there
INFINITY_ALLOWED = {"sensor_msgs/Range": {"range"}}




def _float_paths(msg_class: type, prefix: str = "", depth: int = 0) -> list[tuple[str, bool]]:
    slots = getattr(msg_class, "__slots__", ())
    types = getattr(msg_class, "_slot_types", None)
    if types is None or depth > 20:
        return []
    allowed = INFINITY_ALLOWED.get(getattr(msg_class, "_type", ""), set())
    try:
        example = msg_class()
    except Exception:  # not a plain message class: nothing we can look into
        return []
    paths: list[tuple[str, bool]] = []
    for slot, slot_type in zip(slots, types):
        if slot_type in FLOAT_TYPES:
            paths.append((prefix + slot, slot in allowed))
        elif "[" not in slot_type and hasattr(getattr(example, slot, None), "_slot_types"):
            paths += _float_paths(type(getattr(example, slot)), prefix + slot + ".", depth + 1)
    return paths


@lru_cache(maxsize=None)
def checks_for(msg_class: type) -> tuple[tuple[tuple[str, bool], ...], Callable[[Any], tuple] | None]:
    """The scalar float fields of `msg_class` as (dotted path, infinity allowed), and one getter that reads them
    all into a tuple (a single C call: the check stays cheap on every message)."""
    paths = tuple(_float_paths(msg_class))
    return paths, (attrgetter(*(path for path, _ in paths)) if paths else None)


def non_finite_field(msg: Any) -> str | None:
    """The dotted path of the first scalar float field of `msg` that is NaN (or infinite, where not allowed),
    with its value, e.g. ``'vector.x = nan'``; None when every such field is usable."""
    paths, getter = checks_for(type(msg))
    if getter is None:
        return None
    try:
        values = getter(msg)
        if len(paths) == 1:
            values = (values,)
        if all(map(math.isfinite, values)):
            return None
    except (AttributeError, TypeError):  # a hand-built message with a missing or odd field: look one by one
        values = tuple(_read(msg, path) for path, _ in paths)
    for (path, inf_ok), value in zip(paths, values):
        try:
            finite = math.isfinite(value)
        except TypeError:  # not a number: the module's own code will say what is wrong with it
            continue
        if not finite and not (inf_ok and not math.isnan(value)):
            return f"{path} = {float(value)!r}"
    return None


def _read(msg: Any, path: str) -> Any:
    try:
        return attrgetter(path)(msg)
    except AttributeError:
        return None
