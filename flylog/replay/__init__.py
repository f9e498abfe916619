"""flylog.replay."""
