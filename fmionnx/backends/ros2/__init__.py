"""ROS 2 backend: every component a ROS 2 node speaking ROS 2's wire protocol on Cyclone DDS.

There is no ROS 2 installation on the machines this runs on, so the backend follows the
conventions of ``rmw_cyclonedds_cpp`` directly with the ``cyclonedds`` Python package:
``rt/`` topic prefix, ``pkg::msg::dds_::Type_`` type names, XCDR1 little-endian final structs,
``ros_discovery_info`` for node names. Message definitions come from ``rosbags``' bundled
typestores; serialisation uses ``rosbags``' CDR serialiser (bulk copies for primitive arrays).

Modules, bottom up: :mod:`.messages` (typestores, field paths, default messages),
:mod:`.idl` (cyclonedds types in ROS 2 naming), :mod:`.names`, :mod:`.qos`, :mod:`.env`
(domain and Cyclone configuration from the ROS 2 environment), :mod:`.transport` (raw CDR
writers/readers), :mod:`.discovery` (``ros_discovery_info``), :mod:`.codec` (port values <->
messages), :mod:`.mapping` (default mapping, the ``ros2:`` section, :func:`check_ros2`).
Running: :mod:`.schedule` (which sample a lockstep reader takes), :mod:`.control` (``/clock``
and the ready/done hand-shake), :mod:`.recording`, :mod:`.node` (one component per process,
``fmionnx node``), :mod:`.supervisor` (``fmionnx run --backend ros2``), :mod:`.graph`
(``fmionnx ros2 graph``), :mod:`.launchfile`.
"""
