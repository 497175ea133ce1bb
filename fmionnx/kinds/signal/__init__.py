"""Signal components: stimuli written in the system file, or read from a CSV table.

A ``signal`` component has only outputs (``float64`` scalars that depend on no input) and
needs no model file. Either ``outputs:`` names one waveform per port (``constant``, ``step``,
``ramp``, ``sine``), or ``path:`` names a CSV table whose first column is the time and whose
other columns, by header name, are the ports (``interpolation: linear`` or ``hold``; before
the first row and after the last the end values are held).

Values are a pure function of the time: after ``step(t, h)`` an output holds its value at
``t + h``, after ``setup(start, ...)`` its value at ``start``; nothing is accumulated, so reruns
are bit-identical. A step (or a table row under ``hold``) at time ``T`` already has its new
value at ``t = T``, as in FMI and Simulink. Because ``t + h`` may miss a time of the grid by a
rounding error, a breakpoint (step time, ramp start and end, table row) within
:data:`~fmionnx.kinds.signal.runner.SNAP` steps of ``t + h`` counts as reached there. The
layout of the entry and of tables is in ``docs/components.md``.
"""
