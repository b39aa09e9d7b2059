"""Recording of the drive graph to rosbag2-layout MCAP bags, bag replay in sim time and replay comparison."""
