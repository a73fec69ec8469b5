"""``pfpeople node``: the live ROS 1 node, a thin adapter of the transport-free core :mod:`pfpeople.live`.

- :mod:`pfpeople.ros1.bridge`: the rospy process (system ``python3``, standard library and rospy only) that moves
  ROS 1 message bytes in and out;
- :mod:`pfpeople.ros1.system`: finding a Python that imports rospy (Debian's ``/usr/bin/python3``), or the apt
  packages to install;
- :mod:`pfpeople.ros1.node`: the node: the bridge's messages decoded (:mod:`pfpeople.live.codec`) into a
  :class:`pfpeople.live.session.LiveSession`, its outputs encoded and published, scans dropped rather than queued,
  per-scan latency reported.
"""
