"""Finding a module class from its dotted path, with errors that say what was wrong."""
from __future__ import annotations

import importlib

from .module import Module


class ClassPathError(ImportError):
    """A `package.module:Class` path that does not name a Module subclass."""


def load_module_class(path: str) -> type[Module]:
    """Import `package.module:Class` (or `package.module.Class`) and check it is a Module subclass."""
    if ":" in path:
        module_name, _, class_name = path.partition(":")
    else:
        module_name, _, class_name = path.rpartition(".")
    if not module_name or not class_name:
        raise ClassPathError(f"{path!r} is not of the form package.module:Class")
    try:
        python_module = importlib.import_module(module_name)
    except ImportError as error:
        raise ClassPathError(f"cannot import {module_name!r} for class {path!r}: {error}") from error
    found = getattr(python_module, class_name, None)
    if found is None:
        raise ClassPathError(f"module {module_name!r} has no class {class_name!r}")
    if not (isinstance(found, type) and issubclass(found, Module)):
        raise ClassPathError(f"{path!r} is not a subsumption Module subclass")
    return found
