"""Running the node graph: process supervision, monitoring, recording and run reports.

``safe_legged_c3bf.bringup`` is the command line entry point; the modules here are its parts:

- :mod:`.supervisor` starts node processes in their own process groups and stops them;
- :mod:`.monitor` is the bringup's own node that watches the run and keeps its time series;
- :mod:`.report` turns those into ``report.json``, a printed summary and plots;
- :mod:`.recorder` writes an MCAP file of the contract topics;
- :mod:`.msgdefs` builds rosbag2-style message definitions for the recorder.
"""
