"""flylog.planner."""
