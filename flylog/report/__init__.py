"""Self-contained HTML reports (``flylog report``) of a run or of a sweep."""
