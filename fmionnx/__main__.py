"""``python -m fmionnx``: the command line (how the ROS 2 supervisor starts its nodes)."""

from fmionnx.cli import console

console()
