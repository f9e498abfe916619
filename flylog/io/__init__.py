"""flylog.io."""
