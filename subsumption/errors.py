"""The one error for a file given as input that cannot be used: a network, world, map or goal file.

Every loader raises it (``subsumption.yamlfile``, ``subsumption.mapfile``, ``subsim.world``), so a command catches
one class and prints one line that names the file and, where known, the line or the field at fault; the CLI
exits with code 2 on it. ``YamlFileError``, ``MapError`` and ``WorldError`` are this class under the names their
modules have always exported.
"""
from __future__ import annotations

from pathlib import Path

MAX_PROBLEM_CHARS = 300  # a file's content quoted in a problem is cut here: the message stays one readable line


class InputFileError(ValueError):
    """An input file is unusable; ``str()`` is one line: ``FILE[:LINE]: [field 'FIELD': ]problem``."""

    def __init__(self, file: str | Path, problem: str, line: int | None = None, *, field: str | None = None) -> None:
        problem = " ".join(problem.split())  # one line, whatever the file held
        if len(problem) > MAX_PROBLEM_CHARS:
            problem = problem[:MAX_PROBLEM_CHARS - 3] + "..."
        self.file, self.problem, self.line, self.field = str(file), problem, line, field
        where = f"{self.file}:{line}" if line else self.file
        super().__init__(f"{where}: field '{field}': {problem}" if field is not None else f"{where}: {problem}")

    @classmethod
    def at(cls, file: str | Path, field: str, problem: str) -> "InputFileError":
        """The error of one field of the file (``field`` as the file spells it: ``robots[0].start``)."""
        return cls(file, problem, field=field)

    @property
    def path(self) -> str:
        """The file's name (what ``WorldError`` and ``MapError`` called it)."""
        return self.file
