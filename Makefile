# Two commands on a fresh Debian 12 machine: `make demo` and `make test`.
# Both install what is missing (Debian ROS packages, the virtual environment) and are quick when it is there.

SHELL := /bin/bash
ROOT  := $(abspath $(dir $(lastword $(MAKEFILE_LIST))))
VENV  := $(ROOT)/.venv
PY    := $(VENV)/bin/python
ROSLIBJS_VERSION := 1.4.1
ROSLIBJS := $(VENV)/share/roslibjs/roslib.min.js

# ROS 1 (Noetic-era) from Debian 12, plus the few system tools the project calls.
ROS_DEBS := python3-rospy python3-roslaunch python3-rosmaster rosout python3-rostopic python3-rosnode \
            python3-rosparam python3-rosbag python3-rosgraph python3-rosgraph-msgs topic-tools python3-topic-tools \
            python3-std-msgs python3-diagnostic-msgs python3-geometry-msgs python3-sensor-msgs python3-nav-msgs \
            python3-tf2-ros python3-tf2-msgs python3-tf2-geometry-msgs python3-actionlib python3-actionlib-msgs \
            python3-dynamic-reconfigure catkin python3-catkin-pkg cmake \
            python3-rosservice python3-std-srvs python3-visualization-msgs rviz xvfb \
            rosbash rospack-tools python3-venv python3-yaml graphviz espeak-ng sox alsa-utils chromium

.PHONY: demo test setup debs venv bench clean
demo: setup
	source $(ROOT)/setup.bash && $(VENV)/bin/subsumption demo --out $(ROOT)/out/demo

# Two workers, a test file each at a time (a file's tests share its ROS graph); every ROS test has its own master.
test: setup
	source $(ROOT)/setup.bash && $(PY) -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder --durations=20

bench: setup
	cd $(ROOT) && source $(ROOT)/setup.bash && $(PY) -m bench.arbiter_latency && $(PY) -m bench.sim_speed && $(PY) -m bench.wander_speed && $(PY) -m bench.wander_coverage && $(PY) -m bench.terminal

setup: debs venv $(ROSLIBJS)

# roslibjs from npm (pinned), only for the test that a roslibjs client works with the operator terminal;
# without npm that test is skipped and says so.
$(ROSLIBJS): $(VENV)/.stamp-installed
	@if command -v npm >/dev/null; then \
	  mkdir -p $(dir $@) && cd $(dir $@) && npm pack --silent roslib@$(ROSLIBJS_VERSION) >/dev/null && \
	  tar xzf roslib-$(ROSLIBJS_VERSION).tgz package/build/roslib.min.js && mv package/build/roslib.min.js . && \
	  rm -rf package roslib-$(ROSLIBJS_VERSION).tgz; \
	else echo "npm not found: the roslibjs test of the terminal will be skipped"; fi

# Installs only the Debian packages that are missing; `apt-get update` runs once, and only then.
debs:
	@missing=$$(for p in $(ROS_DEBS); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q 'ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages: $$missing"; \
	  if [ ! -f $(ROOT)/.stamp-apt-update ]; then apt-get -o DPkg::Lock::Timeout=900 update && touch $(ROOT)/.stamp-apt-update; fi; \
	  DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=900 install -y --no-install-recommends $$missing; \
	fi

venv: $(VENV)/.stamp-installed

# The environment is made from Debian's interpreter (where rospy lives), never from the python3 first on PATH.
$(VENV)/.stamp-installed: pyproject.toml
	[ -x $(PY) ] || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	$(PY) -m pip install --disable-pip-version-check -q -e '$(ROOT)[test]'
	touch $@

clean:
	rm -rf $(VENV) out .stamp-apt-update
