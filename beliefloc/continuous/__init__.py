"""The continuous world under the grid: odometry motion, ray casting, the laser's likelihood field,
the surprise check, the grid filter of the real world and a continuous simulated robot.

Pure numpy/scipy, no I/O. Poses are ``(x, y, yaw)`` in the map frame (ROS ``map``, REP 103: metres,
yaw in radians counter-clockwise from +x); an occupancy image is placed in that frame by its
:class:`~beliefloc.model.MapFrame` (Nav2's ``origin``), see :mod:`beliefloc.continuous.image`.
"""
