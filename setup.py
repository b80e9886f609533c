"""For catkin only: ``catkin_python_setup()`` in CMakeLists.txt reads the packages from this file.

pip never needs it: pyproject.toml is where the distribution is described (and its dependencies pinned).
When pip builds the project, catkin_pkg is not importable in its isolated build environment and this file
adds nothing to what pyproject.toml says.
"""
from setuptools import find_packages, setup

PACKAGES = ["subsumption*", "subsim*", "navigation*", "vision*", "terminal*", "robots*", "experiments*"]

try:
    from catkin_pkg.python_setup import generate_distutils_setup
except ImportError:  # pip: pyproject.toml says everything
    setup()
else:  # catkin: name and version from package.xml, the same packages as pyproject.toml's (the rest is there)
    catkin = generate_distutils_setup(packages=find_packages(include=PACKAGES), package_dir={"": "."})
    # the Kobuki's message definitions, which subsumption.kobuki builds its classes from at import
    setup(**{key: catkin[key] for key in ("name", "version", "packages", "package_dir")},
          package_data={"subsumption": ["msg/kobuki_msgs/*.msg"]})
