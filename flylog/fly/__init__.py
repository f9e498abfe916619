"""flylog.fly."""
