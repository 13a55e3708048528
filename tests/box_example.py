"""The box grasps of ``examples/quality/box_grasps.py``, loaded once for the tests that use them."""

from __future__ import annotations

import runpy
from pathlib import Path
from types import SimpleNamespace

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "quality"
box_grasps = SimpleNamespace(**runpy.run_path(str(EXAMPLES / "box_grasps.py"), run_name="box_grasps"))
