"""Reading the model out: the condition survey (docs/survey.md, docs/model.md §10). For each
weathered object and age, every point of its surface as rendered is classed into the pattern its
modes produce there (``core.condition``), and the patterns' true areas in m² are written as a CSV
and its paradata (``condition``: the options, the steps, the files); ``points`` samples the
surface and reads the weathered material's inputs at the points; ``sheet`` draws the condition
maps (SVG and PNG, through matplotlib, loaded when a sheet is drawn).

May import: bpy, numpy, matplotlib, ``core``, ``common``, ``blender``, ``shading``, ``maps`` and ``publish`` (its
``porous_node`` and paradata helpers); not ``ui`` or ``cli``, which import it.
"""

from .condition import SurveyOptions, SurveyResult, condition_survey

__all__ = ["SurveyOptions", "SurveyResult", "condition_survey"]
