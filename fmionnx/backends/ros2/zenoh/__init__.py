"""ROS 2 over Zenoh the way ``rmw_zenoh_cpp`` speaks it, without a ROS 2 installation.

One concern per module: :mod:`.keys` (key expressions, type hashes, liveliness tokens, GIDs),
:mod:`.attachment` (the 33-byte sample attachment), :mod:`.config` (session configuration from
the ROS 2 / rmw_zenoh environment), :mod:`.router` (finding or starting a router),
:mod:`.transport` (writers and readers behind the node's transport protocols) and
:mod:`.graph` (the liveliness graph ``fmionnx ros2 graph`` reads). ``zenoh`` itself is imported
only by the modules that open sessions, so nothing here loads it before it is needed.
"""
