"""ROS messages: beliefloc's answers and runs as ROS 2 message bodies (plain data), for
``ros2 topic pub``, rosbridge's JSON and recordings."""
