import sys
sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f)]
sys.path.insert(0, "/work/wt-heading")
import flylog
assert flylog.__file__.startswith("/work/wt-heading"), flylog.__file__
import pytest
sys.exit(pytest.main(sys.argv[1:]))
