"""flylog.sim."""
