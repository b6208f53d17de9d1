"""The tool tasks: a tool's parameters from loaded motions, its recognition, payloads and drive gains.

The modules, bottom up:

- :mod:`~lwrlab.pipeline.tools.library`: the configured tool library, loaded;
- :mod:`~lwrlab.pipeline.tools.bench`: the computation shared by the tasks (the robot, its base
  parameters, a tool's rows and its identification by eq. (7));
- :mod:`~lwrlab.pipeline.tools.log_rows`: recorded logs read like ``plant=log``'s, as tool rows;
- :mod:`~lwrlab.pipeline.tools.recognition`: tasks ``table3_tools`` and
  ``tool_recognition_benchmark`` (simulated tools identified and recognised);
- :mod:`~lwrlab.pipeline.tools.payload_logs`: task ``payload`` (a payload from recorded logs);
- :mod:`~lwrlab.pipeline.tools.drive_gains`: task ``drive_gains`` (drive gains from current logs).
"""

from lwrlab.pipeline.tools.recognition import (
    ToolStage,
    format_table3,
    run_table3_tools,
    run_tool_recognition_benchmark,
    table3_rows,
)

__all__ = [
    "ToolStage",
    "format_table3",
    "run_table3_tools",
    "run_tool_recognition_benchmark",
    "table3_rows",
]
