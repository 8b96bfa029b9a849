"""A stored mission as an MCAP file, for the robotics tools (Foxglove, PlotJuggler, rosbag
readers): Foxglove's well-known JSON schemas for the scene and the log, Regolith's own for the
rest. docs/service.md ("Export to MCAP") lists the topics."""
