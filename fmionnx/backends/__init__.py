"""Backends execute a :class:`~fmionnx.compile.ir.CompiledSystem`.

Every backend implements :class:`fmionnx.runtime.result.Backend`: ``validate`` rejects what it
cannot run before anything starts, ``run`` executes. The in-process backend lives in
:mod:`fmionnx.backends.inprocess`; the ROS 2 backend in :mod:`fmionnx.backends.ros2`.
"""
