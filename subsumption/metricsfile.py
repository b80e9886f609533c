"""metrics.json, the figures of a run: one writer for every command that writes one (the experiments, `subsumption
map --bag`, `subsumption localize`), so that every metrics.json reads the same way and none is ever half written."""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any


def write_metrics(folder: Path, metrics: dict[str, Any]) -> Path:
    """FOLDER/metrics.json: two-space JSON (one key a line at the top level) and a newline at the end. The text
    is made before anything is written and takes the file's name only when complete (a temporary file in the
    same folder, renamed), so a failure leaves the previous metrics.json, or none, never a part of one."""
    path = Path(folder) / "metrics.json"
    text = json.dumps(metrics, indent=2) + "\n"
    temporary = path.with_name(f".metrics.json.{os.getpid()}.tmp")  # made with the umask's permissions
    try:
        with open(temporary, "w") as file:
            file.write(text)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path


__all__ = ["write_metrics"]
