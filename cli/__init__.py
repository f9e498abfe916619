"""flylog's command-line layer (installed as ``flylog.cli``): parsing, progress, exit codes."""
