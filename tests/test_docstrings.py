"""Every public class, function and method of the core and of the capability packages says what it is for.

Walks the packages with inspect (importing every module, private ones left out), so that a new public name
without a docstring fails here rather than leaving a gap in the API reference (mkdocs, docs/api/). A method
that overrides a documented one inherits its docstring (inspect.getdoc), as help() and the reference show it."""
from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

PACKAGES = ("subsumption", "navigation", "vision", "terminal")


def public_modules(package: str) -> list[str]:
    """`package` and every module under it whose dotted name has no part starting with an underscore."""
    root = importlib.import_module(package)
    names = [package]
    for info in pkgutil.walk_packages(root.__path__, prefix=package + "."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return names


def undocumented(module_name: str) -> list[str]:
    """The public classes, functions and methods defined in the module (not imported into it) without a docstring."""
    module = importlib.import_module(module_name)
    missing = [] if inspect.getdoc(module) else [module_name]
    for name, value in vars(module).items():
        if name.startswith("_") or getattr(value, "__module__", None) != module_name:
            continue
        if inspect.isclass(value):
            if not inspect.getdoc(value) or value.__doc__ is None:
                missing.append(f"{module_name}.{name}")
            for attr, member in vars(value).items():
                if attr.startswith("_"):
                    continue
                function = member.fget if isinstance(member, property) else getattr(member, "__func__", member)
                if inspect.isfunction(function) and not inspect.getdoc(getattr(value, attr) if not
                                                                        isinstance(member, property) else member):
                    missing.append(f"{module_name}.{name}.{attr}")
        elif inspect.isfunction(value) and not inspect.getdoc(value):
            missing.append(f"{module_name}.{name}")
    return missing


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_has_a_docstring(package: str):
    missing = [name for module in public_modules(package) for name in undocumented(module)]
    assert not missing, f"{len(missing)} public names of {package} without a docstring:\n" + "\n".join(missing)
