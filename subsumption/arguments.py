"""Command-line values, checked in one place for every ``subsumption`` command.

Seeds, rates, durations, levels, poses, addresses and ``NAME=VALUE`` parameters are read by these argparse types
(and :func:`parameter_value`), so a bad value gets the same one-line error whichever command it was given to:
argparse's ``subsumption map: error: argument --seed: wants an integer from 0 to 4294967295, got '-1'`` and exit
status 2, before anything starts. Before, ``run`` refused ``--seed -1`` while ``map`` and ``navigate`` raised a
traceback from deep inside numpy, and ``--rate -3`` was taken.

A parameter value is read as YAML (as ``rosparam`` and roslaunch's ``_name:=value`` read it); NaN and infinity
are refused anywhere in it (``.nan``, ``[1, .inf]``): no module parameter means "not a number", and a NaN passes
every ``min``/``max`` comparison unnoticed.
"""
from __future__ import annotations

import argparse
import ipaddress
import math
from typing import Any, Callable

import yaml

MAX_SEED = 2**32 - 1  # numpy's generators take seeds in [0, 2**32)


def seed(text: str) -> int:
    """A random seed: an integer in [0, MAX_SEED]."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"wants an integer from 0 to {MAX_SEED}, got {text!r}") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"wants an integer from 0 to {MAX_SEED}, got {text!r}")
    return value


def number(low: float, low_included: bool, what: str) -> Callable[[str], float]:
    """An argparse type: a finite float above `low` (or at it, when `low_included`); `what` is said on error."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"wants {what}, got {text!r}") from None
        if not math.isfinite(value) or value < low or (value == low and not low_included):
            raise argparse.ArgumentTypeError(f"wants {what}, got {text!r}")
        return value
    return parse


def count(low: int, what: str) -> Callable[[str], int]:
    """An argparse type: an integer >= `low`."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"wants {what}, got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"wants {what}, got {text!r}")
        return value
    return parse


level = count(0, "a level number >= 0")


def pose(text: str) -> tuple[float, float, float]:
    """X,Y,YAW: finite metres, metres, radians."""
    try:
        x, y, yaw = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"wants X,Y,YAW (metres, metres, radians), got {text!r}") from None
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise argparse.ArgumentTypeError(f"X,Y,YAW must be finite numbers, got {text!r}")
    return x, y, yaw


def ip(text: str) -> str:
    """This host's IP address as other hosts reach it."""
    try:
        return str(ipaddress.ip_address(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"wants this host's IP address as other hosts reach it, got {text!r}"
                                         ) from None


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser with its errors on one line (``PROG: error: what (PROG --help ...)``) and exit status 2:
    the usage block argparse prints first buries the line that says what is wrong."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _not_finite(value: Any) -> bool:
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, (list, tuple)):
        return any(_not_finite(v) for v in value)
    if isinstance(value, dict):
        return any(_not_finite(v) for v in value.values())
    return False


def parameter_value(text: str, where: str) -> Any:
    """`text` read as YAML; ValueError starting with `where` when it holds NaN or infinity."""
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        value = text  # not YAML: the string itself, as rosparam takes it
    if _not_finite(value):
        raise ValueError(f"{where}: {text!r} is not a finite number (NaN and infinity are refused)")
    return value


def assignment(text: str) -> tuple[str, Any]:
    """An argparse type: NAME=VALUE, VALUE read by :func:`parameter_value`."""
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    try:
        return name, parameter_value(value, name)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
