"""Bring the system up: the launch file and default parameters (``launch/``, ``config/``), and
:mod:`~wildfire_bringup.launcher`, which starts every node of a ``wildfire run`` as its own
process with the run monitor node (:mod:`~wildfire_bringup.monitor_node`) beside it."""
