"""The wildfire command-line tool, launch files and default parameters."""
