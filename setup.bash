# Source this to use the project from a shell: `source setup.bash`.
# It puts the virtual environment first on PATH (so `python3` has rospy *and* the pinned PyPI packages)
# and this folder on ROS_PACKAGE_PATH (so `rosrun subsumption suppressor` and `roslaunch subsumption ...` work).
_subsumption_root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
export PATH="$_subsumption_root/.venv/bin:$PATH"
export VIRTUAL_ENV="$_subsumption_root/.venv"
case ":${ROS_PACKAGE_PATH:-}:" in
  *":$_subsumption_root:"*) ;;
  *) export ROS_PACKAGE_PATH="$_subsumption_root${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}:/usr/share" ;;
esac
unset _subsumption_root
