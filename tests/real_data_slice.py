"""A short slice of a real log (Intel Research Lab or Freiburg 079, data/carmen/) for the tests: the lines up to the n-th scan."""
from __future__ import annotations

import gzip
from pathlib import Path

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
