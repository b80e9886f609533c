"""Does this interpreter have the PyPI packages pinned in pyproject.toml? Run by CMakeLists.txt at configure time.

Prints one line per package that is missing or at another version and exits 1 if there is any, so that CMake
can warn with the exact fix; exits 0 quietly when everything is there."""
import re
import sys
import tomllib
from importlib.metadata import PackageNotFoundError, version


def main(pyproject: str) -> int:
    with open(pyproject, "rb") as handle:
        pins = tomllib.load(handle)["project"]["dependencies"]
    problems = []
    for pin in pins:
        name, _, wanted = re.split(r"(==)", pin, maxsplit=1) if "==" in pin else (pin, "", "")
        try:
            found = version(name.strip())
        except PackageNotFoundError:
            problems.append(f"{pin}: missing")
            continue
        if wanted and found != wanted.strip():
            problems.append(f"{pin}: {found} installed")
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
