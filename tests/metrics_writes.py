"""How many times each folder's metrics.json is written while a piece of code runs: a run's result is filled by its
observers and steps, then written once (subsumption.metricsfile.write_metrics), and nothing reads it back to write
it again. :class:`MetricsWrites` counts every opening for writing of a file named metrics.json, and every rename onto
one (the writer renames a complete temporary file), by folder, at the places every Python writer goes through
(``io.open``, which ``open()``, ``Path.open`` and ``Path.write_text`` call; ``os.replace`` and ``os.rename``)."""
from __future__ import annotations

import builtins
import io
import os
from collections import Counter
from pathlib import Path

import pytest


class MetricsWrites:
    """Patches ``io.open``, ``builtins.open``, ``os.replace`` and ``os.rename`` while active; `counts` maps each folder
    to its metrics.json writes."""

    def __init__(self) -> None:
        self.counts: Counter[Path] = Counter()
        self._patch = pytest.MonkeyPatch()

    def __enter__(self) -> "MetricsWrites":
        real_open = io.open
        counts = self.counts

        def counted_open(file, mode="r", *args, **kwargs):
            if isinstance(file, (str, os.PathLike)) and any(c in mode for c in "wax+"):
                path = Path(file)
                if path.name == "metrics.json":
                    counts[path.resolve().parent] += 1
            return real_open(file, mode, *args, **kwargs)

        def counted_rename(real):
            def rename(src, dst, *args, **kwargs):
                if isinstance(dst, (str, os.PathLike)) and Path(dst).name == "metrics.json":
                    counts[Path(dst).resolve().parent] += 1
                return real(src, dst, *args, **kwargs)
            return rename

        self._patch.setattr(io, "open", counted_open)
        self._patch.setattr(builtins, "open", counted_open)
        self._patch.setattr(os, "replace", counted_rename(os.replace))
        self._patch.setattr(os, "rename", counted_rename(os.rename))
        return self

    def __exit__(self, *_exc) -> None:
        self._patch.undo()

    def twice(self) -> dict[Path, int]:
        """The folders whose metrics.json was written more than once."""
        return {folder: n for folder, n in self.counts.items() if n > 1}
