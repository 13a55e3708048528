"""The ``task/1`` task-file format, one job a module.

- :mod:`.schema`: the pydantic models every mapping is checked with, and the names a
  file may use (format tag, built-in hands, display primitives).
- :mod:`.errors`: :class:`~prehension.errors.InvalidTask` messages that name the file and
  the field path.
- :mod:`.yaml_text`: YAML text to plain data and back (duplicate keys refused, line
  numbers in errors, short lists in flow style).
- :mod:`.read`: checked models to hands, regions, objects and tasks.
- :mod:`.write`: tasks, hands and regions to plain dicts.

The public entry point is :mod:`prehension.tasks.yaml_io`; its docstring describes the
format.
"""
