"""Reading ROS recordings (rosbag2 in sqlite3 or MCAP storage, ROS 1 bags) with the rosbags library,
and writing simulated runs as recordings for test data."""
