"""End-effector tools: composite-shape models, the tool library, and tool recognition.

- :mod:`lwrlab.tools.shapes` solid primitives (cylinder, tube, box, sphere) → inertial parameters;
- :mod:`lwrlab.tools.model` the :class:`Tool` (geometry + 10 flange-frame parameters);
- :mod:`lwrlab.tools.painting` parametric rollers and brushes;
- :mod:`lwrlab.tools.library` the library, one YAML per tool in ``conf/tool/`` (``load_tool(name)``);
- :mod:`lwrlab.tools.recognition` the classifier protocol and the ``Recognition`` result.
"""

from lwrlab.tools.library import ToolLibrary, load_library, load_tool, tool_names
from lwrlab.tools.model import GEOMETRY_NAMES, Tool

__all__ = ["GEOMETRY_NAMES", "Tool", "ToolLibrary", "load_library", "load_tool", "tool_names"]
