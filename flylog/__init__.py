"""flylog: evolutionary stereovision (the fly algorithm) with sensor fusion, over MCAP logs."""

__version__ = "0.1.0"
