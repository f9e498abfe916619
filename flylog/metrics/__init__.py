"""flylog.metrics."""
