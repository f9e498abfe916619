"""flylog.experiments: the paper's experiments, reproduced with tables and plots."""
