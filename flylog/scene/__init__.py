"""flylog.scene."""
