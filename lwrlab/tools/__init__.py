"""End-effector tools: composite-shape models, the tool library, and tool recognition.

- :mod:`lwrlab.tools.shapes` solid primitives (cylinder, tube, box, sphere) → inertial parameters;
- :mod:`lwrlab.tools.model` the :class:`Tool` (geometry + 10 flange-frame parameters);
- :mod:`lwrlab.tools.painting` parametric rollers and brushes;
- :mod:`lwrlab.tools.library` the :class:`ToolLibrary` (read from ``conf/tool/``, one YAML per tool, by
  :mod:`lwrlab.pipeline.tools.library`: ``load_tool(name)``);
- :mod:`lwrlab.tools.recognition` the classifier protocol and the ``Recognition`` result.
"""

from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.model import GEOMETRY_NAMES, Tool

__all__ = ["GEOMETRY_NAMES", "Tool", "ToolLibrary"]
