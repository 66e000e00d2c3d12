"""The localizer live on a robot: a ROS 2 node over DDS, and runs recorded as ROS 2 bags.

* :mod:`~nightloc.node.conventions` — the graph (topics, types, QoS), REP 105's frames, the
  pose's covariance, ``map -> odom``, the belief as an occupancy grid;
* :mod:`~nightloc.node.build` — ROS 2 messages filled from those numbers, for the node's DDS
  types or rosbags' typestore;
* :mod:`~nightloc.node.messages` — the DDS types (cyclonedds; ``pip install "nightloc[ros2]"``);
* :mod:`~nightloc.node.sync` — odometry matched to frames by stamp (the bag reader's interpolation);
* :mod:`~nightloc.node.runner` — frames localized one at a time (or learned, as ``localize --learn``);
* :mod:`~nightloc.node.record` — a localized night as a ROS 2 MCAP bag (rosbags);
* :mod:`~nightloc.node.participant` — the participant, the latest-wins worker, the publishers.

This stage sits above localization and experience (it runs them) and below the commands
(``nightloc node``, ``nightloc localize --format mcap``). Only ``messages`` and ``participant``
need cyclonedds; they import it themselves.
"""
