"""``python -m fmionnx``: the command line (how the ROS 2 supervisor starts its nodes)."""

from fmionnx.entry import console

console()
