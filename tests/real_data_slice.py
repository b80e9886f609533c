"""A short slice of a real log (Intel Research Lab or Freiburg 079, data/carmen/) for the tests: the lines up to the
n-th scan; and a bag copied with changes, to make bad or unusual bags from a good one."""
from __future__ import annotations

import gzip
from pathlib import Path

import genpy
import rosbag

ROOT = Path(__file__).resolve().parent.parent
INTEL = ROOT / "data" / "carmen" / "intel-corrected.log.gz"
FREIBURG_079 = ROOT / "data" / "carmen" / "freiburg-079-corrected.log.gz"


def write_slice(out: Path, scans: int, source: Path = INTEL) -> Path:
    """The first `scans` FLASER lines of `source` with everything before them, as a plain log at `out`."""
    kept, seen = [], 0
    with gzip.open(source, "rt") as lines:
        for line in lines:
            kept.append(line)
            if line.startswith("FLASER"):
                seen += 1
                if seen == scans:
                    break
    out.write_text("".join(kept))
    return out


def copy_bag(bag: Path, out: Path, change=None, later: dict[str, float] | None = None) -> Path:
    """A copy of `bag` with `change(topic, msg, index)` applied to each message (it returns the message, or None to
    drop it), each topic of `later` recorded that many seconds later than it was."""
    counts: dict[str, int] = {}
    with rosbag.Bag(str(bag)) as src, rosbag.Bag(str(out), "w") as dst:
        for topic, msg, t in src.read_messages():
            counts[topic] = counts.get(topic, 0) + 1
            msg = change(topic, msg, counts[topic]) if change is not None else msg
            if msg is not None:
                dst.write(topic, msg, t + genpy.Duration.from_sec((later or {}).get(topic, 0.0)))
    return out


def without(*topics: str):
    """A `change` for :func:`copy_bag` that drops `topics` and keeps the rest as they are."""
    return lambda topic, msg, index: None if topic in topics else msg
